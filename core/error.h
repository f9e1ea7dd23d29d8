// The exception family every library throws. `main` catches them, prints one line and exits with a distinct code
// (apps/cli.h). Messages follow one shape: "<file>: <what is wrong>; <what to do>".
#pragma once
#include <stdexcept>
#include <string>

namespace bareskin {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The user's data is wrong (corrupt file, NaN vertex, wrong landmark count, ...).
class InvalidInput : public Error {
 public:
  using Error::Error;
  InvalidInput(const std::string& file, const std::string& what, const std::string& hint);
};

// A file cannot be read or written (missing, permission, disk full).
class IoError : public Error {
 public:
  using Error::Error;
  IoError(const std::string& file, const std::string& what, const std::string& hint);
};

// An invariant of our own code does not hold: a bug. Thrown by BS_CHECK with file:line.
class InternalError : public Error {
 public:
  using Error::Error;
};

[[noreturn]] void throw_check_failed(const char* expr, const char* file, int line, const std::string& message);

}  // namespace bareskin

#define BS_CHECK(cond, message)                                                     \
  do {                                                                              \
    if (!(cond)) ::bareskin::throw_check_failed(#cond, __FILE__, __LINE__, message); \
  } while (0)
