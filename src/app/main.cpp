// fogmap command line: render, info, volume, validate, bench, merge. Parses arguments with CLI11
// and maps failures to exit codes: 0 success, 2 bad input (InputError or bad arguments), 1 anything
// else (out of memory included). Every failure prints one line "fogmap: error: ...".

#include "app/commands.h"
#include "app/mpi_ranks.h"
#include "core/error.h"
#include "core/memory_budget.h"
#include "core/output_files.h"
#include "media/density_grid.h"
#include "media/vdb_probe.h"

#include <CLI/CLI.hpp>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream>
#include <new>
#include <string>

namespace {

/// One line of CLI11's message (it may hold several), for "fogmap: error: <command line>: ...".
std::string one_line(std::string text) {
    for (char& c : text)
        if (c == '\n' || c == '\r') c = ' ';
    while (!text.empty() && text.back() == ' ') text.pop_back();
    return text;
}

/// Peak memory of the process so far (VmPeak in /proc/self/status), bytes; 0 if unknown.
uint64_t peak_bytes() {
    std::ifstream status("/proc/self/status");
    std::string key;
    while (status >> key) {
        uint64_t kb = 0;
        if (key == "VmPeak:" && status >> kb) return kb << 10;
    }
    return 0;
}

/// Runs this program again with glibc's malloc advising transparent huge pages for its heap and
/// large blocks (GLIBC_TUNABLES glibc.malloc.hugetlb=1; glibc reads tunables only at start), where
/// the kernel gives them on advice alone (/sys/kernel/mm/transparent_hugepage/enabled
/// "[madvise]", Debian's default). The grids (OpenVDB's leaves, moments, sun shadows) then fault
/// in 2 MB at a time and miss the TLB less: on smoke1 over the ground (160x120, 7 paired runs)
/// a 64-spp photon render took 0.89 of the wall time, ten progressive iterations and a 256-spp
/// path render 0.95 (5 paired runs each). Returns if the variable is set already (by the user,
/// or by the first run) or exec fails.
void run_with_huge_pages(char** argv) {
    const char* tunables = std::getenv("GLIBC_TUNABLES");
    if (tunables && std::strstr(tunables, "glibc.malloc.hugetlb")) return;
    std::ifstream mode("/sys/kernel/mm/transparent_hugepage/enabled");
    std::string line;
    if (!std::getline(mode, line) || line.find("[madvise]") == std::string::npos) return;
    std::string value = "glibc.malloc.hugetlb=1";
    if (tunables && *tunables) value = std::string(tunables) + ":" + value;
    if (setenv("GLIBC_TUNABLES", value.c_str(), 1) != 0) return;
    execv("/proc/self/exe", argv);
}

}  // namespace

