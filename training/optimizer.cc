#include "training/optimizer.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/json_options.h"

namespace bareskin::train {

double Schedule::factor(int64_t step, int64_t steps) const {
  if (kind == "constant") return 1.0;
  if (kind == "linear") {
    if (step < decay_start) return 1.0;
    const double span = double(std::max<int64_t>(1, steps - decay_start));
    return std::max(0.0, 1.0 - double(step - decay_start) / span);
  }
  if (kind == "step") return step_every > 0 ? std::pow(gamma, double(step / step_every)) : 1.0;
  check();
  BS_CHECK(false, "Schedule::check accepted '" + kind + "'");
  return 1.0;
}

Schedule Schedule::linear_from(double fraction, int64_t steps) {
  Schedule s;
  if (fraction < 1) {
    s.kind = "linear";
    s.decay_start = std::llround(fraction * double(steps));
  }
  return s;
}

void Schedule::check() const {
  if (kind != "constant" && kind != "linear" && kind != "step")
    throw InvalidInput("schedule '" + kind + "'", "is not a schedule", "use constant, linear or step");
}

namespace {
// The keys of Schedule, listed once (core/json_options.h).
const auto kScheduleFields = [](auto& v, auto& s) {
  v("kind", s.kind);
  v("decay_start", s.decay_start);
  v("step_every", s.step_every);
  v("gamma", s.gamma);
};
}  // namespace

void to_json(nlohmann::json& j, const Schedule& s) { json_options::write(j, s, kScheduleFields); }
void from_json(const nlohmann::json& j, Schedule& s) { json_options::read(j, s, "schedule", kScheduleFields); }

}  // namespace bareskin::train
