// Trilinear density samples while marching through real grids (smoke1.vdb, the Disney cloud at
// 1/16): the same sample points through
//   dense        a dense float array copy of the grid (this file's own; the baseline,
//                target: fogmap at most 1.5x its cost),
//   fogmap       DensityGrid::Sampler (inline; per 8^3 cell one value or a 9^3 brick, built at
//                load: one table lookup plus 8 loads per sample),
//   gridsampler  openvdb::tools::GridSampler<FloatGrid::ConstAccessor, BoxSampler>::isSample,
//   gridsampler_tree  GridSampler<FloatTree, BoxSampler> (no accessor cache),
//   nanovdb      nanovdb::openToNanoVDB + ReadAccessor + TrilinearSampler (what it would buy),
//   leaf_cache   a prototype per-thread leaf cache over the OpenVDB tree (what it would buy).
// Points: march steps (1 voxel, jittered) of random rays through the grid's bounds, in march
// order ("coherent") or shuffled ("random"); 2^18 per volume, fixed seeds. Each benchmark
// stores its ns/sample (thread CPU time); the others then set `cost_vs_dense` against the dense
// run of the same case (registered first). `max_abs_diff` checks every sampler against dense.
// Memory (MB): dense_MB on the dense row; fogmap_MB (DensityGrid::sampler_bytes, all fogmap
// keeps) and openvdb_MB (the FloatGrid's tree) on the fogmap row.

#include "bench_volumes.h"
#include "core/rng.h"
#include "media/density_grid.h"

#include <benchmark/benchmark.h>
#include <nanovdb/NanoVDB.h>
#include <nanovdb/util/OpenToNanoVDB.h>
#include <nanovdb/util/SampleFromVoxels.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/Interpolation.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <ctime>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace fogmap::bench {
namespace {

using openvdb::FloatGrid;

constexpr uint64_t kSeed = 0x3A2C4ull;
constexpr size_t kSamples = size_t(1) << 18;

/// The grid copied into a dense array over the sampled box; trilinear like BoxSampler
/// (voxel centres at integers), 0 outside.
class DenseGrid {
public:
    DenseGrid() = default;
    /// Covers index points lo .. hi + 1 per axis, so every stencil of a point in [lo, hi] fits.
    DenseGrid(const FloatGrid& grid, const std::array<int, 3>& lo, const std::array<int, 3>& hi)
        : lo_(lo) {
        for (int a = 0; a < 3; ++a) dims_[a] = hi[a] - lo[a] + 2;
        values_.resize(static_cast<size_t>(dims_[0]) * dims_[1] * dims_[2]);
        FloatGrid::ConstAccessor acc = grid.getConstAccessor();
        size_t n = 0;
        for (int k = 0; k < dims_[2]; ++k)
            for (int j = 0; j < dims_[1]; ++j)
                for (int i = 0; i < dims_[0]; ++i)
                    values_[n++] = acc.getValue(openvdb::Coord(lo[0] + i, lo[1] + j, lo[2] + k));
    }

    float density(const Vec3& p) const {
        const float fx = std::floor(p.x), fy = std::floor(p.y), fz = std::floor(p.z);
        const int i = static_cast<int>(fx) - lo_[0], j = static_cast<int>(fy) - lo_[1];
        const int k = static_cast<int>(fz) - lo_[2];
        if (static_cast<unsigned>(i) >= static_cast<unsigned>(dims_[0] - 1) ||
            static_cast<unsigned>(j) >= static_cast<unsigned>(dims_[1] - 1) ||
            static_cast<unsigned>(k) >= static_cast<unsigned>(dims_[2] - 1))
            return 0.0f;
        const size_t sy = static_cast<size_t>(dims_[0]), sz = sy * static_cast<size_t>(dims_[1]);
        const float* c = values_.data() + (k * sz + j * sy + static_cast<size_t>(i));
        const float u = p.x - fx, v = p.y - fy, w = p.z - fz;
        const auto lerp = [](float a, float b, float t) { return a + t * (b - a); };
        const float c00 = lerp(c[0], c[1], u), c10 = lerp(c[sy], c[sy + 1], u);
        const float c01 = lerp(c[sz], c[sz + 1], u), c11 = lerp(c[sz + sy], c[sz + sy + 1], u);
        return lerp(lerp(c00, c10, v), lerp(c01, c11, v), w);
    }
    size_t bytes() const { return values_.size() * sizeof(float); }

private:
    std::array<int, 3> lo_{0, 0, 0}, dims_{0, 0, 0};
    std::vector<float> values_;
};

/// Prototype of a per-thread leaf cache: when the 2×2×2 stencil lies inside one 8³ leaf (343 of
/// 512 cell positions), the 8 values come straight from the last leaf's buffer; a point whose
/// leaf is absent (a tile or the background) takes the constant value there; stencils across
/// leaves fall back to the accessor. Same values as BoxSampler.
class LeafCacheSampler {
public:
    explicit LeafCacheSampler(const FloatGrid& grid) : acc_(grid.getConstAccessor()) {}

