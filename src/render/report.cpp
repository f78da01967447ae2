#include "render/report.h"

#include <cmath>
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

nlohmann::json radii_json(const IterationReport::Radii& r) {
    return {r.global, r.caustic, r.volume};
}

std::string general(double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.3g", v);
    return buf;
}

/// Below this many degrees of freedom the interval's line says why it is wide (Student's t then
/// 2.26 or more, where the normal's is 1.96).
constexpr double kFewDegrees = 9.0;

/// "error estimate: relMSE X [lo, hi] (95%) ..." and the tail's line, or why there is none.
std::string error_text(const ErrorReport& e) {
    if (!e.valid) return "error estimate: none (" + e.why + ")\n";
    std::string text = "error estimate: relMSE " + general(e.rel_mse) + " [" + general(e.lo) +
                       ", " + general(e.hi) + "] (95%), from " + std::to_string(e.batches) +
                       " batches of " + e.batched_by;
    // Few degrees of freedom: a few blocks carry the error and the interval widens (Student's t).
    if (e.dof < kFewDegrees)
        text += "; a few blocks of the image carry it (" + fixed(e.dof, 1) +
                " degrees of freedom), which widens the interval";
    text += "\n";
    const std::string of_which = "error estimate: of which " + e.bias_of + " bias²";
    if (e.bias_valid && e.bias2 <= 0.0)  // noise about a small bias
        text += of_which + ": too small to measure here (95% upper bound " +
                general(std::max(e.bias_hi, 0.0)) + ")\n";
    else if (e.bias_valid) {
        text += of_which + " " + general(e.bias2) + " [" + general(e.bias_lo) + ", " +
                general(e.bias_hi) + "] (95%)\n";
        if (e.bias_lo > 0.0)
            text += "error estimate: " + e.bias_of + " bias is measurable: " + e.bias_remedy + "\n";
    }
    if (!e.excludes.empty()) text += "error estimate: not in it: " + e.excludes + "\n";
    if (e.target > 0.0)
        text += "error estimate: target relMSE " + general(e.target) +
                (e.reached ? " reached after " + std::to_string(e.iterations) + " iterations\n"
                           : " not reached in " + std::to_string(e.iterations) + " iterations: " +
                                 (e.unreached.empty()
                                      ? "the time budget or the iteration cap ended the run"
                                      : e.unreached) +
                                 "\n");
    if (e.tail)
        text += "error estimate: 0.1% of the pixels carry " + fixed(100.0 * e.tail_share, 0) +
                "% of it (the most: pixel (" + std::to_string(e.top_x) + ", " +
                std::to_string(e.top_y) +
                ")): fireflies, whose like may come that no estimate from samples can see, or a "
                "feature a pixel or two wide that its neighbours say too dim (a light seen in a "
                "medium, a caustic's focus), where the estimate errs high\n";
    return text;
}

nlohmann::json error_json(const ErrorReport& e) {
    if (!e.valid) return {{"valid", false}, {"why", e.why}};
    return {{"valid", true},
            {"rel_mse", e.rel_mse},
            {"lo", e.lo},
            {"hi", e.hi},
            {"confidence", 0.95},
            {"dof", std::isfinite(e.dof) ? nlohmann::json(e.dof) : nlohmann::json()},
            {"bias2", e.bias_valid
                          ? nlohmann::json{{"value", e.bias2}, {"lo", e.bias_lo}, {"hi", e.bias_hi}}
                          : nlohmann::json()},
            {"batches", e.batches},
            {"batched_by", e.batched_by},
            {"tail_share", e.tail_share},
            {"tail", e.tail},
            {"top_pixel", {e.top_x, e.top_y}},
            {"excludes", e.excludes},
            {"target", e.target > 0.0 ? nlohmann::json(e.target) : nlohmann::json()},
            {"reached", e.reached},
            {"unreached", e.unreached.empty() ? nlohmann::json() : nlohmann::json(e.unreached)},
            {"iterations", e.iterations}};
}

}  // namespace

void add_phase(Report* report, const std::string& name, double s) {
    for (auto& [n, t] : report->phases_s)
        if (n == name) {
            t += s;
            return;
        }
    report->phases_s.emplace_back(name, s);
}

