// DensityGrid: trilinear sampling equals hand interpolation (voxel centres at integers, 0 outside),
// majorants bound every sample and are tight, tiles count as voxels, bad voxels are zeroed and
// counted, the index→world matrix is GLM column-vector, and the four real VDB files of
// /work/shared/volumes load with the figures their SOURCES.md states. The sampler (bricks of 16-bit
// steps built at load) equals openvdb::tools::BoxSampler on the tree OpenVDB reads from the same
// file within half a step, and never leaves its cell's majorants, whatever the values' range.

#include "media/density_grid.h"

#include "core/error.h"
#include "core/rng.h"
#include "media/vdb_probe.h"
#include "media/volume_gen.h"
#include "test_support.h"

#include <gtest/gtest.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/Interpolation.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace fogmap {
namespace {

namespace fs = std::filesystem;

const std::string kShared = FOGMAP_SHARED_VOLUMES;

/// A fresh directory per test, removed afterwards.
class DensityGridTest : public ::testing::Test {
protected:
    void SetUp() override { openvdb::initialize(); }
    std::string path(const std::string& name) const { return (tmp_.path() / name).string(); }

    test::TempDir tmp_{"fogmap_dg"};
};

/// Writes an OpenVDB grid built by the test itself (tiles, other value types, backgrounds).
void write_vdb(const std::string& path, const openvdb::GridBase::Ptr& grid) {
    openvdb::io::File file(path);
    file.write({grid});
    file.close();
}

std::string shared_file(const std::string& name) {
    const std::string p = kShared + "/" + name;
    return fs::exists(p) ? p : std::string();
}

/// Trilinear interpolation of value(i, j, k) (0 outside [0,n)) at p: the independent reference
/// (docs/design.md, Density between voxels: voxel (i,j,k) sits at index point (i,j,k)).
float hand_trilinear(const std::function<float(int, int, int)>& value, const Vec3& p) {
    const int x0 = static_cast<int>(std::floor(p.x)), y0 = static_cast<int>(std::floor(p.y));
    const int z0 = static_cast<int>(std::floor(p.z));
    const double fx = p.x - x0, fy = p.y - y0, fz = p.z - z0;
    double sum = 0.0;
    for (int c = 0; c < 8; ++c) {
        const int dx = c & 1, dy = (c >> 1) & 1, dz = c >> 2;
        const double w = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy) * (dz ? fz : 1 - fz);
        sum += w * value(x0 + dx, y0 + dy, z0 + dz);
    }
    return static_cast<float>(sum);
}

/// The most a sample can differ from the file's trilinear density by the bricks' 16-bit steps:
/// half a step of a footprint spanning 0 .. the grid's largest value.
float half_step(const DensityGrid& grid) {
    return 0.5f * grid.max_density() / float(detail::kBrickSteps);
}

/// Majorant of the cell holding index point p (0 outside the majorant grid).
float majorant_at(const MajorantGrid& m, const Vec3& p) {
    int c[3];
    for (int a = 0; a < 3; ++a) {
        c[a] = static_cast<int>(std::floor((p[a] - m.origin[a]) / m.cell));
        if (c[a] < 0 || c[a] >= m.dims[a]) return 0.0f;
    }
    return m.at(c[0], c[1], c[2]);
}

TEST_F(DensityGridTest, TrilinearMatchesHandInterpolation) {
    const int nx = 5, ny = 6, nz = 7;
    auto value = [&](int i, int j, int k) -> float {
        if (i < 0 || j < 0 || k < 0 || i >= nx || j >= ny || k >= nz) return 0.0f;
        return 0.1f + 0.05f * i + 0.11f * j * j + 0.03f * k + 0.02f * ((i * 7 + j * 3 + k) % 5);
    };
    write_float_grid(path("g.vdb"), "density", nx, ny, nz, value);
    auto grid = DensityGrid::load(path("g.vdb"), "density", "/media/0");
    DensityGrid::Sampler sampler(*grid);
    Rng rng(42, 0);
    for (int n = 0; n < 2000; ++n) {
        const Vec3 p(-1.5f + rng.uniform() * (nx + 1.0f), -1.5f + rng.uniform() * (ny + 1.0f),
                     -1.5f + rng.uniform() * (nz + 1.0f));
        // Half a brick step (of values <= 4.5), and float weights against double here.
        EXPECT_NEAR(sampler.density(p), hand_trilinear(value, p), half_step(*grid) + 2e-5f)
            << p.x << " " << p.y;
    }
    EXPECT_EQ(grid->active_voxels(), static_cast<uint64_t>(nx * ny * nz));
    EXPECT_EQ(grid->name(), "density");
}

TEST_F(DensityGridTest, HalfVoxelRampAtBoxEdges) {
    const int n = 4;
    write_float_grid(path("box.vdb"), "density", n, n, n, [](int, int, int) { return 1.0f; });
    auto grid = DensityGrid::load(path("box.vdb"), "density", "");
    DensityGrid::Sampler s(*grid);
    const float mid = 1.5f;
    for (int a = 0; a < 3; ++a) {
        Vec3 p(mid);
        p[a] = -0.5f;
        EXPECT_FLOAT_EQ(s.density(p), 0.5f);
        p[a] = n - 0.5f;
        EXPECT_FLOAT_EQ(s.density(p), 0.5f);
        p[a] = -1.0f;
        EXPECT_FLOAT_EQ(s.density(p), 0.0f);
        p[a] = static_cast<float>(n);
        EXPECT_FLOAT_EQ(s.density(p), 0.0f);
        p[a] = 0.0f;
        EXPECT_FLOAT_EQ(s.density(p), 1.0f);
        p[a] = n - 1.0f;
        EXPECT_FLOAT_EQ(s.density(p), 1.0f);
    }
    EXPECT_FLOAT_EQ(s.density(Vec3(0.3f, 2.9f, 1.7f)), 1.0f);
    EXPECT_EQ(grid->index_bounds().lo, Vec3(-1.0f));
    EXPECT_EQ(grid->index_bounds().hi, Vec3(static_cast<float>(n)));
    EXPECT_FLOAT_EQ(grid->max_density(), 1.0f);
}

