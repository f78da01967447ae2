// KdTree<Photon> against nanoflann's KDTreeSingleIndexAdaptor (leaf sizes 10 and 20) on the same
// photon sets: uniform, surface-clustered and volume-clustered, 1e5 and 1e6 photons (1e7 is
// registered as "n:1e7" and runs only when --benchmark_filter names "1e7"). Measured: build time,
// k nearest (k = 50, 200), radius queries sized per query to find 50 photons; queries drawn like
// the data, in random and in Morton order. Fixed seeds.
//
// Speedup: each case registers nanoflann leaf 10, nanoflann leaf 20, then ours, and benchmarks run
// in registration order. Every benchmark stores its own ns/query (timed by hand around the query
// loop, thread CPU time; builds in wall time) in a table; ours then sets `speedup_vs_nanoflann`
// against the faster nanoflann variant of the same run (and per leaf size), when those ran.

#include "core/parallel.h"
#include "core/rng.h"
#include "photon/kd_tree.h"
#include "photon/photon.h"

#include <benchmark/benchmark.h>
#include <nanoflann.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <ctime>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace fogmap {
namespace {

constexpr uint64_t kSeed = 0xBE4C4ull;
constexpr size_t kQueries = 4096;
constexpr int kRadiusTarget = 50;  ///< radius queries use the distance to the 50th neighbour

enum class Dist { Uniform, Surface, Volume };
const char* dist_name(Dist d) {
    switch (d) {
        case Dist::Uniform:
            return "uniform";
        case Dist::Surface:
            return "surface";
        case Dist::Volume:
            return "volume";
    }
    return "?";
}

float normal(Rng& rng) {
    const float u = 1.0f - rng.uniform();
    return std::sqrt(-2.0f * std::log(u)) * std::cos(kTwoPi * rng.uniform());
}

Vec3 sphere_dir(Rng& rng) {
    const float z = 1.0f - 2.0f * rng.uniform(), r = std::sqrt(std::fmax(0.0f, 1.0f - z * z));
    const float phi = kTwoPi * rng.uniform();
    return Vec3(r * std::cos(phi), r * std::sin(phi), z);
}

/// A point of the distribution: a unit box; the walls of a Cornell-like box and two spheres with
/// 1e-4 noise (surface photons); Gaussian blobs of very different sizes in a box (smoke).
Vec3 sample(Dist d, Rng& rng) {
    const float u = rng.uniform(), v = rng.uniform();
    switch (d) {
        case Dist::Uniform:
            return Vec3(u, v, rng.uniform());
        case Dist::Surface: {
            Vec3 p;
            switch (rng.next_u32() % 6) {
                case 0:
                    p = Vec3(u, 0.0f, v);
                    break;  // floor
                case 1:
                    p = Vec3(u, 1.0f, v);
                    break;  // ceiling
                case 2:
                    p = Vec3(0.0f, u, v);
                    break;  // left wall
                case 3:
                    p = Vec3(1.0f, u, v);
                    break;  // right wall
                case 4:
                    p = Vec3(u, v, 1.0f);
                    break;  // back wall
                default:
                    p = (rng.uniform() < 0.5f ? Vec3(0.3f, 0.2f, 0.6f) : Vec3(0.7f, 0.25f, 0.4f)) +
                        0.2f * sphere_dir(rng);
            }
            return p + 1e-4f * Vec3(normal(rng), normal(rng), normal(rng));
        }
        case Dist::Volume: {
            static const Vec3 centers[] = {Vec3(0.5f, 0.3f, 0.5f), Vec3(0.2f, 0.7f, 0.3f),
                                           Vec3(0.8f, 0.6f, 0.7f), Vec3(0.5f, 0.5f, 0.5f)};
            static const float sigmas[] = {0.02f, 0.05f, 0.1f, 0.25f};
            const uint32_t c = rng.next_u32() % 4;
            return centers[c] + sigmas[c] * Vec3(normal(rng), normal(rng), normal(rng));
        }
    }
    return Vec3(0.0f);
}

std::vector<Photon> make_photons(Dist d, size_t n, uint64_t stream) {
    Rng rng(kSeed, stream);
    std::vector<Photon> photons;
    photons.reserve(n);
    for (size_t i = 0; i < n; ++i) {
        const Vec3 p = sample(d, rng);
        photons.emplace_back(p, sphere_dir(rng), Color(1.0f));
    }
    return photons;
}

uint32_t spread_bits10(uint32_t x) {
    x &= 0x3FFu;
    x = (x | (x << 16)) & 0x030000FFu;
    x = (x | (x << 8)) & 0x0300F00Fu;
    x = (x | (x << 4)) & 0x030C30C3u;
    x = (x | (x << 2)) & 0x09249249u;
    return x;
}

/// 30-bit Morton code of p quantised to 1024³ cells of `box`.
uint32_t morton(const Vec3& p, const Box3& box) {
    const Vec3 t = (p - box.lo) / glm::max(box.extent(), Vec3(1e-20f));
    const auto q = [](float x) {
        return static_cast<uint32_t>(std::clamp(x, 0.0f, 1.0f) * 1023.0f);
    };
    return spread_bits10(q(t.x)) | (spread_bits10(q(t.y)) << 1) | (spread_bits10(q(t.z)) << 2);
}

/// nanoflann dataset adaptor over the original (unsorted) photon array.
struct PhotonCloud {
    const std::vector<Photon>* photons;
    size_t kdtree_get_point_count() const { return photons->size(); }
    float kdtree_get_pt(uint32_t i, size_t dim) const { return (*photons)[i].pos[dim]; }
    template <class Bbox>
    bool kdtree_get_bbox(Bbox&) const {
        return false;
    }
};
using NanoTree =
    nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, PhotonCloud>,
                                        PhotonCloud, 3, uint32_t>;

/// Counts and sums (so the work is not optimised away) without allocating, like ours. nanoflann
/// keeps points with dist2 < worstDist(), so the limit is the float after r², as in ours.
struct CountingResultSet {
    float limit;
    size_t count = 0;
    float sum = 0.0f;
    size_t size() const { return count; }
    bool full() const { return true; }
    bool addPoint(float dist2, uint32_t) {
        if (dist2 < limit) {
            ++count;
            sum += dist2;
        }
        return true;
    }
    float worstDist() const { return limit; }
};

/// One data set with its trees and queries; only the current one is kept (1e7 needs ~1 GB).
struct Fixture {
    std::vector<Photon> photons;
    PhotonCloud cloud{&photons};
    KdTree<Photon> ours;
    std::unique_ptr<NanoTree> nano10, nano20;
    std::vector<Vec3> queries[2];  ///< [0] random order, [1] Morton order
    std::vector<float> radii[2];   ///< per query: distance to its kRadiusTarget-th neighbour
};

std::pair<Dist, size_t> g_fixture_key{Dist::Uniform, 0};
std::unique_ptr<Fixture> g_fixture;

const Fixture& fixture(Dist d, size_t n) {
    if (g_fixture && g_fixture_key == std::make_pair(d, n)) return *g_fixture;
    g_fixture.reset();
    auto f = std::make_unique<Fixture>();
    f->photons = make_photons(d, n, 1 + static_cast<uint64_t>(d));
    f->ours = KdTree<Photon>(f->photons);
    f->nano10 =
        std::make_unique<NanoTree>(3, f->cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
    f->nano20 =
        std::make_unique<NanoTree>(3, f->cloud, nanoflann::KDTreeSingleIndexAdaptorParams(20));
    Rng rng(kSeed, 100 + static_cast<uint64_t>(d));
    Box3 box;
    for (const Photon& ph : f->photons) box.extend(ph.position());
    std::vector<std::pair<uint32_t, Vec3>> keyed;
    for (size_t i = 0; i < kQueries; ++i) {
        const Vec3 q = sample(d, rng);
        f->queries[0].push_back(q);
        keyed.emplace_back(morton(q, box), q);
    }
    std::stable_sort(keyed.begin(), keyed.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& kq : keyed) f->queries[1].push_back(kq.second);
    NeighborList list;
    for (int order = 0; order < 2; ++order) {
        for (const Vec3& q : f->queries[order]) {
            f->ours.knn(q, kRadiusTarget, kInfinity, &list);
            f->radii[order].push_back(std::sqrt(list.max_dist2()));
        }
    }
    g_fixture_key = {d, n};
    g_fixture = std::move(f);
    return *g_fixture;
}

enum class Impl { Nano10, Nano20, Ours, OursOneThread };
const char* impl_name(Impl impl) {
    switch (impl) {
        case Impl::Nano10:
            return "nanoflann_leaf10";
        case Impl::Nano20:
            return "nanoflann_leaf20";
        case Impl::Ours:
            return "ours";
        case Impl::OursOneThread:
            return "ours_1thread";
    }
    return "?";
}

enum class Query { Knn50, Knn200, Radius50 };

/// Same-run results: case name (without the implementation) → implementation → ns per item.
std::map<std::string, std::map<Impl, double>> g_results;

double thread_cpu_seconds() {
    timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

double wall_seconds() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

/// Records ns per item (query or built photon) as `counter` and, for ours, the speedups against
/// the nanoflann runs of the same case.
void report(benchmark::State& state, const std::string& case_name, Impl impl, const char* counter,
            double ns) {
    state.counters[counter] = ns;
    auto& row = g_results[case_name];
    row[impl] = ns;
    if (impl != Impl::Ours && impl != Impl::OursOneThread) return;
    double best = 0.0;
    for (Impl base : {Impl::Nano10, Impl::Nano20}) {
        const auto it = row.find(base);
        if (it == row.end()) continue;
        state.counters[std::string("speedup_vs_") + impl_name(base)] = it->second / ns;
        best = best == 0.0 ? it->second : std::min(best, it->second);
    }
    if (best > 0.0) state.counters["speedup_vs_nanoflann"] = best / ns;
}

bool skipped_large(benchmark::State& state, size_t n) {
    if (n < 10000000 || benchmark::GetBenchmarkFilter().find("1e7") != std::string::npos) {
        return false;
    }
    state.SkipWithError("n = 1e7 runs only when --benchmark_filter names 1e7");
    return true;
}

void bm_build(benchmark::State& state, Dist d, size_t n, Impl impl, const std::string& case_name) {
    if (skipped_large(state, n)) return;
    const Fixture& f = fixture(d, n);
    double seconds = 0.0;
    int64_t builds = 0;
    for (auto _ : state) {
        state.PauseTiming();
        std::vector<Photon> copy = f.photons;
        state.ResumeTiming();
        const double t0 = wall_seconds();
        if (impl == Impl::Ours) {
            KdTree<Photon> tree(std::move(copy));
            benchmark::DoNotOptimize(tree.records().data());
        } else if (impl == Impl::OursOneThread) {
            const ThreadLimit one(1);
            KdTree<Photon> tree(std::move(copy));
            benchmark::DoNotOptimize(tree.records().data());
        } else {
            NanoTree tree(
                3, f.cloud,
                nanoflann::KDTreeSingleIndexAdaptorParams(impl == Impl::Nano10 ? 10 : 20));
            benchmark::DoNotOptimize(&tree);
        }
        seconds += wall_seconds() - t0;
        ++builds;
    }
    report(state, case_name, impl, "ns_per_photon",
           1e9 * seconds / static_cast<double>(builds) / static_cast<double>(n));
    state.counters["build_ms"] = 1e3 * seconds / static_cast<double>(builds);
}

void bm_query(benchmark::State& state, Dist d, size_t n, Impl impl, Query query, int order,
              const std::string& case_name) {
    if (skipped_large(state, n)) return;
    const Fixture& f = fixture(d, n);
    const std::vector<Vec3>& queries = f.queries[order];
    const std::vector<float>& radii = f.radii[order];
    const NanoTree& nano = impl == Impl::Nano10 ? *f.nano10 : *f.nano20;
    const int k = query == Query::Knn200 ? 200 : 50;
    NeighborList list;
    std::vector<uint32_t> nano_indices(static_cast<size_t>(k));
    std::vector<float> nano_dist2(static_cast<size_t>(k));
    double seconds = 0.0;
    int64_t done = 0;
    size_t found = 0;
    for (auto _ : state) {
        const double t0 = thread_cpu_seconds();
        for (size_t i = 0; i < queries.size(); ++i) {
            const Vec3& q = queries[i];
            if (query == Query::Radius50) {
                if (impl == Impl::Ours) {
                    size_t count = 0;
                    float sum = 0.0f;
                    f.ours.for_each_in_radius(q, radii[i], [&](const Photon&, float dist2) {
                        ++count;
                        sum += dist2;
                    });
                    benchmark::DoNotOptimize(sum);
                    found += count;
                } else {
                    CountingResultSet result{std::nextafter(radii[i] * radii[i], kInfinity)};
                    nano.findNeighbors(result, &q.x, nanoflann::SearchParams());
                    benchmark::DoNotOptimize(result.sum);
                    found += result.count;
                }
            } else if (impl == Impl::Ours) {
                f.ours.knn(q, k, kInfinity, &list);
                found += list.size();
            } else {
                nanoflann::KNNResultSet<float, uint32_t> result(static_cast<size_t>(k));
                result.init(nano_indices.data(), nano_dist2.data());
                nano.findNeighbors(result, &q.x, nanoflann::SearchParams());
                found += result.size();
            }
        }
        seconds += thread_cpu_seconds() - t0;
        done += static_cast<int64_t>(queries.size());
    }
    state.SetItemsProcessed(done);
    state.counters["found_per_query"] = static_cast<double>(found) / static_cast<double>(done);
    report(state, case_name, impl, "ns_per_query", 1e9 * seconds / static_cast<double>(done));
}

void register_all() {
    const std::pair<size_t, const char*> sizes[] = {
        {100000, "100000"}, {1000000, "1000000"}, {10000000, "1e7"}};
    const std::pair<Query, const char*> queries[] = {
        {Query::Knn50, "knn_k50"}, {Query::Knn200, "knn_k200"}, {Query::Radius50, "radius_50"}};
    const char* orders[] = {"random", "morton"};
    for (const auto& [n, n_name] : sizes) {
        for (Dist d : {Dist::Uniform, Dist::Surface, Dist::Volume}) {
            const std::string data = std::string(dist_name(d)) + "/n:" + n_name;
            const std::string build_case = "build/" + data;
            for (Impl impl : {Impl::Nano10, Impl::Nano20, Impl::Ours, Impl::OursOneThread}) {
                benchmark::RegisterBenchmark((build_case + "/" + impl_name(impl)).c_str(), bm_build,
                                             d, n, impl, build_case)
                    ->Unit(benchmark::kMillisecond)
                    ->UseRealTime()
                    ->MinTime(n <= 100000 ? 0.2 : 0.5);
            }
            for (const auto& [query, q_name] : queries) {
                for (int order = 0; order < 2; ++order) {
                    const std::string query_case =
                        std::string(q_name) + "/" + data + "/" + orders[order];
                    for (Impl impl : {Impl::Nano10, Impl::Nano20, Impl::Ours}) {
                        benchmark::RegisterBenchmark((query_case + "/" + impl_name(impl)).c_str(),
                                                     bm_query, d, n, impl, query, order, query_case)
                            ->Unit(benchmark::kMillisecond)
                            ->MinTime(0.1);
                    }
                }
            }
        }
    }
}

const bool g_registered = (register_all(), true);

}  // namespace
}  // namespace fogmap
