// Status and Result<T>: how every fallible operation in SimplexDB reports
// failure.
//
// A Status is a cheap value: an OK status holds no heap memory. A failed
// status carries a code (what kind of failure, so callers can branch on it:
// IsCorruption(), IsNotFound(), ...) and a message that names the file, the
// value and what was expected. Errors from errno, zstd and LMDB are translated
// into a Status once, at the boundary where they occur.
//
// Both types are [[nodiscard]]: ignoring a failure is a compile error under
// -Werror. Programming errors (violated REQUIRES: lines) are assertions, not
// statuses.
//
// Thread safety: distinct objects may be used from distinct threads; const
// methods may be called concurrently.
#pragma once

#include <cassert>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <variant>

namespace simplexdb {

class [[nodiscard]] Status {
 public:
  enum class Code : unsigned char {
    kOk = 0,
    kInvalidArgument,  // the caller's input is malformed or out of range
    kNotFound,         // a named file or key does not exist
    kCorruption,       // stored data fails a checksum or an invariant
    kIOError,          // the operating system refused a read or write
    kNotSupported,     // well-formed input this build cannot handle
    kResourceExhausted,  // a disk, map or memory budget is full
  };

  // An OK status.
  Status() noexcept = default;
  static Status OK() noexcept { return Status(); }

  static Status InvalidArgument(std::string_view msg) {
    return Status(Code::kInvalidArgument, msg);
  }
  static Status NotFound(std::string_view msg) {
    return Status(Code::kNotFound, msg);
  }
  static Status Corruption(std::string_view msg) {
    return Status(Code::kCorruption, msg);
  }
  static Status IOError(std::string_view msg) {
    return Status(Code::kIOError, msg);
  }
  static Status NotSupported(std::string_view msg) {
    return Status(Code::kNotSupported, msg);
  }
  static Status ResourceExhausted(std::string_view msg) {
    return Status(Code::kResourceExhausted, msg);
  }

  Status(const Status& other)
      : rep_(other.rep_ ? std::make_unique<Rep>(*other.rep_) : nullptr) {}
  Status& operator=(const Status& other) {
    if (this != &other) {
      rep_ = other.rep_ ? std::make_unique<Rep>(*other.rep_) : nullptr;
    }
    return *this;
  }
  Status(Status&&) noexcept = default;
  Status& operator=(Status&&) noexcept = default;

  bool ok() const noexcept { return rep_ == nullptr; }
  Code code() const noexcept { return rep_ ? rep_->code : Code::kOk; }
  bool IsInvalidArgument() const noexcept {
    return code() == Code::kInvalidArgument;
  }
  bool IsNotFound() const noexcept { return code() == Code::kNotFound; }
  bool IsCorruption() const noexcept { return code() == Code::kCorruption; }
  bool IsIOError() const noexcept { return code() == Code::kIOError; }
  bool IsNotSupported() const noexcept {
    return code() == Code::kNotSupported;
  }
  bool IsResourceExhausted() const noexcept {
    return code() == Code::kResourceExhausted;
  }

  // The message alone ("" when OK).
  std::string_view message() const noexcept {
    return rep_ ? std::string_view(rep_->message) : std::string_view();
  }

  // "OK", or "<code name>: <message>", e.g. "corruption: store.sdb: block 7
  // checksum mismatch".
  std::string ToString() const {
    if (ok()) return "OK";
    return std::string(CodeName(rep_->code)) + ": " + rep_->message;
  }

  static std::string_view CodeName(Code code) noexcept {
    switch (code) {
      case Code::kOk: return "OK";
      case Code::kInvalidArgument: return "invalid argument";
      case Code::kNotFound: return "not found";
      case Code::kCorruption: return "corruption";
      case Code::kIOError: return "I/O error";
      case Code::kNotSupported: return "not supported";
      case Code::kResourceExhausted: return "resource exhausted";
    }
    return "unknown";
  }

 private:
  struct Rep {
    Code code;
    std::string message;
  };
  Status(Code code, std::string_view msg)
      : rep_(std::make_unique<Rep>(Rep{code, std::string(msg)})) {}

  std::unique_ptr<Rep> rep_;  // null when OK
};

// Either a value of type T or a failed Status.
//
// REQUIRES: value()/operator*/operator-> only when ok().
template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : v_(std::move(value)) {}  // NOLINT: implicit by design
  // REQUIRES: !status.ok(). (A release build turns an OK status into an
  // InvalidArgument failure rather than hold neither a value nor an error.)
  Result(Status status) : v_(Failed(std::move(status))) {}  // NOLINT: implicit

  bool ok() const noexcept { return std::holds_alternative<T>(v_); }

  // OK when a value is held. The reference lives as long as this Result.
  const Status& status() const noexcept {
    static const Status kOk;
    return ok() ? kOk : std::get<Status>(v_);
  }

  const T& value() const& {
    assert(ok());
    return std::get<T>(v_);
  }
  T& value() & {
    assert(ok());
    return std::get<T>(v_);
  }
  T&& value() && {
    assert(ok());
    return std::get<T>(std::move(v_));
  }
  const T& operator*() const& { return value(); }
  T& operator*() & { return value(); }
  T&& operator*() && { return std::move(*this).value(); }
  const T* operator->() const { return &value(); }
  T* operator->() { return &value(); }

 private:
  static Status Failed(Status status) {
    assert(!status.ok() && "Result needs a failed Status");
    if (status.ok()) return Status::InvalidArgument("Result made from an OK status");
    return status;
  }

  std::variant<T, Status> v_;
};

}  // namespace simplexdb

// Propagates a failed Status from an expression returning Status.
#define SDB_RETURN_IF_ERROR(expr)                 \
  do {                                            \
    ::simplexdb::Status sdb_status_ = (expr);     \
    if (!sdb_status_.ok()) return sdb_status_;    \
  } while (false)

// `SDB_ASSIGN_OR_RETURN(auto x, MakeX());` declares x from the value of a
// Result, or returns its failed Status.
#define SDB_CONCAT_INNER_(a, b) a##b
#define SDB_CONCAT_(a, b) SDB_CONCAT_INNER_(a, b)
#define SDB_ASSIGN_OR_RETURN(decl, expr)                                  \
  auto SDB_CONCAT_(sdb_result_, __LINE__) = (expr);                       \
  if (!SDB_CONCAT_(sdb_result_, __LINE__).ok())                           \
    return SDB_CONCAT_(sdb_result_, __LINE__).status();                   \
  decl = std::move(SDB_CONCAT_(sdb_result_, __LINE__)).value()
