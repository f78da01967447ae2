#pragma once
// The run report printed at the end of `fogmap render`: effective settings, per-phase wall times,
// samples, rays per second, dropped samples and output files; as text or as JSON (--json).

#include <nlohmann/json.hpp>

#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace fogmap {

/// One photon map's figures.
struct MapReport {
    std::string name;      ///< "global", "caustic", "volume"
    uint64_t stored = 0;   ///< photons in the map
    uint64_t emitted = 0;  ///< photons emitted when it filled
    uint64_t bytes = 0;    ///< records + tree
    double build_s = 0.0;  ///< kd-tree build wall time
    std::string stopped;   ///< why it closed below its budget by rule ("" if it did not)
    uint64_t beams = 0;    ///< photon beams kept beside the volume map's photons (28 bytes each)
};

/// One iteration of a run (a plain render is one iteration; progressive runs have many).
struct IterationReport {
    int index = 0;           ///< 1-based
    double elapsed_s = 0.0;  ///< since the run started, after this iteration
    struct Radii {
        float global = 0.0f, caustic = 0.0f, volume = 0.0f;
    } radii;                  ///< the gather radii of this iteration (0: map not built)
    /// Camera paths ending in the volume map with an adaptive radius: the photons gathered where
    /// the ball holds many, k_1 (r_i / r_1)^3 (render/volume_map_end.h); 0 otherwise.
    float volume_k = 0.0f;
    double rel_mse = -1.0;    ///< of the running mean against the reference (-1: none)
    size_t photon_bytes = 0;  ///< memory of this iteration's maps
};

/// The run's estimate of its own error (render/error_estimate.h): relMSE per value.
struct ErrorReport {
    bool valid = false;                        ///< false: too few batches (why says)
    std::string why;                           ///< when not valid, why
    double rel_mse = 0.0, lo = 0.0, hi = 0.0;  ///< the estimate and its 95% interval
    /// The interval's degrees of freedom (Student's t; infinite: the normal's quantile).
    double dof = std::numeric_limits<double>::infinity();
    bool bias_valid = false;                   ///< the maps' bias² was estimated
    std::string bias_of;      ///< whose bias, possessive: "the volume map's", "the photon maps'"
    std::string bias_remedy;  ///< what lowers it
    double bias2 = 0.0, bias_lo = 0.0, bias_hi = 0.0;  ///< its part of rel_mse, interval
    int batches = 0;                           ///< batches holding samples
    std::string batched_by;                    ///< "samples" (of a pixel) or "iterations"
    double tail_share = 0.0;                   ///< share of it the top 0.1% of pixels carry
    bool tail = false;                         ///< tail_share above one half: fireflies
    int top_x = -1, top_y = -1;                ///< the pixel that carries the most of it
    std::string excludes;                      ///< the errors it cannot see ("": none known)
    double target = 0.0;                       ///< progressive.target_relmse (0: none)
    bool reached = false;                      ///< hi at most target
    /// Why the target was not reached ("": the time budget or the iteration cap ended the run).
    std::string unreached;
    int iterations = 0;                        ///< of the run (progressive)
};

struct Report {
    std::string scene;                                     ///< scene file
    nlohmann::json settings;                               ///< effective render settings
    std::vector<std::pair<std::string, double>> phases_s;  ///< phase name → wall seconds
    int width = 0, height = 0, spp = 0, threads = 0;
    int ranks = 1;  ///< MPI ranks that ran (core/ranks.h); iterations lists rank 0's own
    int parts = 0;  ///< processes of `render --part` merged (0: none); iterations lists them all
    uint64_t samples = 0, rays = 0, nonfinite = 0;
    /// The work done, counted (deterministic, whatever the machine, threads or ranks): the
    /// render's medium density evaluations and tentative collisions, its photon-map and
    /// sun-grid lookups and the photons they gathered from kd-trees, the photon pass's medium steps
    /// and photon path interactions, the nodes of the tables built once per render (camera
    /// paths ending in the volume map; the guided tracer's AdjointGrid), and the medium steps,
    /// rays and lookups of the guided tracer's pixel estimate (a few samples a pixel, whatever
    /// the render's spp).
    uint64_t steps = 0, lookups = 0, photon_steps = 0, photon_interactions = 0;
    uint64_t gathered = 0, precompute_nodes = 0, estimate_events = 0;
    double render_s = 0.0;
    std::vector<std::string> outputs;                  ///< files written
    std::string plan_text;                             ///< make_plan's five lines
    nlohmann::json plan;                               ///< the same as JSON
    std::vector<MapReport> maps;                       ///< photon maps built
    nlohmann::json streams = nlohmann::json::array();  ///< photon streams: name, attempts, ...
    uint64_t photons_emitted = 0;
    uint64_t depth_capped = 0;          ///< camera samples cut by render.max_depth
    uint64_t photons_capped = 0;        ///< photon paths cut by photons.max_bounces
    double photons_capped_power = 0.0;  ///< their power / all emitted power
    std::vector<IterationReport> iterations;
    std::vector<std::string> warnings;  ///< also printed on stderr as they arise
    double mean = 0.0;                  ///< mean of the beauty image over pixels and channels
    ErrorReport error;                  ///< estimated without a reference
    std::string reference;              ///< reference image, "" = none
    double rmse = 0.0, rel_mse = 0.0, bias = 0.0;  ///< against the reference
};

/// Adds `s` seconds to the phase `name` (appended the first time: phases keep their order).
void add_phase(Report* report, const std::string& name, double s);

/// Human-readable multi-line report.
std::string report_text(const Report& report);
/// The same content as JSON.
nlohmann::json report_json(const Report& report);

}  // namespace fogmap
