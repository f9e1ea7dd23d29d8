// libFuzzer target: the JSON readers of options and coefficients. An options struct with every kind of field goes
// through json_options::read (refused, or read and written back to the same JSON read again), and the same text
// through the coefficient file's reader. Both accept or raise InvalidInput.
#include <cstdlib>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/json_options.h"
#include "morphable/coefficients.h"
#include "tests/fuzz/fuzz_input.h"

namespace {

struct Options {
  bool flag = false;
  int count = 3;
  int64_t steps = 100;
  double rate = 0.5;
  float weight = 1;
  std::string name = "x";
  std::vector<double> values{1, 2};
  void check() const {
    if (!(rate >= 0)) throw bareskin::InvalidInput("", "'rate' must be >= 0", "");
  }
  bool operator==(const Options& o) const {
    return flag == o.flag && count == o.count && steps == o.steps && rate == o.rate && weight == o.weight &&
           name == o.name && values == o.values;
  }
};
const auto kFields = [](auto& v, auto& o) {
  v("flag", o.flag);
  v("count", o.count);
  v("steps", o.steps);
  v.unless_default("rate", o.rate);
  v("weight", o.weight);
  v.unwritten("name", o.name);
  v("values", o.values);
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string input = bareskin::fuzz::text(data, size);
  const nlohmann::json j = nlohmann::json::parse(input, nullptr, false);
  if (!j.is_discarded()) {
    try {
      Options o;
      bareskin::json_options::read(j, o, "fuzz", kFields);
      nlohmann::json again;
      bareskin::json_options::write(again, o, kFields);
      Options back;
      back.name = o.name;  // unwritten: not in the JSON
      bareskin::json_options::read(again, back, "fuzz", kFields);
      if (!(back == o) && o.rate == o.rate) std::abort();  // what was read must survive its own round trip
    } catch (const bareskin::InvalidInput&) {
    }
  }
  try {
    bareskin::parse_coefficients(input, "fuzz.json");
  } catch (const bareskin::InvalidInput&) {
  }
  return 0;
}
