// Errors by kind. Bad input throws InputError (the CLI maps it to exit code 2); a solver that
// cannot give an answer throws or returns NumericalError-kind status (exit code 3); a broken
// invariant is a bug and fails POLYRAD_CHECK (exit code 1).
#pragma once

#include <stdexcept>
#include <string>

namespace polyrad {

// Where in an input file something was found. line/column are 1-based; 0 means unknown.
struct SourceLocation {
  std::string file;
  int line = 0;
  int column = 0;

  // "file:line:column", "file:line" or "file", whichever the location knows.
  std::string str() const;
};

// Bad input: a malformed or inconsistent scene, a bad flag, a stale operator file.
class InputError : public std::runtime_error {
 public:
  InputError(SourceLocation where, const std::string& message);
  explicit InputError(const std::string& message) : InputError(SourceLocation{}, message) {}
  const SourceLocation& where() const { return where_; }
  const std::string& message() const { return message_; }

 private:
  SourceLocation where_;
  std::string message_;
};

// A computation that cannot give a trustworthy answer (divergence, non-finite values).
class NumericalError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

[[noreturn]] void check_failed(const char* condition, const char* file, int line);

}  // namespace polyrad

// CHECK is always on; DCHECK compiles out in Release builds.
#define POLYRAD_CHECK(cond) \
  ((cond) ? static_cast<void>(0) : ::polyrad::check_failed(#cond, __FILE__, __LINE__))
#ifdef NDEBUG
#define POLYRAD_DCHECK(cond) static_cast<void>(0)
#else
#define POLYRAD_DCHECK(cond) POLYRAD_CHECK(cond)
#endif
