// BeamTree against brute force on clustered photons (density varying by 100x): every radius is the
// exact distance to the k-th neighbour of some photon at most that far away (the leaf's first, or
// the photon itself), and a segment query visits exactly the photons whose sphere it crosses, each
// once, with the kernel 3 / (4π r³) times the length of the segment inside the sphere (from the
// roots of |o + t d − p|² = r² in double) — compared with a scan of all photons.

#include "photon/beam_tree.h"

#include "core/sampling.h"

#include "core/rng.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <vector>

namespace fogmap {
namespace {

constexpr int kK = 20;
constexpr float kRMax = 10.0f;

/// Gaussian clusters of very different widths plus a uniform background.
PhotonMap clustered_map(size_t n) {
    Rng rng(0xBEA7u, 1);
    auto normal = [&] {
        const float u = 1.0f - rng.uniform();
        return std::sqrt(-2.0f * std::log(u)) * std::cos(kTwoPi * rng.uniform());
    };
    const Vec3 centres[3] = {Vec3(0.0f), Vec3(2.0f, 0.5f, 0.0f), Vec3(-1.0f, 1.0f, 1.5f)};
    const float widths[3] = {0.05f, 0.3f, 0.6f};
    std::vector<Photon> photons;
    for (size_t i = 0; i < n; ++i) {
        Vec3 p;
        if (i % 10 == 0) {
            p = Vec3(rng.uniform(), rng.uniform(), rng.uniform()) * 6.0f - Vec3(3.0f);
        } else {
            const int c = static_cast<int>(i % 3);
            p = centres[c] + widths[c] * Vec3(normal(), normal(), normal());
        }
        const Vec3 d = sample_uniform_sphere(Vec2(rng.uniform(), rng.uniform()));
        photons.emplace_back(p, d, Color(1.0f));
    }
    PhotonMap map;
    map.tree = KdTree<Photon>(std::move(photons));
    map.photon_power = 1.0f;
    return map;
}

/// Distance from x to its (k+1)-th nearest photon (the first is the photon at x itself).
float kth_distance(const std::vector<Photon>& photons, const Vec3& x) {
    std::vector<float> d2;
    d2.reserve(photons.size());
    for (const Photon& p : photons) {
        const Vec3 v = p.position() - x;
        d2.push_back(glm::dot(v, v));
    }
    std::nth_element(d2.begin(), d2.begin() + kK, d2.end());
    return std::sqrt(d2[kK]);
}

TEST(BeamTree, EveryRadiusIsTheKthNeighbourDistanceOfAPhotonWithinIt) {
    const PhotonMap map = clustered_map(3000);
    const BeamTree beam(map, kK, kRMax);
    const std::vector<Photon>& photons = map.tree.records();
    ASSERT_EQ(beam.records().size(), photons.size());
    std::vector<float> exact(photons.size());
    for (size_t i = 0; i < photons.size(); ++i)
        exact[i] = kth_distance(photons, photons[i].position());
    size_t own = 0;
    for (const BeamTree::Record& rec : beam.records()) {
        const float r = std::sqrt(rec.r2);
        bool found = false;
        for (size_t i = 0; i < photons.size() && !found; ++i)
            found = std::fabs(exact[i] - r) <= 1e-5f * r &&
                    glm::length(photons[i].position() - rec.position) <= r * (1.0f + 1e-5f);
        EXPECT_TRUE(found) << "radius " << r << " at (" << rec.position.x << ", " << rec.position.y
                           << ", " << rec.position.z << ")";
        own += std::fabs(kth_distance(photons, rec.position) - r) <= 1e-5f * r;
    }
    // Sharing is what saves the queries: most photons take their leaf's radius, not their own.
    EXPECT_LT(own, photons.size() / 2);
}

TEST(BeamTree, SegmentQueriesVisitExactlyTheSpheresTheyCross) {
    const PhotonMap map = clustered_map(5000);
    const BeamTree beam(map, kK, kRMax);
    Rng rng(0xBEA7u, 2);
    for (int q = 0; q < 200; ++q) {
        const Vec3 o = Vec3(rng.uniform(), rng.uniform(), rng.uniform()) * 8.0f - Vec3(4.0f);
        const Vec3 target = Vec3(rng.uniform(), rng.uniform(), rng.uniform()) * 2.0f - Vec3(1.0f);
        const Ray ray{o, glm::normalize(target - o)};
        const float t0 = rng.uniform() * 2.0f, t1 = t0 + rng.uniform() * 6.0f;
        std::map<const BeamTree::Record*, std::pair<float, float>> expected, got;
        for (const BeamTree::Record& rec : beam.records()) {
            // a t² − 2 b t + c = 0 with a = |d|² (1 to a float's precision), b = d·(p − o),
            // c = |p − o|² − r².
            const glm::dvec3 v = glm::dvec3(rec.position) - glm::dvec3(ray.o);
            const glm::dvec3 d = glm::dvec3(ray.d);
            const double a = glm::dot(d, d), b = glm::dot(v, d), c = glm::dot(v, v) - rec.r2;
            if (b * b - a * c <= 0.0) continue;
            const double lo = std::max<double>((b - std::sqrt(b * b - a * c)) / a, t0);
            const double hi = std::min<double>((b + std::sqrt(b * b - a * c)) / a, t1);
            if (hi <= lo) continue;
            const double r = std::sqrt(double(rec.r2));
            expected[&rec] = {float(std::clamp<double>(b / a, lo, hi)),
                              float(3.0 * (hi - lo) / (4.0 * kPi * r * r * r))};
        }
        int visits = 0;
        beam.for_each_hit(ray, t0, t1, [&](const BeamTree::Record& rec, float t, float kernel) {
            ++visits;
            got[&rec] = {t, kernel};
        });
        ASSERT_EQ(visits, static_cast<int>(got.size())) << "a photon was visited twice";
        ASSERT_EQ(got.size(), expected.size()) << "query " << q;
        for (const auto& [rec, tk] : expected) {
            const auto it = got.find(rec);
            ASSERT_NE(it, got.end());
            EXPECT_NEAR(it->second.first, tk.first, 1e-4f);
            EXPECT_NEAR(it->second.second, tk.second, 1e-3f * tk.second);
        }
    }
}

}  // namespace
}  // namespace fogmap
