#pragma once
// Part files of a run split over processes that never talk (`fogmap render --part i/N`, merged by
// `fogmap merge`; docs/distributed.md): one part's sums (render/pipeline.h, PartSums) and what a
// merge must know of the run — its resolved settings, method and film shape, and fingerprints of
// the settings and of the input files' contents, so that parts of different runs are told apart.
// Written atomically; nothing in a part file is trusted before it is checked against itself (a
// checksum of all of it) and against the other parts.

#include "render/pipeline.h"
#include "render/run_setup.h"

#include <cstdint>
#include <string>

namespace fogmap {

/// The run a part belongs to, as the part file states it.
struct PartRun {
    int index = 1, count = 1;  ///< part index of count, 1-based
    uint64_t seed = 0;         ///< render.seed, named apart for its message
    uint64_t settings = 0;     ///< fingerprint of the resolved run (not render.threads)
    uint64_t inputs = 0;       ///< fingerprint of the input files' contents
    RunSetup setup;            ///< the resolved run: its desc, method and progressive alone
};

/// A part file's content.
struct PartFile {
    PartRun run;
    PartSums sums;
};

/// The file's bytes: a header line "fogmap part 4", a JSON block (the run, the film's shape, the
/// part's unfinished report), the counts, the film's values (runs of zeros stored as their
/// length: a plain render's part holds its own tiles alone), the count of iteration 1's estimate
/// values (0 where the part holds none) and those (render/error_estimate.h, estimate_values),
/// then the FNV-1a checksum of everything before it, all integers little-endian.
std::string part_bytes(const PartFile& part);

/// The run the part file at `path` belongs to, from its first bytes alone (no checksum: read_part
/// checks the whole). Throws InputError{path, FIELD, reason} (FIELD: size, format, run).
PartRun read_part_run(const std::string& path);

/// Reads the part file at `path`. Throws InputError{path, FIELD, reason} (FIELD: size, format,
/// checksum, run, counts, values, estimate) when it is unreadable, not a part file, corrupt, or its
/// fields disagree with each other.
PartFile read_part(const std::string& path);

/// The fingerprint PartRun::settings of `setup`.
uint64_t part_settings_fingerprint(const RunSetup& setup);

}  // namespace fogmap
