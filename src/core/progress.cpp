#include "core/progress.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <utility>

namespace fogmap {

namespace {

constexpr double kRedrawInterval_s = 0.2;  // at most ~5 redraws per second on a terminal
constexpr int kBarWidth = 30;

bool stderr_is_tty() { return ::isatty(::fileno(stderr)) == 1; }

/// Completed 10% steps, 0..10.
int decile(uint64_t done, uint64_t total) {
    if (total == 0 || done >= total) return 10;
    return static_cast<int>(done * 10 / total);
}

}  // namespace

// last_draw_s_ holds what was drawn last: on a terminal the time of the last redraw (s); when
// stderr is a file or pipe, the last 10% step printed (-1: none), since there a line is printed
// per step instead of redrawing on a timer.
Progress::Progress(std::string label, uint64_t total, bool quiet)
    : label_(std::move(label)), total_(total), quiet_(quiet) {}

Progress::~Progress() { finish(); }

void Progress::add(uint64_t n) {
    const uint64_t done = done_.fetch_add(n, std::memory_order_relaxed) + n;
    if (quiet_) return;
    // Only one thread draws; the others just count and carry on.
    std::unique_lock<std::mutex> lock(mutex_, std::try_to_lock);
    if (!lock.owns_lock() || finished_) return;
    if (stderr_is_tty()) {
        const double now_s = timer_.seconds();
        if (last_draw_s_ >= 0.0 && now_s - last_draw_s_ < kRedrawInterval_s) return;
        last_draw_s_ = now_s;
        draw(done);
    } else {
        const int step = decile(done, total_);
        if (step <= static_cast<int>(last_draw_s_)) return;
        last_draw_s_ = step;
        draw(done);
    }
}

void Progress::finish() {
    if (quiet_) return;
    std::lock_guard<std::mutex> lock(mutex_);
    if (finished_) return;
    finished_ = true;
    const bool tty = stderr_is_tty();
    if (!tty && static_cast<int>(last_draw_s_) >= 10) return;  // the 100% line is out already
    draw(std::max(total_, done_.load(std::memory_order_relaxed)));
    if (tty) std::fputc('\n', stderr);
    std::fflush(stderr);
}

void Progress::draw(uint64_t done) {
    const double fraction =
        total_ == 0 ? 1.0 : std::min(1.0, static_cast<double>(done) / static_cast<double>(total_));
    const int filled = static_cast<int>(fraction * kBarWidth);
    char bar[kBarWidth + 1];
    for (int i = 0; i < kBarWidth; ++i) bar[i] = i < filled ? '#' : '-';
    bar[kBarWidth] = '\0';

    const double elapsed_s = timer_.seconds();
    char eta[32];
    if (fraction >= 1.0) {
        std::snprintf(eta, sizeof(eta), "%6.1fs", 0.0);
    } else if (fraction > 0.0) {
        std::snprintf(eta, sizeof(eta), "%6.1fs", elapsed_s * (1.0 - fraction) / fraction);
    } else {
        std::snprintf(eta, sizeof(eta), "%7s", "?");
    }
    const bool tty = stderr_is_tty();
    // Fixed field widths keep every redraw the same length, so '\r' overwrites it completely.
    std::fprintf(stderr, "%s%s [%s] %3d%%  elapsed %6.1fs  eta %s%s", tty ? "\r" : "",
                 label_.c_str(), bar, static_cast<int>(fraction * 100.0), elapsed_s, eta,
                 tty ? "" : "\n");
    std::fflush(stderr);
}

}  // namespace fogmap
