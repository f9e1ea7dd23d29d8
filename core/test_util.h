// Helpers for tests: a fresh temporary directory per test.
#pragma once
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

namespace bareskin::testing {

// A test data location: the environment variable if set, else the path the build compiled in.
inline std::string data_path(const char* variable, const char* compiled_default) {
  const char* env = std::getenv(variable);
  return env && *env ? env : compiled_default;
}

inline std::string temp_dir() {
  std::random_device rd;
  const auto dir = std::filesystem::temp_directory_path() / ("bareskin_test_" + std::to_string(rd()));
  std::filesystem::create_directories(dir);
  return dir.string();
}

inline void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

inline size_t count_files(const std::string& dir) {
  size_t n = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++n;
  return n;
}

}  // namespace bareskin::testing

#ifdef BARESKIN_TEST_ASSETS
#define BARESKIN_ASSETS_DIR ::bareskin::testing::data_path("BARESKIN_ASSETS", BARESKIN_TEST_ASSETS)
#define BARESKIN_TEMPLATE_DIR ::bareskin::testing::data_path("BARESKIN_TEMPLATE", BARESKIN_TEST_TEMPLATE)
#endif
