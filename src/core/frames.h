#pragma once
// Frame sequences: a frame range "first-last[:step]" and the frame patterns of file names — `####`
// (Houdini and Blender: zero-padded to the number of #), `$F4` / `$F` (Houdini: padded to 4
// digits / not padded) and `%04d` / `%d` (printf). Pure string functions; thread-safe.

#include <string>
#include <vector>

namespace fogmap {

/// The most digits a frame pattern pads to (frames lie within ±1e8), and the most frames a
/// range may hold (an hour at 24 frames a second is 86 400).
inline constexpr int kMaxFrameDigits = 9;
inline constexpr long kMaxFrameCount = 100000;

struct FrameRange {
    int first = 1, last = 1, step = 1;
    /// The frames first, first + step, ... up to last.
    std::vector<int> frames() const;
};

/// Parses "12", "1-48" or "1-48:2" (first <= last, step >= 1, frames within ±1e8, at most
/// kMaxFrameCount frames). Throws InputError{"", option, reason} naming what it found and what
/// it expected.
FrameRange parse_frame_range(const std::string& text, const std::string& option);

/// True when `name` holds a frame pattern (#, $F or %d forms).
bool has_frame_pattern(const std::string& name);

/// Throws InputError{file, field, reason} when a frame pattern of `name` pads to more than
/// kMaxFrameDigits digits.
void check_frame_pattern(const std::string& name, const std::string& file,
                         const std::string& field);

/// `name` with every frame pattern replaced by `frame` (negative frames keep their sign ahead of
/// the padding: -0003; padding beyond kMaxFrameDigits is cut to it).
std::string expand_frame(const std::string& name, int frame);

}  // namespace fogmap