    float density(const Vec3& p) {
        const float fx = std::floor(p.x), fy = std::floor(p.y), fz = std::floor(p.z);
        const int i = static_cast<int>(fx), j = static_cast<int>(fy), k = static_cast<int>(fz);
        if ((i & 7) == 7 || (j & 7) == 7 || (k & 7) == 7)
            return openvdb::tools::BoxSampler::sample(acc_, openvdb::Vec3R(p.x, p.y, p.z));
        const openvdb::Coord origin(i & ~7, j & ~7, k & ~7);
        if (origin != origin_) {
            origin_ = origin;
            const FloatGrid::TreeType::LeafNodeType* leaf = acc_.probeConstLeaf(origin);
            data_ = leaf ? leaf->buffer().data() : nullptr;
            tile_ = leaf ? 0.0f : acc_.getValue(origin);
        }
        if (!data_) return tile_;
        // Leaf offset = x << 6 | y << 3 | z (local coordinates).
        const float* c = data_ + (((i & 7) << 6) | ((j & 7) << 3) | (k & 7));
        const float u = p.x - fx, v = p.y - fy, w = p.z - fz;
        const auto lerp = [](float a, float b, float t) { return a + t * (b - a); };
        const float c00 = lerp(c[0], c[64], u), c10 = lerp(c[8], c[72], u);
        const float c01 = lerp(c[1], c[65], u), c11 = lerp(c[9], c[73], u);
        return lerp(lerp(c00, c10, v), lerp(c01, c11, v), w);
    }

private:
    FloatGrid::ConstAccessor acc_;
    openvdb::Coord origin_{openvdb::Coord::max()};
    const float* data_ = nullptr;
    float tile_ = 0.0f;
};

/// One volume in every representation, with its sample points (only the current one is kept).
struct Fixture {
    std::string path;
    std::unique_ptr<DensityGrid> fogmap_grid;
    FloatGrid::Ptr vdb_grid;
    nanovdb::GridHandle<nanovdb::HostBuffer> nano_handle;
    const nanovdb::NanoGrid<float>* nano_grid = nullptr;
    DenseGrid dense;
    std::vector<Vec3> points[2];  ///< [Coherent], [Random]: index space
};

std::unique_ptr<Fixture> g_fixture;

/// March points: rays from a sphere around the grid's bounds towards random points inside,
/// 1-voxel steps with one jitter per ray, as RayMarcher::march places them.
std::vector<Vec3> march_points(const Box3& box, Rng& rng) {
    std::vector<Vec3> points;
    points.reserve(kSamples + 4096);
    const float radius = glm::length(box.extent());
    while (points.size() < kSamples) {
        const float z = 1.0f - 2.0f * rng.uniform(), phi = kTwoPi * rng.uniform();
        const float s = std::sqrt(std::max(0.0f, 1.0f - z * z));
        const Vec3 o = box.center() + radius * Vec3(s * std::cos(phi), s * std::sin(phi), z);
        const Vec3 target =
            box.lo + box.extent() * Vec3(rng.uniform(), rng.uniform(), rng.uniform());
        const Ray ray{o, glm::normalize(target - o)};
        float t0, t1;
        if (!intersect_box(box, ray, 0.0f, kInfinity, &t0, &t1) || !(t1 > t0)) continue;
        const int steps = std::max(1, static_cast<int>(std::ceil(t1 - t0)));
        const float h = (t1 - t0) / steps, jitter = rng.uniform();
        for (int k = 0; k < steps && points.size() < kSamples; ++k)
            points.push_back(ray.at(t0 + (k + jitter) * h));
    }
    return points;
}

/// FNV-1a of the file's name (not its folder): the same points wherever the volumes live.
uint64_t name_stream(const std::string& path) {
    uint64_t h = 0xCBF29CE484222325ull;
    for (const char c : path.substr(path.find_last_of('/') + 1))
        h = (h ^ static_cast<unsigned char>(c)) * 0x100000001B3ull;
    return h;
}

const Fixture& fixture(const std::string& path) {
    if (g_fixture && g_fixture->path == path) return *g_fixture;
    g_fixture.reset();
    auto f = std::make_unique<Fixture>();
    f->path = path;
    f->fogmap_grid = DensityGrid::load(path, "density", "");
    openvdb::initialize();
    openvdb::io::File file(path);
    file.open(/*delayLoad=*/false);
    f->vdb_grid = openvdb::gridPtrCast<FloatGrid>(file.readGrid("density"));
    file.close();
    if (!f->vdb_grid) throw std::runtime_error(path + ": no float grid 'density'");
    f->nano_handle = nanovdb::openToNanoVDB(*f->vdb_grid);
    f->nano_grid = f->nano_handle.grid<float>();
    const Box3& box = f->fogmap_grid->index_bounds();
    std::array<int, 3> lo{}, hi{};
    for (int a = 0; a < 3; ++a) {
        lo[a] = static_cast<int>(std::floor(box.lo[a]));
        hi[a] = static_cast<int>(std::ceil(box.hi[a]));
    }
    f->dense = DenseGrid(*f->vdb_grid, lo, hi);
    Rng rng(kSeed, name_stream(path));
    f->points[0] = march_points(box, rng);
    f->points[1] = f->points[0];
    std::vector<Vec3>& shuffled = f->points[1];
    for (size_t i = shuffled.size() - 1; i > 0; --i)
        std::swap(shuffled[i], shuffled[rng.next_u32() % (i + 1)]);
    g_fixture = std::move(f);
    return *g_fixture;
}

double thread_cpu_seconds() {
    timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

enum class Impl { Dense, Fogmap, GridSampler, GridSamplerTree, NanoVdb, LeafCache };
const char* impl_name(Impl impl) {
    switch (impl) {
        case Impl::Dense:
            return "dense";
        case Impl::Fogmap:
            return "fogmap";
        case Impl::GridSampler:
            return "gridsampler";
        case Impl::GridSamplerTree:
            return "gridsampler_tree";
        case Impl::NanoVdb:
            return "nanovdb";
        case Impl::LeafCache:
            return "leaf_cache";
    }
    return "?";
}

/// Calls sample(points[i]) for every point; returns Σ density (kept, so nothing is optimised
/// away). `out` (optional) receives each value.
template <class F>
double sample_all(const std::vector<Vec3>& points, F&& sample, std::vector<float>* out) {
    double sum = 0.0;
    for (const Vec3& p : points) {
        const float d = sample(p);
        sum += d;
        if (out) out->push_back(d);
    }
    return sum;
}

/// Runs `impl` over the points once; returns Σ density.
double run(const Fixture& f, Impl impl, const std::vector<Vec3>& points,
           std::vector<float>* out = nullptr) {
    switch (impl) {
        case Impl::Dense:
            return sample_all(
                points, [&](const Vec3& p) { return f.dense.density(p); }, out);
        case Impl::Fogmap: {
            DensityGrid::Sampler s(*f.fogmap_grid);
            return sample_all(
                points, [&](const Vec3& p) { return s.density(p); }, out);
        }
        case Impl::GridSampler: {
            const FloatGrid::ConstAccessor acc = f.vdb_grid->getConstAccessor();
            const openvdb::tools::GridSampler<FloatGrid::ConstAccessor, openvdb::tools::BoxSampler>
                s(acc, f.vdb_grid->transform());
            return sample_all(
                points, [&](const Vec3& p) { return s.isSample(openvdb::Vec3d(p.x, p.y, p.z)); },
                out);
        }
        case Impl::GridSamplerTree: {
            const openvdb::tools::GridSampler<FloatGrid::TreeType, openvdb::tools::BoxSampler> s(
                f.vdb_grid->tree(), f.vdb_grid->transform());
            return sample_all(
                points, [&](const Vec3& p) { return s.isSample(openvdb::Vec3d(p.x, p.y, p.z)); },
                out);
        }
        case Impl::NanoVdb: {
            const auto acc = f.nano_grid->getAccessor();
            const auto s = nanovdb::createSampler<1>(acc);
            return sample_all(
                points, [&](const Vec3& p) { return s(nanovdb::Vec3f(p.x, p.y, p.z)); }, out);
        }
        case Impl::LeafCache: {
            LeafCacheSampler s(*f.vdb_grid);
            return sample_all(
                points, [&](const Vec3& p) { return s.density(p); }, out);
        }
    }
    return 0.0;
}

/// Same-run results: case name (volume/order) → implementation → ns per sample.
std::map<std::string, std::map<Impl, double>> g_results;

void bm_sample(benchmark::State& state, std::string vdb, SampleOrder order, Impl impl,
               std::string case_name) {
    if (!shared_volume_exists(vdb)) {
        state.SkipWithError((shared_volume(vdb) + " not found").c_str());
        return;
    }
    const Fixture& f = fixture(shared_volume(vdb));
    const std::vector<Vec3>& points = f.points[static_cast<int>(order)];
    // Correctness first: every sampler returns the dense array's values (to rounding).
    std::vector<float> ref, got;
    ref.reserve(points.size());
    got.reserve(points.size());
    run(f, Impl::Dense, points, &ref);
    run(f, impl, points, &got);
    float max_diff = 0.0f;
    for (size_t i = 0; i < ref.size(); ++i)
        max_diff = std::max(max_diff, std::abs(ref[i] - got[i]));
    double seconds = 0.0;
    int64_t done = 0;
    for (auto _ : state) {
        const double t0 = thread_cpu_seconds();
        benchmark::DoNotOptimize(run(f, impl, points));
        seconds += thread_cpu_seconds() - t0;
        done += static_cast<int64_t>(points.size());
    }
    state.SetItemsProcessed(done);
    const double ns = 1e9 * seconds / static_cast<double>(done);
    state.counters["ns_per_sample"] = ns;
    state.counters["max_abs_diff"] = max_diff;
    auto& row = g_results[case_name];
    row[impl] = ns;
    if (impl == Impl::Dense) {
        state.counters["dense_MB"] = static_cast<double>(f.dense.bytes()) / (1 << 20);
        return;
    }
    if (const auto it = row.find(Impl::Dense); it != row.end())
        state.counters["cost_vs_dense"] = ns / it->second;
    if (impl == Impl::Fogmap) {
        state.counters["fogmap_MB"] =
            static_cast<double>(f.fogmap_grid->sampler_bytes()) / (1 << 20);
        state.counters["openvdb_MB"] = static_cast<double>(f.vdb_grid->memUsage()) / (1 << 20);
    }
    if (impl == Impl::NanoVdb || impl == Impl::LeafCache) {
        if (const auto it = row.find(Impl::Fogmap); it != row.end())
            state.counters["speedup_vs_fogmap"] = it->second / ns;
    }
}

void register_all() {
    const char* orders[] = {"coherent", "random"};
    for (const char* vdb : {kSmokeVdb, kCloudVdb}) {
        for (int order = 0; order < 2; ++order) {
            const std::string case_name = std::string("march_sample/") + vdb + "/" + orders[order];
            for (Impl impl : {Impl::Dense, Impl::Fogmap, Impl::GridSampler, Impl::GridSamplerTree,
                              Impl::NanoVdb, Impl::LeafCache}) {
                benchmark::RegisterBenchmark((case_name + "/" + impl_name(impl)).c_str(), bm_sample,
                                             std::string(vdb), static_cast<SampleOrder>(order),
                                             impl, case_name)
                    ->Unit(benchmark::kMillisecond)
                    ->MinTime(0.2);
            }
        }
    }
}

const bool g_registered = (register_all(), true);

}  // namespace

double gridsampler_ns_per_sample(const std::string& path, SampleOrder order) {
    const Fixture& f = fixture(path);
    const std::vector<Vec3>& points = f.points[static_cast<int>(order)];
    run(f, Impl::GridSampler, points);  // warm the caches
    double seconds = 0.0;
    size_t done = 0;
    while (seconds < 0.2) {
        const double t0 = thread_cpu_seconds();
        benchmark::DoNotOptimize(run(f, Impl::GridSampler, points));
        seconds += thread_cpu_seconds() - t0;
        done += points.size();
    }
    return 1e9 * seconds / static_cast<double>(done);
}

}  // namespace fogmap::bench
