#include "bench/bench.h"

#include "core/ranks.h"
#include "core/timer.h"
#include "render/metrics.h"
#include "render/pipeline.h"
#include "render/run_setup.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>
#include <sstream>

namespace fogmap {

namespace {

std::string csv_field(const std::string& s) {
    if (s.find_first_of(",\"\n") == std::string::npos) return s;
    std::string out = "\"";
    for (char c : s) {
        if (c == '"') out += '"';
        out += c;
    }
    return out + "\"";
}

std::string number(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.6g", v);
    return buf;
}

/// Four significant digits for the summary table.
std::string short_number(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.4g", v);
    return buf;
}

std::string padded(const std::string& s, size_t width) {
    return s.size() >= width ? s + " " : s + std::string(width - s.size(), ' ');
}

/// relMSE of the path tracer at `time_s`, interpolated linearly in log-log between the path rows
/// (sorted by time) and extrapolated with the nearest segment's slope outside them; sets
/// *extrapolated. NaN if there are no usable path rows.
double path_error_at(const std::vector<const BenchRow*>& path, double time_s, bool* extrapolated) {
    *extrapolated = false;
    std::vector<const BenchRow*> p;
    for (const BenchRow* r : path)
        if (r->total_s > 0.0 && r->error() > 0.0) p.push_back(r);
    if (p.empty()) return std::nan("");
    if (p.size() == 1) {
        *extrapolated = time_s != p[0]->total_s;
        return p[0]->error();
    }
    size_t i = 0;  // segment [i, i+1]
    while (i + 2 < p.size() && time_s > p[i + 1]->total_s) ++i;
    *extrapolated = time_s < p.front()->total_s || time_s > p.back()->total_s;
    const double x0 = std::log(p[i]->total_s), x1 = std::log(p[i + 1]->total_s);
    const double y0 = std::log(p[i]->error()), y1 = std::log(p[i + 1]->error());
    if (x1 == x0) return std::exp(0.5 * (y0 + y1));
    const double t = (std::log(time_s) - x0) / (x1 - x0);
    return std::exp(y0 + t * (y1 - y0));
}

}  // namespace

std::vector<std::vector<std::string>> sweep_runs(const std::vector<SweepAxis>& axes) {
    std::vector<std::vector<std::string>> runs{{}};
    for (const SweepAxis& axis : axes) {
        std::vector<std::vector<std::string>> next;
        next.reserve(runs.size() * axis.values.size());
        for (const auto& run : runs) {
            for (const std::string& v : axis.values) {
                next.push_back(run);
                next.back().push_back(axis.key + "=" + v);
            }
        }
        runs = std::move(next);
    }
    return runs;
}

double median(std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    const size_t n = v.size();
    return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

BenchRow run_bench_case(const SceneDesc& desc, int repeats, const Image& reference, Ranks* ranks) {
    BenchRow row;
    const RunSetup setup = resolve_run(desc);
    row.method = integrator_name(setup.method);
    const bool progressive = setup.photon() && desc.progressive.enabled();
    row.spp = progressive ? setup.run.render.spp : desc.render.spp;  // as the run takes it
    row.repeats = std::max(repeats, 1);
    row.measured = !reference.pixels.empty();
    std::vector<std::vector<double>> phases(kBenchPhases.size());
    std::vector<double> totals, rmse, rel_mse, bias, est, est_lo, est_hi;
    for (int rep = 0; rep < row.repeats; ++rep) {
        const Timer timer;
        const PipelineResult result = run_pipeline(desc, /*quiet=*/true, nullptr, ranks);
        totals.push_back(timer.seconds());
        row.ranks = result.report.ranks;
        row.threads = result.report.threads;
        for (size_t p = 0; p < kBenchPhases.size(); ++p) {
            double s = 0.0;
            for (const auto& [name, t] : result.report.phases_s)
                if (name == kBenchPhases[p]) s += t;
            phases[p].push_back(s);
        }
        if (ranks && ranks->rank() != 0) continue;  // rank 0 alone holds the image
        const ErrorReport& own = result.report.error;
        row.est_valid = own.valid;
        est.push_back(own.rel_mse);
        est_lo.push_back(own.lo);
        est_hi.push_back(own.hi);
        if (!row.measured) continue;
        const ImageError e = image_error(result.film.beauty, reference);
        rmse.push_back(e.rmse);
        rel_mse.push_back(e.rel_mse);
        bias.push_back(e.bias);
        if (rep > 0) continue;
        for (const MapReport& m : result.report.maps) {
            row.bytes += m.bytes;
            for (size_t i = 0; i < kBenchMaps.size(); ++i)
                if (m.name == kBenchMaps[i]) row.stored[i] = m.stored;
        }
    }
    row.rmse = median(rmse);
    row.rel_mse = median(rel_mse);
    row.bias = median(bias);
    row.est_rel_mse = median(est);
    row.est_lo = median(est_lo);
    row.est_hi = median(est_hi);
    for (size_t p = 0; p < kBenchPhases.size(); ++p) row.phase_s[p] = median(phases[p]);
    row.total_s = median(totals);
    return row;
}

std::string bench_csv_header(const std::vector<std::string>& swept_keys) {
    std::string h = "method";
    for (const std::string& k : swept_keys) h += "," + csv_field(k);
    h += ",spp,repeats,ranks,threads";
    for (const char* phase : kBenchPhases) {
        std::string name = std::string(phase) + "_s";
        std::replace(name.begin(), name.end(), ' ', '_');
        h += "," + name;
    }
    h += ",total_s";
    for (const char* map : kBenchMaps) h += std::string(",stored_") + map;
    return h + ",bytes,rmse,rel_mse,bias,est_rel_mse,est_lo,est_hi\n";
}

std::string bench_csv_row(const BenchRow& row) {
    std::string s = csv_field(row.method);
    for (const std::string& v : row.swept) s += "," + csv_field(v);
    s += "," + std::to_string(row.spp) + "," + std::to_string(row.repeats) + "," +
         std::to_string(row.ranks) + "," + std::to_string(row.threads);
    for (double t : row.phase_s) s += "," + number(t);
    s += "," + number(row.total_s);
    for (uint64_t n : row.stored) s += "," + std::to_string(n);
    s += "," + std::to_string(row.bytes);
    s += row.measured ? "," + number(row.rmse) + "," + number(row.rel_mse) + "," + number(row.bias)
                      : ",,,";
    s += row.est_valid
             ? "," + number(row.est_rel_mse) + "," + number(row.est_lo) + "," + number(row.est_hi)
             : ",,,";
    return s + "\n";
}

std::vector<size_t> pareto_frontier(const std::vector<double>& time_s,
                                    const std::vector<double>& error) {
    std::vector<size_t> order(std::min(time_s.size(), error.size()));
    std::iota(order.begin(), order.end(), size_t{0});
    // By time, then error, then index: a point is on the frontier iff its error is below that of
    // every point before it in this order (which are all at least as fast).
    std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
        if (time_s[a] != time_s[b]) return time_s[a] < time_s[b];
        if (error[a] != error[b]) return error[a] < error[b];
        return a < b;
    });
    std::vector<size_t> frontier;
    for (size_t i : order)
        if (frontier.empty() || error[i] < error[frontier.back()]) frontier.push_back(i);
    return frontier;
}