std::string report_text(const Report& r) {
    std::ostringstream out;
    out << "scene: " << r.scene << "\n";
    out << "settings: " << r.settings.dump() << "\n";
    out << r.plan_text;
    for (const MapReport& m : r.maps) {
        out << m.name << " map: " << m.stored << " photons (" << m.emitted << " emitted), "
            << m.bytes << " bytes, "
            << fixed(m.stored > 0 ? double(m.bytes) / double(m.stored) : 0.0, 1)
            << " bytes/photon, tree built in " << fixed(m.build_s, 3) << " s"
            << (m.beams > 0 ? "; " + std::to_string(m.beams) + " photon beams" : "")
            << (m.stopped.empty() ? "" : "; " + m.stopped) << "\n";
    }
    if (r.photons_emitted > 0) out << "photons emitted: " << r.photons_emitted << "\n";
    for (const auto& st : r.streams)
        out << "stream " << st["name"].get<std::string>() << ": " << st["attempts"] << " attempts, "
            << st["photons"] << " photons, " << fixed(100.0 * st["media_share"].get<double>(), 1)
            << "% reach the media; stored global " << st["stored"]["global"] << ", caustic "
            << st["stored"]["caustic"] << ", volume " << st["stored"]["volume"] << "\n";
    out << "image: " << r.width << " x " << r.height << ", " << r.spp << " spp, " << r.threads
        << " threads" << (r.ranks > 1 ? " per rank, " + std::to_string(r.ranks) + " MPI ranks" : "")
        << (r.parts > 0 ? " per part, " + std::to_string(r.parts) + " parts merged" : "") << "\n";
    double total = 0.0;
    if (r.parts > 0)
        out << "time: the parts' seconds added up (their processes' time, not the wall clock), "
               "then the merge's\n";
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
    out << "samples cut by render.max_depth: " << r.depth_capped << "\n";
    if (r.photons_emitted > 0)
        out << "photon paths cut by photons.max_bounces: " << r.photons_capped << " ("
            << fixed(100.0 * r.photons_capped_power, 3) << "% of the emitted power)\n";
    for (const IterationReport& it : r.iterations)
        out << "iteration " << it.index << ": " << fixed(it.elapsed_s, 2) << " s, radii "
            << radii_json(it.radii).dump()
            << (it.rel_mse >= 0.0 ? ", relmse " + nlohmann::json(it.rel_mse).dump() : "") << "\n";
    for (const std::string& w : r.warnings) out << "warning: " << w << "\n";
    out << "image mean: " << r.mean << "\n";
    out << error_text(r.error);
    if (!r.reference.empty())
        out << "error vs " << r.reference << ": rmse " << r.rmse << ", relmse " << r.rel_mse
            << ", bias " << r.bias << "\n";
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
    nlohmann::json iterations = nlohmann::json::array();
    for (const IterationReport& it : r.iterations)
        iterations.push_back({{"index", it.index},
                              {"elapsed_s", it.elapsed_s},
                              {"radii", radii_json(it.radii)},
                              {"volume_k", it.volume_k},
                              {"rel_mse", it.rel_mse},
                              {"photon_bytes", it.photon_bytes}});
    nlohmann::json maps = nlohmann::json::object();
    for (const MapReport& m : r.maps)
        maps[m.name] = {{"stored", m.stored},
                        {"emitted", m.emitted},
                        {"bytes", m.bytes},
                        {"bytes_per_photon", m.stored > 0 ? double(m.bytes) / m.stored : 0.0},
                        {"build_s", m.build_s},
                        {"stopped", m.stopped},
                        {"beams", m.beams}};
    return {{"scene", r.scene},
            {"settings", r.settings},
            {"width", r.width},
            {"height", r.height},
            {"spp", r.spp},
            {"threads", r.threads},
            {"time_s", phases},
            {"ranks", r.ranks},
            {"parts", r.parts},
            {"samples", r.samples},
            {"samples_per_s", per_second(r.samples, r.render_s)},
            {"rays", r.rays},
            {"rays_per_s", per_second(r.rays, r.render_s)},
            {"nonfinite_samples", r.nonfinite},
            {"work",
             {{"steps", r.steps},
              {"lookups", r.lookups},
              {"gathered", r.gathered},
              {"photon_steps", r.photon_steps},
              {"photon_interactions", r.photon_interactions},
              {"precompute_nodes", r.precompute_nodes},
              {"estimate_events", r.estimate_events}}},
            {"outputs", r.outputs},
            {"plan", r.plan},
            {"photons_emitted", r.photons_emitted},
            {"capped",
             {{"samples_by_max_depth", r.depth_capped},
              {"photon_paths_by_max_bounces", r.photons_capped},
              {"photon_power_fraction", r.photons_capped_power}}},
            {"maps", maps},
            {"streams", r.streams},
            {"mean", r.mean},
            {"iterations", iterations},
            {"warnings", r.warnings},
            {"error_estimate", error_json(r.error)},
            {"reference", r.reference.empty() ? nlohmann::json()
                                              : nlohmann::json{{"file", r.reference},
                                                               {"rmse", r.rmse},
                                                               {"rel_mse", r.rel_mse},
                                                               {"bias", r.bias}}}};
}

}  // namespace fogmap
