// Logging goes through spdlog's default logger, to stderr. Apps set the level from -v / -q.
#pragma once
#include <spdlog/spdlog.h>

namespace bareskin {

enum class Verbosity { Quiet, Normal, Verbose };

// Routes spdlog to stderr with a short pattern ("[warn] ...") and sets the level for the verbosity.
void init_logging(Verbosity verbosity);

}  // namespace bareskin
