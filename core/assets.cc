#include "core/assets.h"

#include <cstdlib>
#include <filesystem>

#include "core/error.h"

#ifndef BARESKIN_SOURCE_ASSETS
#define BARESKIN_SOURCE_ASSETS ""
#endif

namespace bareskin {

namespace fs = std::filesystem;

std::string executable_dir() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  return ec ? std::string() : exe.parent_path().string();
}

std::vector<SearchPlace> data_search_path(DataKind kind, const std::string& given) {
  const bool assets = kind == DataKind::Assets;
  const char* flag = assets ? "--assets" : "--template";
  const char* variable = assets ? "BARESKIN_ASSETS" : "BARESKIN_TEMPLATE";
  if (!given.empty()) return {{given, flag}};
  if (const char* env = std::getenv(variable); env && *env) return {{env, variable}};
  std::vector<SearchPlace> places;
  if (const std::string exe = executable_dir(); !exe.empty()) {
    places.push_back({(fs::path(exe) / ".." / "share" / "bareskin" / (assets ? "assets" : "template")).lexically_normal().string(),
                      "the install folder beside the executable"});
  }
  if (assets && std::string(BARESKIN_SOURCE_ASSETS).size() > 0) {
    places.push_back({BARESKIN_SOURCE_ASSETS, "the source tree the executable was built from"});
  }
  return places;
}

std::string find_data_dir(DataKind kind, const std::string& given, const std::string& entry) {
  const std::vector<SearchPlace> places = data_search_path(kind, given);
  std::string searched;
  for (const SearchPlace& p : places) {
    if (fs::exists(fs::path(p.path) / entry)) return p.path;
    searched += (searched.empty() ? "" : ", ") + p.path + " (" + p.origin + ")";
  }
  const bool assets = kind == DataKind::Assets;
  const std::string file = places.size() == 1 ? (fs::path(places[0].path) / entry).string() : entry;
  throw IoError(file, "not found in " + (searched.empty() ? std::string("any search place") : searched),
                assets ? "run 'make deps', or pass --assets DIR / set BARESKIN_ASSETS (docs/cli.md)"
                       : "build one with 'bareskin template -o DIR' and pass --template DIR / set BARESKIN_TEMPLATE, or "
                         "install the tool (make install)");
}

}  // namespace bareskin
