// Small portable compiler hints.
#pragma once

// For the few hot functions whose callers must see their body (the
// constant-time neighbor step): GCC otherwise declines to inline them past a
// size threshold and passes the state through memory.
#if defined(__GNUC__) || defined(__clang__)
#define SDB_ALWAYS_INLINE [[gnu::always_inline]] inline
#else
#define SDB_ALWAYS_INLINE inline
#endif
