#pragma once
// Surface materials: Lambertian diffuse, perfect mirror and a smooth dielectric with exact Fresnel
// reflectance, and the one specular-scattering rule every tracer uses (camera paths carry radiance,
// photons importance-like power). Plain data plus pure helpers; thread-safe.

#include "core/math.h"

namespace fogmap {

enum class MaterialType { Diffuse, Mirror, Glass };

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

/// What a path carries across a specular surface: camera paths carry radiance, which is
/// compressed by (n_t/n_i)² entering a denser medium; photons carry power, which is not (Veach
/// 1997, ch. 5: the adjoint BTDF).
enum class Transport { Radiance, Importance };

/// A specular bounce: the continuing ray (origin offset to the side it leaves on) and the
/// path weight (mirror: its albedo; glass: 1, or 1/η² for radiance refracted across).
struct SpecularScatter {
    Ray ray;
    Color weight{1.0f};
};

/// Scatters a path travelling along unit d that hit a specular material at p with geometric
/// normal ng (either side): a mirror reflects; glass reflects with the Fresnel probability
/// (u < F, u uniform in [0, 1); total internal reflection always reflects) and refracts
/// otherwise. `offset_floor` as offset_point. Only for materials with is_specular().
inline SpecularScatter scatter_specular(const Material& m, const Vec3& d, const Vec3& p,
                                        const Vec3& ng, float u, Transport mode,
                                        float offset_floor) {
    const bool front = glm::dot(d, ng) < 0.0f;
    const Vec3 n = front ? ng : -ng;  // faces where the path came from
    const Ray reflected{offset_point(p, n, offset_floor), glm::normalize(reflect(d, n))};
    if (m.type == MaterialType::Mirror) return {reflected, m.albedo};
    const float eta = front ? m.ior : 1.0f / m.ior;
    Vec3 wt;
    if (u < fresnel_dielectric(-glm::dot(d, n), eta) || !refract(d, n, eta, &wt))
        return {reflected, Color(1.0f)};
    const float weight = mode == Transport::Radiance ? 1.0f / (eta * eta) : 1.0f;
    return {Ray{offset_point(p, -n, offset_floor), wt}, Color(weight)};
}

}  // namespace fogmap
