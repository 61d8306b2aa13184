#pragma once
// How many threads weft's parallel loops use. Those loops give the same bits at every thread
// count: work is cut into pieces that do not depend on the count, and their results are
// combined in a fixed order.

namespace weft {

/// Limits the threads to n (n >= 1), or lets them use every core of the machine (n = 0, the
/// default). Throws std::invalid_argument for n < 0. Holds for the whole process.
void set_thread_count(int n);
/// The threads a parallel loop may use now.
int thread_count();

}  // namespace weft
