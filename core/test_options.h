// Tests of an options struct: its JSON (core/json_options.h) and its check(), shared by every module's unit tests.
#pragma once
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "core/error.h"

namespace bareskin::testing {

// `valid` passes its check(); with `edit` applied, check() throws InvalidInput in one line that contains `needle`
// (the flag or the value that is wrong).
template <typename T, typename Edit>
void expect_check_refuses(const T& valid, Edit edit, const std::string& needle) {
  EXPECT_NO_THROW(valid.check()) << needle;
  T bad = valid;
  edit(bad);
  try {
    bad.check();
    ADD_FAILURE() << "check() accepted what it should refuse (" << needle << ")";
  } catch (const InvalidInput& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(needle), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
}

// `changes` (keys of T with non-default values) read over T's defaults are written back as given, with the same
// JSON types (an integer stays an integer); to_json → from_json → to_json is the identity; an unknown key is refused
// in one line naming it and every key the defaults write; a number given as a string is refused naming its key.
template <typename T>
void expect_options_json(const nlohmann::json& changes) {
  const T read = changes.get<T>();
  const nlohmann::json written = read;
  for (const auto& [key, value] : changes.items()) {
    ASSERT_TRUE(written.contains(key)) << key << " is not written: " << written.dump();
    EXPECT_EQ(written.at(key), value) << key;
    EXPECT_EQ(written.at(key).is_number_integer(), value.is_number_integer()) << key;
  }
  EXPECT_EQ(nlohmann::json(written.get<T>()), written);

  const nlohmann::json defaults = T{};
  try {
    (void)nlohmann::json({{"no_such_key", 1}}).get<T>();
    ADD_FAILURE() << "an unknown key was accepted";
  } catch (const InvalidInput& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("unknown key 'no_such_key'"), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    for (const auto& [key, value] : defaults.items())
      EXPECT_NE(message.find(key), std::string::npos) << key << " is not listed: " << message;
  }
  for (const auto& [key, value] : defaults.items()) {
    if (!value.is_number()) continue;
    try {
      (void)nlohmann::json({{key, "1"}}).get<T>();
      ADD_FAILURE() << key << " accepted a string";
    } catch (const InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find("'" + key + "'"), std::string::npos) << e.what();
    }
    break;
  }
}

}  // namespace bareskin::testing
