#include "scene/scene.h"

#include "core/error.h"
#include "core/world_range.h"
#include "media/blackbody.h"
#include "media/ray_march.h"

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <map>

namespace fogmap {

namespace {

MediumParams medium_params(const MediumDesc& m) {
    return MediumParams{m.sigma_s * m.density_scale, m.sigma_a * m.density_scale, m.g};
}

/// A medium's mean free path at its densest must span a few float steps of the coordinates it
/// lies at, or positions stop advancing along free paths and it renders as another medium (a
/// surface-like random walk, far brighter than the opaque medium it is): σ_t,max × max |x| must
/// stay within 2^20 (eight float steps per free path; at three, an opaque box rendered 7% too
/// bright). Such a medium is opaque at every scale an image resolves; the error says by how much
/// to thin it.
void check_resolvable(const Medium& m, const SceneDesc& desc, size_t index) {
    constexpr double kLimit = 1048576.0;  // 2^20
    const Box3& b = m.world_bounds();
    if (b.empty()) return;
    const double x = std::max(max_component(glm::abs(b.lo)), max_component(glm::abs(b.hi)));
    const double sigma =
        double(max_component(m.sigma_t())) * (m.grid() ? m.grid()->max_density() : 1.0);
    if (!(sigma * x > kLimit)) return;
    char text[400];
    std::snprintf(text, sizeof text,
                  "extinction up to %.3g per world unit at coordinates up to %.3g: its mean free "
                  "path is below the float resolution there, so it cannot be traced; it is opaque "
                  "at every scale an image resolves — lower density_scale, sigma_s or sigma_a "
                  "(extinction at most %.3g here), or move it nearer the origin",
                  sigma, x, kLimit / x);
    throw InputError(desc.path, "/media/" + std::to_string(index), text);
}

/// What reaches Embree and the renderer stays in the world range (core/world_range.h).
void check_world(const SceneDesc& desc, const std::string& field, const Box3& bounds,
                 const std::string& what) {
    if (!within_world(bounds))
        throw InputError(desc.path, field,
                         what + " spans " + box_text(bounds) +
                             "; expected every coordinate within ±" + g_text(kMaxWorldCoordinate) +
                             " world units");
}

/// Sun and environment powers depend on the scene's size (light.h, light_power): computed in
/// double and held to the bound validate() holds the other lights to (kMaxLightPower).
void check_light_powers(const SceneDesc& desc, const Box3& bounds) {
    if (bounds.empty()) return;
    const double r = 0.5 * glm::length(glm::dvec3(bounds.extent()));
    for (size_t i = 0; i < desc.lights.size(); ++i) {
        const LightDesc& l = desc.lights[i];
        const bool sun = l.type == LightType::Sun;
        if (!sun && l.type != LightType::Environment) continue;
        const Color& c = sun ? l.irradiance : l.radiance;
        const double factor = sun ? kPi * r * r : 4.0 * kPi * kPi * r * r;
        for (int ch = 0; ch < 3; ++ch) {
            const double power = factor * c[ch];
            if (power <= kMaxLightPower) continue;
            throw InputError(
                desc.path, "/lights/" + std::to_string(i) + (sun ? "/irradiance" : "/radiance"),
                std::string(sun ? "irradiance " : "radiance ") + g_text(c[ch]) +
                    " over the scene's bounding sphere (radius " + g_text(r) +
                    ") makes a power of " + g_text(power) + " W (channel " + std::to_string(ch) +
                    "); expected at most " + g_text(kMaxLightPower) + " W per channel");
        }
    }
}

/// Steps per camera ray through each medium, estimated up front from the medium's diagonal and
/// the marcher's own step (ray_march.h): the marcher takes at most kMaxStepsPerPiece steps per
/// piece and lengthens them beyond, so a step that would need more is refused rather than
/// silently changed (photon integrator: camera rays always march; plan.cpp).
void check_march_steps(const SceneDesc& desc, const std::vector<Medium>& media) {
    if (desc.render.integrator != Integrator::Photon) return;
    const RayMarcher marcher(media, desc.march);
    for (size_t i = 0; i < media.size(); ++i) {
        const Medium& m = media[i];
        if (m.world_bounds().empty()) continue;
        const double diagonal = glm::length(glm::dvec3(m.world_bounds().extent()));
        const bool grid = m.grid() != nullptr;
        const double step = marcher.step(static_cast<int>(i));
        const double steps = diagonal / step;
        if (!(steps > RayMarcher::kMaxStepsPerPiece)) continue;
        const std::string key = grid ? "step_voxels" : "step_world";
        const double asked = grid ? desc.march.step_voxels : desc.march.step_world;
        throw InputError(
            desc.path, "/march/" + key,
            key + " " + g_text(asked) + " makes about " + g_text(steps) +
                " march steps per camera ray across medium " + std::to_string(i) + " (diagonal " +
                g_text(diagonal) + " world units, step " + g_text(step) + "); at most " +
                std::to_string(RayMarcher::kMaxStepsPerPiece) + " are marched, so expected " + key +
                " >= " + g_text(asked * steps / RayMarcher::kMaxStepsPerPiece));
    }
}

using GridCache = std::map<std::pair<std::string, std::string>, std::shared_ptr<const DensityGrid>>;

/// Grid `name` of the VDB file at `path`, loaded on first use (its load warnings then added to
/// *warnings, so each grid's are said once) and shared after.
std::shared_ptr<const DensityGrid> cached_grid(GridCache* grids, const std::string& path,
                                               const std::string& name, const std::string& field,
                                               std::vector<std::string>* warnings) {
    std::shared_ptr<const DensityGrid>& g = (*grids)[{path, name}];
    if (!g) {
        g = DensityGrid::load(path, name, field);
        warnings->insert(warnings->end(), g->warnings().begin(), g->warnings().end());
    }
    return g;
}

/// Medium i's colour grid (its color_grid), values above 1 clamped and said.
void attach_colour(const SceneDesc& desc, size_t i, const std::string& path, Medium* medium,
                   std::vector<std::string>* warnings) {
    const MediumDesc& m = desc.media[i];
    const std::string field = "/media/" + std::to_string(i) + "/color_grid";
    uint64_t clamped = 0;
    auto channels = DensityGrid::load_channels(path, m.color_grid, field, &clamped);
    medium->set_colour({std::move(channels[0]), std::move(channels[1]), std::move(channels[2])},
                       m.transform.matrix);
    if (clamped > 0)
        warnings->push_back(path + ": grid '" + m.color_grid + "': " + std::to_string(clamped) +
                            " channel values above 1 clamped to 1 (a colour above 1 would "
                            "scatter more light than reaches it)");
}

/// Medium i's velocity grid (its velocity_grid) for the camera's shutter: a velocity that moves the
/// medium farther than its own extent in one frame is refused (most likely other units).
void attach_velocity(const SceneDesc& desc, size_t i, const std::string& path, Medium* medium) {
    const MediumDesc& m = desc.media[i];
    const std::string field = "/media/" + std::to_string(i) + "/velocity_grid";
    const ShutterDesc& shutter = *desc.camera.shutter;
    const float frames = std::max(std::abs(shutter.open), std::abs(shutter.close));
    auto loaded = DensityGrid::load_velocity(path, m.velocity_grid, field);
    std::array<std::shared_ptr<const DensityGrid>, 6> parts;
    for (size_t c = 0; c < parts.size(); ++c) parts[c] = std::move(loaded[c]);
    // Checked before the medium's majorants are widened by the move (a work that grows with it).
    const double per_frame = Medium::max_speed(parts, m.transform.matrix) / shutter.fps;
    const double extent = double(glm::length(medium->world_bounds().extent()));
    if (frames > 0.0f && !medium->world_bounds().empty() && per_frame > extent)
        throw InputError(path, field,
                         "grid '" + m.velocity_grid + "' moves the medium up to " +
                             g_text(per_frame) + " world units a frame (at camera.shutter.fps " +
                             g_text(shutter.fps) + "), more than its extent, " + g_text(extent) +
                             "; expected world units per second");
    medium->set_velocity(std::move(parts), m.transform.matrix, frames / shutter.fps);
}

/// The first of kEmissionGridNames that `names` holds, or "".
std::string find_emission_grid(const std::vector<std::string>& names) {
    for (const char* want : kEmissionGridNames)
        if (std::find(names.begin(), names.end(), want) != names.end()) return want;
    return "";
}

/// A medium emits at most kMaxLightPower, as a light may: its power is estimated from the grid's
/// values and the emission mapping when it is attached, so a scale that would overflow the image
/// is refused at load, naming the power it would give.
void check_emitted_power(const SceneDesc& desc, size_t i, const Medium& medium) {
    const double power = medium.emitted_power();
    if (std::isfinite(medium.emission_bound_power()) && std::isfinite(power) &&
        power <= kMaxLightPower)
        return;
    char text[300];
    std::snprintf(text, sizeof text,
                  "the medium would emit %s (from its grid's values and emission.scale %g); "
                  "expected at most %g W, as a light may: lower emission.scale",
                  std::isfinite(power) ? (g_text(power) + " W").c_str() : "more than a float holds",
                  double(desc.media[i].emission->scale), kMaxLightPower);
    throw InputError(desc.path, "/media/" + std::to_string(i) + "/emission/scale", text);
}

/// Makes scene medium `medium` (desc medium i, its VDB file at `path`; "" for a homogeneous one)
/// emit as desc says: the grid named, else one of kEmissionGridNames found in the file, else a
/// constant. Returns the Plan's line for it (without the power); a grid it loads adds its
/// warnings to *warnings.
std::string attach_emission(const SceneDesc& desc, size_t i, const std::string& path,
                            GridCache* grids, Medium* medium, std::vector<std::string>* warnings) {
    const MediumDesc& m = desc.media[i];
    const EmissionDesc& e = *m.emission;
    const std::string field = "/media/" + std::to_string(i) + "/emission";
    EmissionParams p{EmissionKind::Constant, e.color, e.scale, e.temperature_scale,
                     e.temperature_offset};
    std::string grid = e.grid;
    bool found = false;
    if (!path.empty() && grid.empty() && e.kind != EmissionSource::Constant) {
        const std::vector<std::string> names = vdb_grid_names(path, field);
        grid = find_emission_grid(names);
        found = !grid.empty();
        if (!found && e.kind != EmissionSource::Auto) {
            std::string list;
            for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
            throw InputError(path, field + "/grid",
                             "no emission grid: kind \"" + std::string(to_string(e.kind)) +
                                 "\" needs a grid, none is named and the file has none of "
                                 "temperature, heat, flame, flames (grids present: " +
                                 list + "); name one with \"grid\"");
        }
    }
    const std::string name = "medium " + std::to_string(i) + ": ";
    if (grid.empty()) {
        medium->set_emission(Emission::constant(p), Mat4(1.0f));
        check_emitted_power(desc, i, *medium);
        return name + "constant";
    }
    p.kind = e.kind == EmissionSource::Blackbody ? EmissionKind::Blackbody
             : e.kind == EmissionSource::Scalar  ? EmissionKind::Scalar
             : grid == "temperature"             ? EmissionKind::Blackbody
                                                 : EmissionKind::Scalar;
    const std::shared_ptr<const DensityGrid> g =
        cached_grid(grids, path, grid, field + "/grid", warnings);
    Emission emission = Emission::from_grid(p, g);
    if (emission.max_kelvin() > kMaxKelvin) {
        char text[300];
        std::snprintf(text, sizeof text,
                      "temperatures reach %.3g K (grid '%s' up to %g × temperature_scale %g + "
                      "temperature_offset %g); expected at most %g K: set temperature_scale so "
                      "that the grid's values map to kelvin",
                      emission.max_kelvin(), grid.c_str(), double(g->max_density()),
                      double(e.temperature_scale), double(e.temperature_offset), kMaxKelvin);
        throw InputError(desc.path, field, text);
    }
    if (p.kind == EmissionKind::Blackbody && emission.max_kelvin() < kDraperKelvin) {
        // A grid that is not in kelvin (a 0-1 heat ramp, say) glows in no visible colour.
        const double top = double(g->max_density());
        char text[400];
        std::snprintf(text, sizeof text,
                      "medium %zu: blackbody from grid '%s' reaches only %.3g K (its values up "
                      "to %g x temperature_scale %g + temperature_offset %g), below the %g K "
                      "where a black body starts to glow: it renders nearly black. If the grid "
                      "is not in kelvin, map it, e.g. temperature_scale %.3g puts its maximum at "
                      "2000 K, or use kind \"scalar\"",
                      i, grid.c_str(), emission.max_kelvin(), top, double(e.temperature_scale),
                      double(e.temperature_offset), kDraperKelvin,
                      top > 0.0 ? (2000.0 - double(e.temperature_offset)) / top : 1.0);
        warnings->push_back(text);
    }
    medium->set_emission(std::move(emission), m.transform.matrix);
    check_emitted_power(desc, i, *medium);
    return name + (p.kind == EmissionKind::Blackbody ? "blackbody" : "scalar") + " from grid '" +
           grid + "'" + (found ? " (found in the file)" : "");
}

}  // namespace

bool media_move(const Scene& scene) {
    return std::any_of(scene.media.begin(), scene.media.end(),
                       [](const Medium& m) { return m.max_shift() > 0.0f; });
}

std::string resolve(const SceneDesc& desc, const std::string& file) {
    const std::filesystem::path p(file);
    if (p.is_absolute() || desc.base_dir.empty()) return file;
    return (std::filesystem::path(desc.base_dir) / p).string();
}

double emitted_power(const Scene& scene) {
    double sum = 0.0;
    for (const Medium& m : scene.media) sum += m.emitted_power();
    return sum;
}

std::unique_ptr<Scene> load_scene(const SceneDesc& desc) {
    auto scene = std::make_unique<Scene>();
    scene->camera = desc.camera;

    std::map<std::string, int> material_index;
    for (const auto& [name, m] : desc.materials) {
        material_index[name] = static_cast<int>(scene->materials.size());
        scene->materials.push_back(Material{m.type, m.albedo, m.ior});
    }

    std::vector<Mesh> meshes;
    std::vector<Sphere> spheres;
    for (size_t i = 0; i < desc.lights.size(); ++i) {
        const LightDesc& l = desc.lights[i];
        scene->lights.push_back(make_light(l));
        if (l.type == LightType::Quad) {
            Mesh quad = make_quad(l.corner, l.edge_u, l.edge_v);
            quad.light = static_cast<int>(i);
            meshes.push_back(std::move(quad));
        }
        if (l.type == LightType::Point || l.type == LightType::Spot)
            scene->bounds.extend(l.position);
    }
    for (size_t i = 0; i < desc.shapes.size(); ++i) {
        const ShapeDesc& s = desc.shapes[i];
        const Mat4& m = s.transform.matrix;
        const int material = material_index.at(s.material);  // validate() checked it exists
        switch (s.type) {
            case ShapeType::Quad: {
                Mesh q = make_quad(transform_point(m, s.corner), transform_vector(m, s.edge_u),
                                   transform_vector(m, s.edge_v));
                q.material = material;
                meshes.push_back(std::move(q));
                break;
            }
            case ShapeType::Box: {
                Mesh b = make_box(s.min, s.max, m);
                b.material = material;
                meshes.push_back(std::move(b));
                break;
            }
            case ShapeType::Sphere: {
                const float scale = glm::length(transform_vector(m, Vec3(1.0f, 0.0f, 0.0f)));
                spheres.push_back(Sphere{transform_point(m, s.center), s.radius * scale, material});
                break;
            }
            case ShapeType::Mesh: {
                Mesh mesh =
                    load_mesh(resolve(desc, s.file), m, "/shapes/" + std::to_string(i) + "/file");
                mesh.material = material;
                Box3 bounds;
                bool finite = true;
                for (const Vec3& p : mesh.positions) {
                    finite = finite && is_finite(p);
                    bounds.extend(p);
                }
                const std::string what = "mesh '" + s.file + "' (after the transform)";
                const std::string field = "/shapes/" + std::to_string(i) + "/transform";
                if (!finite)
                    throw InputError(desc.path, field, what + " has a vertex that is not finite");
                check_world(desc, field, bounds, what);
                meshes.push_back(std::move(mesh));
                break;
            }
        }
    }
    if (!meshes.empty() || !spheres.empty()) {
        scene->surfaces = std::make_unique<EmbreeScene>(std::move(meshes), std::move(spheres));
        scene->bounds.extend(scene->surfaces->bounds());
    }

    if (desc.media.size() > static_cast<size_t>(kMaxMedia))
        throw InputError(
            desc.path, "/media",
            "found " + std::to_string(desc.media.size()) + " media; at most 16 are supported");
    GridCache grids;
    std::vector<std::string> emitters(desc.media.size());
    for (size_t i = 0; i < desc.media.size(); ++i) {
        const MediumDesc& m = desc.media[i];
        if (m.type != MediumType::Vdb) continue;
        const std::string path = resolve(desc, m.file);
        const std::shared_ptr<const DensityGrid> grid =
            cached_grid(&grids, path, m.grid, "/media/" + std::to_string(i), &scene->warnings);
        scene->media.push_back(Medium::heterogeneous(medium_params(m), grid, m.transform.matrix));
        if (!m.color_grid.empty())
            attach_colour(desc, i, path, &scene->media.back(), &scene->warnings);
        if (!m.velocity_grid.empty() && desc.camera.shutter)
            attach_velocity(desc, i, path, &scene->media.back());
        else if (!m.velocity_grid.empty())
            scene->warnings.push_back("media." + std::to_string(i) + ".velocity_grid '" +
                                      m.velocity_grid +
                                      "' is not read: without camera.shutter nothing moves");
        if (m.emission) {
            emitters[i] =
                attach_emission(desc, i, path, &grids, &scene->media.back(), &scene->warnings);
        } else {
            const std::string hint =
                find_emission_grid(vdb_grid_names(path, "/media/" + std::to_string(i)));
            if (!hint.empty())
                scene->emission_hints.push_back("medium " + std::to_string(i) +
                                                "'s file has grid '" + hint + "'");
        }
        const Box3& bounds = scene->media.back().world_bounds();
        if (!grid->empty())
            check_world(desc, "/media/" + std::to_string(i) + "/transform", bounds,
                        "grid '" + m.grid + "' of '" + m.file + "' (after both transforms)");
        check_resolvable(scene->media.back(), desc, i);
        scene->bounds.extend(bounds);
    }
    scene->bounds.extend(desc.camera.position);
    for (size_t i = 0; i < desc.media.size(); ++i) {
        const MediumDesc& m = desc.media[i];
        if (m.type != MediumType::Homogeneous) continue;
        Box3 bounds = m.bounds ? *m.bounds : scene->bounds;
        if (!m.bounds) {
            if (bounds.empty() || glm::length(bounds.extent()) <= 0.0f)
                throw InputError(desc.path, "/media/" + std::to_string(i) + "/bounds",
                                 "no bounds given and the rest of the scene has no extent; "
                                 "expected \"bounds\": {\"min\": [x,y,z], \"max\": [x,y,z]}");
            const Vec3 pad = 1e-3f * bounds.extent();
            bounds.lo -= pad;
            bounds.hi += pad;
        }
        scene->media.push_back(Medium::homogeneous(medium_params(m), bounds));
        check_resolvable(scene->media.back(), desc, i);
        if (m.emission)
            emitters[i] =
                attach_emission(desc, i, "", &grids, &scene->media.back(), &scene->warnings);
    }
    // The Plan's lines, in scene order, with each medium's power (scene->media holds the VDB
    // media first).
    const size_t n_vdb = static_cast<size_t>(
        std::count_if(desc.media.begin(), desc.media.end(),
                      [](const MediumDesc& d) { return d.type == MediumType::Vdb; }));
    for (size_t i = 0, vdb = 0, homogeneous = 0; i < desc.media.size(); ++i) {
        const bool is_vdb = desc.media[i].type == MediumType::Vdb;
        const Medium& medium = scene->media[is_vdb ? vdb++ : n_vdb + homogeneous++];
        if (emitters[i].empty()) continue;
        char power[64];
        std::snprintf(power, sizeof power, ", %.3g W", medium.emitted_power());
        scene->emitters.push_back(emitters[i] + power);
    }
    for (const Medium& m : scene->media) scene->bounds.extend(m.world_bounds());
    check_light_powers(desc, scene->bounds);
    check_march_steps(desc, scene->media);
    if (!scene->bounds.empty()) scene->offset_floor = 1e-6f * glm::length(scene->bounds.extent());
    return scene;
}

}  // namespace fogmap
