#include "app/commands.h"

#include "core/error.h"
#include "core/image.h"
#include "core/timer.h"
#include "media/density_grid.h"
#include "media/volume_gen.h"
#include "photon/photon_pass.h"
#include "render/metrics.h"
#include "render/path_tracer.h"
#include "render/photon_integrator.h"
#include "render/report.h"
#include "scene/plan.h"
#include "scene/scene.h"
#include "scene/scene_desc_json.h"

#include <tbb/global_control.h>
#include <tbb/info.h>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <iostream>

namespace fogmap {

namespace {

namespace fs = std::filesystem;

bool has_extension(const std::string& path, const char* ext) {
    return fs::path(path).extension() == ext;
}

void make_parent_dir(const std::string& path) {
    const fs::path parent = fs::path(path).parent_path();
    std::error_code ec;
    if (!parent.empty()) fs::create_directories(parent, ec);
    if (ec)
        throw InputError("", "-o",
                         "cannot create folder '" + parent.string() + "': " + ec.message());
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

int run_render(const RenderArgs& args) {
    std::string exr = args.output;
    if (exr.empty()) exr = "out/" + fs::path(args.scene).stem().string() + ".exr";
    if (!has_extension(exr, ".exr"))
        throw InputError("", "-o", "'" + exr + "' does not end in .exr; expected an .exr path");
    std::string png =
        args.png.empty() ? fs::path(exr).replace_extension(".png").string() : args.png;
    if (!has_extension(png, ".png"))
        throw InputError("", "--png", "'" + png + "' does not end in .png; expected a .png path");

    Report report;
    Timer timer;
    // Read the reference first: a bad reference fails before any work.
    Image reference;
    if (!args.reference.empty()) reference = read_exr(args.reference);
    const SceneDesc desc = load_scene_desc(args.scene, args.overrides);
    if (!args.reference.empty() &&
        (reference.width != desc.camera.width || reference.height != desc.camera.height))
        throw InputError(args.reference, "",
                         "reference is " + std::to_string(reference.width) + "x" +
                             std::to_string(reference.height) + ", the camera renders " +
                             std::to_string(desc.camera.width) + "x" +
                             std::to_string(desc.camera.height));
    const Plan plan = make_plan(desc);
    report.plan_text = plan_text(plan);
    report.plan = plan_json(plan);
    if (!args.quiet) std::fprintf(stderr, "%s", report.plan_text.c_str());
    const std::unique_ptr<Scene> scene = load_scene(desc);
    report.phases_s.emplace_back("load", timer.seconds());

    // One thread limit for every parallel phase of this run.
    const int threads =
        desc.render.threads > 0 ? desc.render.threads : tbb::info::default_concurrency();
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    RenderStats stats;
    Image beauty;
    AovImages aov;
    std::vector<NamedImage> layers;
    if (desc.render.integrator == Integrator::Photon) {
        PhotonPassResult pass = trace_photons(*scene, plan, args.quiet);
        for (const std::string& w : pass.warnings)
            std::fprintf(stderr, "fogmap: warning: %s\n", w.c_str());
        report.phases_s.emplace_back("photon pass", pass.time_s);
        report.photons_emitted = pass.emitted;
        const PhotonMaps maps = build_trees(std::move(pass));
        const std::pair<const char*, const std::optional<PhotonMap>*> named[] = {
            {"global", &maps.global}, {"caustic", &maps.caustic}, {"volume", &maps.volume}};
        for (const auto& [name, map] : named) {
            if (!*map) continue;
            report.maps.push_back({name, (*map)->tree.size(), (*map)->emitted, (*map)->tree.bytes(),
                                   (*map)->build_s});
            report.phases_s.emplace_back(std::string("build ") + name, (*map)->build_s);
        }
        double precompute_s = 0.0;
        aov = render_photon(*scene, maps, desc.render, args.quiet, &stats, &precompute_s);
        if (precompute_s > 0.0) report.phases_s.emplace_back("irradiance precompute", precompute_s);
        report.phases_s.emplace_back("render", stats.render_s);
        layers = aov.layers();
    } else {
        beauty = render_path(*scene, desc.render, args.quiet, &stats);
        report.phases_s.emplace_back("render", stats.render_s);
    }
    const Image& image = desc.render.integrator == Integrator::Photon ? aov.beauty : beauty;

    report.mean = image.mean();
    if (!args.reference.empty()) {
        const ImageError e = image_error(image, reference);
        report.reference = args.reference;
        report.rmse = e.rmse;
        report.rel_mse = e.rel_mse;
        report.bias = e.bias;
    }

    timer.reset();
    make_parent_dir(exr);
    make_parent_dir(png);
    write_exr(exr, image, layers);
    write_png(png, image, args.exposure);
    report.phases_s.emplace_back("write", timer.seconds());

    report.scene = args.scene;
    report.settings = settings_json(desc);
    report.width = image.width;
    report.height = image.height;
    report.spp = desc.render.spp;
    report.threads = stats.threads;
    report.samples = stats.samples;
    report.rays = stats.rays;
    report.nonfinite = stats.nonfinite;
    report.render_s = stats.render_s;
    report.outputs = {exr, png};
    if (args.json)
        std::cout << report_json(report).dump(2) << "\n";
    else
        std::cout << report_text(report);
    return 0;
}

int run_info(const std::string& vdb_path, bool json) {
    const std::vector<GridInfo> grids = inspect_vdb(vdb_path);
    if (json) {
        nlohmann::json j = {{"file", vdb_path}, {"grids", nlohmann::json::array()}};
        for (const GridInfo& g : grids) j["grids"].push_back(grid_info_json(g));
        std::cout << j.dump(2) << "\n";
        return 0;
    }
    std::cout << vdb_path << ": " << grids.size() << " grid(s)\n";
    for (const GridInfo& g : grids) {
        std::cout << "  " << g.name << ": " << g.value_type << ", class " << g.grid_class << "\n"
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

int run_volume(const VolumeArgs& args) {
    VolumeGenSettings s;
    if (args.shape == "cloud")
        s.shape = VolumeShape::Cloud;
    else if (args.shape == "plume")
        s.shape = VolumeShape::Plume;
    else
        throw InputError("", "shape", "unknown shape '" + args.shape + "'; expected cloud, plume");
    if (!has_extension(args.output, ".vdb"))
        throw InputError("", "-o", "'" + args.output + "' does not end in .vdb");
    if (args.resolution < 2 || args.resolution > 1024)
        throw InputError("", "--resolution",
                         "expected 2 .. 1024, found " + std::to_string(args.resolution));
    if (!(args.voxel_size > 0.0f) || !std::isfinite(args.voxel_size))
        throw InputError("", "--voxel-size", "expected a positive number");
    s.resolution = args.resolution;
    s.voxel_size = args.voxel_size;
    s.seed = args.seed;
    make_parent_dir(args.output);
    generate_volume(s, args.output);
    std::cout << "wrote: " << args.output << "\n";
    return 0;
}

}  // namespace fogmap
