#pragma once
// Wall-clock time of weft's stages, for the seconds that summary.json reports.
#include <chrono>

namespace weft {

using Clock = std::chrono::steady_clock;

/// Seconds of wall-clock time since t0.
inline double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

}  // namespace weft
