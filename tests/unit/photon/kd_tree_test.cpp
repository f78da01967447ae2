// KdTree<Photon> against brute force (all distances in double, sorted) on uniform, surface- and
// volume-clustered, duplicate-heavy and degenerate (coplanar, collinear, identical) point sets,
// n = 0 and 1. knn ties at equal distance make the index set ambiguous, so knn compares the sorted
// distances of the returned records; radius queries compare index sets. Radii are nudged so that
// no record lies within a relative 1e-4 of r² (float and double then agree on membership: a float
// difference of floats is correctly rounded, so the float dist2 is within ~3e-7 relative).
// Structure: Hooley's layout with leaves of at most 8 records, balanced (leaf depths differ by at
// most 1; at most 1 + ceil(log2((n + 1) / 9)) levels), median splits, thread-count independent.

#include "photon/kd_tree.h"

#include "core/parallel.h"
#include "core/rng.h"
#include "photon/photon.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

namespace fogmap {
namespace {

constexpr uint64_t kSeed = 0x6D0Bull;
constexpr uint32_t kLeafSize = 8;  // the documented leaf size of photon/kd_tree.h
constexpr double kRelTol = 1e-5;   // float vs double squared distances (see the file comment)

struct PointSet {
    std::string name;
    std::vector<Vec3> points;
};

Vec3 uniform_in_box(Rng& rng, const Vec3& lo, const Vec3& hi) {
    return lo + (hi - lo) * Vec3(rng.uniform(), rng.uniform(), rng.uniform());
}

/// Standard normal by Box–Muller.
float normal(Rng& rng) {
    const float u = 1.0f - rng.uniform();  // (0, 1]
    return std::sqrt(-2.0f * std::log(u)) * std::cos(kTwoPi * rng.uniform());
}

std::vector<Vec3> uniform_points(size_t n, uint64_t stream) {
    Rng rng(kSeed, stream);
    std::vector<Vec3> pts(n);
    for (Vec3& p : pts) p = uniform_in_box(rng, Vec3(-1.0f), Vec3(3.0f, 1.0f, 2.0f));
    return pts;
}

/// Two axis-aligned planes, a tilted plane and two spheres, with noise 1e-4 (photons on walls).
std::vector<Vec3> surface_points(size_t n, uint64_t stream) {
    Rng rng(kSeed, stream);
    std::vector<Vec3> pts(n);
    for (Vec3& p : pts) {
        const float u = rng.uniform(), v = rng.uniform();
        switch (rng.next_u32() % 5) {
            case 0:
                p = Vec3(4.0f * u, 0.0f, 4.0f * v);
                break;
            case 1:
                p = Vec3(0.0f, 4.0f * u, 4.0f * v);
                break;
            case 2:
                p = Vec3(4.0f * u, 4.0f * v, 0.3f * u + 0.7f * v + 1.0f);
                break;
            case 3: {
                const float z = 1.0f - 2.0f * u, r = std::sqrt(std::fmax(0.0f, 1.0f - z * z));
                p = Vec3(2.0f, 2.0f, 2.0f) +
                    0.5f * Vec3(r * std::cos(kTwoPi * v), r * std::sin(kTwoPi * v), z);
                break;
            }
            default: {
                const float z = 1.0f - 2.0f * u, r = std::sqrt(std::fmax(0.0f, 1.0f - z * z));
                p = Vec3(3.0f, 1.0f, 3.0f) +
                    0.05f * Vec3(r * std::cos(kTwoPi * v), r * std::sin(kTwoPi * v), z);
            }
        }
        p += 1e-4f * Vec3(normal(rng), normal(rng), normal(rng));
    }
    return pts;
}

/// Gaussian blobs of very different sizes plus a 10% uniform background (photons in smoke).
std::vector<Vec3> volume_points(size_t n, uint64_t stream) {
    Rng rng(kSeed, stream);
    const Vec3 centers[] = {Vec3(1, 1, 1), Vec3(5, 2, 3), Vec3(2, 8, 6), Vec3(7, 7, 7),
                            Vec3(4, 4, 9)};
    const float sigmas[] = {0.02f, 0.3f, 1.0f, 0.005f, 2.0f};
    std::vector<Vec3> pts(n);
    for (Vec3& p : pts) {
        const uint32_t c = rng.next_u32() % 6;
        p = c == 5 ? uniform_in_box(rng, Vec3(0.0f), Vec3(10.0f))
                   : centers[c] + sigmas[c] * Vec3(normal(rng), normal(rng), normal(rng));
    }
    return pts;
}

/// 90% exact copies of 30 base points, 10% uniform.
std::vector<Vec3> duplicate_points(size_t n, uint64_t stream) {
    Rng rng(kSeed, stream);
    const std::vector<Vec3> base = uniform_points(30, stream + 1000);
    std::vector<Vec3> pts(n);
    for (Vec3& p : pts) {
        p = rng.uniform() < 0.9f ? base[rng.next_u32() % base.size()]
                                 : uniform_in_box(rng, Vec3(-1.0f), Vec3(3.0f, 1.0f, 2.0f));
    }
    return pts;
}

std::vector<PointSet> point_sets() {
    std::vector<PointSet> sets;
    sets.push_back({"empty", {}});
    sets.push_back({"single", {Vec3(0.25f, -1.0f, 2.0f)}});
    sets.push_back({"uniform9", uniform_points(9, 1)});
    sets.push_back({"uniform17", uniform_points(17, 2)});
    sets.push_back({"uniform", uniform_points(3000, 3)});
    sets.push_back({"uniform_large", uniform_points(40000, 4)});
    sets.push_back({"surfaces", surface_points(5000, 5)});
    sets.push_back({"volume", volume_points(5000, 6)});
    sets.push_back({"duplicates", duplicate_points(3000, 7)});
    Rng rng(kSeed, 8);
    PointSet coplanar{"coplanar", {}}, collinear{"collinear", {}}, diagonal{"diagonal", {}};
    for (int i = 0; i < 2000; ++i) {
        coplanar.points.push_back(Vec3(rng.uniform(), 1.25f, 4.0f * rng.uniform()));
        collinear.points.push_back(Vec3(-0.5f, 3.0f * rng.uniform(), 2.0f));
        const float t = std::floor(100.0f * rng.uniform()) * 0.25f;  // many repeats along the line
        diagonal.points.push_back(Vec3(t, t, t));
    }
    sets.push_back(coplanar);
    sets.push_back(collinear);
    sets.push_back(diagonal);
    sets.push_back({"identical", std::vector<Vec3>(1500, Vec3(0.5f, -2.0f, 3.0f))});
    return sets;
}

std::vector<Photon> to_photons(const std::vector<Vec3>& points) {
    std::vector<Photon> photons;
    photons.reserve(points.size());
    for (const Vec3& p : points) photons.emplace_back(p, Vec3(0.0f, 0.0f, 1.0f), Color(1.0f));
    return photons;
}

double dist2_double(const Vec3& a, const Vec3& b) {
    const DVec3 d = DVec3(a) - DVec3(b);
    return glm::dot(d, d);
}

/// Data points (zero distances, duplicates), points in the slightly grown bounding box and far
/// away points.
std::vector<Vec3> queries_for(const std::vector<Vec3>& points, uint64_t stream) {
    Rng rng(kSeed, stream);
    std::vector<Vec3> queries;
    Box3 box;
    for (const Vec3& p : points) box.extend(p);
    if (box.empty()) box.extend(Vec3(0.0f));
    const Vec3 grow(std::fmax(0.1f * max_component(box.extent()), 1.0f));
    for (int i = 0; i < 20 && !points.empty(); ++i)
        queries.push_back(points[rng.next_u32() % points.size()]);
    for (int i = 0; i < 20; ++i)
        queries.push_back(uniform_in_box(rng, box.lo - grow, box.hi + grow));
    for (int i = 0; i < 3; ++i) {
        queries.push_back(box.center() +
                          100.0f * grow * Vec3(normal(rng), normal(rng), normal(rng)));
    }
    return queries;
}

/// Moves r up until no sorted squared distance lies within a relative 1e-4 of r² (r = 0 and
/// r = inf are kept: zero distances are exact and every finite distance is inside infinity).
float nudge_radius(float r, const std::vector<double>& sorted_dist2) {
    if (r == 0.0f || std::isinf(r)) return r;
    for (;;) {
        const double r2 = static_cast<double>(r) * r;
        const auto it = std::lower_bound(sorted_dist2.begin(), sorted_dist2.end(), r2 * (1 - 1e-4));
        if (it == sorted_dist2.end() || *it > r2 * (1 + 1e-4)) return r;
        r *= 1.001f;
    }
}

/// 0, a small radius (about the 3rd neighbour), a large one (about the n/2-th) and infinity.
std::vector<float> radii_for(const std::vector<double>& sorted_dist2) {
    std::vector<float> radii = {0.0f, kInfinity};
    if (!sorted_dist2.empty()) {
        const size_t n = sorted_dist2.size();
        const float small =
            static_cast<float>(1.2 * std::sqrt(sorted_dist2[std::min<size_t>(2, n - 1)]));
        const float large = static_cast<float>(std::sqrt(sorted_dist2[n / 2]));
        radii.push_back(nudge_radius(std::fmax(small, 1e-3f), sorted_dist2));
        radii.push_back(nudge_radius(std::fmax(large, 1e-2f), sorted_dist2));
    }
    return radii;
}

bool near_rel(double a, double b) { return std::fabs(a - b) <= kRelTol * std::fmax(a, b) + 1e-30; }

TEST(KdTree, KnnMatchesBruteForce) {
    uint64_t stream = 100;
    for (const PointSet& set : point_sets()) {
        const KdTree<Photon> tree(to_photons(set.points));
        ASSERT_EQ(tree.size(), set.points.size());
        const std::vector<Photon>& recs = tree.records();
        const size_t n = recs.size();
        NeighborList list;
        for (const Vec3& q : queries_for(set.points, ++stream)) {
            std::vector<double> all;
            for (const Photon& ph : recs) all.push_back(dist2_double(ph.position(), q));
            std::sort(all.begin(), all.end());
            for (int k : {1, 5, 50, static_cast<int>(n) + 3}) {
                for (float r : radii_for(all)) {
                    SCOPED_TRACE(set.name + " k=" + std::to_string(k) + " r=" + std::to_string(r) +
                                 " q=(" + std::to_string(q.x) + "," + std::to_string(q.y) + "," +
                                 std::to_string(q.z) + ")");
                    const double r2 = static_cast<double>(r) * r;
                    const size_t in_radius =
                        std::upper_bound(all.begin(), all.end(), r2) - all.begin();
                    const size_t expected = std::min(static_cast<size_t>(k), in_radius);
                    tree.knn(q, k, r, &list);
                    ASSERT_EQ(list.size(), expected);
                    std::vector<double> got;
                    std::vector<uint32_t> indices;
                    float max_dist2 = 0.0f;
                    for (size_t i = 0; i < list.size(); ++i) {
                        ASSERT_LT(list[i].index, n);
                        const double d2 = dist2_double(recs[list[i].index].position(), q);
                        ASSERT_TRUE(near_rel(list[i].dist2, d2)) << list[i].dist2 << " vs " << d2;
                        got.push_back(d2);
                        indices.push_back(list[i].index);
                        max_dist2 = std::max(max_dist2, list[i].dist2);
                    }
                    EXPECT_EQ(list.max_dist2(), max_dist2);
                    std::sort(indices.begin(), indices.end());
                    ASSERT_TRUE(std::adjacent_find(indices.begin(), indices.end()) ==
                                indices.end());
                    std::sort(got.begin(), got.end());
                    for (size_t i = 0; i < got.size(); ++i) {
                        ASSERT_TRUE(near_rel(got[i], all[i]))
                            << i << ": " << got[i] << " vs " << all[i];
                    }
                }
            }
        }
    }
}

TEST(KdTree, RadiusQueryMatchesBruteForce) {
    uint64_t stream = 200;
    for (const PointSet& set : point_sets()) {
        const KdTree<Photon> tree(to_photons(set.points));
        const std::vector<Photon>& recs = tree.records();
        for (const Vec3& q : queries_for(set.points, ++stream)) {
            std::vector<double> all;
            for (const Photon& ph : recs) all.push_back(dist2_double(ph.position(), q));
            std::vector<double> sorted = all;
            std::sort(sorted.begin(), sorted.end());
            for (float r : radii_for(sorted)) {
                SCOPED_TRACE(set.name + " r=" + std::to_string(r));
                const double r2 = static_cast<double>(r) * r;
                std::vector<uint32_t> expected;
                for (uint32_t i = 0; i < all.size(); ++i) {
                    if (all[i] <= r2) expected.push_back(i);
                }
                std::vector<uint32_t> got;
                tree.for_each_in_radius(q, r, [&](const Photon& ph, float dist2) {
                    const uint32_t i = static_cast<uint32_t>(&ph - recs.data());
                    EXPECT_TRUE(near_rel(dist2, all[i]));
                    got.push_back(i);
                });
                std::sort(got.begin(), got.end());
                ASSERT_EQ(got, expected);
            }
        }
    }
}

TEST(KdTree, ZeroRadiusFindsExactlyTheDuplicates) {
    const std::vector<Vec3> points = duplicate_points(2000, 7);
    const KdTree<Photon> tree(to_photons(points));
    NeighborList list;
    for (size_t i = 0; i < 50; ++i) {
        const Vec3 q = points[i * 37];
        const size_t copies = std::count(points.begin(), points.end(), q);
        tree.knn(q, 100000, 0.0f, &list);
        ASSERT_EQ(list.size(), copies);
        for (size_t j = 0; j < list.size(); ++j) EXPECT_EQ(list[j].dist2, 0.0f);
        tree.knn(q + Vec3(1e-3f, 0.0f, 0.0f), 100000, 0.0f, &list);
        EXPECT_TRUE(list.empty());
    }
}

TEST(KdTree, EmptyAndSingleRecordTrees) {
    const KdTree<Photon> empty(std::vector<Photon>{});
    NeighborList list;
    empty.knn(Vec3(0.0f), 5, kInfinity, &list);
    EXPECT_TRUE(list.empty());
    EXPECT_EQ(list.max_dist2(), 0.0f);
    int calls = 0;
    empty.for_each_in_radius(Vec3(0.0f), kInfinity, [&](const Photon&, float) { ++calls; });
    EXPECT_EQ(calls, 0);
    EXPECT_EQ(empty.bytes(), 0u);

    const KdTree<Photon> one(to_photons({Vec3(1.0f, 2.0f, 3.0f)}));
    one.knn(Vec3(1.0f, 2.0f, 5.0f), 5, kInfinity, &list);
    ASSERT_EQ(list.size(), 1u);
    EXPECT_EQ(list[0].index, 0u);
    EXPECT_EQ(list[0].dist2, 4.0f);
    one.knn(Vec3(1.0f, 2.0f, 5.0f), 1, 1.999f, &list);
    EXPECT_TRUE(list.empty());
    one.knn(Vec3(1.0f, 2.0f, 5.0f), 1, 2.0f, &list);  // r² = dist2 exactly: included
    EXPECT_EQ(list.size(), 1u);
    EXPECT_EQ(one.bytes(), one.records().capacity() * sizeof(Photon));
}

TEST(KdTree, BuildPermutesTheInput) {
    const std::vector<Vec3> points = volume_points(20000, 9);
    const KdTree<Photon> tree(to_photons(points));
    const auto less = [](const Vec3& a, const Vec3& b) {
        return std::make_tuple(a.x, a.y, a.z) < std::make_tuple(b.x, b.y, b.z);
    };
    std::vector<Vec3> in = points, out;
    for (const Photon& ph : tree.records()) out.push_back(ph.position());
    std::sort(in.begin(), in.end(), less);
    std::sort(out.begin(), out.end(), less);
    EXPECT_EQ(in, out);
}

struct Shape {
    int min_leaf_depth = 1 << 30;
    int max_leaf_depth = 0;
};

/// Walks [lo, hi) as the documented layout; checks leaf slots and median splits.
void check_subtree(const std::vector<Photon>& recs, uint32_t lo, uint32_t hi, int depth,
                   Shape* shape) {
    if (hi - lo <= kLeafSize) {
        for (uint32_t i = lo; i < hi; ++i) ASSERT_EQ(recs[i].axis(), 3) << i;
        shape->min_leaf_depth = std::min(shape->min_leaf_depth, depth);
        shape->max_leaf_depth = std::max(shape->max_leaf_depth, depth);
        return;
    }
    const uint32_t m = lo + (hi - lo) / 2;
    const int axis = recs[m].axis();
    ASSERT_GE(axis, 0);
    ASSERT_LE(axis, 2);
    const float split = recs[m].pos[axis];
    for (uint32_t i = lo; i < m; ++i) ASSERT_LE(recs[i].pos[axis], split) << i;
    for (uint32_t i = m + 1; i < hi; ++i) ASSERT_GE(recs[i].pos[axis], split) << i;
    check_subtree(recs, lo, m, depth + 1, shape);
    check_subtree(recs, m + 1, hi, depth + 1, shape);
}

TEST(KdTree, IsBalancedWithMedianSplits) {
    for (const PointSet& set : point_sets()) {
        for (size_t n :
             {size_t{8}, size_t{9}, size_t{18}, size_t{143}, size_t{144}, set.points.size()}) {
            if (n > set.points.size()) continue;
            SCOPED_TRACE(set.name + " n=" + std::to_string(n));
            const std::vector<Vec3> points(set.points.begin(), set.points.begin() + n);
            const KdTree<Photon> tree(to_photons(points));
            Shape shape;
            check_subtree(tree.records(), 0, static_cast<uint32_t>(n), 1, &shape);
            if (n == 0) continue;
            // A tree with L split levels holds up to 9 * 2^L - 1 records.
            int levels = 0;
            while (9 * (size_t{1} << levels) - 1 < n) ++levels;
            EXPECT_LE(shape.max_leaf_depth, levels + 1);
            EXPECT_LE(shape.max_leaf_depth - shape.min_leaf_depth, 1);
        }
    }
}

TEST(KdTree, BuildIsIdenticalForOneAndTwoThreads) {
    // Large enough for the parallel path (subtrees above 16384 records are built in tasks).
    const std::vector<Photon> photons = to_photons(surface_points(300000, 10));
    std::vector<Photon> serial, parallel;
    {
        const ThreadLimit threads(1);
        serial = KdTree<Photon>(photons).records();
    }
    {
        const ThreadLimit threads(2);
        parallel = KdTree<Photon>(photons).records();
    }
    ASSERT_EQ(serial.size(), parallel.size());
    EXPECT_EQ(std::memcmp(serial.data(), parallel.data(), serial.size() * sizeof(Photon)), 0);
}

}  // namespace
}  // namespace fogmap
