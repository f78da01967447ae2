#include "scene/vdb_scene.h"

#include "core/error.h"
#include "core/frames.h"
#include "media/emission.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <initializer_list>
#include <iterator>
#include <map>
#include <mutex>

namespace fogmap {

namespace {

namespace fs = std::filesystem;

std::string lower(std::string s) {
    for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

template <class Names>
bool named(const GridInfo& g, const Names& names) {
    const std::string n = lower(g.name);
    return std::any_of(std::begin(names), std::end(names), [&](const char* s) { return n == s; });
}
bool named(const GridInfo& g, std::initializer_list<const char*> names) {
    return named<std::initializer_list<const char*>>(g, names);
}

bool is_float(const GridInfo& g) { return g.value_type == "float"; }

// Numbers of the made scene to 6 significant digits (a file for people to edit), and points.
double num(double v) {
    char text[32];
    std::snprintf(text, sizeof text, "%.6g", v);
    return std::strtod(text, nullptr);
}
nlohmann::json point(const Vec3& p) { return {num(p.x), num(p.y), num(p.z)}; }

// Houdini and Blender names: density; the emission's (kEmissionGridNames: Houdini's pyro
// temperature is not in kelvin); Cd and color (colour, vec3s); vel, velocity and v (and their
// .x/.y/.z).
const GridInfo* density_grid(const std::vector<GridInfo>& grids) {
    for (const GridInfo& g : grids)
        if (is_float(g) && named(g, {"density"})) return &g;
    for (const GridInfo& g : grids)
        if (is_float(g) && g.grid_class == "fog volume" && !named(g, kEmissionGridNames)) return &g;
    return nullptr;
}

const GridInfo* colour_grid(const std::vector<GridInfo>& grids) {
    for (const GridInfo& g : grids)
        if (g.value_type == "vec3s" && named(g, {"cd", "color", "colour"})) return &g;
    return nullptr;
}

/// Houdini's and Blender's names of a velocity (any case).
bool velocity_name(const std::string& name) {
    const std::string n = lower(name);
    return n == "vel" || n == "velocity" || n == "v";
}

/// The velocity_grid a medium would name: a vec3s vel, velocity or v, else the base name of
/// float grids NAME.x, NAME.y and NAME.z (a split vector volume); "" for none.
std::string velocity_grid(const std::vector<GridInfo>& grids) {
    for (const GridInfo& g : grids)
        if (g.value_type == "vec3s" && velocity_name(g.name)) return g.name;
    for (const GridInfo& g : grids) {
        const size_t dot = g.name.rfind('.');
        if (!is_float(g) || dot == std::string::npos || g.name.substr(dot) != ".x") continue;
        const std::string base = g.name.substr(0, dot);
        if (!velocity_name(base)) continue;
        int found = 0;
        for (const GridInfo& h : grids)
            found += is_float(h) && (h.name == base + ".y" || h.name == base + ".z") ? 1 : 0;
        if (found == 2) return base;
    }
    return "";
}

const GridInfo* emission_grid(const std::vector<GridInfo>& grids) {
    for (const char* name : kEmissionGridNames)
        for (const GridInfo& g : grids)
            if (is_float(g) && named(g, {name}) && g.max_value > 0.0) return &g;
    return nullptr;
}

// Temperatures at least this hot are taken as kelvin; a cooler grid (Houdini's pyro
// temperature is about 0-2) is mapped so that its hottest voxel is kMappedKelvin.
constexpr double kKelvinFloor = 500.0, kMappedKelvin = 2500.0;
// The glow's brightness beside the sun (scenes/fire.json's), and a scalar glow's colour (a
// black body's at about 1800 K).
constexpr double kEmissionScale = 8.0;
constexpr double kFlameRgb[3] = {1.0, 0.45, 0.12};

std::string emission_use(const GridInfo& g) {
    if (named(g, {"temperature"}))
        return g.max_value >= kKelvinFloor ? "emission (blackbody, in kelvin)"
                                           : "emission (blackbody, its hottest voxel as 2500 K)";
    return "emission (scalar, a flame's colour)";
}

nlohmann::json emission_json(const GridInfo& g) {
    nlohmann::json e = {{"grid", g.name}, {"scale", kEmissionScale}};
    if (named(g, {"temperature"})) {
        e["kind"] = "blackbody";
        if (g.max_value < kKelvinFloor) e["temperature_scale"] = num(kMappedKelvin / g.max_value);
    } else {
        e["kind"] = "scalar";
        e["color"] = {kFlameRgb[0], kFlameRgb[1], kFlameRgb[2]};
        e["scale"] = num(kEmissionScale / g.max_value * 0.25);
    }
    return e;
}

// The optical depth through the volume's typical extent at its densest value: dense enough to
// look like smoke, whatever the cache's units (users set media.0.density_scale to taste).
constexpr double kDepthAcross = 10.0;

nlohmann::json medium_json(const std::string& file, const GridInfo& density, const GridInfo* colour,
                           const std::string& velocity, const GridInfo* emission) {
    const Vec3 e = density.world_bounds.hi - density.world_bounds.lo;
    const double across = std::cbrt(std::max(double(e.x) * e.y * e.z, 1e-30));
    const double top = density.max_value > 0.0 ? density.max_value : 1.0;
    nlohmann::json m = {{"type", "vdb"},
                        {"file", fs::path(file).filename().string()},
                        {"grid", density.name},
                        {"density_scale", num(kDepthAcross / (top * across))},
                        {"sigma_s", 0.93},
                        {"sigma_a", 0.07},
                        {"g", 0.3}};
    if (colour) m["color_grid"] = colour->name;
    if (!velocity.empty()) m["velocity_grid"] = velocity;
    if (emission) m["emission"] = emission_json(*emission);
    return m;
}

// A 16:9 camera at 40° (vertical), looking at the bounds' centre from the front, right and a
// little above, as near as lets every corner of the bounds fall within kFill of the image's
// half-width and half-height.
constexpr int kWidth = 480, kHeight = 270;
constexpr float kFovDeg = 40.0f, kFill = 0.85f;

nlohmann::json camera_json(const Box3& b) {
    const Vec3 c = 0.5f * (b.lo + b.hi);
    const Vec3 back = glm::normalize(Vec3(0.45f, 0.25f, 1.0f));  // from the centre to the camera
    const Vec3 right = glm::normalize(glm::cross(Vec3(0.0f, 1.0f, 0.0f), back));
    const Vec3 up = glm::cross(back, right);
    const float tan_y = kFill * std::tan(0.5f * kFovDeg * kPi / 180.0f),
                tan_x = tan_y * float(kWidth) / float(kHeight);
    float distance = 0.0f;
    for (int n = 0; n < 8; ++n) {
        const Vec3 q((n & 1) ? b.hi.x : b.lo.x, (n & 2) ? b.hi.y : b.lo.y,
                     (n & 4) ? b.hi.z : b.lo.z);
        const Vec3 r = q - c;  // seen at depth distance - r.back
        distance = std::max({distance, glm::dot(r, back) + std::abs(glm::dot(r, up)) / tan_y,
                             glm::dot(r, back) + std::abs(glm::dot(r, right)) / tan_x});
    }
    const Vec3 p = c + distance * back;
    return {{"position", point(p)}, {"look_at", point(c)}, {"up", {0, 1, 0}},
            {"fov_deg", kFovDeg},   {"width", kWidth},     {"height", kHeight}};
}

// inspect_vdb reads every grid: the made scene and its warnings read a file once.
const std::vector<GridInfo>& inspected(const std::string& file) {
    static std::mutex mutex;
    static std::map<std::string, std::vector<GridInfo>> cache;
    const std::lock_guard<std::mutex> lock(mutex);
    auto it = cache.find(file);
    if (it == cache.end()) it = cache.emplace(file, inspect_vdb(file)).first;
    return it->second;
}

}  // namespace

bool is_vdb_path(const std::string& path) {
    return lower(fs::path(path).extension().string()) == ".vdb";
}

std::vector<std::string> grid_uses(const std::vector<GridInfo>& grids) {
    const GridInfo* density = density_grid(grids);
    const GridInfo* emission = emission_grid(grids);
    const GridInfo* colour = colour_grid(grids);
    const std::string velocity = velocity_grid(grids);
    std::vector<std::string> uses;
    for (const GridInfo& g : grids) {
        const std::string base = lower(g.name.substr(0, g.name.find('.')));
        if (&g == density)
            uses.push_back("density (the medium)");
        else if (&g == emission)
            uses.push_back(emission_use(g));
        else if (&g == colour)
            uses.push_back("colour (the scattering's albedo per channel)");
        else if (base == "cd" || base == "color" || base == "colour")
            uses.push_back("not used: a colour grid is read from a vec3s grid");
        else if (!velocity.empty() && (g.name == velocity || g.name == velocity + ".x" ||
                                       g.name == velocity + ".y" || g.name == velocity + ".z"))
            uses.push_back("velocity (motion blur over camera.shutter)");
        else if (velocity_name(base))
            uses.push_back(
                "not used: a velocity is read from a vec3s grid or from float grids "
                "NAME.x, NAME.y and NAME.z");
        else
            uses.push_back("not used");
    }
    return uses;
}

std::vector<std::string> unused_grid_warnings(const std::string& file, int frame) {
    const std::string name = expand_frame(file, frame);
    const std::vector<GridInfo>& grids = inspected(name);
    const std::vector<std::string> uses = grid_uses(grids);
    std::vector<std::string> out;
    for (size_t i = 0; i < grids.size(); ++i)
        if (uses[i].rfind("not used: ", 0) == 0)
            out.push_back(name + ": grid '" + grids[i].name + "': " + uses[i]);
    return out;
}

nlohmann::json vdb_scene_json(const std::string& file, int frame) {
    const std::string name = expand_frame(file, frame);
    const std::vector<GridInfo>& grids = inspected(name);
    const GridInfo* density = density_grid(grids);
    if (!density || density->world_bounds.empty())
        throw InputError(name, "",
                         density ? "grid '" + density->name + "' has no active voxel to render"
                                 : "no float grid named density, nor another float fog volume; "
                                   "expected one to render as the medium");
    const Box3& b = density->world_bounds;
    const Vec3 c = 0.5f * (b.lo + b.hi);
    const float half = 50.0f * glm::length(b.hi - b.lo);
    nlohmann::json scene = {{"camera", camera_json(b)},
                            {"lights",
                             {{{"type", "sun"},
                               {"direction", {-0.55, -0.75, -0.35}},
                               {"irradiance", {3.2, 3.0, 2.7}},
                               {"angular_radius_deg", 0.27}},
                              {{"type", "environment"}, {"radiance", {0.16, 0.2, 0.28}}}}},
                            {"materials", {{"ground", {{"type", "diffuse"}, {"albedo", 0.5}}}}},
                            {"shapes",
                             {{{"type", "quad"},
                               {"corner", point(Vec3(c.x - half, b.lo.y, c.z - half))},
                               {"edge_u", {0, 0, num(2.0f * half)}},
                               {"edge_v", {num(2.0f * half), 0, 0}},
                               {"material", "ground"}}}},
                            {"media",
                             {medium_json(file, *density, colour_grid(grids), velocity_grid(grids),
                                          emission_grid(grids))}},
                            {"render", {{"spp", 16}}}};
    // A 180° shutter at 24 frames per second, centred on the frame.
    if (!velocity_grid(grids).empty())
        scene["camera"]["shutter"] = {{"open", -0.25}, {"close", 0.25}, {"fps", 24}};
    return scene;
}

}  // namespace fogmap
