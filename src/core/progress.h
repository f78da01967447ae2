#pragma once
// Progress bar on stderr: percent, elapsed and ETA, redrawn at most ~5 times a second.
// add() is thread-safe (atomic counter; one thread redraws at a time). Silent when quiet.

#include <atomic>
#include <cstdint>
#include <mutex>
#include <string>

#include "core/timer.h"

namespace fogmap {

class Progress {
public:
    /// total: units of work (e.g. tiles); label: shown before the bar.
    Progress(std::string label, uint64_t total, bool quiet);
    ~Progress();
    /// Marks n more units done; may redraw.
    void add(uint64_t n = 1);
    /// Draws 100% and ends the line (idempotent; also called by the destructor).
    void finish();

private:
    void draw(uint64_t done);
    std::string label_;
    uint64_t total_;
    bool quiet_;
    bool finished_ = false;
    std::atomic<uint64_t> done_{0};
    std::mutex mutex_;
    Timer timer_;
    double last_draw_s_ = -1.0;
};

}  // namespace fogmap
