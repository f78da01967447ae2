#pragma once
// The run report printed at the end of `fogmap render`: effective settings, per-phase wall times,
// samples, rays per second, dropped samples and output files; as text or as JSON (--json).

#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace fogmap {

struct Report {
    std::string scene;                                     ///< scene file
    nlohmann::json settings;                               ///< effective render settings
    std::vector<std::pair<std::string, double>> phases_s;  ///< phase name → wall seconds
    int width = 0, height = 0, spp = 0, threads = 0;
    uint64_t samples = 0, rays = 0, nonfinite = 0;
    double render_s = 0.0;
    std::vector<std::string> outputs;  ///< files written
};

/// Human-readable multi-line report.
std::string report_text(const Report& report);
/// The same content as JSON.
nlohmann::json report_json(const Report& report);

}  // namespace fogmap
