#include "media/volume_gen.h"

#include "core/error.h"
#include "core/output_files.h"
#include "core/rng.h"
#include "media/vdb_probe.h"

#include <openvdb/openvdb.h>
#include <openvdb/tools/Morphology.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <stdexcept>
#include <vector>

namespace fogmap {

namespace {

/// Voxels below this density stay inactive (and are not written).
constexpr float kMinDensity = 1e-3f;

void init_openvdb() {
    static std::once_flag once;
    std::call_once(once, [] { openvdb::initialize(); });
}

/// Writes `grid` to "<path>.tmp-<pid>", then renames it over `path` (docs/contributing.md: outputs
/// go to a temp file, then rename; core/output_files.h). OpenVDB writes through a std::ofstream
/// whose failures it may not report, so the temp is renamed only after its header and grid
/// descriptors were read back and found complete (check_vdb_file). Active-mask + Blosc (or zip)
/// compression keeps files small.
void write_grids_atomic(const openvdb::GridPtrVec& grids, const std::string& path) {
    init_openvdb();
    OutputFiles out;
    const StagedFile to = out.stage(path);
    try {
        openvdb::io::File file(to.temp);
        const uint32_t codec = openvdb::io::Archive::hasBloscCompression()
                                   ? openvdb::io::COMPRESS_BLOSC
                                   : openvdb::io::COMPRESS_ZIP;
        file.setCompression(openvdb::io::COMPRESS_ACTIVE_MASK | codec);
        file.write(grids);
        file.close();
        check_vdb_file(to.temp, "");
    } catch (const InputError& e) {
        throw std::runtime_error("cannot write volume '" + path +
                                 "': the file written is incomplete (" + e.reason + ")");
    } catch (const std::exception& e) {
        throw std::runtime_error("cannot write volume '" + path + "': " + e.what());
    }
    out.commit();
}

openvdb::math::Transform::Ptr make_transform(const Vec3& voxel_size, const Vec3& translation) {
    openvdb::Mat4d m = openvdb::Mat4d::identity();  // row-vector convention: translation in row 3
    for (int a = 0; a < 3; ++a) {
        m(a, a) = voxel_size[a];
        m(3, a) = translation[a];
    }
    return openvdb::math::Transform::createLinearTransform(m);
}

// --- Noise: hashed gradient noise (Perlin 2002 quintic fade) and fBm, deterministic per seed.

float smoothstep(float e0, float e1, float x) {
    const float t = std::clamp((x - e0) / (e1 - e0), 0.0f, 1.0f);
    return t * t * (3.0f - 2.0f * t);
}

class Noise {
public:
    /// `drift`: the noise field moves by it (noise units), so a sequence's eddies rise.
    explicit Noise(uint64_t seed, const Vec3& drift = Vec3(0.0f))
        : seed_(mix64(seed ^ stream::kNoise)), drift_(drift) {}

    /// Gradient noise, roughly in [-1, 1], 0 at integer lattice points.
    float gradient(const Vec3& p) const {
        const Vec3 f = glm::floor(p);
        const int x0 = static_cast<int>(f.x), y0 = static_cast<int>(f.y);
        const int z0 = static_cast<int>(f.z);
        const Vec3 t = p - f;
        const Vec3 u = t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f);
        float v[8];
        for (int c = 0; c < 8; ++c) {
            const int dx = c & 1, dy = (c >> 1) & 1, dz = c >> 2;
            v[c] = glm::dot(
                lattice_gradient(x0 + dx, y0 + dy, z0 + dz),
                t - Vec3(static_cast<float>(dx), static_cast<float>(dy), static_cast<float>(dz)));
        }
        const float x00 = v[0] + u.x * (v[1] - v[0]), x10 = v[2] + u.x * (v[3] - v[2]);
        const float x01 = v[4] + u.x * (v[5] - v[4]), x11 = v[6] + u.x * (v[7] - v[6]);
        const float y0v = x00 + u.y * (x10 - x00), y1v = x01 + u.y * (x11 - x01);
        return 1.5f * (y0v + u.z * (y1v - y0v));
    }