/// Checks maj >= density at `per_cell` random points of every majorant cell, plus each cell's
/// lower corner and a point just below its upper corner, and 0 density outside index_bounds.
void expect_majorants_bound(const DensityGrid& grid, int per_cell, uint64_t seed) {
    const MajorantGrid& m = grid.majorants();
    DensityGrid::Sampler s(grid);
    Rng rng(seed, 1);
    ASSERT_EQ(m.max_density.size(), static_cast<size_t>(m.dims[0]) * m.dims[1] * m.dims[2]);
    for (int k = 0; k < m.dims[2]; ++k)
        for (int j = 0; j < m.dims[1]; ++j)
            for (int i = 0; i < m.dims[0]; ++i) {
                const Vec3 lo(m.origin[0] + i * m.cell, m.origin[1] + j * m.cell,
                              m.origin[2] + k * m.cell);
                const float maj = m.at(i, j, k);
                for (int n = 0; n < per_cell + 2; ++n) {
                    Vec3 p = lo;
                    if (n == 1) p += Vec3(m.cell * (1.0f - 1e-5f));
                    if (n >= 2) {
                        p += float(m.cell) * Vec3(rng.uniform(), rng.uniform(), rng.uniform());
                    }
                    ASSERT_LE(s.density(p), maj + 1e-6f) << "cell " << i << " " << j << " " << k;
                }
            }
    for (int n = 0; n < 2000; ++n) {  // density is 0 outside index_bounds
        const Box3& b = grid.index_bounds();
        const Vec3 p =
            b.lo - Vec3(3.0f) +
            (b.extent() + Vec3(6.0f)) * Vec3(rng.uniform(), rng.uniform(), rng.uniform());
        if (!b.contains(p)) {
            ASSERT_EQ(s.density(p), 0.0f);
        }
        if (s.density(p) > 0.0f) {
            ASSERT_GT(majorant_at(m, p), 0.0f);
        }
    }
}

TEST_F(DensityGridTest, MajorantBoundsEverySample) {
    // Random sparse values with voxels at negative coordinates and across cell borders.
    openvdb::FloatGrid::Ptr g = openvdb::FloatGrid::create(0.0f);
    auto acc = g->getAccessor();
    Rng rng(7, 3);
    for (int n = 0; n < 3000; ++n) {
        const openvdb::Coord c(static_cast<int>(rng.uniform() * 40) - 17,
                               static_cast<int>(rng.uniform() * 30) - 9,
                               static_cast<int>(rng.uniform() * 25) - 3);
        acc.setValue(c, rng.uniform() * rng.uniform() * 3.0f);
    }
    g->setName("density");
    write_vdb(path("rand.vdb"), g);
    auto grid = DensityGrid::load(path("rand.vdb"), "density", "");
    const MajorantGrid& m = grid->majorants();
    for (int a = 0; a < 3; ++a) EXPECT_EQ(m.origin[a] % DensityGrid::kMajorantCell, 0);
    EXPECT_EQ(m.cell, DensityGrid::kMajorantCell);
    expect_majorants_bound(*grid, 300, 11);
}

TEST_F(DensityGridTest, MajorantIsTightForSpikeVoxels) {
    // Base 0.1 everywhere in [0,24)^3; a spike 0.7 inside cell (1,1,1) and 0.9 on the border
    // voxel x = 16, which cell 1 along x also interpolates (its footprint is voxels 8..16).
    write_float_grid(path("spike.vdb"), "density", 24, 24, 24, [](int i, int j, int k) {
        if (i == 12 && j == 13 && k == 11) return 0.7f;
        if (i == 16 && j == 4 && k == 4) return 0.9f;
        return 0.1f;
    });
    auto grid = DensityGrid::load(path("spike.vdb"), "density", "");
    const MajorantGrid& m = grid->majorants();
    // index_bounds = [-1, 24]: cells from floor(-1/8) = -1 to floor(24/8) = 3.
    ASSERT_EQ(m.origin, (std::array<int, 3>{-8, -8, -8}));
    ASSERT_EQ(m.dims, (std::array<int, 3>{5, 5, 5}));
    auto maj = [&](int cx, int cy, int cz) { return m.at(cx + 1, cy + 1, cz + 1); };
    EXPECT_FLOAT_EQ(maj(1, 1, 1), 0.7f);
    EXPECT_FLOAT_EQ(maj(0, 0, 0), 0.1f);
    EXPECT_FLOAT_EQ(maj(2, 0, 0), 0.9f);
    EXPECT_FLOAT_EQ(maj(1, 0, 0), 0.9f);
    EXPECT_FLOAT_EQ(maj(0, 1, 1), 0.1f);
    EXPECT_FLOAT_EQ(maj(-1, -1, -1), 0.1f);  // reads voxel (0,0,0)
    EXPECT_FLOAT_EQ(maj(3, 3, 3), 0.0f);     // voxels 24..32: all background
    DensityGrid::Sampler s(*grid);
    EXPECT_FLOAT_EQ(s.density(Vec3(12.0f, 13.0f, 11.0f)), 0.7f);
    expect_majorants_bound(*grid, 200, 12);
}

