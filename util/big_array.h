// A zero-filled array of a trivial type for the builder's large buffers (the
// field as doubles, the diamond table): hundreds of megabytes that are
// filled once and then read in orders other than their own.
//
// On Linux, an array of 2 MiB or more is its own anonymous mapping, aligned
// to 2 MiB and offered to the kernel for transparent huge pages (madvise
// MADV_HUGEPAGE; where the system says "never" it has no effect). Its pages
// come zeroed from the kernel when first touched, by the thread touching
// them, so zero-filling costs nothing up front. With 4 KiB pages, filling a
// 135 MB field took a page fault every 512 doubles, and the exact row
// scans, whose rows lie a grid row apart, missed the TLB at nearly every
// row. Smaller arrays, other systems and AddressSanitizer builds (which
// check heap accesses only) use the heap, zeroed by calloc.
//
// Thread safety: as a plain array. Errors: the constructor throws
// std::bad_alloc when the memory is not there.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <new>
#include <type_traits>
#include <utility>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace simplexdb {

template <class T>
class BigArray {
  static_assert(std::is_trivial_v<T>);

 public:
  BigArray() = default;
  // n elements, each zero.
  explicit BigArray(size_t n) : size_(n) {
    if (n > std::numeric_limits<size_t>::max() / sizeof(T) / 2) throw std::bad_alloc();
#if defined(__linux__) && !defined(__SANITIZE_ADDRESS__)
    const size_t bytes = n * sizeof(T);
    constexpr size_t kHuge = size_t{2} << 20;
    if (bytes >= kHuge) {
      // Mapped with a huge page of slack, then trimmed to a 2 MiB-aligned
      // range.
      const size_t length = (bytes + kHuge - 1) / kHuge * kHuge;
      void* raw = mmap(nullptr, length + kHuge, PROT_READ | PROT_WRITE,
                       MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
      if (raw == MAP_FAILED) throw std::bad_alloc();
      const auto base = reinterpret_cast<uintptr_t>(raw);
      const uintptr_t aligned = (base + kHuge - 1) / kHuge * kHuge;
      if (aligned > base) munmap(raw, aligned - base);
      const uintptr_t end = base + length + kHuge;
      if (end > aligned + length) munmap(reinterpret_cast<void*>(aligned + length), end - aligned - length);
#if defined(MADV_HUGEPAGE)
      madvise(reinterpret_cast<void*>(aligned), length, MADV_HUGEPAGE);  // advice: a failure changes nothing
#endif
      data_ = reinterpret_cast<T*>(aligned);
      mapped_ = length;
      return;
    }
#endif
    data_ = static_cast<T*>(std::calloc(n == 0 ? 1 : n, sizeof(T)));
    if (data_ == nullptr) throw std::bad_alloc();
  }
  ~BigArray() { Release(); }
  BigArray(BigArray&& o) noexcept
      : data_(std::exchange(o.data_, nullptr)),
        size_(std::exchange(o.size_, 0)),
        mapped_(std::exchange(o.mapped_, 0)) {}
  BigArray& operator=(BigArray&& o) noexcept {
    if (this != &o) {
      Release();
      data_ = std::exchange(o.data_, nullptr);
      size_ = std::exchange(o.size_, 0);
      mapped_ = std::exchange(o.mapped_, 0);
    }
    return *this;
  }
  BigArray(const BigArray&) = delete;
  BigArray& operator=(const BigArray&) = delete;

  T* data() { return data_; }
  const T* data() const { return data_; }
  size_t size() const { return size_; }
  T& operator[](size_t i) { return data_[i]; }
  const T& operator[](size_t i) const { return data_[i]; }

 private:
  void Release() {
    if (data_ == nullptr) return;
#if defined(__linux__) && !defined(__SANITIZE_ADDRESS__)
    if (mapped_ > 0) {
      munmap(data_, mapped_);
      data_ = nullptr;
      return;
    }
#endif
    std::free(data_);
    data_ = nullptr;
  }

  T* data_ = nullptr;
  size_t size_ = 0;
  size_t mapped_ = 0;  // bytes of the mapping (0: from the heap)
};

}  // namespace simplexdb
