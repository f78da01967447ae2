// Lights (scene/light.h) against closed forms and brute force: each light's power — point 4πI, a
// spot I·2π(1 − (cos θ_outer + cos θ_inner)/2) (its smoothstep falloff in the cosine integrates to
// the midpoint of the ramp), also summed over a sphere of directions from what sample_light
// delivers; a quad π A L; a sun E π R² over the disc of the scene's bounding sphere; an
// environment 4π² R² L — and the sampling pdfs: a quad's integrates to 1 over the sphere of
// directions and E[1/pdf] is its solid angle (closed form for a point over a corner); a sun
// disc's integrates to 1, its radiance to the sun's irradiance and its samples stay in the cone; an
// environment's samples give the irradiance π L on any plane.

#include "scene/light.h"

#include "scene_builders.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>

namespace fogmap {
namespace {

constexpr double kPiD = 3.14159265358979323846;

// Bounds [0, 0, 0]..[2, 3, 6]: diagonal 7, bounding sphere radius R = 3.5.
const Box3 kBounds{Vec3(0.0f), Vec3(2.0f, 3.0f, 6.0f)};
constexpr double kR = 3.5;

/// Σ f(ω) dω over an equal-area midpoint grid (n_mu rows uniform in μ = ω·axis over
/// [mu_lo, 1], n_phi columns) on the cap around unit `axis`; the frame is built here.
double integrate_cap(const Vec3& axis, double mu_lo, int n_mu, int n_phi,
                     const std::function<double(const Vec3&)>& f) {
    const glm::dvec3 w = glm::dvec3(axis);
    const glm::dvec3 helper = std::abs(w.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
    const glm::dvec3 a = glm::normalize(glm::cross(helper, w)), b = glm::cross(w, a);
    const double d_mu = (1.0 - mu_lo) / n_mu, d_phi = 2.0 * kPiD / n_phi;
    double sum = 0.0;
    for (int i = 0; i < n_mu; ++i) {
        const double mu = mu_lo + (i + 0.5) * d_mu, s = std::sqrt(std::max(0.0, 1.0 - mu * mu));
        for (int j = 0; j < n_phi; ++j) {
            const double phi = (j + 0.5) * d_phi;
            sum += f(Vec3(s * std::cos(phi) * a + s * std::sin(phi) * b + mu * w));
        }
    }
    return sum * d_mu * d_phi;
}

double integrate_sphere(const Vec3& axis, int n_mu, int n_phi,
                        const std::function<double(const Vec3&)>& f) {
    return integrate_cap(axis, -1.0, n_mu, n_phi, f);
}

TEST(Light, PointPowerIsFourPiIntensityAndItsSampleFallsOffAsInverseSquare) {
    const Light l = make_light(test::point_light(Vec3(1.0f, 2.0f, 3.0f), 2.5f));
    EXPECT_TRUE(l.is_delta());
    EXPECT_FALSE(l.is_infinite());
    EXPECT_NEAR(light_power(l, kBounds).x, 4.0 * kPiD * 2.5, 1e-5);
    const Vec3 p(1.0f, 2.0f, -1.0f);  // 4 below the light along z
    const LightSample s = sample_light(l, p, Vec2(0.3f, 0.7f));
    EXPECT_NEAR(s.dist, 4.0f, 1e-6f);
    EXPECT_NEAR(s.wi.z, 1.0f, 1e-6f);
    EXPECT_NEAR(s.Li.x, 2.5f / 16.0f, 1e-7f);
    EXPECT_EQ(s.pdf, 1.0f);
    EXPECT_EQ(light_pdf(l, p, s.wi, s.dist), 0.0f);  // a delta light is never hit
}

TEST(Light, SpotPowerIsItsFalloffIntegratedOverTheSphere) {
    const Vec3 position(0.5f, 2.0f, -1.0f), axis = glm::normalize(Vec3(0.3f, -1.0f, 0.2f));
    const struct {
        float angle, delta;
    } cones[] = {{30.0f, 5.0f}, {45.0f, 20.0f}, {120.0f, 50.0f}, {10.0f, 10.0f}, {60.0f, 0.0f}};
    for (const auto& cone : cones) {
        const Light l =
            make_light(test::spot_light(position, axis * 2.0f, 3.0f, cone.angle, cone.delta));
        const double cos_outer = std::cos(cone.angle * kPiD / 180.0);
        const double cos_inner = std::cos((cone.angle - cone.delta) * kPiD / 180.0);
        // 2π [∫_{cos_outer}^{cos_inner} smoothstep + (1 − cos_inner)]; the smoothstep's integral
        // over its ramp is half the ramp.
        const double closed = 3.0 * 2.0 * kPiD * (1.0 - 0.5 * (cos_outer + cos_inner));
        EXPECT_NEAR(light_power(l, kBounds).y, closed, 1e-5 * closed)
            << "cone " << cone.angle << ", delta " << cone.delta;
        // Brute force: the intensity sample_light delivers to points on a sphere of radius 2
        // around the spot (Li·d²), over the sphere, on a grid whose poles are not the spot's axis.
        const double summed =
            integrate_sphere(Vec3(0.0f, 0.0f, 1.0f), 2048, 1024, [&](const Vec3& w) {
                const LightSample s = sample_light(l, position + 2.0f * w, Vec2(0.5f));
                return double(s.Li.y) * double(s.dist) * s.dist;
            });
        // 2·10⁶ cells integrate the smooth falloff to ~1e-6 (measured ≤ 5e-6); a ramp of 0 (a
        // hard edge) leaves the cells the edge crosses, ~1e-3 of the cone's (measured 1.4e-4).
        EXPECT_NEAR(summed, closed, (cone.delta > 0.0f ? 2e-5 : 1e-3) * closed)
            << "cone " << cone.angle << ", delta " << cone.delta;
    }
}

// A 2 x 3 quad, tilted: edges 2 (0.6, 0.8, 0) and 3 (0, 0, 1), emitting along (0.8, −0.6, 0).
LightDesc tilted_quad(float radiance) {
    return test::quad_light(Vec3(1.0f, -2.0f, 0.5f), Vec3(1.2f, 1.6f, 0.0f), Vec3(0.0f, 0.0f, 3.0f),
                            radiance);
}

TEST(Light, QuadPowerIsPiAreaRadianceAndItRadiatesFromItsFrontOnly) {
    const Light l = make_light(tilted_quad(1.5f));
    EXPECT_FALSE(l.is_delta());
    EXPECT_NEAR(l.area, 6.0f, 1e-5f);
    EXPECT_NEAR(glm::length(l.normal - Vec3(0.8f, -0.6f, 0.0f)), 0.0f, 1e-6f);
    EXPECT_NEAR(light_power(l, kBounds).z, kPiD * 6.0 * 1.5, 1e-4);
    EXPECT_EQ(quad_radiance(l, Vec3(-0.8f, 0.6f, 0.0f)), Color(1.5f));  // arriving at its front
    EXPECT_EQ(quad_radiance(l, Vec3(0.8f, -0.6f, 0.0f)), Color(0.0f));
    // From behind, nothing.
    const LightSample behind =
        sample_light(l, Vec3(1.0f, -2.0f, 0.5f) - Vec3(0.8f, -0.6f, 0.0f), Vec2(0.5f));
    EXPECT_EQ(behind.pdf, 0.0f);
}

TEST(Light, QuadMeanInversePdfIsItsSolidAngle) {
    // A point at height d on the normal through a corner of an a x b rectangle sees the solid
    // angle atan(ab / (d √(a² + b² + d²))). E_u[1/pdf] over uniform u is that solid angle;
    // a 400 x 400 midpoint grid of u integrates the smooth 1/pdf to ~1e-6 (measured 3e-7).
    const Light l = make_light(tilted_quad(1.0f));
    const double a = 2.0, b = 3.0;
    for (double d : {0.5, 1.5, 6.0}) {
        const Vec3 p = l.corner + float(d) * Vec3(0.8f, -0.6f, 0.0f);
        const int n = 400;
        double sum = 0.0;
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j) {
                const LightSample s = sample_light(l, p, Vec2((i + 0.5f) / n, (j + 0.5f) / n));
                ASSERT_GT(s.pdf, 0.0f);
                EXPECT_NEAR(light_pdf(l, p, s.wi, s.dist), s.pdf, 1e-5f * s.pdf);
                sum += 1.0 / s.pdf;
            }
        const double omega = std::atan(a * b / (d * std::sqrt(a * a + b * b + d * d)));
        EXPECT_NEAR(sum / (n * n), omega, 1e-5 * omega) << "d " << d;
    }
}

TEST(Light, QuadPdfIntegratesToOneOverTheSphere) {
    // Every direction from p, the quad hit (or not) by a ray-plane intersection written here,
    // light_pdf at the hit's distance. The cells the quad's edges cross are the error: the quad
    // covers ~10⁶ of the 8·10⁶ cells and its edges ~5·10³, each off by up to half a cell either
    // way: ~3e-3 were they all off alike, ~1e-5 as they scatter (measured 3e-5 and 4e-5).
    const Light l = make_light(tilted_quad(1.0f));
    const Vec3 n(0.8f, -0.6f, 0.0f), u(1.2f, 1.6f, 0.0f), v(0.0f, 0.0f, 3.0f);
    for (const Vec3& p :
         {l.corner + 0.7f * u + 0.4f * v + 1.1f * n, l.corner - 0.5f * u + 1.3f * v + 2.5f * n}) {
        const double total =
            integrate_sphere(Vec3(0.0f, 1.0f, 0.0f), 2048, 4096, [&](const Vec3& w) {
                const double facing = glm::dot(w, n);
                if (facing >= 0.0) return 0.0;
                const double t = glm::dot(l.corner - p, n) / facing;
                const Vec3 hit = p + float(t) * w;
                const double s = glm::dot(hit - l.corner, u) / glm::dot(u, u);
                const double r = glm::dot(hit - l.corner, v) / glm::dot(v, v);
                if (s < 0.0 || s > 1.0 || r < 0.0 || r > 1.0) return 0.0;
                return double(light_pdf(l, p, w, float(t)));
            });
        EXPECT_NEAR(total, 1.0, 5e-4);
    }
}

TEST(Light, SunPowerIsIrradianceOverTheDiscOfTheBoundingSphere) {
    for (float radius_deg : {0.0f, 0.27f, 5.0f}) {
        LightDesc d = test::sun(Vec3(0.2f, -1.0f, 0.4f), 2.0f);
        d.angular_radius_deg = radius_deg;
        const Light l = make_light(d);
        EXPECT_TRUE(l.is_infinite());
        EXPECT_EQ(l.is_delta(), radius_deg == 0.0f);
        EXPECT_NEAR(light_power(l, kBounds).x, 2.0 * kPiD * kR * kR, 1e-4);
        EXPECT_EQ(light_power(l, Box3{}), Color(0.0f));  // no scene, no power
    }
}

TEST(Light, DeltaSunArrivesAlongItsDirectionWithItsIrradiance) {
    const Light l = make_light(test::sun(Vec3(0.0f, -2.0f, 0.0f), 3.0f));  // normalised
    const LightSample s = sample_light(l, Vec3(5.0f), Vec2(0.1f, 0.9f));
    EXPECT_EQ(s.wi, Vec3(0.0f, 1.0f, 0.0f));
    EXPECT_EQ(s.dist, kInfinity);
    EXPECT_EQ(s.Li, Color(3.0f));
    EXPECT_EQ(s.pdf, 1.0f);
    EXPECT_EQ(light_pdf(l, Vec3(0.0f), Vec3(0.0f, 1.0f, 0.0f), kInfinity), 0.0f);
    EXPECT_EQ(escaped_radiance(l, Vec3(0.0f, 1.0f, 0.0f)), Color(0.0f));
}

TEST(Light, SunOneMinusCosIsOneMinusCos) {
    for (double deg : {0.01, 0.27, 1.0, 10.0, 45.0, 90.0}) {
        const long double want = 1.0L - std::cos(static_cast<long double>(deg) * kPiD / 180.0L);
        EXPECT_NEAR(sun_one_minus_cos(float(deg)), double(want), 1e-6 * double(want)) << deg;
    }
}

TEST(Light, SunDiscPdfIntegratesToOneAndItsRadianceToTheIrradiance) {
    const double theta = 5.0 * kPiD / 180.0, irradiance = 2.0;
    LightDesc d = test::sun(Vec3(0.2f, -1.0f, 0.4f), float(irradiance));
    d.angular_radius_deg = 5.0f;
    const Light l = make_light(d);
    const Vec3 towards = glm::normalize(Vec3(-0.2f, 1.0f, -0.4f));
    // The cap out to 6°: the disc's edge falls inside one of 20000 rows, the disc spanning ~14000
    // of them, so the edge row costs at most 7e-5 (measured 3e-5).
    const double mu_lo = std::cos(6.0 * kPiD / 180.0);
    const double pdf_integral = integrate_cap(towards, mu_lo, 20000, 16, [&](const Vec3& w) {
        return double(light_pdf(l, Vec3(0.0f), w, kInfinity));
    });
    EXPECT_NEAR(pdf_integral, 1.0, 1e-4);
    // ∫ L cos dω over the disc, seen by a plane facing the sun, is the sun's irradiance.
    const double irradiance_integral = integrate_cap(towards, mu_lo, 20000, 16, [&](const Vec3& w) {
        return double(escaped_radiance(l, w).x) * glm::dot(w, towards);
    });
    EXPECT_NEAR(irradiance_integral, irradiance, 1e-4 * irradiance);
    EXPECT_NEAR(l.radiance.x, irradiance / (kPiD * std::sin(theta) * std::sin(theta)),
                1e-5 * l.radiance.x);
    // Outside the disc: no pdf and no radiance; inside: both.
    integrate_sphere(Vec3(1.0f, 0.0f, 0.0f), 400, 800, [&](const Vec3& w) {
        const double angle = std::acos(std::clamp(double(glm::dot(w, towards)), -1.0, 1.0));
        if (angle > 1.001 * theta) {
            EXPECT_EQ(light_pdf(l, Vec3(0.0f), w, kInfinity), 0.0f);
            EXPECT_EQ(escaped_radiance(l, w), Color(0.0f));
        } else if (angle < 0.999 * theta) {
            EXPECT_GT(light_pdf(l, Vec3(0.0f), w, kInfinity), 0.0f);
            EXPECT_GT(escaped_radiance(l, w).x, 0.0f);
        }
        return 0.0;
    });
}

TEST(Light, SunDiscSamplesStayInTheConeUniformly) {
    // Uniform in the cone's solid angle: cos θ uniform on [cos θ_max, 1], mean (1 + cos θ_max)/2.
    LightDesc d = test::sun(Vec3(0.2f, -1.0f, 0.4f), 2.0f);
    d.angular_radius_deg = 5.0f;
    const Light l = make_light(d);
    const Vec3 towards = glm::normalize(Vec3(-0.2f, 1.0f, -0.4f));
    const double cos_max = std::cos(5.0 * kPiD / 180.0);
    const int n = 256;
    double sum = 0.0;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const LightSample s = sample_light(l, Vec3(1.0f), Vec2((i + 0.5f) / n, (j + 0.5f) / n));
            const double c = glm::dot(s.wi, towards);
            ASSERT_GE(c, cos_max - 1e-6);
            EXPECT_EQ(s.pdf, light_pdf(l, Vec3(1.0f), s.wi, kInfinity));
            EXPECT_EQ(s.Li, l.radiance);
            sum += c;
        }
    EXPECT_NEAR(sum / (n * n), 0.5 * (1.0 + cos_max), 1e-6);
}

TEST(Light, EnvironmentPowerIsFourPiSquaredRSquaredRadiance) {
    const Light l = make_light(test::environment(0.7f));
    EXPECT_TRUE(l.is_infinite());
    EXPECT_FALSE(l.is_delta());
    EXPECT_NEAR(light_power(l, kBounds).x, 4.0 * kPiD * kPiD * kR * kR * 0.7, 1e-3);
    EXPECT_EQ(light_power(l, Box3{}), Color(0.0f));
}

TEST(Light, EnvironmentSamplesGiveTheIrradiancePiRadianceOnAnyPlane) {
    const Light l = make_light(test::environment(0.7f));
    EXPECT_NEAR(integrate_sphere(
                    Vec3(0.0f, 0.0f, 1.0f), 64, 64,
                    [&](const Vec3& w) { return double(light_pdf(l, Vec3(0.0f), w, kInfinity)); }),
                1.0, 1e-6);
    // E[Li max(0, ω·n) / pdf] = L ∫ cos⁺ dω = π L; a 512 x 512 midpoint grid of u, the kink of
    // cos⁺ along a great circle costing ~1e-5 (measured 1e-6).
    for (const Vec3& normal : {Vec3(0.0f, 0.0f, 1.0f), glm::normalize(Vec3(0.3f, -0.5f, 0.8f))}) {
        const int n = 512;
        double sum = 0.0;
        for (int i = 0; i < n; ++i)
            for (int j = 0; j < n; ++j) {
                const LightSample s =
                    sample_light(l, Vec3(0.0f), Vec2((i + 0.5f) / n, (j + 0.5f) / n));
                ASSERT_NEAR(glm::length(s.wi), 1.0f, 1e-5f);
                EXPECT_EQ(s.pdf, light_pdf(l, Vec3(0.0f), s.wi, kInfinity));
                EXPECT_EQ(escaped_radiance(l, s.wi), Color(0.7f));
                sum += s.Li.x * std::max(0.0, double(glm::dot(s.wi, normal))) / s.pdf;
            }
        EXPECT_NEAR(sum / (n * n), kPiD * 0.7, 1e-4 * kPiD * 0.7);
    }
}

}  // namespace
}  // namespace fogmap