std::string bench_label(const BenchRow& row, const std::vector<std::string>& swept_keys) {
    std::string label;
    for (size_t i = 0; i < swept_keys.size() && i < row.swept.size(); ++i) {
        if (row.swept[i].empty()) continue;
        if (!label.empty()) label += " ";
        label += swept_keys[i] + "=" + row.swept[i];
    }
    if (row.method == "path" || label.empty()) {
        const std::string base = row.method + " " + std::to_string(row.spp) + " spp";
        label = label.empty() ? base : base + " " + label;
    }
    return label;
}

std::string bench_summary(const std::vector<BenchRow>& rows,
                          const std::vector<std::string>& swept_keys) {
    std::vector<const BenchRow*> photon, path;
    for (const BenchRow& r : rows) (r.method == "path" ? path : photon).push_back(&r);
    std::sort(path.begin(), path.end(),
              [](const BenchRow* a, const BenchRow* b) { return a->total_s < b->total_s; });

    std::ostringstream out;
    std::vector<double> t, e;
    for (const BenchRow* r : photon) {
        t.push_back(r->total_s);
        e.push_back(r->error());
    }
    const std::vector<size_t> frontier = pareto_frontier(t, e);
    out << "Pareto frontier of the photon runs (best setting at each time budget):\n";
    if (!rows.empty() && !rows.front().measured)
        out << "  (no reference: relMSE is each run's own estimate, render/error_estimate.h)\n";
    out << "  " << padded("total_s", 10) << padded("relMSE", 12) << padded("path relMSE", 14)
        << padded("path/photon", 13) << "setting\n";
    for (size_t i : frontier) {
        const BenchRow& r = *photon[i];
        bool extrapolated = false;
        const double pe = path_error_at(path, r.total_s, &extrapolated);
        const std::string pe_text =
            std::isnan(pe) ? "-" : short_number(pe) + (extrapolated ? "*" : "");
        const std::string ratio =
            std::isnan(pe) || r.error() <= 0.0 ? "-" : short_number(pe / r.error()) + "x";
        out << "  " << padded(short_number(r.total_s), 10) << padded(short_number(r.error()), 12)
            << padded(pe_text, 14) << padded(ratio, 13) << bench_label(r, swept_keys) << "\n";
    }
    if (photon.empty()) out << "  (no photon runs)\n";
    out << "  (path relMSE: the path tracer at the same total time, interpolated log-log between "
           "its runs; * = extrapolated; path/photon > 1: the photon map has the lower error)\n";
    out << "Path tracer:\n";
    out << "  " << padded("total_s", 10) << padded("relMSE", 12) << "spp\n";
    for (const BenchRow* r : path)
        out << "  " << padded(short_number(r->total_s), 10) << padded(short_number(r->error()), 12)
            << r->spp << "\n";
    if (path.empty()) out << "  (no path runs)\n";
    return out.str();
}

