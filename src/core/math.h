#pragma once
// Math vocabulary of fogmap: GLM aliases, constants, rays, boxes and orthonormal frames.
// Units: world space is whatever the scene file uses (metres by convention); angles in radians.
// Everything here is header-only, allocation-free and thread-safe.

#include <glm/glm.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace fogmap {

using Vec2 = glm::vec2;
using Vec3 = glm::vec3;
using DVec3 = glm::dvec3;
using Mat3 = glm::mat3;
using Mat4 = glm::mat4;
using DMat4 = glm::dmat4;
using Color = glm::vec3;  ///< linear RGB radiance, power or reflectance

constexpr double kPiDouble = 3.14159265358979323846;  ///< for sums and angles kept in double
constexpr float kPi = 3.14159265358979323846f;
static_assert(kPi == static_cast<float>(kPiDouble), "one π, in float and in double");
constexpr float kTwoPi = 2.0f * kPi;
constexpr float kInvPi = 1.0f / kPi;
constexpr float kInvTwoPi = 1.0f / kTwoPi;
constexpr float kInvFourPi = 1.0f / (4.0f * kPi);
constexpr float kInfinity = std::numeric_limits<float>::infinity();

/// A ray o + t d; d need not be unit length (media walks use the same t in index space).
struct Ray {
    Vec3 o{0.0f};
    Vec3 d{0.0f, 0.0f, 1.0f};
    Vec3 at(float t) const { return o + t * d; }
};

/// Axis-aligned box; empty when lo > hi on any axis.
struct Box3 {
    Vec3 lo{kInfinity};
    Vec3 hi{-kInfinity};
    bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
    void extend(const Vec3& p) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    void extend(const Box3& b) {
        lo = glm::min(lo, b.lo);
        hi = glm::max(hi, b.hi);
    }
    Vec3 center() const { return 0.5f * (lo + hi); }
    Vec3 extent() const { return hi - lo; }
    bool contains(const Vec3& p) const {
        return p.x >= lo.x && p.y >= lo.y && p.z >= lo.z && p.x <= hi.x && p.y <= hi.y &&
               p.z <= hi.z;
    }
};

/// Slab test: the parametric interval of the ray inside the box, clipped to [t0, t1].
/// Returns false if the ray misses. Works for zero direction components (IEEE infinities).
inline bool intersect_box(const Box3& box, const Ray& ray, float t0, float t1, float* t_enter,
                          float* t_exit) {
    for (int a = 0; a < 3; ++a) {
        const float inv = 1.0f / ray.d[a];
        float tn = (box.lo[a] - ray.o[a]) * inv;
        float tf = (box.hi[a] - ray.o[a]) * inv;
        if (std::isnan(tn) || std::isnan(tf)) {  // origin on the slab plane, parallel ray
            if (ray.o[a] < box.lo[a] || ray.o[a] > box.hi[a]) return false;
            continue;
        }
        if (tn > tf) std::swap(tn, tf);
        t0 = std::max(t0, tn);
        t1 = std::min(t1, tf);
        if (t0 > t1) return false;
    }
    *t_enter = t0;
    *t_exit = t1;
    return true;
}

/// A lattice's cell edge over `extent`: `cell`, or larger where the lattice would exceed
/// max_cells cells.
inline float capped_cell(const Vec3& extent, float cell, size_t max_cells) {
    const double volume = double(extent.x) * extent.y * extent.z;
    if (volume / (double(cell) * cell * cell) > double(max_cells))
        return static_cast<float>(std::cbrt(volume / double(max_cells)));
    return cell;
}

inline float max_component(const Color& c) { return std::max(c.x, std::max(c.y, c.z)); }
inline float average(const Color& c) { return (c.x + c.y + c.z) * (1.0f / 3.0f); }
inline float luminance(const Color& c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }
inline bool is_finite(const Color& c) {
    return std::isfinite(c.x) && std::isfinite(c.y) && std::isfinite(c.z);
}

/// Orthonormal basis around unit n (Duff et al. 2017, branchless).
inline void make_frame(const Vec3& n, Vec3* t, Vec3* b) {
    const float sign = std::copysign(1.0f, n.z);
    const float a = -1.0f / (sign + n.z);
    const float c = n.x * n.y * a;
    *t = Vec3(1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x);
    *b = Vec3(c, sign + n.y * n.y * a, -n.y);
}

/// Local (x, y, z) around unit n → world direction.
inline Vec3 to_world(const Vec3& local, const Vec3& n) {
    Vec3 t, b;
    make_frame(n, &t, &b);
    return local.x * t + local.y * b + local.z * n;
}

/// Ray origin moved off a surface at p along unit n (towards the side the ray leaves on): by
/// 2e-5 of the point's largest coordinate, at least `floor` (scene-relative), so rays neither
/// re-hit their own surface nor tunnel through thin geometry.
inline Vec3 offset_point(const Vec3& p, const Vec3& n, float floor) {
    const float scale = std::max(std::abs(p.x), std::max(std::abs(p.y), std::abs(p.z)));
    return p + std::max(floor, 2e-5f * scale) * n;
}

/// A shadow ray towards a light sample at distance d stops at d·(1 − kShadowRayEpsilon), so a
/// surface at the sampled light point itself (a light placed on geometry) is not a blocker.
constexpr float kShadowRayEpsilon = 1e-4f;

/// Transform a point / a direction by an affine 4x4 matrix.
inline Vec3 transform_point(const Mat4& m, const Vec3& p) { return Vec3(m * glm::vec4(p, 1.0f)); }
inline Vec3 transform_vector(const Mat4& m, const Vec3& v) { return Vec3(m * glm::vec4(v, 0.0f)); }

}  // namespace fogmap
