#pragma once
// Scene pieces the test programs build scenes from in code (lights, a diffuse ground, media), so
// each test states only what its scene is about. Plain SceneDesc values: they still go through
// load_scene (and validate where a test runs the pipeline).

#include "scene/scene_desc.h"

#include <string>

namespace fogmap::test {

inline LightDesc environment(float radiance) {
    LightDesc l;
    l.type = LightType::Environment;
    l.radiance = Color(radiance);
    return l;
}

/// A delta sun travelling along `direction` (make_light normalises it) with irradiance E.
inline LightDesc sun(const Vec3& direction, float irradiance) {
    LightDesc l;
    l.type = LightType::Sun;
    l.direction = direction;
    l.irradiance = Color(irradiance);
    return l;
}

inline LightDesc point_light(const Vec3& position, float intensity) {
    LightDesc l;
    l.type = LightType::Point;
    l.position = position;
    l.intensity = Color(intensity);
    return l;
}

/// A spot at `position` pointing along `direction`: intensity I within cone_angle − cone_delta of
/// the axis, falling smoothly to 0 at cone_angle (degrees).
inline LightDesc spot_light(const Vec3& position, const Vec3& direction, float intensity,
                            float cone_angle_deg = 30.0f, float cone_delta_deg = 5.0f) {
    LightDesc l = point_light(position, intensity);
    l.type = LightType::Spot;
    l.direction = direction;
    l.cone_angle_deg = cone_angle_deg;
    l.cone_delta_deg = cone_delta_deg;
    return l;
}

/// A one-sided quad light of radiance L, emitting towards edge_u × edge_v.
inline LightDesc quad_light(const Vec3& corner, const Vec3& edge_u, const Vec3& edge_v,
                            float radiance) {
    LightDesc l;
    l.type = LightType::Quad;
    l.corner = corner;
    l.edge_u = edge_u;
    l.edge_v = edge_v;
    l.radiance = Color(radiance);
    return l;
}

inline ShapeDesc quad(const Vec3& corner, const Vec3& edge_u, const Vec3& edge_v,
                      const std::string& material) {
    ShapeDesc s;
    s.type = ShapeType::Quad;
    s.corner = corner;
    s.edge_u = edge_u;
    s.edge_v = edge_v;
    s.material = material;
    return s;
}

/// A diffuse square of side 2·half at height y centred above the origin, facing up, with its
/// material `name` of the given albedo.
inline void add_ground(SceneDesc* d, float y, float half, float albedo,
                       const std::string& name = "ground") {
    d->materials[name] = MaterialDesc{MaterialType::Diffuse, Color(albedo), 1.5f};
    d->shapes.push_back(quad(Vec3(-half, y, -half), Vec3(0.0f, 0.0f, 2.0f * half),
                             Vec3(2.0f * half, 0.0f, 0.0f), name));
}

inline MediumDesc homogeneous(const Box3& bounds, const Color& sigma_s, const Color& sigma_a,
                              float g = 0.0f) {
    MediumDesc m;
    m.type = MediumType::Homogeneous;
    m.bounds = bounds;
    m.sigma_s = sigma_s;
    m.sigma_a = sigma_a;
    m.g = g;
    return m;
}

inline MediumDesc vdb_medium(const std::string& file, const Color& sigma_s, const Color& sigma_a,
                             float density_scale = 1.0f) {
    MediumDesc m;
    m.type = MediumType::Vdb;
    m.file = file;
    m.sigma_s = sigma_s;
    m.sigma_a = sigma_a;
    m.density_scale = density_scale;
    return m;
}

/// Every kind of photon-stream target at once: a sun, a sky, a point light and a spot over a
/// diffuse floor "floor" (albedo 0.5, 2 `half` wide at height `floor_y`), a glass ball and a box
/// of fog over [-1, 1]^3 (σ_s 1, σ_a 0.1).
inline SceneDesc four_lights_ball_and_fog(float floor_y, float half) {
    SceneDesc d;
    d.lights.push_back(sun(Vec3(-0.4f, -1.0f, -0.3f), 2.0f));
    d.lights.push_back(environment(0.5f));
    d.lights.push_back(point_light(Vec3(3.0f, 2.0f, 1.0f), 4.0f));
    d.lights.push_back(
        spot_light(Vec3(-1.0f, 3.5f, 0.5f), Vec3(0.2f, -1.0f, -0.1f), 3.0f, 35.0f, 10.0f));
    d.materials["glass"] = MaterialDesc{MaterialType::Glass, Color(1.0f), 1.5f};
    add_ground(&d, floor_y, half, 0.5f, "floor");
    ShapeDesc ball;
    ball.type = ShapeType::Sphere;
    ball.center = Vec3(2.0f, 0.8f, -2.0f);
    ball.radius = 0.5f;
    ball.material = "glass";
    d.shapes.push_back(ball);
    d.media.push_back(homogeneous(Box3{Vec3(-1.0f), Vec3(1.0f)}, Color(1.0f), Color(0.1f)));
    return d;
}

}  // namespace fogmap::test
