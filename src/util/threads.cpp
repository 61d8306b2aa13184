#include "util/threads.hpp"

#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>

#include <tbb/global_control.h>

namespace weft {

namespace {
std::mutex limit_mutex;
std::unique_ptr<tbb::global_control> limit;
}  // namespace

void set_thread_count(int n) {
  if (n < 0) throw std::invalid_argument("thread count must be 0 (every core) or positive, got " + std::to_string(n));
  std::lock_guard<std::mutex> lock(limit_mutex);
  limit.reset();
  if (n > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, n);
}

int thread_count() {
  return static_cast<int>(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
}

}  // namespace weft