TEST_F(DensityGridTest, StepsStayWithinTheCellsMajorantsAtAnyRange) {
    // Blocks of extreme ranges: 1 and 3e38 (a step near the float limit), a 16^3 block of values
    // 1e-7 apart (a fine step in its first cell, whose footprint lies inside it), and 1e-30 and
    // 1.000001e-30 (a step below the least normal float: read as their least). Every sample lies
    // between its cell's least and greatest values, finite, exactly (no slack); at a voxel centre
    // within half a step of the file's value, the step being the cell's footprint's range / 65535.
    openvdb::FloatGrid::Ptr g = openvdb::FloatGrid::create(0.0f);
    auto acc = g->getAccessor();
    for (int v = 0; v < 512; ++v) {
        const openvdb::Coord c(v >> 6, (v >> 3) & 7, v & 7);
        acc.setValue(c, v % 3 == 0 ? 3.0e38f : 1.0f);
    }
    const auto fine = [](int x, int y, int z) {
        return 1.0f + 1e-7f * float((x * 7 + y * 3 + z) % 512);
    };
    for (int x = 0; x < 16; ++x)
        for (int y = 0; y < 16; ++y)
            for (int z = 0; z < 16; ++z) {
                acc.setValue(openvdb::Coord(16 + x, y, z), fine(x, y, z));
                acc.setValue(openvdb::Coord(48 + x, y, z),
                             (x + y + z) % 2 ? 1e-30f : 1.000001e-30f);
            }
    g->setName("density");
    write_vdb(path("range.vdb"), g);
    auto grid = DensityGrid::load(path("range.vdb"), "density", "");
    const MajorantGrid& m = grid->majorants();
    DensityGrid::Sampler s(*grid);
    const auto cell_of = [&](const Vec3& p) {
        int c[3];
        for (int a = 0; a < 3; ++a) c[a] = int(std::floor((p[a] - m.origin[a]) / m.cell));
        return m.index(c[0], c[1], c[2]);
    };
    Rng rng(17, 2);
    for (int n = 0; n < 30000; ++n) {
        const Vec3 p = Vec3(-1.0f) + Vec3(66.0f, 17.0f, 17.0f) *
                                         Vec3(rng.uniform(), rng.uniform(), rng.uniform());
        const size_t cell = cell_of(p);
        const float d = s.density(p);
        ASSERT_TRUE(std::isfinite(d));
        ASSERT_LE(d, m.max_density[cell]) << p.x << " " << p.y << " " << p.z;
        ASSERT_GE(d, m.min_density[cell]) << p.x << " " << p.y << " " << p.z;
    }
    const auto half_step_at = [&](const Vec3& p) {
        const size_t c = cell_of(p);
        return 0.5f * (m.max_density[c] - m.min_density[c]) / 65535.0f;
    };
    for (const Vec3& p : {Vec3(1, 2, 3), Vec3(0, 0, 0), Vec3(7, 7, 7)}) {
        const int v = (int(p.x) << 6) | (int(p.y) << 3) | int(p.z);
        EXPECT_NEAR(s.density(p), v % 3 == 0 ? 3.0e38f : 1.0f, 1.01f * half_step_at(p));
    }
    EXPECT_GT(half_step_at(Vec3(1, 2, 3)), 1e33f);
    for (int x = 0; x < 8; ++x)
        for (int y = 0; y < 8; y += 3)
            for (int z = 0; z < 8; z += 2) {
                const Vec3 p(16 + x, y, z);
                // Half a step (< 4e-10) and the float rounding of values near 1 (6e-8).
                EXPECT_NEAR(s.density(p), fine(x, y, z), half_step_at(p) + 1.2e-7f);
            }
    EXPECT_LT(half_step_at(Vec3(17, 1, 1)), 4e-10f);
    EXPECT_EQ(s.density(Vec3(50, 2, 2)), 1e-30f);
}

TEST_F(DensityGridTest, TilesAreSampledAndBounded) {
    // Two active 128^3 tiles (level 2: tiles of the upper internal nodes), one at negative x,
    // plus one leaf voxel.
    openvdb::FloatGrid::Ptr g = openvdb::FloatGrid::create(0.0f);
    g->tree().addTile(2, openvdb::Coord(0, 0, 0), 0.5f, true);
    g->tree().addTile(2, openvdb::Coord(-128, 0, 0), 0.25f, true);
    g->tree().setValue(openvdb::Coord(3, 130, 5), 2.0f);
    g->setName("density");
    write_vdb(path("tiles.vdb"), g);
    auto grid = DensityGrid::load(path("tiles.vdb"), "density", "");
    EXPECT_EQ(grid->active_voxels(), 2ull * 128 * 128 * 128 + 1);
    DensityGrid::Sampler s(*grid);
    Rng rng(3, 4);
    for (int n = 0; n < 500; ++n) {
        const Vec3 u(rng.uniform(), rng.uniform(), rng.uniform());
        // A cell at a tile's border keeps its footprint's values as steps: half a step off.
        EXPECT_NEAR(s.density(Vec3(0.0f, 0.0f, 0.0f) + u * 127.0f * Vec3(1, 0.98f, 1)), 0.5f,
                    half_step(*grid));
        EXPECT_NEAR(s.density(Vec3(-128.0f, 0.0f, 0.0f) + u * 127.0f), 0.25f, half_step(*grid));
    }
    EXPECT_FLOAT_EQ(s.density(Vec3(-0.5f, 60.0f, 60.0f)), 0.375f);
    EXPECT_FLOAT_EQ(s.density(Vec3(60.0f, 60.0f, 128.0f)), 0.0f);
    EXPECT_FLOAT_EQ(s.density(Vec3(60.0f, 60.0f, 127.5f)), 0.25f);
    EXPECT_EQ(grid->index_bounds().lo, Vec3(-129.0f, -1.0f, -1.0f));
    EXPECT_EQ(grid->index_bounds().hi, Vec3(128.0f, 131.0f, 128.0f));
    EXPECT_FLOAT_EQ(majorant_at(grid->majorants(), Vec3(-0.5f, 60.0f, 60.0f)), 0.5f);
    EXPECT_FLOAT_EQ(majorant_at(grid->majorants(), Vec3(-60.0f, 60.0f, 60.0f)), 0.25f);
    EXPECT_FLOAT_EQ(majorant_at(grid->majorants(), Vec3(3.0f, 129.0f, 5.0f)), 2.0f);
    expect_majorants_bound(*grid, 4, 13);
}