    /// Fractional Brownian motion: sum of `octaves` gradient-noise octaves (gain 1/2,
    /// lacunarity 2), normalised to roughly [-1, 1].
    float fbm(Vec3 p, int octaves) const {
        p -= drift_;
        float sum = 0.0f, amp = 1.0f, norm = 0.0f;
        for (int o = 0; o < octaves; ++o) {
            sum += amp * gradient(p);
            norm += amp;
            amp *= 0.5f;
            p = p * 2.0f + Vec3(17.3f, -9.1f, 5.7f);  // offset decorrelates octaves' lattices
        }
        return sum / norm;
    }

private:
    Vec3 lattice_gradient(int x, int y, int z) const {
        uint64_t h = mix64(seed_ ^ static_cast<uint32_t>(x));
        h = mix64(h ^ (static_cast<uint64_t>(static_cast<uint32_t>(y)) << 21));
        h = mix64(h ^ (static_cast<uint64_t>(static_cast<uint32_t>(z)) << 42));
        // 12 cube-edge directions (Perlin 2002): unbiased and cheap.
        static const std::array<Vec3, 12> kDirs = {
            Vec3(1, 1, 0), Vec3(-1, 1, 0), Vec3(1, -1, 0), Vec3(-1, -1, 0),
            Vec3(1, 0, 1), Vec3(-1, 0, 1), Vec3(1, 0, -1), Vec3(-1, 0, -1),
            Vec3(0, 1, 1), Vec3(0, -1, 1), Vec3(0, 1, -1), Vec3(0, -1, -1)};
        return kDirs[(h >> 32) % 12];
    }

