// Photon beams: the hierarchy's queries against brute force (every beam's chord through its
// cylinder, found by sampling the ray densely), and the photon pass's beams against its own
// photons: in a homogeneous medium the scattering events a path stores (a collision estimate of
// σ_s ∫ fluence) and the length of its beams (a track-length estimate of ∫ fluence) measure the
// same light.

#include "photon/photon_beams.h"
#include "render/run_setup.h"

#include "core/rng.h"
#include "core/sampling.h"
#include "scene_builders.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

namespace fogmap {
namespace {

using namespace test;

struct Segment {
    Vec3 a, b;
};

// The length of the part of ray o + t d, t in [t0, t1], inside the finite cylinder of radius r
// around segment s, by the midpoint rule over n steps.
double sampled_chord(const Ray& ray, float t0, float t1, const Segment& s, float r, int n) {
    const DVec3 a(s.a), w = glm::normalize(DVec3(s.b) - DVec3(s.a));
    const double length = glm::length(DVec3(s.b) - DVec3(s.a)), dt = (double(t1) - t0) / n;
    int inside = 0;
    for (int i = 0; i < n; ++i) {
        const DVec3 x = DVec3(ray.o) + (t0 + (i + 0.5) * dt) * DVec3(ray.d);
        const double along = glm::dot(x - a, w);
        const DVec3 off = x - a - along * w;
        inside += along >= 0.0 && along <= length && glm::dot(off, off) < double(r) * r;
    }
    return inside * dt;
}

// 400 beams of 0.002 to 1.2 (cut into pieces of at most 8 radii) in a unit cube, 150 ray segments
// through it: the kernels a query reports, × π r², add up per beam to the beam's chord through
// its cylinder, and every reported point lies on the segment within the cylinder. A beam whose
// pieces the query missed, or chords not clipped at a piece's ends, fail it.
TEST(PhotonBeams, QueriesReturnEveryBeamsChordThroughItsCylinder) {
    constexpr float kR = 0.04f;
    PhotonMap map;
    map.photon_power = 1.0f;
    std::vector<Segment> segments;
    Rng rng(7, 0, 0);
    for (int i = 0; i < 400; ++i) {
        const Vec3 a(rng.uniform(), rng.uniform(), rng.uniform());
        const Vec3 dir = sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform()));
        const float length = 0.002f + 1.2f * rng.uniform() * rng.uniform();
        segments.push_back({a, a + length * dir});
        map.beams.emplace_back(a, a + length * dir, Color(1.0f));
    }
    const PhotonBeams beams(map, 0, kR);  // k 0: the radius is kR
    ASSERT_EQ(beams.radius(), kR);
    ASSERT_GT(beams.pieces().size(), segments.size());  // long beams were cut

    // The beam a piece was cut from: its start on that beam's axis, the same direction.
    auto owner = [&](const PhotonBeams::Piece& p) {
        for (size_t j = 0; j < segments.size(); ++j) {
            const Vec3 w = glm::normalize(segments[j].b - segments[j].a);
            if (glm::dot(w, p.dir) > 0.99999f &&
                glm::length(glm::cross(p.start - segments[j].a, w)) < 1e-4f)
                return static_cast<int>(j);
        }
        return -1;
    };
    int checked = 0, crossed = 0;
    for (int q = 0; q < 150; ++q) {
        const Vec3 o =
            Vec3(0.5f) + 2.0f * sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform()));
        const Vec3 target(rng.uniform(), rng.uniform(), rng.uniform());
        const Ray ray{o, glm::normalize(target - o)};
        const float t0 = 1.0f + rng.uniform(), t1 = t0 + 0.3f + 1.5f * rng.uniform();
        std::vector<double> got(segments.size(), 0.0);
        beams.for_each_hit(ray, t0, t1, [&](const PhotonBeams::Piece& p, float t, float kernel) {
            EXPECT_GE(t, t0);
            EXPECT_LE(t, t1);
            const Vec3 x = ray.o + t * ray.d;
            const float along = glm::dot(x - p.start, p.dir);
            EXPECT_LE(glm::length(x - p.start - along * p.dir), kR * 1.001f);
            const int j = owner(p);
            ASSERT_GE(j, 0);
            got[j] += double(kernel) * kPi * kR * kR;
        });
        constexpr int kSteps = 4000;
        const double step = (double(t1) - t0) / kSteps;
        for (size_t j = 0; j < segments.size(); ++j) {
            const double want = sampled_chord(ray, t0, t1, segments[j], kR, kSteps);
            EXPECT_NEAR(got[j], want, 2.0 * step + 1e-5 * want) << "ray " << q << ", beam " << j;
            ++checked;
            crossed += want > 0.0;
        }
    }
    EXPECT_GT(crossed, 500);
    std::printf("%d ray-beam pairs, %d crossing\n", checked, crossed);
}

// A sun over a homogeneous box (albedo 0.75) on a ground: Σ ΔΦ of the stored volume photons
// against σ_s Σ ΔΦ_b L_b of the beams, same pass (both: light after a first interaction, every
// stream, the bounce stream's ground light too). Measured 0.05% apart; beams also on the segments
// from the light (depth 0) gave +52%, beams only on segments ending in a collision −32%.
TEST(PhotonBeams, BeamLengthsCarryTheFluenceThePhotonsCollideIn) {
    SceneDesc d;
    d.lights.push_back(sun(Vec3(0.3f, -1.0f, 0.2f), 2.0f));
    add_ground(&d, 0.0f, 4.0f, 0.5f);
    constexpr float kSigmaS = 1.5f;
    d.media.push_back(homogeneous(Box3{Vec3(-1.0f, 0.0f, -1.0f), Vec3(1.0f, 2.0f, 1.0f)},
                                  Color(kSigmaS), Color(0.5f)));
    d.render.integrator = Integrator::Photon;
    d.photons.caustic = 0;
    d.photons.global = 20000;
    d.photons.volume = 100000;
    PhotonSettings photons = d.photons;
    photons.volume_beams = true;
    const auto scene = load_scene(d);
    const PhotonPassResult r =
        trace_photons(*scene, make_plan(d), photons, d.march, d.render.seed, true);
    ASSERT_TRUE(r.volume);
    ASSERT_GT(r.volume->beams.size(), r.volume->photons.size());
    double collided = 0.0, tracked = 0.0;
    for (const Photon& p : r.volume->photons) collided += average(p.power());
    for (const PhotonBeam& b : r.volume->beams)
        tracked += average(b.power()) * glm::length(b.end() - b.start());
    std::printf("photons %.1f, sigma_s x beam length %.1f (relative powers)\n", collided,
                kSigmaS * tracked);
    EXPECT_NEAR(kSigmaS * tracked, collided, 0.02 * collided);
}

}  // namespace
}  // namespace fogmap
