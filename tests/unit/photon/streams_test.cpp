// Photon streams and the photon pass's allocation (docs/design.md, Photon emission and streams),
// against values computed here independently: the streams of a light partition its paths, so
// their powers sum to the light's analytic total and each accepted path belongs to its own stream
// only; the allocation rule is the closed-form optimum of the variance-per-work problem, floored
// at 5% of plain emission; a round's counts follow the rates and stop at the cap; and every photon
// a stream stores in a map carries that stream's power over its attempts.

#include "photon/streams.h"
#include "photon/photon_pass.h"
#include "scene_builders.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numeric>

namespace fogmap {
namespace {

using namespace test;

// Whether a ray's first segment enters a sphere of radius r, from the cross product in double
// (independent of streams.cpp's meets_sphere, which the streams use).
bool enters_sphere(const Ray& ray, const Vec3& centre, double r) {
    const glm::dvec3 oc = glm::dvec3(centre) - glm::dvec3(ray.o), d = glm::dvec3(ray.d);
    if (glm::dot(oc, oc) <= r * r) return true;
    const glm::dvec3 c = glm::cross(oc, d);
    return glm::dot(oc, d) > 0.0 && glm::dot(c, c) < r * r * glm::dot(d, d);
}

// The four lights over a 16 m floor, 1 m below the fog box: targets specular, media and near
// media, all within the scene's bounding sphere.
SceneDesc four_lights() { return four_lights_ball_and_fog(-1.0f, 8.0f); }

// Σ over light l's streams of Φ_s × (accepted attempts / attempts): the power of all the paths
// the streams hold together, with its standard error (streams independent).
std::pair<double, double> streams_power(const StreamSet& set, const Scene& scene, int light,
                                        int n) {
    double total = 0.0, var = 0.0;
    for (size_t s = 0; s < set.streams.size(); ++s) {
        if (set.streams[s].light != light) continue;
        int accepted = 0;
        for (int i = 0; i < n; ++i) {
            Rng rng(21, i, set.streams[s].key);
            Ray ray;
            accepted += sample_stream(set, static_cast<int>(s), scene, rng, &ray) ? 1 : 0;
        }
        const double p = double(accepted) / n, phi = set.streams[s].region_power;
        total += phi * p;
        var += phi * phi * p * (1.0 - p) / n;
    }
    return {total, std::sqrt(var)};
}

// Every path belongs to exactly one stream, so the streams' powers sum to the light's: E π R²
// for a sun and 4π² R² L for a sky over the scene's bounding sphere (radius R), 4π I for a point
// light, and for a spot 2π I [(1 − cos_inner) + (cos_inner − cos_outer) / 2] (its smoothstep
// falloff integrates to half the band between the cones).
TEST(PhotonStreams, StreamsOfALightSumToItsAnalyticPower) {
    const SceneDesc d = four_lights();
    const auto scene = load_scene(d);
    const StreamSet set = make_streams(*scene, true, true);
    ASSERT_EQ(set.targets.size(), 3u);
    const double R = 0.5 * glm::length(glm::dvec3(scene->bounds.extent()));
    for (const StreamTarget& t : set.targets)  // the discs lie within the scene's
        ASSERT_LE(glm::length(t.center - scene->bounds.center()) + t.radius, R * 1.0001);
    const double deg = kPi / 180.0;
    const double cos_outer = std::cos(35.0 * deg), cos_inner = std::cos(25.0 * deg);
    const double expected[4] = {
        2.0 * kPi * R * R,                                                      // sun, E = 2
        4.0 * kPi * kPi * R * R * 0.5,                                          // sky, L = 0.5
        4.0 * kPi * 4.0,                                                        // point, I = 4
        2.0 * kPi * 3.0 * ((1.0 - cos_inner) + 0.5 * (cos_inner - cos_outer)),  // spot, I = 3
    };
    for (int l = 0; l < 4; ++l) {
        int streams = 0;
        for (const PhotonStream& st : set.streams) streams += st.light == l ? 1 : 0;
        EXPECT_GE(streams, 2) << "light " << l;  // the light's paths are partitioned
        const auto [total, se] = streams_power(set, *scene, l, 100000);
        EXPECT_NEAR(total, expected[l], 4.0 * se + 1e-6 * expected[l]) << "light " << l;
    }
}

// What makes the partition: an accepted path of stream (light, k) meets target k and no earlier
// target; one of the rest meets no target at all. Checked with a sphere test of its own, its
// radius moved by 10⁻⁴ towards the claim's safe side so that grazing rays cannot decide.
TEST(PhotonStreams, EachAcceptedPathBelongsToItsOwnStreamOnly) {
    const auto scene = load_scene(four_lights());
    const StreamSet set = make_streams(*scene, true, true);
    for (size_t s = 0; s < set.streams.size(); ++s) {
        const PhotonStream& st = set.streams[s];
        if (st.light < 0) continue;
        const size_t earlier = st.target < 0 ? set.targets.size() : size_t(st.target);
        int accepted = 0;
        for (int i = 0; i < 20000; ++i) {
            Rng rng(7, i, st.key);
            Ray ray;
            if (!sample_stream(set, static_cast<int>(s), *scene, rng, &ray)) continue;
            ++accepted;
            for (size_t j = 0; j < earlier; ++j) {
                const StreamTarget& t = set.targets[j];
                ASSERT_FALSE(enters_sphere(ray, t.center, t.radius * (1.0 - 1e-4)))
                    << st.name << ": attempt " << i << " meets earlier target " << t.name;
            }
            if (st.target >= 0) {
                const StreamTarget& t = set.targets[st.target];
                ASSERT_TRUE(enters_sphere(ray, t.center, t.radius * (1.0 + 1e-4)))
                    << st.name << ": attempt " << i << " misses its target";
            }
        }
        EXPECT_GT(accepted, 0) << st.name;
    }
}

// Each stream's region power is the light's power through the region it samples, computed here
// from the targets' geometry: sun E π r² over target k's disc, point light I 2π (1 − cos θ_k),
// θ_k the half-angle of the cone holding sphere k, and the rest stream the whole light (the
// scene's disc for the sun, the whole sphere of directions for the point light).
TEST(PhotonStreams, RegionPowersAreTheLightsPowerThroughTheirRegions) {
    SceneDesc d;
    d.lights.push_back(sun(Vec3(0.2f, -1.0f, 0.1f), 3.0f));
    d.lights.push_back(point_light(Vec3(0.0f, 9.0f, 0.0f), 2.0f));
    add_ground(&d, -1.0f, 10.0f, 0.5f);
    d.media.push_back(homogeneous(Box3{Vec3(-1.0f), Vec3(1.0f)}, Color(1.0f), Color(0.1f)));
    const auto scene = load_scene(d);
    const StreamSet set = make_streams(*scene, false, true);
    ASSERT_EQ(set.targets.size(), 2u);
    const double r[2] = {std::sqrt(3.0), 3.0 * std::sqrt(3.0)};  // the box's sphere, 3× that
    const double R = 0.5 * glm::length(glm::dvec3(scene->bounds.extent()));
    int checked = 0;
    for (const PhotonStream& st : set.streams) {
        double expected;
        if (st.light == 0) {
            const double radius = st.target < 0 ? R : r[st.target];
            expected = 3.0 * kPi * radius * radius;
        } else if (st.light == 1) {
            const double cos_t =
                st.target < 0 ? -1.0 : std::sqrt(1.0 - std::pow(r[st.target] / 9.0, 2));
            expected = 2.0 * 2.0 * kPi * (1.0 - cos_t);
        } else {
            continue;  // the bounce stream
        }
        EXPECT_NEAR(st.region_power, expected, 1e-5 * expected) << st.name;
        ++checked;
    }
    EXPECT_EQ(checked, 6);  // media, near media and the rest of each light
}

// Two streams, one map: Φ = (4, 1), deposits P = (3, 1) per attempt (P_m = 4), costs c = (1, 4).
// N_s ∝ √(Φ_s P_s / P_m² / c_s) = √(3/4) and √(1/64): the second stream gets 1/√48 of the first.
TEST(PhotonAllocation, TwoStreamsGetTheHandComputedProportions) {
    const std::vector<double> rate = stream_proportions(
        {4.0, 1.0}, {{{3.0, 0.0, 0.0}}, {{1.0, 0.0, 0.0}}}, {true, false, false}, {1.0, 4.0});
    ASSERT_EQ(rate.size(), 2u);
    EXPECT_DOUBLE_EQ(rate[0], 1.0);
    EXPECT_NEAR(rate[1], 1.0 / std::sqrt(48.0), 1e-12);
}

// The summed relative variance of the open maps for N_s attempts of each stream: a photon of
// stream s weighs Φ_s / N_s, so map m's variance is about Σ_s (Φ_s / N_s) P_ms, over P_m².
double relative_variance(const std::vector<double>& n, const std::vector<double>& power,
                         const std::vector<std::array<double, 3>>& deposit,
                         const std::array<bool, 3>& open) {
    double sum = 0.0;
    for (int m = 0; m < 3; ++m) {
        if (!open[m]) continue;
        double pm = 0.0, var = 0.0;
        for (size_t s = 0; s < n.size(); ++s) {
            pm += deposit[s][m];
            var += power[s] / n[s] * deposit[s][m];
        }
        if (pm > 0.0) sum += var / (pm * pm);
    }
    return sum;
}

// Three streams, two open maps and a closed one: the proportions minimise the relative variance
// for their work — every reallocation of the same work (Σ N_s c_s) does worse — and what streams
// deposit in the closed map does not matter.
TEST(PhotonAllocation, ProportionsMinimiseTheVariancePerWork) {
    const std::vector<double> power{5.0, 2.0, 0.5}, cost{1.5, 3.0, 1.2};
    std::vector<std::array<double, 3>> deposit{
        {{0.8, 0.1, 0.3}}, {{0.2, 0.0, 0.9}}, {{0.05, 0.4, 0.1}}};
    const std::array<bool, 3> open{true, false, true};
    const std::vector<double> rate = stream_proportions(power, deposit, open, cost);
    ASSERT_EQ(rate.size(), 3u);
    for (size_t s = 0; s < 3; ++s)  // the 5% floor does not bind here
        ASSERT_GT(rate[s], 0.05 * power[s] / 5.0);
    double work = 0.0;
    for (size_t s = 0; s < 3; ++s) work += rate[s] * cost[s];
    const double best = relative_variance(rate, power, deposit, open);
    Rng rng(3, 0, 0);
    for (int i = 0; i < 2000; ++i) {
        const double scale = i % 2 ? 0.02 : 0.3;  // small and large moves
        std::vector<double> n(3);
        double w = 0.0;
        for (size_t s = 0; s < 3; ++s) {
            n[s] = rate[s] * std::exp(scale * (2.0 * rng.uniform() - 1.0));
            w += n[s] * cost[s];
        }
        for (double& x : n) x *= work / w;  // the same work
        EXPECT_GE(relative_variance(n, power, deposit, open), best * (1.0 - 1e-12)) << i;
    }
    for (auto& d : deposit) d[1] = 7.0;  // the closed map
    EXPECT_EQ(stream_proportions(power, deposit, open, cost), rate);
}

// The floor: a stream that has deposited nothing (or very little) still gets 5% of its share
// under plain emission, 0.05 Φ_s / max Φ; one above the floor keeps its optimum; with no deposits
// at all every stream gets its floor, in proportion to its power.
TEST(PhotonAllocation, EveryStreamKeepsFivePercentOfPlainEmission) {
    const std::vector<double> power{10.0, 4.0, 2.0}, cost{1.0, 1.0, 1.0};
    const std::array<bool, 3> open{true, false, false};
    // Stream 0 and 1 deposit 1 and 1 (P_m = 2 + tiny): rates √(10/4) and √(4/4) before the
    // normalisation; stream 2 deposits 10⁻⁹.
    const std::vector<double> rate =
        stream_proportions(power, {{{1.0, 0, 0}}, {{1.0, 0, 0}}, {{1e-9, 0, 0}}}, open, cost);
    EXPECT_DOUBLE_EQ(rate[0], 1.0);
    EXPECT_NEAR(rate[1], std::sqrt(4.0 / 10.0), 1e-6);
    EXPECT_DOUBLE_EQ(rate[2], 0.05 * 2.0 / 10.0);
    const std::vector<double> none =
        stream_proportions(power, {{{0, 0, 0}}, {{0, 0, 0}}, {{0, 0, 0}}}, open, cost);
    for (size_t s = 0; s < 3; ++s) EXPECT_DOUBLE_EQ(none[s], 0.05 * power[s] / 10.0) << s;
}

// A round: ⌈batch × rate⌉ attempts per stream; under the cap, the same proportions scaled to
// what is left (rounded down); all of it to the first stream when scaling leaves none.
TEST(PhotonAllocation, RoundCountsFollowTheRatesAndStopAtTheCap) {
    EXPECT_EQ(round_counts({1.0, 0.5, 0.0101}, 1000, 1u << 20),
              (std::vector<uint64_t>{1000, 500, 11}));
    // 1511 planned, 755 left: 1000·755/1511 = 499.67, 500·755/1511 = 249.8, 11·755/1511 = 5.50.
    const std::vector<uint64_t> last = round_counts({1.0, 0.5, 0.0101}, 1000, 755);
    EXPECT_EQ(last, (std::vector<uint64_t>{499, 249, 5}));
    EXPECT_LE(std::accumulate(last.begin(), last.end(), uint64_t{0}), 755u);
    EXPECT_EQ(round_counts({0.0005, 0.0005}, 1000, 1), (std::vector<uint64_t>{1, 0}));
}

// Every photon a stream stores in a map carries the same power, Φ_s / N_s (N_s its attempts, the
// maps open to the cap): a point light over a grey floor with a grey fog box and a mirror ball —
// Russian roulette on grey albedos leaves a photon's power as it left the light — whose streams
// aim at the ball, the fog, the ground around it and the rest. Φ_s from the cones the targets
// subtend; each stored photon's power must be one stream's Φ_s / N_s, as many times as the report
// says that stream stored (RGBE keeps powers to 1%).
TEST(PhotonPass, EachStreamsPhotonsCarryItsPowerOverItsAttempts) {
    SceneDesc d;
    const Vec3 light(0.0f, 8.0f, 0.0f);
    const float I = 5.0f;
    d.lights.push_back(point_light(light, I));
    add_ground(&d, -1.0f, 20.0f, 0.5f);
    d.materials["mirror"] = MaterialDesc{MaterialType::Mirror, Color(1.0f), 1.5f};
    ShapeDesc ball;
    ball.type = ShapeType::Sphere;
    ball.center = Vec3(3.0f, 0.0f, 3.0f);
    ball.radius = 0.5f;
    ball.material = "mirror";
    d.shapes.push_back(ball);
    d.media.push_back(homogeneous(Box3{Vec3(-1.0f), Vec3(1.0f)}, Color(0.3f), Color(0.3f)));
    const auto scene = load_scene(d);
    Plan plan;
    plan.global_map.on = plan.caustic_map.on = plan.volume_map.on = true;
    PhotonSettings settings;
    settings.global = settings.caustic = settings.volume = 2000000;  // never full
    settings.max_emitted = 300000;
    const PhotonPassResult r = trace_photons(*scene, plan, settings, d.march, 5, true);
    ASSERT_EQ(r.emitted, 300000u);
    ASSERT_EQ(r.streams.size(), 4u);  // mirror, media, near media, rest

    // Targets: the ball's box's sphere (radius 0.5 √3), the fog box's (√3) and 3× that.
    const std::pair<Vec3, double> targets[3] = {{ball.center, 0.5 * std::sqrt(3.0)},
                                                {Vec3(0.0f), std::sqrt(3.0)},
                                                {Vec3(0.0f), 3.0 * std::sqrt(3.0)}};
    std::vector<double> weight;  // Φ_s / N_s
    for (size_t s = 0; s < 4; ++s) {
        double cos_t = -1.0;  // the rest: the whole sphere of directions
        if (s < 3) {
            const double dist = glm::length(glm::dvec3(targets[s].first - light));
            cos_t = std::sqrt(1.0 - std::pow(targets[s].second / dist, 2));
        }
        ASSERT_GT(r.streams[s].attempts, 0u);
        weight.push_back(I * 2.0 * kPi * (1.0 - cos_t) / double(r.streams[s].attempts));
    }
    for (size_t a = 0; a < 4; ++a)  // far enough apart to tell the streams' photons apart
        for (size_t b = a + 1; b < 4; ++b)
            ASSERT_GT(std::abs(weight[a] / weight[b] - 1.0), 0.03) << a << " " << b;

    const std::optional<StoredPhotons>* maps[3] = {&r.global, &r.caustic, &r.volume};
    for (int m = 0; m < 3; ++m) {
        ASSERT_TRUE(maps[m]->has_value());
        const StoredPhotons& map = **maps[m];
        EXPECT_EQ(map.emitted, 300000u);
        std::vector<uint64_t> count(4, 0);
        for (const Photon& p : map.photons) {
            const double w = average(p.power()) * map.photon_power;
            int stream = -1;
            for (size_t s = 0; s < 4; ++s)
                if (std::abs(w / weight[s] - 1.0) < 0.01) stream = static_cast<int>(s);
            ASSERT_GE(stream, 0) << "map " << m << ": a photon of power " << w;
            ++count[stream];
        }
        uint64_t stored = 0;
        for (size_t s = 0; s < 4; ++s) {
            EXPECT_EQ(count[s], r.streams[s].stored[m]) << "map " << m << ", stream " << s;
            stored += count[s];
        }
        EXPECT_GT(stored, 0u) << "map " << m;
    }
}

}  // namespace
}  // namespace fogmap