    uint64_t seed_;
    Vec3 drift_;
};

/// Rising column: radius grows with height, sways and is fBm-eroded at the edge, fades at top.
/// `q` is the voxel position divided by the resolution: y in [0, 1], x and z in [-0.5, 0.5].
float plume_density(const Noise& noise, const Vec3& q) {
    const float h = q.y;
    const Vec3 sway(0.07f * h * noise.fbm(Vec3(1.3f, 2.5f * h, 0.0f), 3), 0.0f,
                    0.07f * h * noise.fbm(Vec3(7.9f, 2.5f * h, 3.1f), 3));
    const float radius = 0.06f + 0.2f * h;
    const float rho = glm::length(Vec2(q.x - sway.x, q.z - sway.z));
    // Noise is stretched along y and advected upward, so eddies look like rising turbulence.
    const Vec3 nq(q.x * 7.0f, q.y * 5.0f, q.z * 7.0f);
    const float rho_eroded = rho + 0.35f * radius * noise.fbm(nq, 5);
    float d = 1.0f - smoothstep(0.45f * radius, radius, rho_eroded);
    d *= 1.0f - smoothstep(0.7f, 0.98f, h);                     // fade toward the top
    d *= smoothstep(0.0f, 0.04f, h + 0.02f);                    // soft but dense base at y = 0
    d *= 0.75f + 0.25f * noise.fbm(nq * 2.0f + Vec3(3.3f), 3);  // interior wisps
    d *= 1.0f - smoothstep(0.42f, 0.5f, std::max(std::abs(q.x), std::abs(q.z)));
    return std::clamp(d, 0.0f, 1.0f);
}

struct Fire {
    float density = 0.0f;
    float kelvin = 0.0f;
};

/// Fireball: a billowing core (centre 0.22 up, radius 0.17, fBm-eroded) at up to ~2500 K, with
/// the plume's rising column of smoke above it, cooling with height from ~1300 K to ~600 K. `q`
/// as for the plume. Hot gas is thin (density 0.35 in the core) and smoke denser above.
Fire fireball(const Noise& noise, const Vec3& q) {
    const Vec3 centre(0.0f, 0.22f, 0.0f);
    const float radius = 0.17f;
    const Vec3 nq = q * 6.0f;
    const float dist = glm::length(q - centre) + 0.3f * radius * noise.fbm(nq + Vec3(5.1f), 4);
    const float core = 1.0f - smoothstep(0.4f * radius, radius, dist);
    const float smoke = plume_density(noise, q) * smoothstep(0.2f, 0.45f, q.y);
    Fire f;
    f.density = std::max(0.35f * core * (0.8f + 0.2f * noise.fbm(nq * 2.0f, 3)), 0.9f * smoke);
    if (f.density < kMinDensity) return f;
    const float cooling = 1.0f - smoothstep(centre.y, 0.95f, q.y);  // 1 at the core, 0 at the top
    const float smoke_kelvin = 600.0f + 700.0f * cooling;
    f.kelvin = smoke_kelvin + (2500.0f - smoke_kelvin) * core;
    return f;
}

/// Cumulus: union of spheres (smallest signed distance), fBm-displaced, flattened base.
/// `q` is the voxel position divided by the resolution: x in [-0.5, 0.5], y, z in [-0.4, 0.4].
float cloud_density(const Noise& noise, const Vec3& q) {
    static const std::array<std::array<float, 4>, 6> kSpheres = {{
        {0.0f, -0.07f, 0.0f, 0.2f},
        {-0.19f, -0.11f, 0.03f, 0.14f},
        {0.2f, -0.12f, -0.02f, 0.13f},
        {0.05f, 0.06f, 0.0f, 0.13f},
        {-0.08f, 0.02f, 0.07f, 0.12f},
        {0.1f, -0.05f, 0.08f, 0.1f},
    }};
    float sd = 1e9f;
    for (const auto& s : kSpheres)
        sd = std::min(sd, glm::length(q - Vec3(s[0], s[1], s[2])) - s[3]);
    sd = std::max(sd, -0.17f - q.y);  // flat base at y = -0.17
    sd += 0.06f * noise.fbm(q * 6.0f, 5);
    float d = smoothstep(0.02f, -0.03f, sd);  // soft edge, ~5% of the resolution
    d *= 0.8f + 0.2f * noise.fbm(q * 12.0f + Vec3(5.1f), 3);
    d *= 1.0f - smoothstep(0.44f, 0.5f, std::abs(q.x));
    d *= 1.0f - smoothstep(0.34f, 0.4f, std::max(std::abs(q.y), std::abs(q.z)));
    return std::clamp(d, 0.0f, 1.0f);
}

/// The density (and the fireball's temperature) of the voxels with k in [k0, k1]: each voxel is
/// a function of its index alone, so slabs are made apart, in parallel, and merged.
struct Slab {
    openvdb::FloatGrid::Ptr density = openvdb::FloatGrid::create(0.0f);
    openvdb::FloatGrid::Ptr temperature = openvdb::FloatGrid::create(0.0f);
};

Slab make_slab(const VolumeGenSettings& settings, const Noise& noise, int k0, int k1) {
    const int res = std::max(settings.resolution, 8);
    const float inv_res = 1.0f / static_cast<float>(res);
    // Index ranges: the plume stands on voxel row y = 0 centred on x = z = 0; the cloud is
    // centred on the index origin. Translation 0 keeps those placements in world space.
    const int half = res / 2;
    const bool plume = settings.shape != VolumeShape::Cloud;  // the fireball stands like a plume
    const bool fire = settings.shape == VolumeShape::Fireball;
    const int y0 = plume ? 0 : -static_cast<int>(0.4f * res);
    const int y1 = plume ? res - 1 : -y0;
    Slab slab;
    auto acc = slab.density->getAccessor();
    auto temperature_acc = slab.temperature->getAccessor();
    for (int k = k0; k <= k1; ++k) {
        for (int j = y0; j <= y1; ++j) {
            for (int i = -half; i <= half; ++i) {
                const Vec3 q =
                    Vec3(static_cast<float>(i), static_cast<float>(j), static_cast<float>(k)) *
                    inv_res;
                if (fire) {
                    const Fire f = fireball(noise, q);
                    if (f.density < kMinDensity) continue;
                    acc.setValue(openvdb::Coord(i, j, k), f.density);
                    temperature_acc.setValue(openvdb::Coord(i, j, k), f.kelvin);
                    continue;
                }
                const float d = plume ? plume_density(noise, q) : cloud_density(noise, q);
                if (d >= kMinDensity) acc.setValue(openvdb::Coord(i, j, k), d);
            }
        }
    }
    return slab;
}

/// The noise's rise per frame, in its own units.
constexpr float kDrift = 0.15f;

/// The plume's eddies rise with the noise: its main octaves are read at y × 5 / resolution
/// (plume_density), so kDrift / 5 resolutions a frame; that speed in world units per second at
/// kVelocityFps, upward, over the density's voxels and 2 around them (a lookup just outside the
/// smoke moves too).
openvdb::Vec3SGrid::Ptr rise_velocity(const openvdb::FloatGrid& density,
                                      const VolumeGenSettings& settings) {
    const float speed = kDrift / 5.0f * float(std::max(settings.resolution, 8)) *
                        settings.voxel_size * kVelocityFps;
    openvdb::Vec3SGrid::Ptr vel = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.0f));
    vel->tree().topologyUnion(density.tree());
    openvdb::tools::dilateActiveValues(vel->tree(), 2, openvdb::tools::NN_FACE_EDGE_VERTEX,
                                       openvdb::tools::IGNORE_TILES);
    for (auto it = vel->tree().beginValueOn(); it; ++it)
        it.setValue(openvdb::Vec3s(0.0f, speed, 0.0f));
    vel->setName("vel");
    vel->setTransform(density.transform().copy());
    vel->setSaveFloatAsHalf(true);
    return vel;
}

