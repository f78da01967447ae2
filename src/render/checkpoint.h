#pragma once
// Checkpoints of progressive runs (README, "Rendering on many machines"): after a whole number of
// iterations, the fixed-point sum of their films (render/film.h, FixedFilm), the summed counts
// and a fingerprint of the scene and settings, written atomically beside the output. A resumed
// run adds the remaining iterations to that sum, so it ends with the same image, bit for bit, as
// a run that was never stopped — at any rank count, since the sums are integers.

#include "render/film.h"

#include <cstdint>
#include <string>
#include <vector>

namespace fogmap {

struct Checkpoint {
    uint64_t fingerprint = 0;     ///< resumable_fingerprint (scene/scene_desc_json.h) of the run
    int iterations = 0;           ///< iterations 1 .. iterations are in `sum`
    std::vector<int64_t> counts;  ///< the pipeline's summed counts (render/pipeline.cpp)
    FixedFilm sum;
};

/// The file's bytes: a header line "fogmap checkpoint 1", then the fields, little-endian.
std::string checkpoint_bytes(const Checkpoint& c);

/// Reads a checkpoint. Throws InputError{path, option, reason}: unreadable, not a checkpoint,
/// cut short, or written for another scene or other settings than `fingerprint`.
Checkpoint read_checkpoint(const std::string& path, const std::string& option,
                           uint64_t fingerprint);

}  // namespace fogmap
