#include "training/optimizer.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace bareskin::train {

double Schedule::factor(int64_t step, int64_t steps) const {
  if (kind == "constant") return 1.0;
  if (kind == "linear") {
    if (step < decay_start) return 1.0;
    const double span = double(std::max<int64_t>(1, steps - decay_start));
    return std::max(0.0, 1.0 - double(step - decay_start) / span);
  }
  if (kind == "step") return step_every > 0 ? std::pow(gamma, double(step / step_every)) : 1.0;
  throw InvalidInput("schedule '" + kind + "'", "is not a schedule", "use constant, linear or step");
}

void to_json(nlohmann::json& j, const Schedule& s) {
  j = {{"kind", s.kind}, {"decay_start", s.decay_start}, {"step_every", s.step_every}, {"gamma", s.gamma}};
}
void from_json(const nlohmann::json& j, Schedule& s) {
  s.kind = j.value("kind", s.kind);
  s.decay_start = j.value("decay_start", s.decay_start);
  s.step_every = j.value("step_every", s.step_every);
  s.gamma = j.value("gamma", s.gamma);
}

}  // namespace bareskin::train
