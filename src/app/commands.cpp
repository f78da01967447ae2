#include "app/commands.h"

#include "core/error.h"
#include "core/image.h"
#include "core/timer.h"
#include "media/density_grid.h"
#include "media/volume_gen.h"
#include "render/metrics.h"
#include "render/pipeline.h"
#include "render/report.h"

#include "scene/scene_desc_json.h"

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
    if (args.progressive && !desc.progressive.enabled())
        throw InputError("", "--progressive",
                         "needs --time-budget SECONDS or --iterations N (or progressive.iterations "
                         "or progressive.time_budget in the scene)");
    PipelineResult run =
        run_pipeline(desc, args.quiet, args.reference.empty() ? nullptr : &reference);
    Report& report = run.report;
    const Image& image = run.film.beauty;

    if (!args.reference.empty()) {
        const ImageError e = image_error(image, reference);
        report.reference = args.reference;
        report.rmse = e.rmse;
        report.rel_mse = e.rel_mse;
        report.bias = e.bias;
    }

    const Timer timer;
    make_parent_dir(exr);
    make_parent_dir(png);
    write_exr(exr, image, run.film.named_layers());
    write_png(png, image, args.exposure);
    report.phases_s.emplace_back("write", timer.seconds());

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
