#pragma once
// The one thread limit of a run: a ThreadLimit caps every TBB parallel loop started while it lives
// (tbb::global_control), so the photon pass, the kd-tree builds and the render pass all run on the
// same number of workers. Results never depend on it (docs/design.md, Determinism). Construct one
// per run, on the thread that starts the work.

#include <tbb/global_control.h>
#include <tbb/info.h>

namespace fogmap {

/// Worker threads for a `threads` setting: the setting itself, or every core when 0.
inline int thread_count(int threads) {
    return threads > 0 ? threads : tbb::info::default_concurrency();
}

/// Worker threads TBB uses now (the innermost active limit, at most every core).
inline int active_thread_count() {
    const int limit = static_cast<int>(
        tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
    return limit > 0 ? limit : tbb::info::default_concurrency();
}

class ThreadLimit {
public:
    /// threads = 0: every core.
    explicit ThreadLimit(int threads)
        : count_(thread_count(threads)),
          control_(tbb::global_control::max_allowed_parallelism, static_cast<size_t>(count_)) {}
    int count() const { return count_; }

private:
    int count_;
    tbb::global_control control_;
};

}  // namespace fogmap
