#include "scene/light.h"

#include "core/sampling.h"

#include <cmath>

namespace fogmap {

namespace {

float smoothstep(float a, float b, float x) {
    if (b <= a) return x >= b ? 1.0f : 0.0f;
    const float t = std::clamp((x - a) / (b - a), 0.0f, 1.0f);
    return t * t * (3.0f - 2.0f * t);
}

float sun_cone_pdf(const Light& l) { return 1.0f / (kTwoPi * l.sun_one_minus_cos); }

}  // namespace

float sun_one_minus_cos(float angular_radius_deg) {
    const double theta = angular_radius_deg * (kPiDouble / 180.0);
    const double s = std::sin(0.5 * theta);
    return static_cast<float>(2.0 * s * s);
}

Light make_light(const LightDesc& d) {
    Light l;
    l.type = d.type;
    l.intensity = d.intensity;
    l.radiance = d.radiance;
    l.irradiance = d.irradiance;
    l.position = d.position;
    const float len = glm::length(d.direction);
    l.direction = len > 0.0f ? d.direction / len : Vec3(0.0f, -1.0f, 0.0f);
    const double deg = kPiDouble / 180.0;
    l.cos_outer = static_cast<float>(std::cos(d.cone_angle_deg * deg));
    l.cos_inner = static_cast<float>(std::cos((d.cone_angle_deg - d.cone_delta_deg) * deg));
    if (d.type == LightType::Sun && d.angular_radius_deg > 0.0f) {
        const double theta = d.angular_radius_deg * deg;
        l.sun_one_minus_cos = sun_one_minus_cos(d.angular_radius_deg);
        const double sin_theta = std::sin(theta);
        l.radiance = d.irradiance / static_cast<float>(kPiDouble * sin_theta * sin_theta);
    }
    l.corner = d.corner;
    l.edge_u = d.edge_u;
    l.edge_v = d.edge_v;
    const Vec3 n = glm::cross(d.edge_u, d.edge_v);
    l.area = glm::length(n);
    if (l.area > 0.0f) l.normal = n / l.area;
    return l;
}

LightSample sample_light(const Light& l, const Vec3& p, Vec2 u) {
    LightSample s;
    switch (l.type) {
        case LightType::Point:
        case LightType::Spot: {
            const Vec3 to = l.position - p;
            const float d2 = glm::dot(to, to);
            if (d2 <= 0.0f) return s;
            s.dist = std::sqrt(d2);
            s.wi = to / s.dist;
            Color I = l.intensity;
            if (l.type == LightType::Spot)
                I *= smoothstep(l.cos_outer, l.cos_inner, glm::dot(-s.wi, l.direction));
            s.Li = I / d2;
            s.pdf = 1.0f;
            return s;
        }
        case LightType::Quad: {
            const Vec3 q = l.corner + u.x * l.edge_u + u.y * l.edge_v;
            const Vec3 to = q - p;
            const float d2 = glm::dot(to, to);
            if (d2 <= 0.0f || l.area <= 0.0f) return s;
            s.dist = std::sqrt(d2);
            s.wi = to / s.dist;
            const float cos_l = -glm::dot(s.wi, l.normal);
            if (cos_l <= 0.0f) return s;
            s.Li = l.radiance;
            s.pdf = d2 / (l.area * cos_l);
            return s;
        }
        case LightType::Sun: {
            const Vec3 axis = -l.direction;
            if (l.sun_one_minus_cos == 0.0f) {
                s.wi = axis;
                s.Li = l.irradiance;
                s.pdf = 1.0f;
                return s;
            }
            const float omc = u.x * l.sun_one_minus_cos;  // 1 − cos θ, uniform in the cone
            const float cos_t = 1.0f - omc;
            const float sin_t = std::sqrt(std::max(0.0f, omc * (2.0f - omc)));
            const float phi = kTwoPi * u.y;
            s.wi = glm::normalize(
                to_world(Vec3(sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t), axis));
            s.Li = l.radiance;
            s.pdf = sun_cone_pdf(l);
            return s;
        }
        case LightType::Environment:
            s.wi = sample_uniform_sphere(u);
            s.Li = l.radiance;
            s.pdf = kInvFourPi;
            return s;
    }
    return s;
}

float light_pdf(const Light& l, const Vec3& p, const Vec3& wi, float dist) {
    switch (l.type) {
        case LightType::Quad: {
            const float cos_l = -glm::dot(wi, l.normal);
            if (cos_l <= 0.0f || l.area <= 0.0f) return 0.0f;
            (void)p;
            return dist * dist / (l.area * cos_l);
        }
        case LightType::Sun:
            if (l.sun_one_minus_cos == 0.0f) return 0.0f;
            return 1.0f - glm::dot(wi, -l.direction) <= l.sun_one_minus_cos ? sun_cone_pdf(l)
                                                                            : 0.0f;
        case LightType::Environment:
            return kInvFourPi;
        default:
            return 0.0f;
    }
}

Color escaped_radiance(const Light& l, const Vec3& d) {
    if (l.type == LightType::Environment) return l.radiance;
    if (l.type == LightType::Sun && l.sun_one_minus_cos > 0.0f &&
        1.0f - glm::dot(d, -l.direction) <= l.sun_one_minus_cos)
        return l.radiance;
    return Color(0.0f);
}

Color quad_radiance(const Light& l, const Vec3& d) {
    return glm::dot(d, l.normal) < 0.0f ? l.radiance : Color(0.0f);
}

namespace {

// Spot falloff integrated over the sphere: 2π ∫ falloff(μ) dμ on [cos_outer, 1] (midpoint rule,
// 512 panels; the falloff is a smoothstep, so this is accurate to ~1e-6).
float spot_solid_angle(const Light& l) {
    const int n = 512;
    const double a = l.cos_outer, h = (1.0 - a) / n;
    double sum = 0.0;
    for (int i = 0; i < n; ++i)
        sum += smoothstep(l.cos_outer, l.cos_inner, static_cast<float>(a + (i + 0.5) * h));
    return static_cast<float>(2.0 * kPiDouble * sum * h);
}

float bounding_radius(const Box3& b) { return 0.5f * glm::length(b.extent()); }

}  // namespace

Color light_power(const Light& l, const Box3& bounds) {
    switch (l.type) {
        case LightType::Point:
            return 4.0f * kPi * l.intensity;
        case LightType::Spot:
            return spot_solid_angle(l) * l.intensity;
        case LightType::Quad:
            return kPi * l.area * l.radiance;
        case LightType::Sun: {
            if (bounds.empty()) return Color(0.0f);
            const float r = bounding_radius(bounds);
            return kPi * r * r * l.irradiance;
        }
        case LightType::Environment: {
            if (bounds.empty()) return Color(0.0f);
            const float r = bounding_radius(bounds);
            return 4.0f * kPi * kPi * r * r * l.radiance;
        }
    }
    return Color(0.0f);
}

}  // namespace fogmap