TEST_F(DensityGridTest, TheSamplerKeepsABrickPerFootprintOfTwoValuesAndNoMore) {
    // A 4^3 block of leaf-sized tiles of 0.5, one inner tile made a leaf of 0.5 (uniform, yet a
    // leaf), and a 20^3 block of random values apart: a cell needs a brick exactly when its 9^3
    // footprint (its voxels and the first layer of its +x, +y, +z neighbours) holds two values,
    // counted here by reading the footprints from the tree; the sampler keeps that many bricks
    // and no spare capacity.
    openvdb::FloatGrid::Ptr g = openvdb::FloatGrid::create(0.0f);
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
            for (int k = 0; k < 4; ++k)
                g->tree().addTile(1, openvdb::Coord(8 * i, 8 * j, 8 * k), 0.5f, true);
    g->tree().touchLeaf(openvdb::Coord(8, 8, 8));  // the tile's values, as a leaf
    ASSERT_NE(g->tree().probeConstLeaf(openvdb::Coord(8, 8, 8)), nullptr);
    Rng rng(5, 6);
    for (int n = 0; n < 20 * 20 * 20; ++n)
        g->tree().setValue(openvdb::Coord(60 + n / 400, 60 + (n / 20) % 20, 60 + n % 20),
                           0.1f + rng.uniform());
    g->setName("density");
    write_vdb(path("mixed.vdb"), g);
    auto grid = DensityGrid::load(path("mixed.vdb"), "density", "");
    const MajorantGrid& m = grid->majorants();
    openvdb::FloatGrid::ConstAccessor acc = g->getConstAccessor();
    size_t cells = 0, bricks = 0;
    for (int i = 0; i < m.dims[0]; ++i)
        for (int j = 0; j < m.dims[1]; ++j)
            for (int k = 0; k < m.dims[2]; ++k, ++cells) {
                const openvdb::Coord o(m.origin[0] + m.cell * i, m.origin[1] + m.cell * j,
                                       m.origin[2] + m.cell * k);
                const float first = acc.getValue(o);
                bool two = false;
                for (int n = 0; n < 9 * 9 * 9 && !two; ++n)
                    two = acc.getValue(o.offsetBy(n / 81, (n / 9) % 9, n % 9)) != first;
                bricks += two;
            }
    EXPECT_GT(bricks, 0u);
    EXPECT_LT(bricks, cells / 2);
    EXPECT_EQ(grid->sampler_bytes(),
              cells * sizeof(detail::BrickCell) + bricks * 729 * sizeof(uint16_t));
}

TEST_F(DensityGridTest, BadVoxelsAreCountedAndZeroed) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    const float denormal = std::numeric_limits<float>::denorm_min() * 1000.0f;
    ASSERT_EQ(std::fpclassify(denormal), FP_SUBNORMAL);
    write_float_grid(path("bad.vdb"), "density", 4, 4, 4, [&](int i, int j, int k) {
        if (j == 0 && k == 0) {
            const float row[4] = {nan, inf, -inf, -0.5f};
            return row[i];
        }
        if (i == 0 && j == 1 && k == 0) return denormal;
        return 0.5f;
    });
    auto grid = DensityGrid::load(path("bad.vdb"), "density", "");
    const SanitizeStats& st = grid->sanitize_stats();
    EXPECT_EQ(st.nan, 1u);
    EXPECT_EQ(st.inf, 2u);
    EXPECT_EQ(st.negative, 1u);
    EXPECT_EQ(st.denormal, 1u);
    EXPECT_EQ(st.total(), 5u);
    DensityGrid::Sampler s(*grid);
    for (int i = 0; i < 4; ++i) EXPECT_EQ(s.density(Vec3(i, 0, 0)), 0.0f);
    EXPECT_EQ(s.density(Vec3(0, 1, 0)), 0.0f);
    EXPECT_FLOAT_EQ(s.density(Vec3(0.5f, 0.0f, 0.0f)), 0.0f);
    EXPECT_FLOAT_EQ(s.density(Vec3(0.0f, 2.0f, 0.0f)), 0.5f);
    EXPECT_FLOAT_EQ(s.density(Vec3(0.0f, 1.5f, 0.0f)), 0.25f);
    EXPECT_FLOAT_EQ(grid->max_density(), 0.5f);
}

TEST_F(DensityGridTest, NonZeroBackgroundBecomesZero) {
    openvdb::FloatGrid::Ptr g = openvdb::FloatGrid::create(2.0f);
    g->tree().setValue(openvdb::Coord(1, 1, 1), 0.5f);
    g->setName("density");
    write_vdb(path("bg.vdb"), g);
    auto grid = DensityGrid::load(path("bg.vdb"), "density", "");
    DensityGrid::Sampler s(*grid);
    EXPECT_FLOAT_EQ(s.density(Vec3(1.0f)), 0.5f);
    EXPECT_FLOAT_EQ(s.density(Vec3(1.5f, 1.0f, 1.0f)), 0.25f);
    EXPECT_FLOAT_EQ(s.density(Vec3(100.0f, -50.0f, 7.0f)), 0.0f);
    EXPECT_FLOAT_EQ(grid->max_density(), 0.5f);
}

TEST_F(DensityGridTest, EmptyGridIsEmpty) {
    write_float_grid(path("zeros.vdb"), "density", 3, 3, 3, [](int, int, int) { return 0.0f; });
    auto grid = DensityGrid::load(path("zeros.vdb"), "density", "");
    EXPECT_TRUE(grid->empty());
    EXPECT_EQ(grid->active_voxels(), 0u);
    EXPECT_TRUE(grid->majorants().max_density.empty());
    DensityGrid::Sampler s(*grid);
    EXPECT_EQ(s.density(Vec3(1.0f)), 0.0f);

    // Active voxels that are all 0 render as vacuum too.
    openvdb::FloatGrid::Ptr g = openvdb::FloatGrid::create(0.0f);
    g->tree().setValueOn(openvdb::Coord(2, 2, 2), 0.0f);
    g->setName("density");
    write_vdb(path("active_zero.vdb"), g);
    auto zero = DensityGrid::load(path("active_zero.vdb"), "density", "");
    EXPECT_EQ(zero->active_voxels(), 1u);
    EXPECT_TRUE(zero->empty());
}

