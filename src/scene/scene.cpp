#include "scene/scene.h"

#include "core/error.h"

#include <cstdio>
#include <filesystem>
#include <map>

namespace fogmap {

namespace {

std::string resolve(const SceneDesc& desc, const std::string& file) {
    const std::filesystem::path p(file);
    if (p.is_absolute() || desc.base_dir.empty()) return file;
    return (std::filesystem::path(desc.base_dir) / p).string();
}

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

}  // namespace

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
    std::map<std::pair<std::string, std::string>, std::shared_ptr<const DensityGrid>> grids;
    for (size_t i = 0; i < desc.media.size(); ++i) {
        const MediumDesc& m = desc.media[i];
        if (m.type != MediumType::Vdb) continue;
        const std::string path = resolve(desc, m.file);
        auto& grid = grids[{path, m.grid}];
        if (!grid) grid = DensityGrid::load(path, m.grid, "/media/" + std::to_string(i));
        scene->media.push_back(Medium::heterogeneous(medium_params(m), grid, m.transform.matrix));
        check_resolvable(scene->media.back(), desc, i);
        scene->bounds.extend(scene->media.back().world_bounds());
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
    }
    for (const Medium& m : scene->media) scene->bounds.extend(m.world_bounds());
    if (!scene->bounds.empty()) scene->offset_floor = 1e-6f * glm::length(scene->bounds.extent());
    return scene;
}

}  // namespace fogmap