/// The grids of generate_volume.
openvdb::GridPtrVec make_grids(const VolumeGenSettings& settings) {
    init_openvdb();
    const int res = std::max(settings.resolution, 8);
    // A sequence's frames: the noise rises by kDrift units a frame (about a plume's eddy in 7).
    const Noise noise(settings.seed, Vec3(0.0f, kDrift * settings.time, 0.0f));
    const bool fire = settings.shape == VolumeShape::Fireball;
    const int zh = settings.shape != VolumeShape::Cloud ? res / 2 : static_cast<int>(0.4f * res);
    // Slabs of half an internal node's depth (64 voxels along k, aligned), merged in k order:
    // the grid is the same whatever the thread count. Each slab's tree has its own internal
    // nodes over the whole x-y extent (33 KB per 128^2 voxels), all held until the merge, so
    // slabs are not thin (8 voxels deep: a 3.1 GB grid at 2304^3 peaked at 3.6 GB).
    constexpr int kDepth = 64;
    const int first = -zh - ((-zh % kDepth) + kDepth) % kDepth;
    const int slabs = (zh - first) / kDepth + 1;
    std::vector<Slab> parts(static_cast<size_t>(slabs));
    tbb::parallel_for(0, slabs, [&](int s) {
        const int k0 = std::max(-zh, first + kDepth * s);
        const int k1 = std::min(zh, first + kDepth * s + kDepth - 1);
        parts[size_t(s)] = make_slab(settings, noise, k0, k1);
    });
    openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(0.0f);
    openvdb::FloatGrid::Ptr temperature = openvdb::FloatGrid::create(0.0f);
    for (Slab& part : parts) {  // disjoint leaves: the merge moves them
        grid->tree().merge(part.density->tree());
        temperature->tree().merge(part.temperature->tree());
    }
    grid->pruneGrid();
    grid->setName("density");
    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    grid->setTransform(make_transform(Vec3(settings.voxel_size), Vec3(0.0f)));
    grid->setSaveFloatAsHalf(true);  // noise fields need no more; halves the file
    openvdb::GridPtrVec grids{grid};
    if (fire) {
        temperature->pruneGrid();
        temperature->setName("temperature");
        temperature->setGridClass(openvdb::GRID_FOG_VOLUME);
        temperature->setTransform(grid->transform().copy());
        temperature->setSaveFloatAsHalf(true);
        grids.push_back(temperature);
    }
    if (settings.velocity && settings.shape != VolumeShape::Cloud)
        grids.push_back(rise_velocity(*grid, settings));
    return grids;
}

}  // namespace

