#pragma once
// Checkpoints of progressive runs (docs/distributed.md): after a whole number of iterations, the
// fixed-point sum of their films (render/film.h, FixedFilm), the summed counts and a fingerprint
// of the scene, settings and input files, written atomically beside the output with a checksum of
// all of it. A resumed run adds the remaining iterations to that sum, so it ends with the same
// image, bit for bit, as a run that was never stopped — at any rank count, since the sums are
// integers. Nothing in a checkpoint is trusted before it is checked against the run and itself.

#include "render/error_estimate.h"
#include "render/film.h"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace fogmap {

/// The counts a run sums over iterations and ranks (render/pipeline.cpp): the first is the
/// number of iterations in the sum.
inline constexpr size_t kRunCounts = 11;

struct Checkpoint {
    uint64_t fingerprint = 0;     ///< of the run and its inputs (app/commands.cpp)
    int iterations = 0;           ///< iterations 1 .. iterations are in `sum`
    std::vector<int64_t> counts;  ///< the pipeline's summed counts, kRunCounts of them
    FixedFilm sum;
    /// Iteration 1's own estimate, where the run may end after it (RunSetup::
    /// first_iteration_estimate) and it was valid: a resumed run that ends there states it.
    std::optional<ErrorEstimate> first;
};

/// What a checkpoint must hold to resume a run.
struct CheckpointShape {
    uint64_t fingerprint = 0;
    int width = 0, height = 0;  ///< the camera's
    bool layered = false;       ///< the film has layers (the photon gather)
    bool bias = false;          ///< the sum has bias halves (FixedFilm::bias)
    int max_iterations = 0;     ///< the most iterations a run takes
};

/// The file's bytes: a header line "fogmap checkpoint 7", the fields little-endian (the film's
/// values, then the count of `first`'s, 0 without it, and those: error_estimate.h,
/// estimate_values), then the FNV-1a checksum of everything before it.
std::string checkpoint_bytes(const Checkpoint& c);

/// Reads the checkpoint at `path` for a run of `shape`. Throws InputError{path, FIELD, reason}
/// (FIELD names the checkpoint's field: format, size, fingerprint, checksum, iterations, width,
/// height, layers, bias, counts, values, estimate) when the file is unreadable, a folder, not a
/// checkpoint, of another size than such a run's, written for another scene, settings or input
/// files, corrupt, or its fields disagree with the run or each other. Reads at most the size such a
/// run's has.
Checkpoint read_checkpoint(const std::string& path, const CheckpointShape& shape);

}  // namespace fogmap
