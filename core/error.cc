#include "core/error.h"

namespace bareskin {
namespace {
std::string compose(const std::string& file, const std::string& what, const std::string& hint) {
  std::string message = file.empty() ? what : file + ": " + what;
  if (!hint.empty()) message += "; " + hint;
  return message;
}
}  // namespace

InvalidInput::InvalidInput(const std::string& file, const std::string& what, const std::string& hint)
    : Error(compose(file, what, hint)) {}

IoError::IoError(const std::string& file, const std::string& what, const std::string& hint)
    : Error(compose(file, what, hint)) {}

void throw_check_failed(const char* expr, const char* file, int line, const std::string& message) {
  throw InternalError(std::string(file) + ":" + std::to_string(line) + ": check failed: " + expr +
                      (message.empty() ? "" : " (" + message + ")"));
}

}  // namespace bareskin
