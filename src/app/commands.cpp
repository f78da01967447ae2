#include "app/commands.h"
#include "app/mpi_ranks.h"

#include "core/error.h"
#include "core/frames.h"
#include "core/hash.h"
#include "core/image.h"
#include "core/memory_budget.h"
#include "core/output_files.h"
#include "core/parallel.h"
#include "core/ranks.h"
#include "core/timer.h"
#include "core/world_range.h"
#include "media/density_grid.h"
#include "media/volume_gen.h"
#include "render/checkpoint.h"
#include "render/film.h"
#include "render/metrics.h"
#include "render/part_file.h"
#include "render/pipeline.h"
#include "render/report.h"
#include "render/volume_map_end.h"
#include "scene/scene.h"
#include "scene/scene_desc_json.h"
#include "scene/vdb_scene.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <thread>
#include <utility>

namespace fogmap {

namespace {

namespace fs = std::filesystem;

bool has_extension(const std::string& path, const char* ext) {
    return fs::path(path).extension() == ext;
}

nlohmann::json grid_info_json(const GridInfo& g) {
    nlohmann::json j = {{"name", g.name},
                        {"type", g.value_type},
                        {"class", g.grid_class},
                        {"voxel_size", {g.voxel_size.x, g.voxel_size.y, g.voxel_size.z}},
                        {"translation", {g.translation.x, g.translation.y, g.translation.z}},
                        {"index_min", g.index_min},
                        {"index_max", g.index_max},
                        {"active_voxels", g.active_voxels},
                        {"active_tiles", g.active_tiles}};
    if (!g.world_bounds.empty())
        j["world_bounds"] = {{g.world_bounds.lo.x, g.world_bounds.lo.y, g.world_bounds.lo.z},
                             {g.world_bounds.hi.x, g.world_bounds.hi.y, g.world_bounds.hi.z}};
    if (g.scalar) {
        j["min"] = g.min_value;
        j["max"] = g.max_value;
    }
    return j;
}

}  // namespace

std::string cap_threads(SceneDesc* desc) {
    const int cores = thread_count(0);
    if (desc->render.threads <= cores) return "";
    const std::string text = "render.threads = " + std::to_string(desc->render.threads) +
                             " is more than the " + std::to_string(cores) +
                             " cores this process may use; using " + std::to_string(cores);
    std::fprintf(stderr, "fogmap: warning: %s\n", text.c_str());
    desc->render.threads = cores;
    return text;
}

namespace {

/// What run_memory's maps hold, for messages.
std::string maps_label(const RunSetup& setup) {
    return setup.method == Method::MapEnd ? "photon maps and their lookup grids " : "photon maps ";
}

}  // namespace

RunMemory run_memory(const RunSetup& setup, bool with_reference) {
    const SceneDesc& desc = setup.run;
    const double pixels = double(desc.camera.width) * desc.camera.height;
    const bool photon = setup.photon();
    // A map variance and four bias halves where samples read photon batches.
    const int layers = 1 + kLayerCount + kBatches + (setup.photon_batches() ? 1 + 4 : 0);
    // Films of the beauty, layers, batches, and map variance and bias halves (render/film.h):
    // the run's and the iteration's it adds (pipeline.cpp), a progressive run's in fixed point
    // (FixedFilm: 8 bytes a value, no map variance, and its pixels' samples per batch); the
    // reference and, for progressive runs, the running mean compared with it; the estimate's
    // variance and samples layers; the PNG's 8-bit RGB and its encoding.
    const double sum =
        setup.progressive
            ? sizeof(int64_t) * double(FixedFilm::value_count(desc.camera.width, desc.camera.height,
                                                              /*layered=*/true,
                                                              setup.photon_batches()))
            : pixels * sizeof(Color) * layers;
    const double films = pixels * sizeof(Color) * layers + sum;
    // Adaptive sampling's first-pass figures and allocation (render/adaptive.cpp): 56 bytes a
    // pixel at most; across iterations, the measure's sums (56, summed over MPI ranks in place)
    // and the later counts (4) beside the allocation's 64, and the mean's samples per pixel and
    // batch (36). The error estimate's weights (render/error_estimate.cpp): 9 images at most.
    const double adaptive = !desc.render.adaptive ? 0.0 : setup.measured > 0 ? 160.0 : 56.0;
    const double others = pixels * (with_reference ? 2 * sizeof(Color) : 0) +
                          pixels * (2 + 9) * sizeof(Color) + pixels * 6 + pixels * adaptive;
    // 20 bytes per photon with its kd-tree (docs/measurements.md); the photon gather's beam
    // estimate keeps 48 more per volume photon, photon beams about 200 (1.5 beams per photon
    // measured on smoke.json, each 28 bytes stored and one or more 44-byte pieces in their
    // hierarchy).
    const PhotonSettings& p = setup.photons;
    const VolumeEstimator estimator = desc.volume.estimator;
    const double per_volume_photon =
        estimator == VolumeEstimator::PhotonBeams                              ? 200.0
        : estimator == VolumeEstimator::Beam && setup.method == Method::Gather ? 48.0
                                                                               : 0.0;
    // Camera paths ending in the volume map look it up from grids (VolumeMapEnd::memory_bound).
    const double end_grids =
        setup.method == Method::MapEnd ? VolumeMapEnd::memory_bound(double(p.volume)) : 0.0;
    const double maps = photon ? 20.0 * (double(p.global) + p.caustic + p.volume) +
                                     per_volume_photon * double(p.volume) + end_grids
                               : 0.0;
    return RunMemory{films + others, maps, layers};
}

void check_run_memory(const RunSetup& setup, bool with_reference) {
    const SceneDesc& desc = setup.run;
    const RunMemory m = run_memory(setup, with_reference);
    const double total = m.images + m.maps;
    const uint64_t budget = memory_budget_bytes();
    if (total <= double(budget)) return;
    const auto mb = [](double bytes) { return mb_text(static_cast<uint64_t>(bytes)); };
    const std::string images = std::to_string(desc.camera.width) + " x " +
                               std::to_string(desc.camera.height) + " pixels x " +
                               std::to_string(m.layers) + " images (beauty, layers, batches" +
                               (setup.photon_batches() ? ", the maps' variance, bias halves" : "") +
                               ") x 12 bytes x 2 films (3 for a sum of iterations), and more";
    throw InputError(desc.path, m.maps > m.images ? "/photons" : "/camera/width",
                     "the run needs about " + mb(total) + ": images " + mb(m.images) + " (" +
                         images + "), " + maps_label(setup) + mb(m.maps) + "; only " +
                         mb(double(budget)) +
                         " of memory are available; expected a smaller image or fewer photons");
}

void check_reference_size(const std::string& path, const Image& reference,
                          const CameraDesc& camera) {
    if (reference.width != camera.width || reference.height != camera.height)
        throw InputError(path, "",
                         "reference is " + std::to_string(reference.width) + "x" +
                             std::to_string(reference.height) + ", the camera renders " +
                             std::to_string(camera.width) + "x" + std::to_string(camera.height));
}

void write_image(PipelineResult* run, const std::string& exr, const std::string& png,
                 float exposure, const Image* reference, const std::string& reference_path) {
    Report& report = run->report;
    const Image& image = run->film.beauty;
    if (reference) {
        const ImageError e = image_error(image, *reference);
        report.reference = reference_path;
        report.rmse = e.rmse;
        report.rel_mse = e.rel_mse;
        report.bias = e.bias;
    }
    const Timer timer;
    create_output_folder(exr);
    create_output_folder(png);
    OutputFiles outputs;
    write_exr(outputs.stage(exr), image, run->film.named_layers());
    write_png(outputs.stage(png), image, exposure);
    outputs.commit();
    add_phase(&report, "write", timer.seconds());
    report.outputs = {exr, png};
}

void check_not_an_input(const std::string& output, const std::string& option,
                        const std::vector<std::pair<std::string, std::string>>& inputs) {
    for (const auto& [input, what] : inputs)
        if (!input.empty() && same_file(output, input))
            throw InputError(output, option,
                             "is the " + what + " of this run; expected a different output path");
}

std::vector<std::string> input_files(const SceneDesc& desc) {
    std::vector<std::string> files;
    for (const MediumDesc& m : desc.media)
        if (m.type == MediumType::Vdb) files.push_back(resolve(desc, m.file));
    for (const ShapeDesc& sh : desc.shapes)
        if (sh.type == ShapeType::Mesh) files.push_back(resolve(desc, sh.file));
    return files;
}

std::string file_digest(const std::string& path) {
    std::error_code ec;
    const uint64_t size = fs::file_size(path, ec);
    std::ifstream in(path, std::ios::binary);
    std::string sample(64 * 1024, '\0'), all = std::to_string(size) + ":";
    for (int k = 0; k < 16 && in && size > 0; ++k) {
        in.seekg(std::streamoff(size / 16 * uint64_t(k)));
        in.read(sample.data(), std::streamsize(sample.size()));
        all += std::to_string(fnv1a(sample.substr(0, size_t(in.gcount())))) + ",";
        in.clear();
    }
    return all;
}

namespace {

/// The size and modification time of every file the scene reads: a resumed run must read the
/// very files its checkpoint was made from.
std::string input_stamps(const SceneDesc& desc) {
    std::string stamps;
    for (const std::string& path : input_files(desc)) {
        std::error_code ec;
        const auto size = fs::file_size(path, ec);
        const auto time = fs::last_write_time(path, ec).time_since_epoch().count();
        stamps += path + " " + std::to_string(size) + " " + std::to_string(time) + "\n";
    }
    return stamps;
}

/// The most parts one run is split into (--part): a part renders every N-th tile at least.
constexpr int kMaxParts = 100000;

/// --part I/N as the tiles (and iterations) of rank I-1 of N; none for "". Throws InputError.
std::optional<TileShare> parse_part(const std::string& text) {
    if (text.empty()) return std::nullopt;
    const auto number = [](const std::string& t) {
        const bool digits =
            !t.empty() && t.size() <= 9 && t.find_first_not_of("0123456789") == std::string::npos;
        return digits ? std::stol(t) : -1L;
    };
    const size_t slash = text.find('/');
    const long i = number(text.substr(0, slash)),
               n = slash == std::string::npos ? -1L : number(text.substr(slash + 1));
    if (i < 1 || n < 1 || i > n || n > kMaxParts)
        throw InputError("", "--part",
                         "found '" + text + "'; expected I/N, part I of N parts (1 <= I <= N <= " +
                             std::to_string(kMaxParts) + "), e.g. 3/8");
    return TileShare{int(i - 1), int(n)};
}

/// Writes `run`'s part (`share`) to `path` with the fingerprints of its settings and input files.
void write_part(const std::string& path, const TileShare& share, PipelineResult run) {
    PartFile part;
    part.run.index = share.index + 1;
    part.run.count = share.count;
    part.run.seed = run.setup.run.render.seed;
    part.run.settings = part_settings_fingerprint(run.setup);
    std::string digests;
    for (const std::string& file : input_files(run.setup.run)) digests += file_digest(file) + "\n";
    part.run.inputs = fnv1a(digests);
    part.run.setup = std::move(run.setup);
    part.sums = std::move(*run.part);
    create_output_folder(path);
    OutputFiles out;
    write_staged_text(out.stage(path), part_bytes(part), "part file");
    out.commit();
}

/// Renders `desc` and writes `exr` and `png` (both complete before either replaces an older one,
/// core/output_files.h); returns the report. With --part, writes the part file `exr` alone.
Report render_and_write(const RenderArgs& args, SceneDesc desc, const std::string& exr,
                        const std::string& png, const Image* reference) {
    const bool root = !args.ranks || args.ranks->rank() == 0;
    const std::string threads_warning = root ? cap_threads(&desc) : "";
    RunSetup setup = resolve_run(desc);
    setup.run.render.threads = desc.render.threads;
    check_run_memory(setup, reference != nullptr);
    // Checkpoints beside the EXR: written atomically by rank 0 (the last one at the end, so a
    // finished run can be extended), read by every rank on --resume (each needs the count).
    const std::string checkpoint_path = exr + ".checkpoint";
    const uint64_t fingerprint =
        fnv1a(std::to_string(resumable_fingerprint(setup)) + "\n" + input_stamps(setup.run));
    std::optional<Checkpoint> resume;
    if (args.resume && fs::exists(checkpoint_path))
        resume = read_checkpoint(
            checkpoint_path, {fingerprint, desc.camera.width, desc.camera.height,
                              /*layered=*/true, setup.photon_batches(), kMaxProgressiveIterations});
    Checkpoints checkpoints;
    checkpoints.resume = resume ? &*resume : nullptr;
    checkpoints.every_s = args.checkpoint_every;
    checkpoints.write = [&](const Checkpoint& c) {
        Checkpoint stamped = c;
        stamped.fingerprint = fingerprint;
        OutputFiles out;
        write_staged_text(out.stage(checkpoint_path), checkpoint_bytes(stamped), "checkpoint");
        out.commit();
    };
    if (args.checkpoint_every > 0.0 && root) create_output_folder(checkpoint_path);
    const std::optional<TileShare> part = parse_part(args.part);
    PipelineResult run =
        run_pipeline(desc, args.quiet, reference, args.ranks, &checkpoints, &setup, part);
    Report& report = run.report;
    if (part) {
        const Timer timer;
        Report own = run.part->report;  // the part's lines on stdout
        write_part(exr, *part, std::move(run));
        own.phases_s.emplace_back("write", timer.seconds());
        own.outputs = {exr};
        return own;
    }
    if (!root) return std::move(report);  // rank 0 writes
    if (!threads_warning.empty()) report.warnings.insert(report.warnings.begin(), threads_warning);
    write_image(&run, exr, png, args.exposure, reference, args.reference);
    return std::move(report);
}

/// `desc` for one frame: every VDB medium's file with its frame pattern expanded.
SceneDesc frame_desc(SceneDesc desc, int frame) {
    for (MediumDesc& m : desc.media)
        if (m.type == MediumType::Vdb) m.file = expand_frame(m.file, frame);
    return desc;
}

/// What `fogmap render` checked before any work: outputs, reference, the scene's keys.
struct RenderJob {
    std::string exr, png;
    std::optional<FrameRange> range;
    Image reference;
    SceneDesc desc;
};

/// The report a render prints as JSON: a part's (the image's comes from fogmap merge) is the file
/// it wrote and its phases.
nlohmann::json render_report_json(const RenderArgs& args, const Report& report) {
    if (args.part.empty()) return report_json(report);
    nlohmann::json phases = nlohmann::json::object();
    for (const auto& [name, s] : report.phases_s) phases[name] = s;
    return {{"part", args.part},
            {"outputs", report.outputs},
            {"time_s", phases},
            {"warnings", report.warnings}};
}
/// The same as text.
std::string render_report_text(const RenderArgs& args, const Report& report) {
    if (args.part.empty()) return report_text(report);
    std::string text = "part " + args.part + ": wrote " + report.outputs.at(0) + "\n";
    for (const auto& [name, s] : report.phases_s) {
        char line[200];
        std::snprintf(line, sizeof line, "time %s: %.3f s\n", name.c_str(), s);
        text += line;
    }
    return text;
}

/// What a part (--part) cannot be combined with: parts never talk.
void check_part(const RenderArgs& args, const SceneDesc& desc) {
    if (args.ranks && args.ranks->size() > 1)
        throw InputError("", "--part",
                         "is for farms without MPI; under mpirun the ranks share the run "
                         "themselves: expected one or the other");
    if (!args.reference.empty())
        throw InputError("", "--reference",
                         "a part has no image to compare; give the reference to fogmap merge");
    if (args.checkpoint_every > 0.0 || args.resume)
        throw InputError("", args.resume ? "--resume" : "--checkpoint-every",
                         "cannot be combined with --part; a part is rendered whole (expected one "
                         "or the other)");
    if (desc.progressive.time_budget > 0.0f || desc.progressive.target_relmse > 0.0f)
        throw InputError(desc.path,
                         desc.progressive.time_budget > 0.0f ? "/progressive/time_budget"
                                                             : "/progressive/target_relmse",
                         "parts never talk, so they cannot agree when a time budget or a target "
                         "stops the run; with --part expected progressive.iterations (a count) "
                         "or a plain render");
}

/// The render's checks before any work, in order: options and outputs first, then the reference,
/// then the scene. Throws InputError.
RenderJob prepare_render(const RenderArgs& args) {
    const bool sequence = !args.frames.empty();
    const std::optional<TileShare> part = parse_part(args.part);
    // A part's output is its part file (-o); `fogmap merge` writes the EXR and PNG.
    const std::string ext = part ? ".fogpart" : ".exr";
    std::string exr = args.output;
    if (exr.empty())
        exr = "out/" + fs::path(args.scene).stem().string() + (sequence ? ".####" : "") +
              (part ? ".part-" + std::to_string(part->index + 1) + "-of-" +
                          std::to_string(part->count)
                    : "") +
              ext;
    if (!has_extension(exr, ext.c_str()))
        throw InputError(
            "", "-o",
            "'" + exr + "' does not end in " + ext + "; expected " +
                (part ? "the part file's path (fogmap merge reads it)" : "an .exr path"));
    if (part && !args.png.empty())
        throw InputError("", "--png",
                         "a part writes no image; fogmap merge writes the PNG beside the EXR");
    std::string png = part               ? std::string()
                      : args.png.empty() ? fs::path(exr).replace_extension(".png").string()
                                         : args.png;
    if (!part && !has_extension(png, ".png"))
        throw InputError("", "--png", "'" + png + "' does not end in .png; expected a .png path");
    if (!std::isfinite(args.exposure))
        throw InputError("", "--exposure",
                         "found " + g_text(args.exposure) + "; expected a finite number of stops");
    const std::optional<FrameRange> range =
        sequence ? std::optional<FrameRange>(parse_frame_range(args.frames, "--frames"))
                 : std::nullopt;
    for (const auto& [path, option] : {std::pair{exr, "-o"}, std::pair{png, "--png"}}) {
        if (path.empty()) continue;  // a part's PNG
        check_frame_pattern(path, "", option);
        if (sequence && !has_frame_pattern(path))
            throw InputError("", option,
                             "'" + path +
                                 "' has no frame pattern, so every frame would write "
                                 "it; with --frames expected one such as out/smoke.####.exr "
                                 "(####, $F4 or %04d)");
        if (!sequence && has_frame_pattern(path))
            throw InputError("", option,
                             "'" + path +
                                 "' holds a frame pattern; expected --frames "
                                 "FIRST-LAST to render a sequence");
    }
    if (sequence && !args.reference.empty())
        throw InputError("", "--reference", "cannot be combined with --frames; expected one");
    if (!(args.checkpoint_every >= 0.0 && args.checkpoint_every < 1e9))
        throw InputError("", "--checkpoint-every",
                         "found " + g_text(args.checkpoint_every) +
                             "; expected seconds >= 0 (0: no checkpoints)");

    // Outputs first: never an input of the run, and writable, before any work.
    const std::vector<std::pair<std::string, std::string>> inputs = {
        {args.scene, "scene file"}, {args.reference, "reference image"}};
    const int first = range ? range->first : 0;
    check_not_an_input(expand_frame(exr, first), "-o", inputs);
    check_output_path(expand_frame(exr, first), "-o");
    if (!part) {
        check_not_an_input(expand_frame(png, first), "--png", inputs);
        check_output_path(expand_frame(png, first), "--png");
    }

    // Read the reference first: a bad reference fails before any work.
    Image reference;
    if (!args.reference.empty()) {
        reference = read_exr(args.reference);
        check_finite(reference, args.reference);
    }
    if (is_vdb_path(args.scene) && !sequence && has_frame_pattern(args.scene))
        throw InputError(
            args.scene, "",
            "holds a frame pattern; expected --frames FIRST-LAST to render its frames");
    const SceneDesc desc = load_scene_desc(args.scene, args.overrides, first);
    if (!args.reference.empty()) check_reference_size(args.reference, reference, desc.camera);
    if (args.checkpoint_every > 0.0 && !(resolve_run(desc).photon() && desc.progressive.enabled()))
        throw InputError("", "--checkpoint-every",
                         "checkpoints are for progressive photon mapping; expected --iterations N "
                         "or --time-budget S with the photon integrator");
    // The checkpoint beside each output is a file: a folder there is found before any work.
    if (args.checkpoint_every > 0.0 || args.resume)
        for (const int f : range ? range->frames() : std::vector<int>{0}) {
            const std::string checkpoint = expand_frame(exr, f) + ".checkpoint";
            std::error_code ec;
            if (fs::is_directory(checkpoint, ec))
                throw InputError(checkpoint, args.resume ? "--resume" : "--checkpoint-every",
                                 "is a folder; expected the checkpoint's file path (or none)");
        }
    if (part) check_part(args, desc);
    if (args.progressive && !desc.progressive.enabled())
        throw InputError("", "--progressive",
                         "needs --time-budget SECONDS, --iterations N or --target-relmse X (or "
                         "progressive.iterations, progressive.time_budget or "
                         "progressive.target_relmse in the scene)");
    for (size_t i = 0; i < desc.media.size(); ++i)
        check_frame_pattern(desc.media[i].file, desc.path, "/media/" + std::to_string(i) + "/file");
    for (size_t i = 0; i < desc.media.size(); ++i)
        if (!sequence && has_frame_pattern(desc.media[i].file))
            throw InputError(desc.path, "/media/" + std::to_string(i) + "/file",
                             "'" + desc.media[i].file +
                                 "' holds a frame pattern; expected --frames FIRST-LAST to "
                                 "render its frames");

    return RenderJob{exr, png, range, std::move(reference), desc};
}

/// Every rank must run the same render: its settings (the scene's keys after --set), options and
/// outputs, and the input files behind the scene's paths, compared by digest where every rank has
/// them all (a file missing on some machine is left to the load, which names it and the rank).
/// Collective; throws the same InputError on every rank when one differs from rank 0.
void agree_on_job(const RenderArgs& args, const RenderJob& job) {
    if (!args.ranks || args.ranks->size() == 1) return;
    const std::string settings = to_json(job.desc).dump() + "\n" + job.exr + "\n" + job.png + "\n" +
                                 args.frames + (args.resume ? " resume " : " ") +
                                 std::to_string(args.checkpoint_every);
    const SceneDesc first = job.range ? frame_desc(job.desc, job.range->first) : job.desc;
    std::string files;
    bool complete = true;
    for (const std::string& path : input_files(first)) {
        std::error_code ec;
        complete = complete && fs::is_regular_file(path, ec);
        files += "\n" + file_digest(path);
    }
    const uint64_t mine[2] = {fnv1a(settings), fnv1a(files)};
    std::vector<uint8_t> bytes(17);
    std::memcpy(bytes.data(), mine, 16);
    bytes[16] = complete ? 1 : 0;
    const std::vector<std::vector<uint8_t>> all = args.ranks->all_gather(bytes);
    bool all_complete = true;
    for (const auto& b : all) all_complete = all_complete && b[16] == 1;
    for (size_t r = 1; r < all.size(); ++r) {
        const bool same_settings = std::equal(all[r].begin(), all[r].begin() + 8, all[0].begin());
        const bool same_files =
            std::equal(all[r].begin() + 8, all[r].begin() + 16, all[0].begin() + 8);
        if (!same_settings || (all_complete && !same_files))
            throw InputError("", "mpirun",
                             "MPI rank " + std::to_string(r) +
                                 " was given another render than rank 0 (its " +
                                 (same_settings ? "input files"
                                                : "scene, --set values, options "
                                                  "or outputs") +
                                 " differ); every rank must run the same one");
    }
}

}  // namespace

/// --write-scene: the scene as `render` would read it (a VDB's made scene, --set applied), its
/// files' paths relative to the written file's folder; checked as a render checks it first.
int write_scene_file(const RenderArgs& args) {
    const int frame = args.frames.empty() ? 0 : parse_frame_range(args.frames, "--frames").first;
    nlohmann::json doc = scene_document(args.scene, args.overrides, frame);
    // A scene that would not load is not written.
    load_scene_desc(args.scene, args.overrides, frame);
    check_not_an_input(args.write_scene, "--write-scene", {{args.scene, "scene file"}});
    check_output_path(args.write_scene, "--write-scene");
    const fs::path from = fs::absolute(args.scene).parent_path(),
                   to = fs::absolute(args.write_scene).parent_path();
    for (const char* list : {"media", "shapes"}) {
        if (!doc.contains(list) || !doc[list].is_array()) continue;
        for (nlohmann::json& item : doc[list])
            if (item.is_object() && item.contains("file") && item["file"].is_string())
                item["file"] = (from / item["file"].get<std::string>())
                                   .lexically_normal()
                                   .lexically_relative(to)
                                   .string();
    }
    OutputFiles out;
    write_staged_text(out.stage(args.write_scene), doc.dump(2) + "\n", "scene file");
    out.commit();
    if (!args.quiet) std::cout << "wrote: " << args.write_scene << "\n";
    return 0;
}

/// The process itself, measured: a render of an 8 x 6 image peaks at about this (libraries,
/// thread stacks, allocator arenas).
constexpr double kProgramBytes = 40.0 * (1 << 20);

/// --dry-run: what the run would hold at its peak, from the estimates the checks use (images,
/// photon maps, each grid's tree and sampler from the file's metadata) and the program, and its
/// samples and photons, without loading or tracing anything.
int dry_run(const RenderArgs& args, const RenderJob& job) {
    const RunSetup setup = resolve_run(job.desc);
    const RunMemory m = run_memory(setup, !args.reference.empty());
    double grids = 0.0;
    bool unknown = false;
    const int frame = job.range ? job.range->first : 0;
    for (const MediumDesc& medium : job.desc.media) {
        if (medium.type != MediumType::Vdb) continue;
        const std::string file = resolve(job.desc, expand_frame(medium.file, frame));
        std::vector<std::pair<std::string, int>> read = {{medium.grid, 1}};
        if (!medium.color_grid.empty()) read.push_back({medium.color_grid, 3});
        if (!medium.velocity_grid.empty() && job.desc.camera.shutter)
            read.push_back({medium.velocity_grid, 6});  // at most: a part that is 0 is small
        if (medium.emission && !medium.emission->grid.empty())
            read.push_back({medium.emission->grid, 1});
        for (const auto& [grid, samplers] : read) {
            const GridMemory g = grid_memory(file, grid);
            unknown |= !g.known;
            grids += double(g.tree) + samplers * double(g.sampler);
        }
    }
    const auto mb = [](double bytes) { return mb_text(static_cast<uint64_t>(bytes)); };
    const SceneDesc& d = setup.run;
    std::cout << "dry run: " << args.scene << "\n"
              << "integrator: " << integrator_name(setup.method) << " ("
              << setup.plan.integrator.reason << ")\n"
              << "predicted peak memory: about " << mb(m.images + m.maps + grids + kProgramBytes)
              << " (images " << mb(m.images) << ", " << maps_label(setup) << mb(m.maps)
              << ", grids " << mb(grids) << (unknown ? " and grids without size metadata" : "")
              << ", the program " << mb(kProgramBytes) << ")\n"
              << "work: " << uint64_t(d.camera.width) * d.camera.height * d.render.spp
              << " camera samples (" << d.camera.width << " x " << d.camera.height << " x "
              << d.render.spp << " spp)";
    if (setup.photon())
        std::cout << ", photon budgets: volume " << setup.photons.volume << ", global "
                  << setup.photons.global << ", caustic " << setup.photons.caustic;
    std::cout << (job.range ? ", per frame of " + std::to_string(job.range->frames().size())
                            : std::string())
              << "\n";
    if (const std::optional<TileShare> part = parse_part(args.part))
        std::cout << "part " << args.part << ": "
                  << (setup.progressive ? "every " + std::to_string(part->count) + "th iteration"
                                        : "every " + std::to_string(part->count) +
                                              "th 16x16 tile and every photon round")
                  << " (about 1/" << part->count
                  << " of the camera samples), with the whole film in memory\n";
    return 0;
}

int run_render(const RenderArgs& args) {
    if (!args.write_scene.empty()) return write_scene_file(args);
    RenderJob job;
    agree_on_input(args.ranks, [&] { job = prepare_render(args); });
    if (args.dry_run) return args.ranks && args.ranks->rank() != 0 ? 0 : dry_run(args, job);
    agree_on_job(args, job);
    if (is_vdb_path(args.scene) && (!args.ranks || args.ranks->rank() == 0))
        for (const std::string& w :
             unused_grid_warnings(args.scene, job.range ? job.range->first : 0))
            std::fprintf(stderr, "fogmap: warning: %s\n", w.c_str());
    const std::string &exr = job.exr, &png = job.png;
    const std::optional<FrameRange>& range = job.range;
    const Image& reference = job.reference;
    const SceneDesc& desc = job.desc;
    const bool sequence = !args.frames.empty();
    if (!sequence) {
        const Report report =
            render_and_write(args, desc, exr, png, args.reference.empty() ? nullptr : &reference);
        if (args.ranks && args.ranks->rank() != 0) return 0;
        if (args.json)
            std::cout << render_report_json(args, report).dump(2) << "\n";
        else
            std::cout << render_report_text(args, report);
        return 0;
    }

    // Every frame's files exist before any frame is rendered (on every rank's machine).
    const std::vector<int> frames = range->frames();
    if (!args.quiet && (!args.ranks || args.ranks->rank() == 0))
        std::fprintf(stderr, "render: %zu frames, %d to %d\n", frames.size(), frames.front(),
                     frames.back());
    agree_on_input(args.ranks, [&] {
        for (const int f : frames)
            for (size_t i = 0; i < desc.media.size(); ++i) {
                const MediumDesc& m = desc.media[i];
                if (m.type != MediumType::Vdb) continue;
                const std::string file = resolve(desc, expand_frame(m.file, f));
                if (!fs::exists(file))
                    throw InputError(file, "/media/" + std::to_string(i) + "/file",
                                     "frame " + std::to_string(f) + " of --frames " + args.frames +
                                         ": no such file");
            }
    });
    // Under mpirun the ranks form groups, dealt the frames round-robin; a group's ranks split
    // its frames' iterations, and its rank 0 writes them.
    const int world = args.ranks ? args.ranks->size() : 1;
    const int groups = std::min<int>(world, static_cast<int>(frames.size()));
    const int group = args.ranks ? args.ranks->rank() % groups : 0;
    std::unique_ptr<Ranks> team = args.ranks && world > 1 ? args.ranks->split(group) : nullptr;
    RenderArgs frame_args = args;
    if (team) frame_args.ranks = team.get();
    const bool speaks = !frame_args.ranks || frame_args.ranks->rank() == 0;
    nlohmann::json reports = nlohmann::json::array();
    for (size_t k = 0; k < frames.size(); ++k) {
        if (static_cast<int>(k % groups) != group) continue;
        const int f = frames[k];
        const std::string exr_f = expand_frame(exr, f), png_f = expand_frame(png, f);
        // An output counts only when complete: both are written whole and renamed together.
        if (args.resume && fs::exists(exr_f) && fs::exists(png_f)) {
            if (!args.quiet && speaks)
                std::fprintf(stderr, "frame %d: %s exists, skipped\n", f, exr_f.c_str());
            continue;
        }
        if (!args.quiet && speaks) std::fprintf(stderr, "frame %d\n", f);
        Report report;
        try {
            report = render_and_write(frame_args, frame_desc(desc, f), exr_f, png_f, nullptr);
        } catch (const InputError& e) {  // say which frame
            const InputError framed(e.file, e.field,
                                    e.reason + " (frame " + std::to_string(f) + ")");
            // The other groups render on: the group's first rank says it and ends the job
            // (MPI_Abort); the group's other ranks leave that to it.
            if (groups > 1) {
                if (speaks) {
                    std::fprintf(stderr, "fogmap: error: %s\n", framed.what());
                    abort_mpi(2);
                }
                std::this_thread::sleep_for(std::chrono::seconds(60));
                abort_mpi(2);
            }
            throw framed;
        }
        if (!speaks) continue;
        if (args.json) {
            nlohmann::json j = render_report_json(args, report);
            j["frame"] = f;
            reports.push_back(j);
        } else {
            std::cout << "frame " << f << "\n" << render_report_text(args, report);
        }
    }
    if (args.json && speaks) std::cout << reports.dump(2) << "\n";
    return 0;
}

int run_info(const std::string& vdb_path, bool json) {
    const std::vector<GridInfo> grids = inspect_vdb(vdb_path);
    const std::vector<std::string> uses = grid_uses(grids);
    if (json) {
        nlohmann::json j = {{"file", vdb_path}, {"grids", nlohmann::json::array()}};
        for (size_t i = 0; i < grids.size(); ++i) {
            j["grids"].push_back(grid_info_json(grids[i]));
            j["grids"].back()["use"] = uses[i];
        }
        std::cout << j.dump(2) << "\n";
        return 0;
    }
    std::cout << vdb_path << ": " << grids.size() << " grid(s)\n";
    for (size_t i = 0; i < grids.size(); ++i) {
        const GridInfo& g = grids[i];
        std::cout << "  " << g.name << ": " << g.value_type << ", class " << g.grid_class << "\n"
                  << "    use in `fogmap render " << fs::path(vdb_path).filename().string()
                  << "`: " << uses[i] << "\n"
                  << "    voxel size " << g.voxel_size.x << " " << g.voxel_size.y << " "
                  << g.voxel_size.z << ", translation " << g.translation.x << " " << g.translation.y
                  << " " << g.translation.z << "\n"
                  << "    index bbox [" << g.index_min[0] << "," << g.index_min[1] << ","
                  << g.index_min[2] << "] -> [" << g.index_max[0] << "," << g.index_max[1] << ","
                  << g.index_max[2] << "]\n";
        if (!g.world_bounds.empty())
            std::cout << "    world bbox (" << g.world_bounds.lo.x << ", " << g.world_bounds.lo.y
                      << ", " << g.world_bounds.lo.z << ") -> (" << g.world_bounds.hi.x << ", "
                      << g.world_bounds.hi.y << ", " << g.world_bounds.hi.z << ")\n";
        std::cout << "    active voxels " << g.active_voxels << " (tiles " << g.active_tiles
                  << ")\n";
        if (g.scalar) std::cout << "    values " << g.min_value << " .. " << g.max_value << "\n";
    }
    return 0;
}

CLI::Validator seed_check() {
    return CLI::Validator(
        [](std::string& text) {
            const bool digits =
                !text.empty() && text.find_first_not_of("0123456789") == std::string::npos;
            return digits ? std::string() : "found '" + text + "'; expected a non-negative integer";
        },
        "SEED");
}

int run_volume(const VolumeArgs& args) {
    VolumeGenSettings s;
    if (args.shape == "cloud")
        s.shape = VolumeShape::Cloud;
    else if (args.shape == "plume")
        s.shape = VolumeShape::Plume;
    else if (args.shape == "fireball")
        s.shape = VolumeShape::Fireball;
    else
        throw InputError("", "shape",
                         "unknown shape '" + args.shape + "'; expected cloud, plume, fireball");
    if (!has_extension(args.output, ".vdb"))
        throw InputError("", "-o", "'" + args.output + "' does not end in .vdb");
    if (args.resolution < 2 || args.resolution > 4096)
        throw InputError("", "--resolution",
                         "expected 2 .. 4096, found " + std::to_string(args.resolution));
    // The range every VDB grid must be in to be rendered (density_grid.cpp), and its extent the
    // world range (core/world_range.h): fogmap writes no volume it would refuse to read.
    if (!(args.voxel_size >= kMinScale && args.voxel_size <= kMaxScale))
        throw InputError("", "--voxel-size",
                         "found " + g_text(args.voxel_size) + "; expected " + g_text(kMinScale) +
                             " .. " + g_text(kMaxScale) + " world units");
    if (double(args.voxel_size) * args.resolution > kMaxWorldCoordinate)
        throw InputError("", "--voxel-size",
                         "--voxel-size " + g_text(args.voxel_size) + " x --resolution " +
                             std::to_string(args.resolution) + " = " +
                             g_text(double(args.voxel_size) * args.resolution) +
                             " world units; expected at most " + g_text(kMaxWorldCoordinate));
    s.resolution = args.resolution;
    s.voxel_size = args.voxel_size;
    s.seed = args.seed;
    if (args.velocity && s.shape == VolumeShape::Cloud)
        throw InputError("", "--velocity",
                         "the cloud does not move; expected plume or fireball (or no --velocity)");
    s.velocity = args.velocity;
    const uint64_t need = volume_memory_estimate(s), budget = memory_budget_bytes();
    if (need > budget)
        throw InputError("", "--resolution",
                         std::to_string(args.resolution) + " makes grids of about " +
                             mb_text(need) + "; expected at most the memory available (" +
                             mb_text(budget) + ")");
    if (args.frames.empty()) {
        if (has_frame_pattern(args.output))
            throw InputError("", "-o",
                             "'" + args.output +
                                 "' holds a frame pattern; expected --frames "
                                 "FIRST-LAST to write a sequence");
        check_output_path(args.output, "-o");
        create_output_folder(args.output);
        generate_volume(s, args.output);
        std::cout << "wrote: " << args.output << "\n";
        return 0;
    }
    const FrameRange range = parse_frame_range(args.frames, "--frames");
    if (!has_frame_pattern(args.output))
        throw InputError("", "-o",
                         "'" + args.output +
                             "' has no frame pattern; with --frames expected "
                             "one such as volumes/plume.####.vdb (####, $F4 or %04d)");
    check_frame_pattern(args.output, "", "-o");
    check_output_path(expand_frame(args.output, range.first), "-o");
    create_output_folder(expand_frame(args.output, range.first));
    const std::vector<int> frames = range.frames();
    std::fprintf(stderr, "volume: %zu frames, %d to %d\n", frames.size(), frames.front(),
                 frames.back());
    for (const int f : frames) {
        s.time = static_cast<float>(f);
        const std::string path = expand_frame(args.output, f);
        generate_volume(s, path);
        std::cout << "wrote: " << path << "\n";
    }
    return 0;
}

}  // namespace fogmap