TEST_F(DensityGridTest, OneVoxelGrid) {
    write_float_grid(path("one.vdb"), "density", 1, 1, 1, [](int, int, int) { return 0.8f; });
    auto grid = DensityGrid::load(path("one.vdb"), "density", "");
    ASSERT_FALSE(grid->empty());
    DensityGrid::Sampler s(*grid);
    EXPECT_FLOAT_EQ(s.density(Vec3(0.0f)), 0.8f);
    EXPECT_FLOAT_EQ(s.density(Vec3(0.5f, 0.0f, 0.0f)), 0.4f);
    EXPECT_FLOAT_EQ(s.density(Vec3(-0.5f, 0.5f, 0.5f)), 0.1f);
    EXPECT_EQ(grid->index_bounds().lo, Vec3(-1.0f));
    EXPECT_EQ(grid->index_bounds().hi, Vec3(1.0f));
    const MajorantGrid& m = grid->majorants();
    EXPECT_EQ(m.origin, (std::array<int, 3>{-8, -8, -8}));
    EXPECT_EQ(m.dims, (std::array<int, 3>{2, 2, 2}));
    for (float v : m.max_density) EXPECT_FLOAT_EQ(v, 0.8f);  // every cell reads voxel 0
}

TEST_F(DensityGridTest, IndexToWorldIsColumnVectorAffine) {
    const Vec3 voxel(0.5f, 2.0f, 0.25f), translation(1.0f, -2.0f, 3.0f);
    write_float_grid(
        path("xf.vdb"), "density", 2, 2, 2, [](int, int, int) { return 1.0f; }, voxel, translation);
    auto grid = DensityGrid::load(path("xf.vdb"), "density", "");
    const DMat4& m = grid->index_to_world();
    for (const Vec3 p : {Vec3(0.0f), Vec3(1.0f, 0.0f, 0.0f), Vec3(3.0f, -5.0f, 7.5f)}) {
        const glm::dvec4 w = m * glm::dvec4(DVec3(p), 1.0);
        EXPECT_NEAR(w.x, 1.0 + 0.5 * p.x, 1e-12);
        EXPECT_NEAR(w.y, -2.0 + 2.0 * p.y, 1e-12);
        EXPECT_NEAR(w.z, 3.0 + 0.25 * p.z, 1e-12);
        EXPECT_NEAR(w.w, 1.0, 1e-12);
    }
}

TEST_F(DensityGridTest, MissingFileIsInputError) {
    try {
        DensityGrid::load(path("nope.vdb"), "density", "/media/0/file");
        FAIL() << "no exception";
    } catch (const InputError& e) {
        EXPECT_EQ(e.file, path("nope.vdb"));
        EXPECT_EQ(e.field, "/media/0/file");
        EXPECT_NE(e.reason.find("cannot open file"), std::string::npos) << e.reason;
    }
    std::FILE* f = std::fopen(path("junk.vdb").c_str(), "wb");
    ASSERT_NE(f, nullptr);
    std::fputs("this is not a vdb file", f);
    std::fclose(f);
    EXPECT_THROW(DensityGrid::load(path("junk.vdb"), "density", ""), InputError);
}

TEST_F(DensityGridTest, Vec3GridErrorNamesItsType) {
    openvdb::Vec3SGrid::Ptr g = openvdb::Vec3SGrid::create();
    g->tree().setValue(openvdb::Coord(0), openvdb::Vec3s(1.0f, 2.0f, 3.0f));
    g->setName("vel");
    write_vdb(path("vel.vdb"), g);
    try {
        DensityGrid::load(path("vel.vdb"), "vel", "/media/0/grid");
        FAIL() << "no exception";
    } catch (const InputError& e) {
        EXPECT_EQ(e.field, "/media/0/grid");
        EXPECT_NE(e.reason.find("'vel' has type vec3s"), std::string::npos) << e.reason;
        EXPECT_NE(e.reason.find("expected a float grid"), std::string::npos) << e.reason;
    }
}

TEST_F(DensityGridTest, MissingGridErrorListsGridsPresent) {
    const std::string file = shared_file("usd_densityAndHeat.vdb");
    if (file.empty()) return test::missing_shared_volume(kShared);
    try {
        DensityGrid::load(file, "dens", "/media/0/grid");
        FAIL() << "no exception";
    } catch (const InputError& e) {
        EXPECT_EQ(e.file, file);
        EXPECT_NE(e.reason.find("no grid 'dens'"), std::string::npos) << e.reason;
        EXPECT_NE(e.reason.find("density, heat"), std::string::npos) << e.reason;
    }
    auto heat = DensityGrid::load(file, "heat", "");
    EXPECT_EQ(heat->active_voxels(), 5224u);  // SOURCES.md
}

TEST_F(DensityGridTest, DisneyCloudTilesSampleAsHalf) {
    const std::string file = shared_file("wdas_cloud_sixteenth.vdb");
    if (file.empty()) return test::missing_shared_volume(kShared);
    auto grid = DensityGrid::load(file, "density", "");
    EXPECT_EQ(grid->active_voxels(), 415642u);  // SOURCES.md, tiles included
    EXPECT_EQ(grid->sanitize_stats().total(), 0u);
    EXPECT_FLOAT_EQ(grid->max_density(), 1.0f);

    // Tile positions come from the file; their value (0.5) and number (130) from SOURCES.md.
    openvdb::io::File f(file);
    f.open();
    auto raw = openvdb::gridPtrCast<openvdb::FloatGrid>(f.readGrid("density"));
    f.close();
    DensityGrid::Sampler s(*grid);
    int tiles = 0;
    for (auto it = raw->tree().cbeginValueOn(); it; ++it) {
        if (!it.isTileValue()) continue;
        ++tiles;
        openvdb::CoordBBox box;
        it.getBoundingBox(box);
        const Vec3 lo(box.min().x(), box.min().y(), box.min().z());
        const Vec3 hi(box.max().x(), box.max().y(), box.max().z());
        for (const Vec3& p : {0.5f * (lo + hi), lo, hi, lo + Vec3(0.3f, 6.2f, 4.9f)}) {
            EXPECT_FLOAT_EQ(s.density(p), 0.5f);
            EXPECT_GE(majorant_at(grid->majorants(), p), 0.5f);
        }
    }
    EXPECT_EQ(tiles, 130);
}

