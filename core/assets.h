// Where the toolkit finds its setup assets (fetched by `make deps`) and the default template face. Never relative to
// the current folder, so the tool runs from anywhere. The search order (docs/cli.md, "Assets and the template"):
//   1. the folder given on the command line (--assets, --template, --weights);
//   2. the environment variable (BARESKIN_ASSETS, BARESKIN_TEMPLATE);
//   3. <folder of the executable>/../share/bareskin/{assets,template}: the layout `cmake --install` writes;
//   4. assets only: the source tree's assets/ of the build the executable came from (a compile-time path).
// A folder named on the command line or in the environment is used as given (no fallback), so a typo is an error
// naming it; otherwise the first place holding the expected entry wins. The error lists every place searched.
#pragma once
#include <string>
#include <vector>

namespace bareskin {

enum class DataKind { Assets, Template };

// The places searched for `kind`, in order, with where each comes from ("--assets", "BARESKIN_ASSETS", ...).
struct SearchPlace {
  std::string path, origin;
};
std::vector<SearchPlace> data_search_path(DataKind kind, const std::string& given);

// The first folder of data_search_path(kind, given) holding `entry` (a relative path, e.g. "face_api" or "face.obj").
// IoError naming the entry and every place searched when none holds it.
std::string find_data_dir(DataKind kind, const std::string& given, const std::string& entry);

// The folder holding the running executable (from /proc/self/exe; links named after a command resolve to bareskin).
std::string executable_dir();

}  // namespace bareskin