std::string ranks_summary(const std::vector<BenchRow>& rows,
                          const std::vector<std::string>& swept_keys) {
    // Rows with the same method, spp and swept values are one setting.
    auto setting = [&](const BenchRow& r) {
        std::string key = r.method + " " + std::to_string(r.spp);
        for (const std::string& v : r.swept) key += "\n" + v;
        return key;
    };
    std::vector<std::string> keys;
    std::vector<std::vector<const BenchRow*>> groups;
    for (const BenchRow& r : rows) {
        const size_t g = std::find(keys.begin(), keys.end(), setting(r)) - keys.begin();
        if (g == keys.size()) {
            keys.push_back(setting(r));
            groups.emplace_back();
        }
        groups[g].push_back(&r);
    }
    std::ostringstream out;
    for (const std::vector<const BenchRow*>& g : groups) {
        if (g.size() < 2) continue;
        const BenchRow* base = *std::min_element(
            g.begin(), g.end(),
            [](const BenchRow* a, const BenchRow* b) { return a->ranks < b->ranks; });
        out << "  " << bench_label(*base, swept_keys) << ":\n";
        for (const BenchRow* r : g) {
            double comm = 0.0;
            for (size_t p = 0; p < kBenchPhases.size(); ++p)
                if (std::string(kBenchPhases[p]) == "photon exchange" ||
                    std::string(kBenchPhases[p]) == "reduce")
                    comm += r->phase_s[p];
            const std::string who =
                std::to_string(r->ranks) + (r->ranks == 1 ? " rank" : " ranks") + " x " +
                std::to_string(r->threads) + (r->threads == 1 ? " thread" : " threads");
            out << "    " << padded(who, 22) << padded(short_number(r->total_s) + " s", 12)
                << padded(short_number(base->total_s / r->total_s) + "x the speed", 20)
                << padded("communication " +
                              short_number(r->total_s > 0.0 ? 100.0 * comm / r->total_s : 0.0) +
                              "%",
                          24)
                << "relMSE " << short_number(r->error()) << "\n";
        }
    }
    if (out.str().empty()) return "";
    return "Across rank counts (speed: the fewest ranks' time over this time; communication: "
           "photon exchange and reduction, share of the run):\n" +
           out.str();
}

}  // namespace fogmap