/// Reads grid "density" of `path` with OpenVDB alone (the reference side of the comparisons).
openvdb::FloatGrid::Ptr read_raw(const std::string& path) {
    openvdb::io::File f(path);
    f.open();
    auto grid = openvdb::gridPtrCast<openvdb::FloatGrid>(f.readGrid("density"));
    f.close();
    return grid;
}

/// Largest |DensityGrid::Sampler - BoxSampler| over `points` (BoxSampler on `raw`).
float max_diff_vs_box_sampler(const DensityGrid& grid, const openvdb::FloatGrid& raw,
                              const std::vector<Vec3>& points) {
    DensityGrid::Sampler s(grid);
    const openvdb::FloatGrid::ConstAccessor acc = raw.getConstAccessor();
    float max_diff = 0.0f;
    for (const Vec3& p : points) {
        const float ref = openvdb::tools::BoxSampler::sample(acc, openvdb::Vec3R(p.x, p.y, p.z));
        max_diff = std::max(max_diff, std::abs(s.density(p) - ref));
    }
    return max_diff;
}

/// `n` points: 3/5 uniform in `box` grown by 3 voxels, 1/5 there with 1-3 coordinates moved
/// onto or next to a multiple of 8 (leaf, cell and brick borders), 1/10 up to 1000 voxels away,
/// 1/10 with coordinates in (-1, 1) (the cells around index 0).
std::vector<Vec3> comparison_points(const Box3& box, size_t n, Rng& rng) {
    const float offsets[] = {-1.0f, -0.5f, -1e-3f, 0.0f, 1e-3f, 0.5f, 1.0f};
    const Vec3 lo = box.lo - Vec3(3.0f), ext = box.extent() + Vec3(6.0f);
    std::vector<Vec3> points;
    for (size_t i = 0; i < n; ++i) {
        Vec3 p = lo + ext * Vec3(rng.uniform(), rng.uniform(), rng.uniform());
        switch (i % 10) {
            case 6:
            case 7:
                for (int a = 0; a < 3; ++a)
                    if (a == 0 || rng.uniform() < 0.5f)
                        p[a] = 8.0f * std::floor(p[a] / 8.0f) + offsets[rng.next_u32() % 7];
                break;
            case 8:
                p = box.center() + 2000.0f * Vec3(rng.uniform(), rng.uniform(), rng.uniform()) -
                    Vec3(1000.0f);
                break;
            case 9:
                p = Vec3(rng.uniform(), rng.uniform(), rng.uniform()) * 2.0f - Vec3(1.0f);
                break;
        }
        points.push_back(p);
    }
    return points;
}

TEST_F(DensityGridTest, SamplerMatchesBoxSampler) {
    // Random leaves (some voxels inactive: holes at 0, others keeping a value, which BoxSampler
    // reads too) at negative and positive coordinates, and an active leaf-sized tile among them.
    openvdb::FloatGrid::Ptr g = openvdb::FloatGrid::create(0.0f);
    auto acc = g->getAccessor();
    Rng rng(2024, 5);
    for (int lx = -3; lx <= 2; ++lx)
        for (int ly = -2; ly <= 2; ++ly)
            for (int lz = -1; lz <= 3; ++lz) {
                if (rng.uniform() < 0.4f) continue;
                for (int v = 0; v < 512; ++v) {
                    const openvdb::Coord c(8 * lx + (v >> 6), 8 * ly + ((v >> 3) & 7),
                                           8 * lz + (v & 7));
                    const float u = rng.uniform();
                    if (u < 0.1f) {
                        acc.setValueOff(c, 0.0f);
                    } else if (u < 0.15f) {
                        acc.setValueOff(c, rng.uniform());
                    } else {
                        acc.setValue(c, rng.uniform());
                    }
                }
            }
    g->tree().addTile(1, openvdb::Coord(0, 0, 8), 0.7f, true);  // replaces a leaf if one is there
    ASSERT_EQ(g->tree().activeTileCount(), 1u);
    g->setName("density");
    write_vdb(path("mix.vdb"), g);
    auto grid = DensityGrid::load(path("mix.vdb"), "density", "");
    ASSERT_EQ(grid->sanitize_stats().total(), 0u);
    EXPECT_NEAR(DensityGrid::Sampler(*grid).density(Vec3(4.0f, 3.5f, 11.2f)), 0.7f,
                half_step(*grid));
    // Half a brick step, and trilinear rounding relative to the stencil's values, here <= 1:
    // 1e-6 is ~8 float ulps of 1.
    const std::vector<Vec3> points = comparison_points(grid->index_bounds(), 100000, rng);
    const float diff = max_diff_vs_box_sampler(*grid, *read_raw(path("mix.vdb")), points);
    EXPECT_LE(diff, half_step(*grid) + 1e-6f);
    EXPECT_GT(diff, 0.0f);  // the steps are not the file's floats
}

TEST_F(DensityGridTest, SamplerMatchesBoxSamplerOnSharedVolumes) {
    for (const char* name : {"smoke1.vdb", "wdas_cloud_sixteenth.vdb"}) {
        SCOPED_TRACE(name);
        const std::string file = shared_file(name);
        if (file.empty()) return test::missing_shared_volume(kShared);
        auto grid = DensityGrid::load(file, "density", "");
        ASSERT_EQ(grid->sanitize_stats().total(), 0u);  // so the raw tree is the sampled one
        Rng rng(99, 6);
        const std::vector<Vec3> points = comparison_points(grid->index_bounds(), 100000, rng);
        // As above, relative to the largest voxel value.
        EXPECT_LE(max_diff_vs_box_sampler(*grid, *read_raw(file), points),
                  half_step(*grid) + 1e-6f * grid->max_density());
    }
}