void generate_volume(const VolumeGenSettings& settings, const std::string& path) {
    write_grids_atomic(make_grids(settings), path);
}

namespace {

/// Bytes of the grids made at `resolution`: their leaves', and the rest of their trees'.
struct TreeBytes {
    double leaves = 0.0, rest = 0.0;
    int grids = 0;
};
TreeBytes tree_bytes(VolumeGenSettings settings, int resolution) {
    settings.resolution = resolution;
    TreeBytes b;
    for (const openvdb::GridBase::Ptr& grid : make_grids(settings)) {
        double leaves = 0.0;
        grid->apply<openvdb::TypeList<openvdb::FloatGrid, openvdb::Vec3SGrid>>([&](auto& g) {
            for (auto leaf = g.tree().cbeginLeaf(); leaf; ++leaf)
                leaves += double(leaf->memUsage());
        });
        b.leaves += leaves;
        b.rest += double(grid->memUsage()) - leaves;
        ++b.grids;
    }
    return b;
}

}  // namespace

uint64_t volume_memory_estimate(const VolumeGenSettings& settings) {
    if (settings.resolution <= 128) return 0;
    // Leaves fill the volume (x^3) and line its surface (x^2): L(x) = v x^3 + s x^2 through the
    // grids made at two coarser resolutions (at most 256, a few seconds), x in the coarser one's
    // units; a negative part is dropped and the other fitted to the finer resolution alone.
    const int fine = std::min(settings.resolution / 2, 256), coarse = fine / 2;
    const TreeBytes b1 = tree_bytes(settings, coarse), b2 = tree_bytes(settings, fine);
    double v = (b2.leaves - 4.0 * b1.leaves) / 4.0, s = b1.leaves - v;
    if (v < 0.0) v = 0.0, s = b2.leaves / 4.0;
    if (s < 0.0) s = 0.0, v = b2.leaves / 8.0;
    const double x = double(settings.resolution) / coarse;
    // Internal nodes: at most one of 128^3 voxels per grid over the box (vec3s: twice a float's).
    using Node128 = openvdb::FloatTree::RootNodeType::ChildNodeType::ChildNodeType;
    const double nodes = b2.rest + b2.grids * 2.0 * sizeof(Node128) *
                                       std::pow(double(settings.resolution) / 128.0 + 2.0, 3.0);
    // A quarter more for the slabs' own nodes and the writer's buffers.
    return uint64_t(1.25 * (v * x * x * x + s * x * x + nodes));
}

void write_float_grids(const std::string& path, const std::vector<FloatGridSpec>& specs) {
    init_openvdb();
    openvdb::GridPtrVec grids;
    for (const FloatGridSpec& spec : specs) {
        openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(0.0f);
        auto acc = grid->getAccessor();
        for (int k = 0; k < spec.nz; ++k)
            for (int j = 0; j < spec.ny; ++j)
                for (int i = 0; i < spec.nx; ++i) {
                    const float v = spec.value(i, j, k);
                    if (v != 0.0f) acc.setValue(openvdb::Coord(i, j, k), v);
                }
        grid->setName(spec.name);
        grid->setGridClass(openvdb::GRID_FOG_VOLUME);
        grid->setTransform(make_transform(spec.voxel_size, spec.translation));
        grids.push_back(grid);
    }
    write_grids_atomic(grids, path);
}

void write_float_grid(const std::string& path, const std::string& name, int nx, int ny, int nz,
                      const std::function<float(int, int, int)>& value, Vec3 voxel_size,
                      Vec3 translation) {
    write_float_grids(path, {{name, nx, ny, nz, value, voxel_size, translation}});
}

}  // namespace fogmap
