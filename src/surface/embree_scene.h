#pragma once
// One Embree 3 scene holding every triangle mesh and analytic sphere of a fogmap scene, with
// closest-hit and occlusion queries. The device gets one error callback at creation that turns
// Embree errors into std::runtime_error at the next check. Built once, then queried const from
// any number of threads (Embree's rtcIntersect1/rtcOccluded1 are thread-safe). Embree headers
// stay in embree_scene.cpp.

#include "core/math.h"
#include "surface/mesh.h"

#include <memory>
#include <optional>
#include <vector>

namespace fogmap {

struct SurfaceHit {
    float t = 0.0f;     ///< distance along the (unit-direction) ray
    Vec3 p{0.0f};       ///< world hit point
    Vec3 ng{0.0f};      ///< unit geometric normal: triangle winding (u x v) or sphere outward
    int material = -1;  ///< index into Scene::materials, -1 = black (light geometry)
    int light = -1;     ///< index into Scene::lights when the surface emits
};

class EmbreeScene {
public:
    /// Builds the scene. Throws std::runtime_error if Embree reports an error.
    EmbreeScene(std::vector<Mesh> meshes, std::vector<Sphere> spheres);
    ~EmbreeScene();
    EmbreeScene(const EmbreeScene&) = delete;
    EmbreeScene& operator=(const EmbreeScene&) = delete;

    /// Closest hit with t in [t_min, t_max], or nullopt.
    std::optional<SurfaceHit> intersect(const Ray& ray, float t_min, float t_max) const;
    /// True if anything lies on the ray within [t_min, t_max].
    bool occluded(const Ray& ray, float t_min, float t_max) const;
    /// World bounds of all geometry.
    const Box3& bounds() const { return bounds_; }
    size_t triangle_count() const;
    const std::vector<Mesh>& meshes() const { return meshes_; }
    const std::vector<Sphere>& spheres() const { return spheres_; }

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
    std::vector<Mesh> meshes_;
    std::vector<Sphere> spheres_;
    std::vector<std::vector<Vec3>> normals_;  ///< per mesh, per triangle
    Box3 bounds_;
};

}  // namespace fogmap
