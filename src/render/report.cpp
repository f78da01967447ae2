#include "render/report.h"

#include <cstdio>
#include <sstream>

namespace fogmap {

namespace {

std::string fixed(double v, int digits) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*f", digits, v);
    return buf;
}

double per_second(double n, double s) { return s > 0.0 ? n / s : 0.0; }

}  // namespace

std::string report_text(const Report& r) {
    std::ostringstream out;
    out << "scene: " << r.scene << "\n";
    out << "settings: " << r.settings.dump() << "\n";
    out << "image: " << r.width << " x " << r.height << ", " << r.spp << " spp, " << r.threads
        << " threads\n";
    double total = 0.0;
    for (const auto& [name, s] : r.phases_s) {
        out << "time " << name << ": " << fixed(s, 3) << " s\n";
        total += s;
    }
    out << "time total: " << fixed(total, 3) << " s\n";
    out << "samples: " << r.samples << " (" << fixed(per_second(r.samples, r.render_s), 0)
        << " per second)\n";
    out << "rays: " << r.rays << " (" << fixed(per_second(r.rays, r.render_s), 0)
        << " per second)\n";
    out << "non-finite samples dropped: " << r.nonfinite << "\n";
    for (const std::string& f : r.outputs) out << "wrote: " << f << "\n";
    return out.str();
}

nlohmann::json report_json(const Report& r) {
    nlohmann::json phases = nlohmann::json::object();
    double total = 0.0;
    for (const auto& [name, s] : r.phases_s) {
        phases[name] = s;
        total += s;
    }
    phases["total"] = total;
    return {{"scene", r.scene},
            {"settings", r.settings},
            {"width", r.width},
            {"height", r.height},
            {"spp", r.spp},
            {"threads", r.threads},
            {"time_s", phases},
            {"samples", r.samples},
            {"samples_per_s", per_second(r.samples, r.render_s)},
            {"rays", r.rays},
            {"rays_per_s", per_second(r.rays, r.render_s)},
            {"nonfinite_samples", r.nonfinite},
            {"outputs", r.outputs}};
}

}  // namespace fogmap
