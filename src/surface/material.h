#pragma once
// Surface materials (DESIGN.md, Photons): Lambertian diffuse, perfect mirror and a smooth
// dielectric with exact Fresnel reflectance. Plain data plus pure helpers; thread-safe.

#include "core/math.h"
#include "scene/scene_desc.h"

namespace fogmap {

struct Material {
    MaterialType type = MaterialType::Diffuse;
    Color albedo{0.8f};  ///< diffuse reflectance or mirror reflectance
    float ior = 1.5f;    ///< dielectric index of refraction (outside is 1)
    bool is_specular() const { return type != MaterialType::Diffuse; }
};

/// Unpolarised Fresnel reflectance of a smooth dielectric interface; cos_i = cosine of the
/// incident angle on the incident side (>= 0), eta = n_transmitted / n_incident. 1 on total
/// internal reflection.
inline float fresnel_dielectric(float cos_i, float eta) {
    cos_i = std::clamp(cos_i, 0.0f, 1.0f);
    const float sin2_t = (1.0f - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.0f) return 1.0f;
    const float cos_t = std::sqrt(1.0f - sin2_t);
    const float r_par = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    const float r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    return 0.5f * (r_par * r_par + r_perp * r_perp);
}

/// Refracts travel direction d (unit) through a surface with unit normal n facing against d
/// (dot(d, n) < 0), eta = n_t / n_i. Returns false on total internal reflection.
inline bool refract(const Vec3& d, const Vec3& n, float eta, Vec3* out) {
    const float cos_i = -glm::dot(d, n);
    const float sin2_t = (1.0f - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.0f) return false;
    const float cos_t = std::sqrt(1.0f - sin2_t);
    *out = glm::normalize(d / eta + (cos_i / eta - cos_t) * n);
    return true;
}

inline Vec3 reflect(const Vec3& d, const Vec3& n) { return d - 2.0f * glm::dot(d, n) * n; }

/// Cosine-weighted direction about unit n; pdf = cos/π.
inline Vec3 sample_cosine_hemisphere(const Vec3& n, Vec2 u) {
    const float r = std::sqrt(u.x);
    const float phi = kTwoPi * u.y;
    const Vec3 local(r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0f, 1.0f - u.x)));
    return glm::normalize(to_world(local, n));
}

/// Uniform direction on the unit sphere; pdf = 1/(4π).
inline Vec3 sample_uniform_sphere(Vec2 u) {
    const float z = 1.0f - 2.0f * u.x;
    const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
    const float phi = kTwoPi * u.y;
    return Vec3(r * std::cos(phi), r * std::sin(phi), z);
}

}  // namespace fogmap
