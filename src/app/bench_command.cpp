// `fogmap bench SCENE --sweep KEY=V1,V2,... --csv OUT.csv --plot OUT.svg`: renders the cross
// product of the sweeps and the path tracer at a few sample counts, measures each against a
// reference (without one, takes each run's own error estimate), writes one CSV row per run, an
// SVG plot of relMSE against time with the Pareto frontier, and prints the frontier
// (docs/measurements.md). Every setting is checked
// before the first render; the CSV and SVG appear together at the end (temp file + rename).

#include "app/commands.h"
#include "core/hash.h"

#include "bench/bench.h"
#include "bench/svg_plot.h"
#include "core/error.h"
#include "core/image.h"
#include "core/output_files.h"
#include "core/parallel.h"
#include "core/ranks.h"
#include "core/rng.h"
#include "core/timer.h"
#include "render/pipeline.h"
#include "scene/scene_desc_json.h"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>

namespace fogmap {

namespace {

namespace fs = std::filesystem;

/// `d` running integrator `i` as if the scene named it, at the volume gather depth auto would
/// take.
SceneDesc with_integrator(SceneDesc d, Integrator i) {
    d.volume.gather_depth = resolve_run(d).run.volume.gather_depth;
    d.render.integrator = i;
    return d;
}

struct BenchArgs {
    std::string scene;
    std::string reference;  ///< "" = none
    int reference_spp = 0;  ///< 0 = none
    std::vector<std::string> sweeps;
    std::string csv, plot;
    int repeat = 1;
    std::string path_spp = "1,4,16,64";
    std::vector<std::string> overrides;
    std::string ranks;  ///< "" = every rank of the job
    bool quiet = false;
};

/// Most runs one bench may make (sweep cross product plus path tracer runs): each is a render.
constexpr uint64_t kMaxBenchRuns = 1000;

/// The reference seed differs from the runs' seed: the path tracer draws sample s of a pixel
/// from Rng(seed, pixel, s), so a reference with the same seed would contain the path rows'
/// own samples and understate their error.
constexpr uint64_t kReferenceSeedOffset = stream::kBenchReference;

/// Splits at commas outside [..], {..} and "..", so JSON values such as [1,2,3] stay whole.
std::vector<std::string> split_values(const std::string& text) {
    std::vector<std::string> out;
    std::string cur;
    int depth = 0;
    bool quoted = false;
    for (char c : text) {
        if (c == '"') quoted = !quoted;
        if (!quoted && (c == '[' || c == '{')) ++depth;
        if (!quoted && (c == ']' || c == '}')) --depth;
        if (c == ',' && depth == 0 && !quoted) {
            out.push_back(cur);
            cur.clear();
        } else {
            cur += c;
        }
    }
    out.push_back(cur);
    return out;
}

SweepAxis parse_sweep(const std::string& text) {
    const std::string origin = "--sweep '" + text + "': ";
    const size_t eq = text.find('=');
    if (eq == std::string::npos || eq == 0)
        throw InputError("", "--sweep",
                         origin + "expected KEY=V1,V2,..., e.g. photons.volume=25000,100000");
    SweepAxis axis{text.substr(0, eq), split_values(text.substr(eq + 1))};
    for (const std::string& v : axis.values)
        if (v.empty())
            throw InputError("", "--sweep",
                             origin +
                                 "empty value in the list; expected KEY=V1,V2,... with "
                                 "every value non-empty");
    return axis;
}

std::vector<int> parse_path_spp(const std::string& text) {
    std::vector<int> out;
    if (text == "none") return out;
    for (const std::string& v : split_values(text)) {
        char* end = nullptr;
        errno = 0;
        const long n = std::strtol(v.c_str(), &end, 10);
        if (v.empty() || *end != '\0' || errno != 0 || n < 1 || n > 1000000)
            throw InputError("", "--path-spp",
                             "'" + v + "' in '" + text +
                                 "': expected comma-separated sample counts 1 .. 1000000, or "
                                 "'none'");
        out.push_back(int(n));
    }
    return out;
}

/// The rank counts of --ranks, each at most the job's `available` ranks.
std::vector<int> parse_ranks(const std::string& text, int available) {
    if (text.empty()) return {available};
    std::vector<int> out;
    for (const std::string& v : split_values(text)) {
        char* end = nullptr;
        errno = 0;
        const long n = std::strtol(v.c_str(), &end, 10);
        if (v.empty() || *end != '\0' || errno != 0 || n < 1 || n > 1000000)
            throw InputError(
                "", "--ranks",
                "'" + v + "' in '" + text + "': expected comma-separated rank counts >= 1");
        if (n > available)
            throw InputError("", "--ranks",
                             "'" + v + "' in '" + text + "': this job has " +
                                 std::to_string(available) + (available == 1 ? " rank" : " ranks") +
                                 "; start fogmap bench under mpirun -np " + v + " (or more)");
        out.push_back(int(n));
    }
    return out;
}

/// Writes every (path, text) pair to its temp file first and renames only when all succeeded,
/// so the CSV and the plot appear together or not at all (core/output_files.h).
void write_files_atomically(const std::vector<std::pair<std::string, std::string>>& files) {
    OutputFiles out;
    for (const auto& [path, text] : files) {
        create_output_folder(path);
        write_staged_text(out.stage(path), text);
    }
    out.commit();
}

/// The number of runs the sweeps make, counted before any is built: the product of the value
/// counts plus the path tracer runs. Throws InputError above kMaxBenchRuns, saying the count.
void check_run_count(const std::vector<SweepAxis>& axes, size_t path_runs, size_t rank_counts) {
    uint64_t runs = 1;
    bool overflow = false;
    std::string product;
    for (const SweepAxis& a : axes) {
        const uint64_t n = a.values.size();
        overflow = overflow || (n != 0 && runs > UINT64_MAX / n);
        runs = overflow ? UINT64_MAX : runs * n;
        product += (product.empty() ? "" : " x ") + std::to_string(n);
    }
    if (!overflow && (runs + path_runs) * rank_counts <= kMaxBenchRuns) return;
    throw InputError(
        "", "--sweep",
        "the sweeps make " + product + " = " +
            (overflow ? "more than " + std::to_string(UINT64_MAX) : std::to_string(runs)) +
            " runs, plus " + std::to_string(path_runs) + " path tracer runs, at " +
            std::to_string(rank_counts) + " rank count(s); expected at most " +
            std::to_string(kMaxBenchRuns) + " runs per bench (sweep fewer values)");
}

void check_size(int width, int height, const std::string& file, const SceneDesc& desc,
                const std::string& what) {
    if (width == desc.camera.width && height == desc.camera.height) return;
    throw InputError(file, "",
                     "reference is " + std::to_string(width) + "x" + std::to_string(height) + ", " +
                         what + " renders " + std::to_string(desc.camera.width) + "x" +
                         std::to_string(desc.camera.height));
}

std::string seconds(double s) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3f s", s);
    return buf;
}

LogLogPlot make_plot(const std::vector<BenchRow>& rows, const BenchArgs& args,
                     const SceneDesc& base) {
    LogLogPlot plot;
    plot.title = "fogmap bench: " + fs::path(args.scene).filename().string() + " (" +
                 std::to_string(base.camera.width) + "x" + std::to_string(base.camera.height) +
                 "), relMSE against total time";
    plot.x_label = "total wall time per run (s, log)";
    const bool measured = rows.empty() || rows.front().measured;
    plot.y_label = measured ? "relMSE vs reference (log)" : "estimated relMSE, no reference (log)";
    if (!measured) plot.title += " (estimated error)";
    PlotSeries photon{"photon map runs", "#1f77b4", PlotMarker::Circle, PlotLine::None, {}};
    PlotSeries path{
        "path tracer (spp sweep)", "#2ca02c", PlotMarker::Square, PlotLine::Straight, {}};
    std::vector<double> t, e;
    for (const BenchRow& r : rows) {
        PlotSeries& s = r.method == "path" ? path : photon;
        s.points.push_back({r.total_s, r.error()});
        if (r.method != "path") {
            t.push_back(r.total_s);
            e.push_back(r.error());
        }
    }
    std::sort(path.points.begin(), path.points.end(),
              [](const PlotPoint& a, const PlotPoint& b) { return a.x < b.x; });
    PlotSeries frontier{"photon Pareto frontier", "#ff7f0e", PlotMarker::None, PlotLine::Step, {}};
    for (size_t i : pareto_frontier(t, e)) frontier.points.push_back({t[i], e[i]});
    plot.series = {photon, frontier, path};
    return plot;
}

int run_bench(const BenchArgs& args, Ranks* world) {
    // Under mpirun every rank makes the same checks and runs; rank 0 alone prints and writes.
    const bool root = !world || world->rank() == 0;
    const bool quiet = args.quiet || !root;
    // ---- Check every input before the first render. ----
    if (fs::path(args.csv).extension() != ".csv")
        throw InputError("", "--csv", "'" + args.csv + "' does not end in .csv");
    if (fs::path(args.plot).extension() != ".svg")
        throw InputError("", "--plot", "'" + args.plot + "' does not end in .svg");
    if (args.repeat < 1)
        throw InputError("", "--repeat", "expected >= 1, found " + std::to_string(args.repeat));
    if (!args.reference.empty() && args.reference_spp != 0)
        throw InputError("", "--reference",
                         "expected at most one of --reference REF.exr or --reference-spp N");
    if (args.reference.empty() && args.reference_spp < 0)
        throw InputError("", "--reference-spp",
                         "expected >= 1, found " + std::to_string(args.reference_spp));
    if (args.sweeps.empty())
        throw InputError("", "--sweep", "expected at least one --sweep KEY=V1,V2,...");
    std::vector<SweepAxis> axes;
    std::vector<std::string> keys;
    for (const std::string& s : args.sweeps) {
        axes.push_back(parse_sweep(s));
        for (const std::string& k : keys)
            if (k == axes.back().key)
                throw InputError("", "--sweep", "'" + k + "' is swept twice; give each key once");
        keys.push_back(axes.back().key);
    }
    const std::vector<int> path_spp = parse_path_spp(args.path_spp);
    const std::vector<int> rank_counts = parse_ranks(args.ranks, world ? world->size() : 1);
    check_run_count(axes, path_spp.size(), rank_counts.size());
    const std::vector<std::pair<std::string, std::string>> inputs = {
        {args.scene, "scene file"}, {args.reference, "reference image"}};
    check_not_an_input(args.csv, "--csv", inputs);
    check_not_an_input(args.plot, "--plot", inputs);
    check_output_path(args.csv, "--csv");
    check_output_path(args.plot, "--plot");

    SceneDesc base = load_scene_desc(args.scene, args.overrides);
    const bool threads_set = base.render.threads > 0;
    if (root) cap_threads(&base);  // the warning is printed; the runs below are capped the same way
    std::vector<SceneDesc> runs;
    std::vector<std::vector<std::string>> run_values;
    for (const std::vector<std::string>& assignment : sweep_runs(axes)) {
        std::vector<std::string> overrides = args.overrides;
        overrides.insert(overrides.end(), assignment.begin(), assignment.end());
        try {
            runs.push_back(load_scene_desc(args.scene, overrides));  // the normal checks
            // The sweep measures the photon maps, the path tracer runs beside it (--path-spp):
            // a run that leaves the integrator to auto uses the photon integrator, unless
            // --set or --sweep names auto (then it runs as `fogmap render` does).
            const bool named_auto = std::find(overrides.begin(), overrides.end(),
                                              "render.integrator=auto") != overrides.end();
            if (runs.back().render.integrator == Integrator::Auto && !named_auto)
                runs.back() = with_integrator(runs.back(), Integrator::Photon);
            runs.back().render.threads = std::min(runs.back().render.threads, thread_count(0));
        } catch (const InputError& e) {
            // Name the --sweep a bad value came from rather than the --set it was applied as.
            for (size_t a = 0; a < assignment.size(); ++a) {
                const std::string from_set = " (from --set '" + assignment[a] + "')";
                const size_t at = e.reason.rfind(from_set);
                if (at != std::string::npos && at + from_set.size() == e.reason.size())
                    throw InputError(
                        e.file, e.field,
                        e.reason.substr(0, at) + " (from --sweep '" + args.sweeps[a] + "')");
            }
            throw;
        }
        std::vector<std::string> values;
        for (const std::string& a : assignment) values.push_back(a.substr(a.find('=') + 1));
        run_values.push_back(values);
    }
    for (int spp : path_spp) {
        SceneDesc d = with_integrator(base, Integrator::Path);
        d.render.spp = spp;
        runs.push_back(d);
        run_values.emplace_back(keys.size());
    }

    Image reference;
    std::string reference_file = args.reference;
    std::optional<SceneDesc> reference_desc;
    if (!args.reference.empty()) {
        reference = read_exr(args.reference);
        check_finite(reference, args.reference);
    } else if (args.reference_spp > 0) {
        // Cache name: FNV-1a of the reference's full scene JSON (to_json: every setting, with
        // integrator path, spp N, the reference seed, threads 0) plus the absolute folder that
        // relative files resolve against; so any change of scene or settings renders anew.
        SceneDesc d = with_integrator(base, Integrator::Path);
        d.render.spp = args.reference_spp;
        d.render.seed = base.render.seed + kReferenceSeedOffset;
        d.render.threads = 0;
        char hash[17];
        std::snprintf(hash, sizeof hash, "%016llx",
                      static_cast<unsigned long long>(fnv1a(
                          to_json(d).dump() + "\n" +
                          fs::absolute(base.base_dir.empty() ? "." : base.base_dir).string())));
        d.render.threads = base.render.threads;
        const fs::path dir = fs::path(args.csv).parent_path();
        reference_file = (dir / (fs::path(args.scene).stem().string() + "_ref_path" +
                                 std::to_string(args.reference_spp) + "spp_" + hash + ".exr"))
                             .string();
        reference_desc = d;
    }
    const int ref_width = reference_desc ? reference_desc->camera.width : reference.width;
    const int ref_height = reference_desc ? reference_desc->camera.height : reference.height;
    const bool with_reference = !reference_file.empty();  // else: the runs' own estimates
    for (size_t i = 0; i < runs.size(); ++i) {
        if (with_reference)
            check_size(ref_width, ref_height, reference_file, runs[i],
                       "run " + std::to_string(i + 1) + " of " + std::to_string(runs.size()));
        check_run_memory(resolve_run(runs[i]), with_reference);
    }
    // Rank 0 decides whether the cached reference exists (it alone writes it).
    std::error_code exists_ec;
    bool have_reference = reference_desc && root && fs::exists(reference_file, exists_ec);
    if (world) have_reference = world->any(have_reference);
    if (reference_desc && !have_reference) check_output_path(reference_file, "--reference-spp");

    // ---- Reference. ----
    if (reference_desc) {
        if (have_reference) {
            reference = read_exr(reference_file);
            check_finite(reference, reference_file);
            check_size(reference.width, reference.height, reference_file, *reference_desc,
                       "the scene");
            if (!quiet) std::fprintf(stderr, "reference: reusing %s\n", reference_file.c_str());
        } else {
            if (!quiet)
                std::fprintf(stderr, "reference: rendering path tracer at %d spp -> %s\n",
                             args.reference_spp, reference_file.c_str());
            const Timer timer;
            reference = run_pipeline(*reference_desc, quiet, nullptr, world).film.beauty;
            if (root) {
                create_output_folder(reference_file);
                write_exr(reference_file, reference);
            }
            if (!quiet)
                std::fprintf(stderr, "reference: done in %s\n", seconds(timer.seconds()).c_str());
        }
    }

    // ---- Runs. ----
    // At each rank count R the job's first R ranks run the setting and the others sleep.
    std::vector<BenchRow> rows;
    const size_t total = runs.size() * rank_counts.size();
    for (size_t i = 0; i < runs.size(); ++i)
        for (int n : rank_counts) {
            std::unique_ptr<Ranks> team = world ? world->split(world->rank() < n ? 0 : 1) : nullptr;
            if (team && world->rank() >= n) {
                world->wait_all();
                continue;
            }
            SceneDesc d = runs[i];
            if (team && !threads_set)
                d.render.threads = std::max(1, thread_count(0) / team->on_this_machine());
            BenchRow row = run_bench_case(d, args.repeat, reference, team.get());
            if (world) world->wait_all();
            row.swept = run_values[i];
            if (!quiet)
                std::fprintf(stderr, "[%zu/%zu] %s%s: %s, relMSE %.4g\n", rows.size() + 1, total,
                             bench_label(row, keys).c_str(),
                             world ? (", " + std::to_string(n) + " ranks").c_str() : "",
                             seconds(row.total_s).c_str(), row.error());
            rows.push_back(std::move(row));
        }
    if (!root) return 0;

    // ---- Outputs. ----
    std::string csv = bench_csv_header(keys);
    for (const BenchRow& r : rows) csv += bench_csv_row(r);
    const std::string svg = svg_log_log(make_plot(rows, args, base));
    write_files_atomically({{args.csv, csv}, {args.plot, svg}});

    std::cout << "fogmap bench: " << args.scene << ", " << base.camera.width << "x"
              << base.camera.height << ", " << rows.size() << " runs, median of " << args.repeat
              << ", reference "
              << (reference_file.empty() ? "none (errors are the runs' own estimates)"
                                         : reference_file)
              << "\n";
    for (int n : rank_counts) {
        std::vector<BenchRow> at_n;
        for (const BenchRow& r : rows)
            if (r.ranks == n) at_n.push_back(r);
        if (rank_counts.size() > 1)
            std::cout << "With " << n << (n == 1 ? " rank" : " ranks") << ":\n";
        std::cout << bench_summary(at_n, keys);
    }
    std::cout << ranks_summary(rows, keys);
    std::cout << "wrote: " << args.csv << "\nwrote: " << args.plot << "\n";
    return 0;
}

}  // namespace