struct SharedFile {
    const char* name;
    std::array<int, 3> index_min, index_max;  // active index bbox
    Vec3 world_lo, world_hi;                  // "about", 3 significant digits
    Vec3 voxel_size;                          // 6 significant digits
    uint64_t active_voxels;
};

TEST_F(DensityGridTest, SharedFilesMatchSources) {
    // Figures copied from /work/shared/volumes/SOURCES.md.
    const SharedFile files[] = {
        {"smoke1.vdb",
         {1, 2, 1},
         {111, 223, 112},
         Vec3(-33.6f, -12.1f, -26.0f),
         Vec3(18.8f, 93.1f, 26.9f),
         Vec3(0.476190f),
         1049275},
        {"wdas_cloud_sixteenth.vdb",
         {-66, -21, -90},
         {59, 64, 63},
         Vec3(-220, -70, -300),
         Vec3(197, 213, 210),
         Vec3(3.33333f),
         415642},
        {"usd_smoke_000003.vdb",
         {1, 1, 3},
         {51, 49, 98},
         Vec3(-3.32f, -3.19f, -2.25f),
         Vec3(3.32f, 3.19f, 10.27f),
         Vec3(0.132601f, 0.132903f, 0.131697f),
         90197},
        {"usd_densityAndHeat.vdb",
         {1, 1, 31},
         {23, 23, 72},
         Vec3(-7.74f, -7.74f, -1.92f),
         Vec3(7.74f, 7.74f, 27.45f),
         Vec3(0.703377f, 0.703377f, 0.716455f),
         6124},
    };
    for (const SharedFile& sf : files) {
        SCOPED_TRACE(sf.name);
        const std::string file = shared_file(sf.name);
        if (file.empty()) return test::missing_shared_volume(kShared);
        auto grid = DensityGrid::load(file, "density", "");
        EXPECT_EQ(grid->active_voxels(), sf.active_voxels);
        EXPECT_FALSE(grid->empty());
        for (int a = 0; a < 3; ++a) {
            EXPECT_EQ(grid->index_bounds().lo[a], sf.index_min[a] - 1.0f);
            EXPECT_EQ(grid->index_bounds().hi[a], sf.index_max[a] + 1.0f);
        }
        const DMat4& m = grid->index_to_world();
        for (int a = 0; a < 3; ++a)
            EXPECT_NEAR(glm::length(DVec3(m[a])), sf.voxel_size[a], 1e-5 * sf.voxel_size[a]);
        Box3 world;
        for (int c = 0; c < 8; ++c) {
            const DVec3 p((c & 1) ? sf.index_max[0] : sf.index_min[0],
                          (c & 2) ? sf.index_max[1] : sf.index_min[1],
                          (c & 4) ? sf.index_max[2] : sf.index_min[2]);
            world.extend(Vec3(m * glm::dvec4(p, 1.0)));
        }
        // SOURCES.md rounds to 3 significant digits (error <= 0.05 on coordinates of tens,
        // 0.5 on hundreds), so "1e-3 relative" is relative to the box's largest extent.
        const Vec3 ext = sf.world_hi - sf.world_lo;
        const float tol = 1e-3f * std::max(ext.x, std::max(ext.y, ext.z));
        for (int a = 0; a < 3; ++a) {
            EXPECT_NEAR(world.lo[a], sf.world_lo[a], tol) << "axis " << a;
            EXPECT_NEAR(world.hi[a], sf.world_hi[a], tol) << "axis " << a;
        }
        expect_majorants_bound(*grid, 2, 21);
    }
}

TEST_F(DensityGridTest, InspectListsGridsWithSourcesFigures) {
    const std::string heat_file = shared_file("usd_densityAndHeat.vdb");
    const std::string cloud_file = shared_file("wdas_cloud_sixteenth.vdb");
    const std::string smoke_file = shared_file("smoke1.vdb");
    if (heat_file.empty()) return test::missing_shared_volume(kShared);
    const std::vector<GridInfo> two = inspect_vdb(heat_file);
    ASSERT_EQ(two.size(), 2u);
    EXPECT_EQ(two[0].name, "density");
    EXPECT_EQ(two[1].name, "heat");
    EXPECT_EQ(two[0].value_type, "float");
    EXPECT_EQ(two[0].active_voxels, 6124u);
    EXPECT_EQ(two[1].active_voxels, 5224u);
    EXPECT_EQ(two[1].index_min, (std::array<int, 3>{2, 2, 31}));
    EXPECT_EQ(two[1].index_max, (std::array<int, 3>{23, 22, 62}));
    EXPECT_NEAR(two[0].min_value, 0.00100112, 1e-7);
    EXPECT_NEAR(two[0].max_value, 0.997509, 1e-6);
    EXPECT_NEAR(two[1].max_value, 0.759538, 1e-6);
    EXPECT_NEAR(two[0].voxel_size.z, 0.716455f, 1e-6f);
    EXPECT_NEAR(two[0].translation.x, -8.44f, 0.005f);
    EXPECT_NEAR(two[0].world_bounds.hi.z, 27.45f, 0.005f);
    EXPECT_TRUE(two[0].scalar);

    const std::vector<GridInfo> cloud = inspect_vdb(cloud_file);
    ASSERT_EQ(cloud.size(), 1u);
    EXPECT_EQ(cloud[0].grid_class, "fog volume");
    EXPECT_EQ(cloud[0].active_voxels, 415642u);
    EXPECT_EQ(cloud[0].active_tiles, 130u);
    EXPECT_EQ(cloud[0].min_value, 0.0);
    EXPECT_EQ(cloud[0].max_value, 1.0);

    const std::vector<GridInfo> smoke = inspect_vdb(smoke_file);
    ASSERT_EQ(smoke.size(), 1u);
    EXPECT_NEAR(smoke[0].max_value, 5.71484, 1e-5);
    EXPECT_EQ(smoke[0].index_max, (std::array<int, 3>{111, 223, 112}));

    EXPECT_THROW(inspect_vdb(path("absent.vdb")), InputError);
}

}  // namespace
}  // namespace fogmap

