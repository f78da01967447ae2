// Single scattering of the photon integrator along one camera ray through a homogeneous cube,
// against the integral computed here by quadrature: a point or spot light close to the ray (the
// 1/r² peak equi-angular sampling is for) and a quad light (steps drawn ∝ the march's weights
// only). Every advanced.light_samples setting, including 0 (a shadow ray at every step), must give
// the same expectation.

#include "render/photon_integrator.h"
#include "scene/scene.h"
#include "scene_builders.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace fogmap {
namespace {

using namespace test;

constexpr float kSigmaS = 0.5f, kSigmaA = 0.25f;
constexpr double kSigmaT = kSigmaS + kSigmaA;

SceneDesc cube(const LightDesc& light, int light_samples) {
    SceneDesc d;
    d.lights.push_back(light);
    // Isotropic (g = 0): p = 1/(4π).
    d.media.push_back(homogeneous(Box3{Vec3(-1.0f), Vec3(1.0f)}, Color(kSigmaS), Color(kSigmaA)));
    d.photons.global = d.photons.caustic = 0;
    d.photons.volume = 0;
    d.volume.light_samples = light_samples;
    return d;
}

// The camera ray: from (−3, 0, 0) along +x, inside the cube for t in [2, 4].
const Ray kRay{Vec3(-3.0f, 0.0f, 0.0f), Vec3(1.0f, 0.0f, 0.0f)};

// ∫ σ_s e^{−σ_t (t − 2)} (1/4π) E(t) dt over [2, 4] by the composite Simpson rule with n (even)
// panels, where E(x) = ∫ L_in dω at x, attenuated through the medium (the light is inside it).
template <class Incident>
double quadrature(int n, Incident&& incident) {
    const double a = 2.0, b = 4.0, h = (b - a) / n;
    double sum = 0.0;
    for (int i = 0; i <= n; ++i) {
        const double t = a + i * h;
        const Vec3 x = kRay.o + static_cast<float>(t) * kRay.d;
        const double f = kSigmaS * std::exp(-kSigmaT * (t - a)) / (4.0 * kPi) * incident(x);
        sum += f * (i == 0 || i == n ? 1.0 : (i % 2 ? 4.0 : 2.0));
    }
    return sum * h / 3.0;
}

MeanEstimate single_scatter_mean(const SceneDesc& d, int n) {
    const auto scene = load_scene(d);
    const PhotonMaps maps;
    const PhotonIntegrator integrator(*scene, maps, gather_params(d, *scene, maps, false), d.march,
                                      d.render.max_depth);
    PhotonIntegrator::ThreadState ts = integrator.make_state();
    return estimate_mean(n, [&](int i) {
        Rng rng(5, i);
        return integrator.radiance(kRay, rng, ts)[Layer::VolumeSingle].x;
    });
}

// Every light_samples setting (0: a shadow ray at every step) within 4 standard errors.
void expect_matches(const LightDesc& light, std::initializer_list<int> light_samples,
                    double expected) {
    for (int m : light_samples) {
        const MeanEstimate e = single_scatter_mean(cube(light, m), m == 0 ? 4000 : 40000);
        EXPECT_NEAR(e.mean, expected, 4.0 * e.standard_error + 1e-3 * expected)
            << "light_samples " << m;
    }
}

TEST(SingleScatterSampling, PointLightNextToTheRayMatchesQuadrature) {
    const LightDesc light = point_light(Vec3(0.3f, 0.1f, 0.0f), 2.0f);
    // The 1/r² peak of a light 0.1 from the ray is 0.1 wide: 200 000 panels.
    const double expected = quadrature(200000, [&](const Vec3& x) {
        const double r = glm::length(light.position - x);
        return 2.0 * std::exp(-kSigmaT * r) / (r * r);
    });
    expect_matches(light, {0, 1, 4}, expected);
}

TEST(SingleScatterSampling, SpotLightMatchesQuadrature) {
    const LightDesc light =
        spot_light(Vec3(0.0f, 0.6f, 0.0f), Vec3(0.0f, -1.0f, 0.0f), 3.0f, 30.0f, 10.0f);
    // The spot's emission written out here: intensity I within 20° of the axis, falling as the
    // cubic smoothstep t²(3 − 2t) of the cosine to 0 at 30°, over r², times the medium's
    // transmittance.
    const double cos_outer = std::cos(30.0 * kPi / 180.0), cos_inner = std::cos(20.0 * kPi / 180.0);
    const double expected = quadrature(200000, [&](const Vec3& x) {
        const Vec3 to = x - light.position;
        const double r = glm::length(to), c = -to.y / r;  // cosine to the axis (0, -1, 0)
        const double t = std::clamp((c - cos_outer) / (cos_inner - cos_outer), 0.0, 1.0);
        return 3.0 * t * t * (3.0 - 2.0 * t) / (r * r) * std::exp(-kSigmaT * r);
    });
    expect_matches(light, {0, 2}, expected);
}

TEST(SingleScatterSampling, QuadLightMatchesQuadrature) {
    // A small square light facing down at y = 0.9, inside the cube; its solid angle integral is
    // done by a 32×32 midpoint rule per quadrature point (the square is 0.2 wide).
    const LightDesc light =
        quad_light(Vec3(-0.1f, 0.9f, -0.1f), Vec3(0.2f, 0.0f, 0.0f), Vec3(0.0f, 0.0f, 0.2f), 4.0f);
    const Light l = make_light(light);
    const double expected = quadrature(2000, [&](const Vec3& x) {
        const int k = 32;
        double sum = 0.0;
        for (int i = 0; i < k; ++i) {
            for (int j = 0; j < k; ++j) {
                const Vec3 q = l.corner + ((i + 0.5f) / k) * l.edge_u + ((j + 0.5f) / k) * l.edge_v;
                const Vec3 to = q - x;
                const double r2 = glm::dot(to, to), r = std::sqrt(r2);
                const double cos_l = -glm::dot(to, l.normal) / r;
                if (cos_l <= 0.0) continue;
                sum += 4.0 * cos_l / r2 * std::exp(-kSigmaT * r);
            }
        }
        return sum * l.area / (k * k);
    });
    expect_matches(light, {0, 2}, expected);
}

}  // namespace
}  // namespace fogmap