Subcommand add_bench_command(CLI::App& app) {
    auto args = std::make_shared<BenchArgs>();
    CLI::App* sub = app.add_subcommand(
        "bench",
        "sweep settings; CSV and SVG plot of error against run time (vs a reference, or each "
        "run's own estimate)");
    sub->add_option("scene", args->scene, "scene JSON file")->required();
    sub->add_option("--reference", args->reference,
                    "reference .exr of the same scene and size (without one and without "
                    "--reference-spp: each run's own error estimate)");
    sub->add_option("--reference-spp", args->reference_spp,
                    "render a path-traced reference at N spp, cached beside the CSV as "
                    "<scene>_ref_path<N>spp_<FNV-1a of its scene JSON>.exr");
    sub->add_option("--sweep", args->sweeps,
                    "KEY=V1,V2,...: a setting and its values (photon integrator unless the "
                    "scene or --set names one)")
        ->expected(1)
        ->take_all();
    sub->add_option("--csv", args->csv, "output .csv, one row per run")->required();
    sub->add_option("--plot", args->plot, "output .svg: relMSE against time, log-log")->required();
    sub->add_option("--repeat", args->repeat, "runs per setting; times are medians");
    sub->add_option("--path-spp", args->path_spp,
                    "path tracer sample counts run beside the sweep, or 'none'")
        ->capture_default_str();
    sub->add_option("--set", args->overrides, "override a setting for every run, e.g. a.b=1")
        ->expected(1)
        ->take_all();
    sub->add_option("--ranks", args->ranks,
                    "under mpirun: run every setting on each of these rank counts, e.g. 1,2 "
                    "(default: all the job's ranks); threads per rank: the machine's cores over "
                    "the ranks on it, unless render.threads is set");
    sub->add_flag("-q,--quiet", args->quiet, "no progress on stderr");
    return {sub, [args](Ranks* ranks) { return run_bench(*args, ranks); }, /*mpi=*/true};
}

}  // namespace fogmap