namespace fogmap {
namespace {

/// The probe on (files read by the fogmap binary in a child) while it lives.
struct ProbeOn {
    ProbeOn() { enable_vdb_probe(FOGMAP_BINARY); }
    ~ProbeOn() { enable_vdb_probe(""); }
};

/// Every figure of two grids, and their samples at `n` points of a's box, are equal.
void expect_same_grid(const DensityGrid& a, const DensityGrid& b, int n) {
    EXPECT_EQ(a.name(), b.name());
    EXPECT_EQ(a.index_to_world(), b.index_to_world());
    EXPECT_EQ(a.index_bounds().lo, b.index_bounds().lo);
    EXPECT_EQ(a.index_bounds().hi, b.index_bounds().hi);
    EXPECT_EQ(a.max_density(), b.max_density());
    EXPECT_EQ(a.active_voxels(), b.active_voxels());
    EXPECT_EQ(a.sanitize_stats().total(), b.sanitize_stats().total());
    EXPECT_EQ(a.warnings(), b.warnings());
    EXPECT_EQ(a.sampler_bytes(), b.sampler_bytes());
    EXPECT_EQ(a.majorants().max_density, b.majorants().max_density);
    EXPECT_EQ(a.majorants().min_density, b.majorants().min_density);
    EXPECT_EQ(a.majorants().dims, b.majorants().dims);
    DensityGrid::Sampler sa(a), sb(b);
    Rng rng(5, 5);
    const Box3& box = a.index_bounds();
    int differ = 0;
    for (int i = 0; i < n; ++i) {
        const Vec3 p = box.lo + box.extent() * Vec3(rng.uniform(), rng.uniform(), rng.uniform());
        differ += !(sa.density(p) == sb.density(p));
    }
    EXPECT_EQ(differ, 0);
}

TEST(VdbChild, TheChildSendsWhatThisProcessReads) {
    // The same files read here (the probe off) and by the fogmap binary in a child: density (the
    // shared smoke, a grid with a sanitized voxel and its warning), a colour grid with clamped
    // values, a velocity grid, and `fogmap info`'s figures.
    test::TempDir tmp("fogmap_child");
    const auto at = [&](const std::string& n) { return (tmp.path() / n).string(); };
    openvdb::initialize();
    openvdb::Vec3SGrid::Ptr colour = openvdb::Vec3SGrid::create(openvdb::Vec3s(0.0f));
    openvdb::FloatGrid::Ptr density = openvdb::FloatGrid::create(0.0f);
    for (int n = 0; n < 4000; ++n) {
        const openvdb::Coord c(n % 20, (n / 20) % 20, n / 400);
        colour->tree().setValue(c, openvdb::Vec3s(0.1f * (n % 13), 0.5f, 0.05f * (n % 7)));
        density->tree().setValue(c, n == 7 ? -1.0f : 0.001f * float(n % 97));
    }
    colour->setName("Cd");
    density->setName("density");
    openvdb::io::File(at("cd.vdb")).write({colour, density});
    VolumeGenSettings plume;
    plume.resolution = 40;
    plume.velocity = true;
    generate_volume(plume, at("vel.vdb"));
    const std::string smoke = shared_file("smoke1.vdb");

    const auto here_density = DensityGrid::load(at("cd.vdb"), "density", "");
    uint64_t here_clamped = 0, child_clamped = 0;
    const auto here_colour = DensityGrid::load_channels(at("cd.vdb"), "Cd", "", &here_clamped);
    const auto here_velocity = DensityGrid::load_velocity(at("vel.vdb"), "vel", "");
    const auto here_info = inspect_vdb(at("cd.vdb"));
    const auto here_smoke = smoke.empty() ? nullptr : DensityGrid::load(smoke, "density", "");
    const ProbeOn probe;
    expect_same_grid(*here_density, *DensityGrid::load(at("cd.vdb"), "density", ""), 20000);
    EXPECT_EQ(here_density->warnings().size(), 1u);
    const auto child_colour = DensityGrid::load_channels(at("cd.vdb"), "Cd", "", &child_clamped);
    EXPECT_EQ(here_clamped, child_clamped);
    EXPECT_GT(child_clamped, 0u);
    for (int c = 0; c < 3; ++c) expect_same_grid(*here_colour[c], *child_colour[c], 5000);
    const auto child_velocity = DensityGrid::load_velocity(at("vel.vdb"), "vel", "");
    for (int c = 0; c < 6; ++c) expect_same_grid(*here_velocity[c], *child_velocity[c], 5000);
    const auto child_info = inspect_vdb(at("cd.vdb"));
    ASSERT_EQ(here_info.size(), child_info.size());
    for (size_t g = 0; g < here_info.size(); ++g) {
        EXPECT_EQ(here_info[g].name, child_info[g].name);
        EXPECT_EQ(here_info[g].value_type, child_info[g].value_type);
        EXPECT_EQ(here_info[g].active_voxels, child_info[g].active_voxels);
        EXPECT_EQ(here_info[g].index_max, child_info[g].index_max);
        EXPECT_EQ(here_info[g].world_bounds.hi, child_info[g].world_bounds.hi);
        EXPECT_EQ(here_info[g].max_value, child_info[g].max_value);
        EXPECT_EQ(here_info[g].scalar, child_info[g].scalar);
    }
    if (smoke.empty()) return test::missing_shared_volume(kShared);
    expect_same_grid(*here_smoke, *DensityGrid::load(smoke, "density", ""), 100000);
    // An error in the child is the same one line.
    try {
        DensityGrid::load(at("cd.vdb"), "nope", "/media/3");
        ADD_FAILURE() << "no error";
    } catch (const InputError& e) {
        EXPECT_EQ(e.file, at("cd.vdb"));
        EXPECT_EQ(e.field, "/media/3");
        EXPECT_EQ(e.reason, "no grid 'nope'; grids present: Cd, density");
    }
}

}  // namespace
}  // namespace fogmap