int main(int argc, char** argv) {
    using namespace fogmap;
    run_with_huge_pages(argv);
    CLI::App app{"fogmap: volumetric photon mapping for OpenVDB smoke, fog and clouds"};
    app.require_subcommand(1);
    install_output_signal_handlers();    // temp outputs are removed on SIGINT/TERM/HUP/QUIT
    enable_vdb_probe("/proc/self/exe");  // OpenVDB reads each file in a child first: vdb_probe.h

    RenderArgs render;
    int spp = 0, threads = 0, max_depth = 0, iterations = 0;
    long long seed = 0;
    double time_budget = 0.0, alpha = 0.0, target_relmse = 0.0;
    CLI::App* r = app.add_subcommand("render", "render a scene file to EXR + PNG");
    r->add_option("scene", render.scene, "scene JSON file, or a VDB cache (a scene made for it)")
        ->required();
    r->add_flag("--dry-run", render.dry_run,
                "check the run, print its plan, predicted peak memory and work, and stop");
    r->add_option("--write-scene", render.write_scene,
                  "write the scene (a VDB's made scene, --set applied) to this JSON file and stop");
    r->add_option("-o,--output", render.output, "output .exr (default out/<scene>.exr)");
    r->add_option("--png", render.png, "PNG preview path (default beside the EXR)");
    r->add_option("--set", render.overrides, "override a setting, e.g. render.spp=64")->take_all();
    r->add_option("--spp", spp, "samples per pixel (= --set render.spp=N)");
    r->add_option("--threads", threads, "worker threads, 0 = all (= --set render.threads=N)");
    r->add_option("--seed", seed, "random seed (= --set render.seed=N)");
    r->add_option("--max-depth", max_depth, "max scattering vertices (= --set render.max_depth=N)");
    r->add_option("--reference", render.reference, "reference .exr: report RMSE, relMSE, bias");
    r->add_option("--exposure", render.exposure, "PNG exposure in stops");
    r->add_flag("--progressive", render.progressive,
                "progressive photon mapping (Knaus and Zwicker 2011); needs a budget below");
    r->add_option("--time-budget", time_budget,
                  "progressive: seconds to run (= --set progressive.time_budget=S)");
    r->add_option("--iterations", iterations,
                  "progressive: iterations to run (= --set progressive.iterations=N)");
    r->add_option("--target-relmse", target_relmse,
                  "run iterations until the error estimate's 95% upper bound is at most this "
                  "relMSE (= --set progressive.target_relmse=X)");
    r->add_option("--alpha", alpha,
                  "progressive: radius reduction in (0, 1) (= --set progressive.alpha=A)");
    r->add_flag("-q,--quiet", render.quiet, "no progress bar");
    r->add_flag("--json", render.json, "print the report as JSON on stdout");
    r->add_option("--frames", render.frames,
                  "render frames FIRST-LAST[:STEP]: media files and outputs hold a frame pattern "
                  "(####, $F4 or %04d)");
    r->add_flag("--resume", render.resume,
                "skip frames already written; continue a progressive run from its checkpoint");
    r->add_option("--checkpoint-every", render.checkpoint_every,
                  "progressive: write <output>.checkpoint every S seconds (for --resume)");
    r->add_option("--part", render.part,
                  "I/N: render part I of N of the image to a part file (-o, .fogpart) for "
                  "fogmap merge: a farm without MPI");

    std::string info_path;
    bool info_json = false;
    CLI::App* info = app.add_subcommand("info", "list the grids of a VDB file");
    info->add_option("file", info_path, "VDB file")->required();
    info->add_flag("--json", info_json, "JSON output");

    VolumeArgs volume;
    CLI::App* vol = app.add_subcommand("volume", "generate a procedural density grid");
    vol->add_option("shape", volume.shape, "cloud, plume or fireball (density + temperature)")
        ->required();
    vol->add_option("-o,--output", volume.output, "output .vdb")->required();
    vol->add_option("--resolution", volume.resolution, "voxels along the longest axis");
    vol->add_option("--voxel-size", volume.voxel_size, "world units per voxel");
    vol->add_option("--seed", volume.seed, "noise seed")->check(seed_check());
    vol->add_flag("--velocity", volume.velocity,
                  "plume, fireball: also write a vec3s grid vel, the sequence's rising motion in "
                  "world units per second at 24 frames per second (for camera.shutter)");
    vol->add_option("--frames", volume.frames,
                    "FIRST-LAST[:STEP]: a time-varying sequence; -o holds a frame pattern (####)");

    VdbChildTask child;
    CLI::App* probe = app.add_subcommand("__probe-vdb", "the child of vdb_probe.h");
    probe->group("");  // hidden from --help
    probe->add_option("file", child.path)->required();
    probe->add_option("--what", child.what)->required();
    probe->add_option("--grid", child.grid);
    probe->add_option("--threads", child.threads);
    probe->add_option("--cpu-seconds", child.cpu_s)->required();
    probe->add_option("--memory-bytes", child.memory_bytes)->required();

    const Subcommand extra[] = {add_validate_command(app), add_bench_command(app),
                                add_merge_command(app)};

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        if (e.get_exit_code() == 0) return app.exit(e);  // --help
        std::fprintf(stderr, "fogmap: error: <command line>: %s (see fogmap --help)\n",
                     one_line(e.what()).c_str());
        return 2;
    }
    // mpirun: every rank runs the render; rank 0 alone prints and writes (app/mpi_ranks.h).
    std::unique_ptr<Ranks> ranks;
    bool mpi = bool(*r);
    for (const Subcommand& sub : extra) mpi = mpi || (bool(*sub.app) && sub.mpi);
    if (mpi) {
        ranks = start_mpi(&argc, &argv);
        render.ranks = ranks.get();
    }
    const bool root = !ranks || ranks->rank() == 0;
    // A failure other than bad input is this rank's alone: the others may wait for it in a
    // collective, so it ends the whole job (MPI_Abort) rather than leave them hanging.
    const auto failed = [&](int code, const std::string& text) {
        const std::string who = ranks ? "rank " + std::to_string(ranks->rank()) + ": " : "";
        std::fprintf(stderr, "fogmap: error: %s%s\n", who.c_str(), text.c_str());
        if (ranks && ranks->size() > 1) abort_mpi(code);
        return code;
    };
    try {
        if (*r) {
            if (r->count("--spp")) render.overrides.push_back("render.spp=" + std::to_string(spp));
            if (r->count("--threads"))
                render.overrides.push_back("render.threads=" + std::to_string(threads));
            if (r->count("--seed"))
                render.overrides.push_back("render.seed=" + std::to_string(seed));
            if (r->count("--max-depth"))
                render.overrides.push_back("render.max_depth=" + std::to_string(max_depth));
            if (r->count("--time-budget"))
                render.overrides.push_back("progressive.time_budget=" +
                                           r->get_option("--time-budget")->as<std::string>());
            if (r->count("--iterations"))
                render.overrides.push_back("progressive.iterations=" + std::to_string(iterations));
            if (r->count("--target-relmse"))
                render.overrides.push_back("progressive.target_relmse=" +
                                           r->get_option("--target-relmse")->as<std::string>());
            if (r->count("--alpha"))
                render.overrides.push_back("progressive.alpha=" +
                                           r->get_option("--alpha")->as<std::string>());
            return run_render(render);
        }
        if (*probe) return run_vdb_child(child);
        if (*info) return run_info(info_path, info_json);
        if (*vol) return run_volume(volume);
        for (const Subcommand& sub : extra)
            if (*sub.app) return sub.run(ranks.get());
    } catch (const InputError& e) {
        // Every rank reads the same input and fails alike; the error is said once.
        if (root) std::fprintf(stderr, "fogmap: error: %s\n", e.what());
        return 2;
    } catch (const OutOfMemory& e) {
        return failed(1, e.what());
    } catch (const std::bad_alloc&) {
        // An allocation nobody estimated: name the scene being rendered, if any.
        const std::string file = *r ? render.scene + ": " : std::string();
        return failed(1, file + "out of memory (the process held about " + mb_text(peak_bytes()) +
                             " when an allocation failed)");
    } catch (const std::exception& e) {
        return failed(1, e.what());
    }
    return 0;
}
