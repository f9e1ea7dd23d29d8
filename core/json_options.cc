#include "core/json_options.h"

namespace bareskin::json_options {

void check_keys(const nlohmann::json& j, const std::string& what, const std::vector<std::string>& known) {
  if (!j.is_object())
    throw InvalidInput(what + " options", "options must be a JSON object, not " + j.dump(),
                       "write them as {\"key\": value}");
  for (const auto& item : j.items()) {
    bool found = false;
    for (const std::string& k : known) found = found || item.key() == k;
    if (found) continue;
    std::string list;
    for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
    throw InvalidInput(what + " options", "unknown key '" + item.key() + "'", "known keys: " + list);
  }
}

void Reader::wrong_type(const char* key, const nlohmann::json& value, const char* kind,
                        const std::string& default_value) const {
  throw InvalidInput(what_ + " options", std::string("'") + key + "' has the wrong type (" + value.dump() + ")",
                     std::string("give ") + kind + " (default: " + default_value + ")");
}

}  // namespace bareskin::json_options
