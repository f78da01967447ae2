#include "media/density_grid.h"

#include "core/error.h"
#include "core/fd_stream.h"
#include "core/memory_budget.h"
#include "core/parallel.h"
#include "core/world_range.h"
#include "media/vdb_probe.h"

#include <malloc.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/ChangeBackground.h>
#include <openvdb/tools/Count.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <mutex>

namespace fogmap {

namespace {

using openvdb::Coord;
using openvdb::CoordBBox;
using openvdb::FloatGrid;
using openvdb::FloatTree;
using Internal1 = FloatTree::RootNodeType::ChildNodeType;  // 4096^3 voxel nodes
using Internal2 = Internal1::ChildNodeType;                // 128^3 voxel nodes
using Leaf = FloatTree::LeafNodeType;                      // 8^3 voxels

static_assert(Leaf::DIM == DensityGrid::kMajorantCell, "majorant cells are one leaf each");

void init_openvdb() {
    static std::once_flag once;
    std::call_once(once, [] { openvdb::initialize(); });
}

/// Calls tile_fn(float& value, CoordBBox) for every tile (active or inactive) at every internal
/// level, one at a time, and stores back the values it writes; then leaf_fn(Leaf&) for every leaf
/// node on the run's threads (at once for different leaves). Tree-level value iterators would
/// also visit each leaf voxel, so the levels are walked here.
template <typename LeafFn, typename TileFn>
void visit_nodes(FloatTree& tree, LeafFn&& leaf_fn, TileFn&& tile_fn) {
    std::vector<Leaf*> leaves;
    auto visit_tile = [&](auto& it, int dim) {
        float v = *it;
        const float before = v;
        tile_fn(v, CoordBBox::createCube(it.getCoord(), dim));
        if (!(v == before)) it.setValue(v);  // NaN != NaN, so a sanitized NaN is stored too
    };
    auto& root = tree.root();
    for (auto it = root.beginValueAll(); it; ++it) visit_tile(it, Internal1::DIM);
    for (auto c1 = root.beginChildOn(); c1; ++c1) {
        for (auto it = c1->beginValueAll(); it; ++it) visit_tile(it, Internal2::DIM);
        for (auto c2 = c1->beginChildOn(); c2; ++c2) {
            for (auto it = c2->beginValueAll(); it; ++it) visit_tile(it, Leaf::DIM);
            for (auto leaf = c2->beginChildOn(); leaf; ++leaf) leaves.push_back(&*leaf);
        }
    }
    tbb::parallel_for(tbb::blocked_range<size_t>(0, leaves.size()),
                      [&](const tbb::blocked_range<size_t>& r) {
                          for (size_t n = r.begin(); n != r.end(); ++n) leaf_fn(*leaves[n]);
                      });
}

/// The load-time rule for bad voxel values (docs/design.md, Density between voxels): NaN, ±Inf,
/// negative and denormal values become 0; `count` voxels carry this value (a tile covers many).
void sanitize_value(float& v, uint64_t count, SanitizeStats* stats) {
    if (std::isnan(v)) {
        stats->nan += count;
        v = 0.0f;
    } else if (std::isinf(v)) {
        stats->inf += count;
        v = 0.0f;
    } else if (v < 0.0f) {
        stats->negative += count;
        v = 0.0f;
    } else if (std::fpclassify(v) == FP_SUBNORMAL) {
        stats->denormal += count;
        v = 0.0f;
    }
}

int floor_div(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

/// Majorants of DensityGrid: a point in cell c (index range [8c, 8c+8)) interpolates voxels
/// 8c .. 8c+8 on each axis, so maj(c) = max over voxels in [8c, 8c+8]^3 (active or not).
/// That box is cell c's own 8^3 voxels plus the low face / edge / corner voxels of its +1
/// neighbours: maj(c) = max over d in {0,1}^3 of part(c + d)[d], where part(c')[d] is the max
/// over the voxels of cell c' whose local coordinate is 0 on every axis where d is 1.
MajorantGrid build_majorants(FloatTree& tree, const Box3& index_bounds) {
    constexpr int kCell = DensityGrid::kMajorantCell;
    MajorantGrid maj;
    maj.cell = kCell;
    if (index_bounds.empty()) return maj;
    std::array<int, 3> c_lo{}, part_dims{};
    for (int a = 0; a < 3; ++a) {
        c_lo[a] = floor_div(static_cast<int>(std::floor(index_bounds.lo[a])), kCell);
        const int c_hi = floor_div(static_cast<int>(std::floor(index_bounds.hi[a])), kCell);
        maj.origin[a] = c_lo[a] * kCell;
        maj.dims[a] = c_hi - c_lo[a] + 1;
        part_dims[a] = maj.dims[a] + 1;  // one more cell per axis supplies voxel 8c+8
    }
    using Parts = std::array<float, 8>;  // index d = dx | dy << 1 | dz << 2
    std::vector<Parts> parts(static_cast<size_t>(part_dims[0]) * part_dims[1] * part_dims[2],
                             Parts{});
    auto part_at = [&](int i, int j, int k) -> Parts& {
        return parts[(static_cast<size_t>(k) * part_dims[1] + j) * part_dims[0] + i];
    };
    auto leaf_fn = [&](Leaf& leaf) {
        const Coord o = leaf.origin();
        const int i = floor_div(o.x(), kCell) - c_lo[0], j = floor_div(o.y(), kCell) - c_lo[1];
        const int k = floor_div(o.z(), kCell) - c_lo[2];
        if (i < 0 || j < 0 || k < 0 || i >= part_dims[0] || j >= part_dims[1] || k >= part_dims[2])
            return;
        const float* data = leaf.buffer().data();
        Parts& p = part_at(i, j, k);
        for (openvdb::Index n = 0; n < Leaf::SIZE; ++n) {
            // Leaf offset n = x << 6 | y << 3 | z (local coordinates).
            const unsigned at_zero = ((n >> 6) == 0 ? 1u : 0u) | (((n >> 3) & 7) == 0 ? 2u : 0u) |
                                     ((n & 7) == 0 ? 4u : 0u);
            for (unsigned d = 0; d < 8; ++d)
                if ((d & ~at_zero) == 0) p[d] = std::max(p[d], data[n]);
        }
    };
    auto tile_fn = [&](float& v, const CoordBBox& box) {
        if (!(v > 0.0f)) return;
        std::array<int, 3> lo{}, hi{};
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::max(0, floor_div(box.min()[a], kCell) - c_lo[a]);
            hi[a] = std::min(part_dims[a] - 1, floor_div(box.max()[a], kCell) - c_lo[a]);
            if (lo[a] > hi[a]) return;
        }
        for (int k = lo[2]; k <= hi[2]; ++k)
            for (int j = lo[1]; j <= hi[1]; ++j)
                for (int i = lo[0]; i <= hi[0]; ++i)
                    for (float& p : part_at(i, j, k)) p = std::max(p, v);
    };
    visit_nodes(tree, leaf_fn, tile_fn);

    maj.max_density.assign(static_cast<size_t>(maj.dims[0]) * maj.dims[1] * maj.dims[2], 0.0f);
    for (int k = 0; k < maj.dims[2]; ++k)
        for (int j = 0; j < maj.dims[1]; ++j)
            for (int i = 0; i < maj.dims[0]; ++i) {
                float m = 0.0f;
                for (int d = 0; d < 8; ++d)
                    m = std::max(m, part_at(i + (d & 1), j + ((d >> 1) & 1), k + (d >> 2))[d]);
                maj.max_density[(static_cast<size_t>(k) * maj.dims[1] + j) * maj.dims[0] + i] = m;
            }
    return maj;
}

/// DensityGrid's sampling layout (detail::Bricks): each majorant cell's 9^3 footprint read from
/// the tree (leaf values, active or not, else the tile or background value: what BoxSampler's
/// getValue sees), kept as one value when uniform, else as a brick. A leaf-sized neighbour is a
/// leaf or a single value, so 8 probes per cell find every source. Also fills maj->min_density:
/// the footprint's least value, below every trilinear sample in the cell (a convex combination
/// of footprint values).
using Brick = std::array<float, detail::kBrickValues>;
using ConstAccessor = openvdb::tree::ValueAccessor<const FloatTree>;

/// The 9^3 footprint of the cell with lowest voxel o: the cell's own node, then its +1
/// neighbours' first layer of voxels.
void fill_brick(ConstAccessor& acc, const Coord& o, Brick* brick) {
    constexpr int kEdge = detail::kBrickEdge, kCell = DensityGrid::kMajorantCell;
    for (int d = 0; d < 8; ++d) {  // the cell itself, then its +1 neighbours
        const int dx = d & 1, dy = (d >> 1) & 1, dz = d >> 2;
        const Coord node = o.offsetBy(kCell * dx, kCell * dy, kCell * dz);
        const Leaf* leaf = acc.probeConstLeaf(node);
        const float* data = leaf ? leaf->buffer().data() : nullptr;
        const float tile = leaf ? 0.0f : acc.getValue(node);
        // A neighbour supplies only its local coordinate 0 along the axes it is +1 on.
        for (int x = 0; x < (dx ? 1 : kCell); ++x)
            for (int y = 0; y < (dy ? 1 : kCell); ++y)
                for (int z = 0; z < (dz ? 1 : kCell); ++z) {
                    const int b =
                        ((kCell * dx + x) * kEdge + kCell * dy + y) * kEdge + kCell * dz + z;
                    (*brick)[b] = data ? data[(x << 6) | (y << 3) | z] : tile;
                }
    }
}

bool uniform(const Brick& brick) {
    return std::all_of(brick.begin(), brick.end(), [&](float v) { return v == brick[0]; });
}

/// The cell with lowest voxel o needs a brick: its own leaf holds two values (found at once,
/// almost always), else its whole footprint is not one value.
bool needs_brick(ConstAccessor& acc, const Coord& o, Brick* scratch) {
    const Leaf* leaf = acc.probeConstLeaf(o);
    const float* v = leaf ? leaf->buffer().data() : nullptr;
    if (v && std::any_of(v + 1, v + Leaf::SIZE, [&](float x) { return x != v[0]; })) return true;
    fill_brick(acc, o, scratch);
    return !uniform(*scratch);
}

/// A cell's lowest voxel.
Coord cell_origin(const MajorantGrid& maj, int i, int j, int k) {
    constexpr int kCell = DensityGrid::kMajorantCell;
    return Coord(maj.origin[0] + kCell * i, maj.origin[1] + kCell * j, maj.origin[2] + kCell * k);
}

/// `brick` as steps from its least value (detail::BrickCell) into `out`. The step is rounded down
/// until the greatest step gives at most the greatest value as the sampler computes it, so that
/// every sample stays within the footprint's least and greatest values (the cell's majorants);
/// a step below the least normal float is 0 (values apart by less than 1e-33 read as the least).
void quantize(const Brick& brick, detail::BrickCell* cell, uint16_t* out) {
    constexpr int kSteps = detail::kBrickSteps;
    const auto [lo, hi] = std::minmax_element(brick.begin(), brick.end());
    float step = (*hi - *lo) / float(kSteps);
    while (step > 0.0f && *lo + step * float(kSteps) > *hi) step = std::nextafter(step, 0.0f);
    if (!(step >= std::numeric_limits<float>::min())) step = 0.0f;
    cell->value = *lo;
    cell->step = step;
    const double per_step = step > 0.0f ? 1.0 / double(step) : 0.0;
    for (int n = 0; n < detail::kBrickValues; ++n) {
        // Nearest step: a conversion that truncates, not std::round (a library call).
        const double q = (double(brick[n]) - double(*lo)) * per_step + 0.5;
        out[n] = static_cast<uint16_t>(std::min(int64_t(q), int64_t(kSteps)));
    }
}

/// Calls row(j, k, acc) for every row of cells (along x) on the run's threads, each task with its
/// own accessor (an accessor caches nodes: one per thread).
template <class Row>
void for_each_row(const FloatTree& tree, const MajorantGrid& maj, Row&& row) {
    const int rows = maj.dims[1] * maj.dims[2];
    tbb::parallel_for(tbb::blocked_range<int>(0, rows), [&](const tbb::blocked_range<int>& r) {
        ConstAccessor acc(tree);
        for (int n = r.begin(); n != r.end(); ++n) row(n % maj.dims[1], n / maj.dims[1], acc);
    });
}

detail::Bricks build_bricks(const FloatTree& tree, MajorantGrid* majorants) {
    const MajorantGrid& maj = *majorants;
    const size_t dim_x = size_t(maj.dims[0]);
    detail::Bricks out;
    out.cells.resize(maj.max_density.size());
    majorants->min_density.assign(maj.max_density.size(), 0.0f);
    // The bricks counted first, so that their array is allocated once at its size (grown by
    // doubling and then trimmed, it took up to three times their memory at its peak), and each
    // cell's brick numbered in cell order whatever the thread count.
    std::vector<int32_t> brick_of(maj.max_density.size(), -1);
    for_each_row(tree, maj, [&](int j, int k, ConstAccessor& acc) {
        Brick scratch;
        const size_t first = maj.index(0, j, k);
        for (int i = 0; i < maj.dims[0]; ++i)
            // Values are >= 0 after sanitizing: a zero majorant means 9^3 zeros.
            if (maj.max_density[first + i] > 0.0f)
                brick_of[first + i] = needs_brick(acc, cell_origin(maj, i, j, k), &scratch);
    });
    size_t bricks = 0;
    for (int32_t& b : brick_of) b = b > 0 ? static_cast<int32_t>(bricks++) : -1;
    out.values.resize(bricks * detail::kBrickValues);
    for_each_row(tree, maj, [&](int j, int k, ConstAccessor& acc) {
        Brick brick;
        for (size_t n = maj.index(0, j, k), i = 0; i < dim_x; ++i, ++n) {
            if (maj.max_density[n] == 0.0f) continue;
            fill_brick(acc, cell_origin(maj, int(i), j, k), &brick);
            detail::BrickCell& cell = out.cells[n];
            cell.value = brick[0];
            majorants->min_density[n] = *std::min_element(brick.begin(), brick.end());
            if (brick_of[n] < 0) continue;
            cell.brick = brick_of[n];
            quantize(brick, &cell, &out.values[size_t(cell.brick) * detail::kBrickValues]);
        }
    });
    return out;
}

std::string join(const std::vector<std::string>& names) {
    std::string s;
    for (const std::string& n : names) s += (s.empty() ? "" : ", ") + n;
    return s.empty() ? std::string("(none)") : s;
}

/// OpenVDB's affine matrices act on row vectors (p' = p M, translation in row 3); GLM's act on
/// column vectors, so the GLM matrix is the transpose: column c of ours = row c of theirs.
DMat4 to_glm(const openvdb::Mat4d& m) {
    DMat4 r(1.0);
    for (int c = 0; c < 4; ++c)
        for (int row = 0; row < 4; ++row) r[c][row] = m(c, row);
    return r;
}

/// The sampler (build_majorants, then build_bricks) covers the whole active bounding box with
/// cells of 8^3 voxels, whatever the grid holds: its memory and time follow from the box, so they
/// are estimated from it first: build_majorants' 32 bytes per part (one more cell per axis), 24
/// bytes per cell (two majorants, a BrickCell and its brick's number while bricks are built) and
/// a 9^3 brick of 2-byte steps per leaf (a dense grid's cells each hold one). One active tile at
/// the root level spans 4096^3 voxels: 134 million cells, ~7.5 GB.
constexpr uint64_t kMaxSamplerCells = uint64_t(1) << 26;

/// A float leaf's voxel values in memory (max_leaves).
constexpr double kLeafValueBytes = 512.0 * sizeof(float);

/// The sampler's cells and bytes for an active box and `leaves` leaves (its span in voxels, for
/// messages).
struct SamplerSize {
    double cells = 1.0, bytes = 0.0;
    std::string span;
};
SamplerSize sampler_size(const CoordBBox& active, uint64_t leaves) {
    constexpr int kCell = DensityGrid::kMajorantCell;
    SamplerSize s;
    double parts = 1.0;
    for (int a = 0; a < 3; ++a) {
        // index_bounds() grows the active box by one voxel on each side.
        const int64_t lo = static_cast<int64_t>(active.min()[a]) - 1;
        const int64_t hi = static_cast<int64_t>(active.max()[a]) + 1;
        const double n = std::floor(double(hi) / kCell) - std::floor(double(lo) / kCell) + 1.0;
        s.cells *= n;
        parts *= n + 1.0;
        s.span += (a ? " x " : "") + std::to_string(hi - lo - 1);
    }
    const double bricks = std::min(s.cells, static_cast<double>(leaves));
    s.bytes = 32.0 * parts +
              (2.0 * sizeof(float) + sizeof(detail::BrickCell) + sizeof(int32_t)) * s.cells +
              bricks * detail::kBrickValues * static_cast<double>(sizeof(uint16_t));
    return s;
}

/// Refuses a grid whose sampler (for its active box and `leaves` leaves) has too many cells or,
/// with `tree_bytes` (OpenVDB's tree, not yet read; 0 once it is), needs more than the memory
/// available.
void check_sampler_size(const std::string& path, const std::string& field,
                        const std::string& grid_name, const CoordBBox& active, uint64_t leaves,
                        uint64_t tree_bytes = 0) {
    const SamplerSize size = sampler_size(active, leaves);
    const double cells = size.cells, bytes = size.bytes;
    const std::string& span = size.span;
    const uint64_t budget = memory_budget_bytes();
    if (cells <= double(kMaxSamplerCells) && bytes + double(tree_bytes) <= double(budget)) return;
    const std::string tree =
        tree_bytes > 0 ? "reading it takes about " + mb_text(tree_bytes) + " (OpenVDB's tree) and "
                       : "";
    throw InputError(
        path, field,
        "grid '" + grid_name + "': its active voxels span " + span + " voxels; " + tree +
            "the density sampler (cells of 8^3 voxels over that whole box) would need " +
            std::to_string(static_cast<uint64_t>(cells)) + " cells and about " +
            mb_text(static_cast<uint64_t>(bytes)) + "; expected at most " +
            std::to_string(kMaxSamplerCells) + " cells and the memory available (" +
            mb_text(budget) + ")");
}

/// The file's metadata of grid `grid_name`: file_mem_bytes (its tree's size in memory) and its
/// active box; false when the file has no such metadata or cannot be read.
bool grid_metadata(const std::string& path, const std::string& grid_name, uint64_t* tree_bytes,
                   CoordBBox* active) {
    openvdb::GridBase::Ptr meta;
    try {
        openvdb::io::File file(path);
        file.open(/*delayLoad=*/true);
        if (file.hasGrid(grid_name)) meta = file.readGridMetadata(grid_name);
        file.close();
    } catch (const std::exception&) {
        return false;
    }
    if (!meta) return false;
    const auto bytes = meta->getMetadata<openvdb::Int64Metadata>("file_mem_bytes");
    const auto lo = meta->getMetadata<openvdb::Vec3IMetadata>("file_bbox_min");
    const auto hi = meta->getMetadata<openvdb::Vec3IMetadata>("file_bbox_max");
    if (!bytes || !lo || !hi || bytes->value() <= 0) return false;
    *active = CoordBBox(Coord(lo->value()), Coord(hi->value()));
    *tree_bytes = uint64_t(bytes->value());
    return !active->empty();
}

/// The most leaves a tree of `tree_bytes` in memory holds.
uint64_t max_leaves(uint64_t tree_bytes) {
    return uint64_t(double(tree_bytes) / kLeafValueBytes) + 1;
}

/// A grid's memory from its metadata (grid_metadata): its tree, and its sampler's for its active
/// box. Not known when the metadata is missing or unreadable; *active its box when known.
GridMemory metadata_memory(const std::string& path, const std::string& grid_name,
                           CoordBBox* active) {
    GridMemory m;
    if (!grid_metadata(path, grid_name, &m.tree, active)) return m;
    m.known = true;
    const SamplerSize size = sampler_size(*active, max_leaves(m.tree));
    m.sampler = uint64_t(size.bytes);
    m.cells = uint64_t(size.cells);
    return m;
}

/// Before grid `grid_name` is read (in this process or the reader child): the memory its tree
/// and sampler will take, from the metadata OpenVDB writes with each grid (file_mem_bytes, the
/// tree's in-memory size; file_bbox_min and file_bbox_max, its active box), checked as
/// check_sampler_size does, so that a grid too big for the machine is refused with its sizes
/// instead of the kernel's ending the process; returned for what else needs it. A file without
/// that metadata (or whose metadata cannot be read: the reader says why) is checked once read.
GridMemory check_before_reading(const std::string& path, const std::string& field,
                                const std::string& grid_name) {
    CoordBBox active;
    const GridMemory m = metadata_memory(path, grid_name, &active);
    if (m.known) check_sampler_size(path, field, grid_name, active, max_leaves(m.tree), m.tree);
    return m;
}

}  // namespace

DensityGrid::~DensityGrid() = default;

GridMemory grid_memory(const std::string& path, const std::string& grid_name) {
    init_openvdb();
    CoordBBox active;
    return metadata_memory(path, grid_name, &active);
}

std::vector<std::string> vdb_grid_names(const std::string& path, const std::string& field) {
    init_openvdb();
    check_vdb_file(path, field);
    std::vector<std::string> names;
    try {
        openvdb::io::File file(path);
        file.open(/*delayLoad=*/true);
        for (auto it = file.beginName(); it != file.endName(); ++it) names.push_back(*it);
        file.close();
    } catch (const std::exception& e) {
        throw InputError(path, field, vdb_error_reason(e.what()));
    }
    return names;
}

namespace {

/// Reads grid `grid_name` of `path` in this process (the file and its memory checked first), its
/// affine index-to-world in *to_world, after checking its transform and its voxel count against
/// the file's metadata.
openvdb::GridBase::Ptr read_grid(const std::string& path, const std::string& grid_name,
                                 const std::string& field, DMat4* to_world) {
    init_openvdb();
    check_vdb_file(path, field);
    check_before_reading(path, field, grid_name);
    openvdb::GridBase::Ptr base;
    DMat4 index_to_world(1.0);
    try {
        openvdb::io::File file(path);
        file.open(/*delayLoad=*/false);
        std::vector<std::string> names;
        for (auto it = file.beginName(); it != file.endName(); ++it) names.push_back(*it);
        if (std::find(names.begin(), names.end(), grid_name) == names.end()) {
            throw InputError(path, field,
                             "no grid '" + grid_name + "'; grids present: " + join(names));
        }
        base = file.readGrid(grid_name);
        file.close();
        if (!base->transform().isLinear()) {
            throw InputError(path, field,
                             "grid '" + grid_name + "' has a " + base->transform().mapType() +
                                 " transform; expected an affine (linear) one");
        }
        // Throws ArithmeticError for a singular map (a bit flip in the file's transform).
        index_to_world = to_glm(base->transform().baseMap()->getAffineMap()->getMat4());
    } catch (const InputError&) {
        throw;
    } catch (const std::exception& e) {
        throw InputError(path, field, vdb_error_reason(e.what()));
    }
    const std::string problem = affine_problem(index_to_world, "voxel size");
    if (!problem.empty())
        throw InputError(path, field,
                         "grid '" + grid_name + "': its index-to-world transform " + problem);
    // A grid cut short or with a damaged node reads as fewer voxels than OpenVDB counted when it
    // wrote the file (the stats metadata io::File adds).
    if (const auto written = base->getMetadata<openvdb::Int64Metadata>("file_voxel_count")) {
        const openvdb::Index64 read = base->activeVoxelCount();
        if (written->value() != static_cast<int64_t>(read))
            throw InputError(path, field,
                             "corrupt VDB file: grid '" + grid_name + "' has " +
                                 std::to_string(read) +
                                 " active voxels, but its metadata "
                                 "(file_voxel_count) says " +
                                 std::to_string(written->value()));
    }
    *to_world = index_to_world;
    return base;
}

/// read_grid's grid as a GridT; `expected` names that type (and what a voxel holds) in the error.
template <class GridT>
typename GridT::Ptr read_typed_grid(const std::string& path, const std::string& grid_name,
                                    const std::string& field, const std::string& expected,
                                    DMat4* to_world) {
    const openvdb::GridBase::Ptr base = read_grid(path, grid_name, field, to_world);
    typename GridT::Ptr grid = openvdb::gridPtrCast<GridT>(base);
    if (!grid)
        throw InputError(
            path, field,
            "grid '" + grid_name + "' has type " + base->valueType() + "; expected " + expected);
    return grid;
}

}  // namespace

/// DensityGrid's friend: the grid of an OpenVDB tree (sanitized, then made into majorants and
/// bricks), for load, load_channels and load_velocity.
struct GridBuilder {
    static std::unique_ptr<DensityGrid> build(FloatTree& tree, const DMat4& index_to_world,
                                              const std::string& path, const std::string& field,
                                              const std::string& grid_name);
    /// A grid through a stream (the reader child's result), every member.
    static void send(const DensityGrid& grid, FdWriter& out);
    static std::unique_ptr<DensityGrid> receive(FdReader& in);
    /// The grids of a vec3s grid's parts, named grid_name[names[n]], without the load warnings
    /// a part's emptiness would give (it is not the medium's).
    template <size_t N>
    static std::array<std::unique_ptr<DensityGrid>, N> build_parts(
        std::array<FloatTree, N>& trees, const DMat4& index_to_world, const std::string& path,
        const std::string& field, const std::string& grid_name,
        const std::array<const char*, N>& names) {
        std::array<std::unique_ptr<DensityGrid>, N> out;
        for (size_t n = 0; n < N; ++n) {
            out[n] = build(trees[n], index_to_world, path, field, grid_name + "[" + names[n] + "]");
            out[n]->warnings_.clear();
        }
        return out;
    }
};

namespace {

/// DensityGrid::load in this process.
std::unique_ptr<DensityGrid> read_density(const std::string& path, const std::string& grid_name,
                                          const std::string& field) {
    DMat4 index_to_world(1.0);
    const FloatGrid::Ptr grid =
        read_typed_grid<FloatGrid>(path, grid_name, field, "a float grid", &index_to_world);
    return GridBuilder::build(grid->tree(), index_to_world, path, field, grid_name);
}

/// Sets `tree`'s value where the value iterator `it` stands (a voxel or a tile) to x, active.
template <class Iter>
void put_value(FloatTree* tree, const Iter& it, float x) {
    if (it.isVoxelValue())
        tree->setValueOn(it.getCoord(), x);
    else
        tree->addTile(it.getLevel(), it.getCoord(), x, true);
}

/// N float trees of `grid`'s active values (voxels and tiles alike): tree n holds part(v, n,
/// voxels) of a value v standing for `voxels` voxels.
template <size_t N, class Part>
std::array<FloatTree, N> split_vec3(const openvdb::Vec3SGrid& grid, Part&& part) {
    std::array<FloatTree, N> trees;  // background 0
    for (auto it = grid.tree().cbeginValueOn(); it; ++it) {
        const uint64_t voxels = it.isVoxelValue() ? 1 : it.getVoxelCount();
        for (size_t n = 0; n < N; ++n) put_value(&trees[n], it, part(*it, n, voxels));
    }
    return trees;
}

/// A velocity component's positive and negative parts into *plus and *minus; counts the voxels
/// whose value is not finite (left 0).
template <class Iter>
void put_signed(const Iter& it, float x, FloatTree* plus, FloatTree* minus, uint64_t* bad) {
    if (!std::isfinite(x)) {
        *bad += it.isVoxelValue() ? 1 : it.getVoxelCount();
        x = 0.0f;
    }
    put_value(plus, it, std::max(x, 0.0f));
    put_value(minus, it, std::max(-x, 0.0f));
}

/// DensityGrid::load_channels in this process.
std::array<std::unique_ptr<DensityGrid>, 3> read_channels(const std::string& path,
                                                          const std::string& grid_name,
                                                          const std::string& field,
                                                          uint64_t* clamped) {
    DMat4 index_to_world(1.0);
    const auto grid = read_typed_grid<openvdb::Vec3SGrid>(
        path, grid_name, field, "a vec3s grid (a colour per voxel)", &index_to_world);
    // Values above 1 clamped; a value below 0 or not finite is no colour: the file is wrong.
    *clamped = 0;
    uint64_t bad = 0;
    auto trees = split_vec3<3>(*grid, [&](const openvdb::Vec3s& v, size_t c, uint64_t voxels) {
        bad += !(v[c] >= 0.0f) || !std::isfinite(v[c]) ? voxels : 0;
        *clamped += v[c] > 1.0f ? voxels : 0;
        return std::isfinite(v[c]) ? std::clamp(v[c], 0.0f, 1.0f) : 0.0f;
    });
    if (bad > 0)
        throw InputError(path, field,
                         "grid '" + grid_name + "' has " + std::to_string(bad) +
                             " channel values below 0 or not finite; expected colours in 0 .. 1");
    return GridBuilder::build_parts(trees, index_to_world, path, field, grid_name, {"0", "1", "2"});
}

/// DensityGrid::load_velocity in this process.
std::array<std::unique_ptr<DensityGrid>, 6> read_velocity(const std::string& path,
                                                          const std::string& grid_name,
                                                          const std::string& field) {
    DMat4 index_to_world(1.0);
    // Part 2c + s: axis c's positive (s = 0) or negative (s = 1) part.
    std::array<FloatTree, 6> trees;  // background 0
    uint64_t bad = 0;
    const std::vector<std::string> names = vdb_grid_names(path, field);
    const auto has = [&](const std::string& n) {
        return std::find(names.begin(), names.end(), n) != names.end();
    };
    if (!has(grid_name) && has(grid_name + ".x") && has(grid_name + ".y") &&
        has(grid_name + ".z")) {
        // Split into float grids, as Houdini writes a vector volume's components.
        for (size_t c = 0; c < 3; ++c) {
            const std::string name = grid_name + "." + "xyz"[c];
            DMat4 to_world(1.0);
            const FloatGrid::Ptr grid = read_typed_grid<FloatGrid>(
                path, name, field, "a float grid (a velocity component per voxel)", &to_world);
            if (c > 0 && to_world != index_to_world)
                throw InputError(path, field,
                                 "grids '" + grid_name +
                                     ".x', '.y' and '.z' have different "
                                     "transforms; expected the components of one grid");
            index_to_world = to_world;
            for (auto it = grid->tree().cbeginValueOn(); it; ++it)
                put_signed(it, *it, &trees[2 * c], &trees[2 * c + 1], &bad);
        }
    } else {
        const auto grid = read_typed_grid<openvdb::Vec3SGrid>(
            path, grid_name, field, "a vec3s grid (a velocity per voxel)", &index_to_world);
        for (auto it = grid->tree().cbeginValueOn(); it; ++it)
            for (size_t c = 0; c < 3; ++c)
                put_signed(it, (*it)[c], &trees[2 * c], &trees[2 * c + 1], &bad);
    }
    if (bad > 0)
        throw InputError(path, field,
                         "grid '" + grid_name + "' has " + std::to_string(bad) +
                             " velocity components that are not finite; expected world units "
                             "per second");
    return GridBuilder::build_parts(trees, index_to_world, path, field, grid_name,
                                    {"x+", "x-", "y+", "y-", "z+", "z-"});
}

}  // namespace

std::unique_ptr<DensityGrid> GridBuilder::build(FloatTree& tree, const DMat4& index_to_world,
                                                const std::string& path, const std::string& field,
                                                const std::string& grid_name) {
    std::unique_ptr<DensityGrid> out(new DensityGrid());
    out->name_ = grid_name;
    const float background = tree.background();
    if (background != 0.0f) {
        char text[400];
        std::snprintf(text, sizeof text,
                      "%s: grid '%s' has background %g; replaced by 0 (density outside active "
                      "voxels is 0)",
                      path.c_str(), grid_name.c_str(), background);
        out->warnings_.push_back(text);
        openvdb::tools::changeBackground(tree, 0.0f);
    }

    SanitizeStats& stats = out->sanitize_;
    float max_density = 0.0f;
    struct Found {  // a thread's counts and greatest value: sums and a max, the same in any order
        SanitizeStats stats;
        float max_density = 0.0f;
    };
    tbb::enumerable_thread_specific<Found> found;
    auto leaf_fn = [&](Leaf& leaf) {
        Found& f = found.local();
        float* data = leaf.buffer().data();
        for (openvdb::Index n = 0; n < Leaf::SIZE; ++n) {
            sanitize_value(data[n], 1, &f.stats);
            f.max_density = std::max(f.max_density, data[n]);
        }
    };
    auto tile_fn = [&](float& v, const CoordBBox& box) {
        sanitize_value(v, box.volume(), &stats);
        max_density = std::max(max_density, v);
    };
    visit_nodes(tree, leaf_fn, tile_fn);
    for (const Found& f : found) {
        stats.nan += f.stats.nan;
        stats.inf += f.stats.inf;
        stats.negative += f.stats.negative;
        stats.denormal += f.stats.denormal;
        max_density = std::max(max_density, f.max_density);
    }
    if (stats.total() > 0) {
        char text[400];
        std::snprintf(text, sizeof text,
                      "%s: grid '%s': set to 0: %llu NaN, %llu infinite, %llu negative, %llu "
                      "denormal voxel values",
                      path.c_str(), grid_name.c_str(), static_cast<unsigned long long>(stats.nan),
                      static_cast<unsigned long long>(stats.inf),
                      static_cast<unsigned long long>(stats.negative),
                      static_cast<unsigned long long>(stats.denormal));
        out->warnings_.push_back(text);
    }
    out->max_density_ = max_density;
    out->active_voxels_ = tree.activeVoxelCount();

    CoordBBox active;
    if (tree.evalActiveVoxelBoundingBox(active) && max_density > 0.0f) {
        check_sampler_size(path, field, grid_name, active, tree.leafCount());
        // Grown by one voxel: trilinear density ramps to 0 over the voxel beyond the last centre.
        out->index_bounds_.lo =
            Vec3(active.min().x() - 1, active.min().y() - 1, active.min().z() - 1);
        out->index_bounds_.hi =
            Vec3(active.max().x() + 1, active.max().y() + 1, active.max().z() + 1);
    } else {
        char text[400];
        std::snprintf(text, sizeof text,
                      "%s: grid '%s' has no active voxel above 0 (%llu active voxels); it renders "
                      "as no medium",
                      path.c_str(), grid_name.c_str(),
                      static_cast<unsigned long long>(out->active_voxels_));
        out->warnings_.push_back(text);
    }
    out->majorants_ = build_majorants(tree, out->index_bounds_);
    out->index_to_world_ = index_to_world;
    // Last, on the sanitized tree; the tree itself is not kept (the sampler reads only bricks).
    out->bricks_ = build_bricks(tree, &out->majorants_);
    return out;
}

DensityGrid::Sampler::Sampler(const DensityGrid& grid)
    : cells_(grid.bricks_.cells.data()),
      values_(grid.bricks_.values.data()),
      origin_(grid.majorants_.origin),
      dim_x_(grid.majorants_.dims[0]),
      dim_y_(grid.majorants_.dims[1]) {
    const MajorantGrid& m = grid.majorants_;
    for (int a = 0; a < 3; ++a) {
        lo_[a] = static_cast<float>(m.origin[a]);
        hi_[a] = static_cast<float>(m.origin[a] + m.cell * m.dims[a]);
    }
}

namespace {

/// inspect_vdb in this process.
std::vector<GridInfo> read_infos(const std::string& path) {
    init_openvdb();
    check_vdb_file(path, "");
    std::vector<GridInfo> infos;
    try {
        openvdb::io::File file(path);
        file.open(/*delayLoad=*/false);
        openvdb::GridPtrVecPtr grids = file.getGrids();
        file.close();
        for (const openvdb::GridBase::Ptr& grid : *grids) {
            GridInfo info;
            info.name = grid->getName();
            info.value_type = grid->valueType();
            info.grid_class = openvdb::GridBase::gridClassToString(grid->getGridClass());
            const openvdb::math::Transform& xf = grid->transform();
            const openvdb::Vec3d vs = xf.voxelSize();
            info.voxel_size = Vec3(vs.x(), vs.y(), vs.z());
            const openvdb::Vec3d t = xf.indexToWorld(openvdb::Vec3d(0.0));
            info.translation = Vec3(t.x(), t.y(), t.z());
            const CoordBBox bbox = grid->evalActiveVoxelBoundingBox();
            if (!bbox.empty()) {
                for (int a = 0; a < 3; ++a) {
                    info.index_min[a] = bbox.min()[a];
                    info.index_max[a] = bbox.max()[a];
                }
                for (int n = 0; n < 8; ++n) {
                    const Coord& c0 = bbox.min();
                    const Coord& c1 = bbox.max();
                    const openvdb::Vec3d corner((n & 1) ? c1.x() : c0.x(),
                                                (n & 2) ? c1.y() : c0.y(),
                                                (n & 4) ? c1.z() : c0.z());
                    const openvdb::Vec3d w = xf.indexToWorld(corner);
                    info.world_bounds.extend(Vec3(w.x(), w.y(), w.z()));
                }
            }
            info.active_voxels = grid->activeVoxelCount();
            info.active_tiles = grid->baseTree().activeTileCount();
            if (info.active_voxels > 0) {
                if (auto fg = openvdb::gridPtrCast<FloatGrid>(grid)) {
                    const auto mm = openvdb::tools::minMax(fg->tree(), /*threaded=*/false);
                    info.min_value = mm.min();
                    info.max_value = mm.max();
                    info.scalar = true;
                } else if (auto dg = openvdb::gridPtrCast<openvdb::DoubleGrid>(grid)) {
                    const auto mm = openvdb::tools::minMax(dg->tree(), /*threaded=*/false);
                    info.min_value = mm.min();
                    info.max_value = mm.max();
                    info.scalar = true;
                }
            }
            infos.push_back(std::move(info));
        }
    } catch (const InputError&) {
        throw;
    } catch (const std::exception& e) {
        throw InputError(path, "", vdb_error_reason(e.what()));
    }
    return infos;
}

}  // namespace

void GridBuilder::send(const DensityGrid& g, FdWriter& out) {
    out.values(g.bricks_.cells);
    out.values(g.bricks_.values);
    out.value(g.index_to_world_);
    out.value(g.index_bounds_);
    out.value(g.max_density_);
    const MajorantGrid& m = g.majorants_;
    out.value(m.origin);
    out.value(m.dims);
    out.value(m.cell);
    out.values(m.max_density);
    out.values(m.min_density);
    out.value(g.sanitize_);
    out.value(g.active_voxels_);
    out.text(g.name_);
    out.value(uint64_t(g.warnings_.size()));
    for (const std::string& w : g.warnings_) out.text(w);
}

std::unique_ptr<DensityGrid> GridBuilder::receive(FdReader& in) {
    std::unique_ptr<DensityGrid> g(new DensityGrid());
    in.values(&g->bricks_.cells);
    in.values(&g->bricks_.values);
    g->index_to_world_ = in.value<DMat4>();
    g->index_bounds_ = in.value<Box3>();
    g->max_density_ = in.value<float>();
    MajorantGrid& m = g->majorants_;
    m.origin = in.value<std::array<int, 3>>();
    m.dims = in.value<std::array<int, 3>>();
    m.cell = in.value<int>();
    in.values(&m.max_density);
    in.values(&m.min_density);
    g->sanitize_ = in.value<SanitizeStats>();
    g->active_voxels_ = in.value<uint64_t>();
    g->name_ = in.text();
    g->warnings_.resize(in.value<uint64_t>());
    for (std::string& w : g->warnings_) w = in.text();
    return g;
}

namespace {

void send_info(const GridInfo& g, FdWriter& out) {
    out.text(g.name);
    out.text(g.value_type);
    out.text(g.grid_class);
    out.value(g.voxel_size);
    out.value(g.translation);
    out.value(g.index_min);
    out.value(g.index_max);
    out.value(g.world_bounds);
    out.value(g.active_voxels);
    out.value(g.active_tiles);
    out.value(g.min_value);
    out.value(g.max_value);
    out.value(g.scalar);
}

GridInfo receive_info(FdReader& in) {
    GridInfo g;
    g.name = in.text();
    g.value_type = in.text();
    g.grid_class = in.text();
    g.voxel_size = in.value<Vec3>();
    g.translation = in.value<Vec3>();
    g.index_min = in.value<std::array<int, 3>>();
    g.index_max = in.value<std::array<int, 3>>();
    g.world_bounds = in.value<Box3>();
    g.active_voxels = in.value<uint64_t>();
    g.active_tiles = in.value<uint64_t>();
    g.min_value = in.value<double>();
    g.max_value = in.value<double>();
    g.scalar = in.value<bool>();
    return g;
}

/// What the child needs to build `grids` samplers from grid `grid_name` (memory `m`, from its
/// metadata; or its .x, .y and .z float grids') besides reading the file: the trees it splits
/// them into, and the samplers' memory and time (10 microseconds a cell, 20 MB a second of
/// bricks: several times what they take here); without metadata, 16 bytes and a microsecond per
/// file byte.
ChildNeeds child_needs(const std::string& path, const std::string& grid_name, GridMemory m,
                       int grids) {
    if (!m.known) {
        m = grid_memory(path, grid_name + ".x");
        m.tree *= 3;
    }
    std::error_code ec;
    const double file = double(std::filesystem::file_size(path, ec));
    ChildNeeds needs;
    if (m.known) {
        needs.bytes = 2 * m.tree + uint64_t(grids) * m.sampler;
        needs.cpu_s = grids * (1e-5 * double(m.cells) + double(m.sampler) / 20e6);
    } else {
        needs.bytes = uint64_t(grids) * 16 * uint64_t(file);
        needs.cpu_s = grids * 1e-6 * file;
    }
    return needs;
}

/// The `count` grids the child makes of grid `grid_name` as `what` asks, and its count of
/// values clamped (load_channels').
std::vector<std::unique_ptr<DensityGrid>> load_in_child(const std::string& what,
                                                        const std::string& path,
                                                        const std::string& grid_name,
                                                        const std::string& field, size_t count,
                                                        uint64_t* clamped) {
    init_openvdb();
    check_vdb_file(path, field);
    const GridMemory memory = check_before_reading(path, field, grid_name);
    std::vector<std::unique_ptr<DensityGrid>> grids;
    const std::vector<std::string> args = {
        "--what", what, "--grid", grid_name, "--threads", std::to_string(active_thread_count())};
    const ChildNeeds needs = child_needs(path, grid_name, memory, int(count));
    read_in_child(path, field, args, needs, [&](FdReader& in) {
        const uint64_t clamped_values = in.value<uint64_t>();
        if (clamped) *clamped = clamped_values;
        for (size_t n = 0; n < count; ++n) grids.push_back(GridBuilder::receive(in));
    });
    return grids;
}

template <size_t N>
std::array<std::unique_ptr<DensityGrid>, N> to_array(std::vector<std::unique_ptr<DensityGrid>> v) {
    std::array<std::unique_ptr<DensityGrid>, N> out;
    for (size_t n = 0; n < N; ++n) out[n] = std::move(v[n]);
    return out;
}

}  // namespace

std::unique_ptr<DensityGrid> DensityGrid::load(const std::string& path,
                                               const std::string& grid_name,
                                               const std::string& field) {
    if (!vdb_probe_enabled()) return read_density(path, grid_name, field);
    return std::move(load_in_child("density", path, grid_name, field, 1, nullptr)[0]);
}

std::array<std::unique_ptr<DensityGrid>, 3> DensityGrid::load_channels(const std::string& path,
                                                                       const std::string& grid_name,
                                                                       const std::string& field,
                                                                       uint64_t* clamped) {
    if (!vdb_probe_enabled()) return read_channels(path, grid_name, field, clamped);
    return to_array<3>(load_in_child("colour", path, grid_name, field, 3, clamped));
}

std::array<std::unique_ptr<DensityGrid>, 6> DensityGrid::load_velocity(const std::string& path,
                                                                       const std::string& grid_name,
                                                                       const std::string& field) {
    if (!vdb_probe_enabled()) return read_velocity(path, grid_name, field);
    return to_array<6>(load_in_child("velocity", path, grid_name, field, 6, nullptr));
}

std::vector<GridInfo> inspect_vdb(const std::string& path) {
    if (!vdb_probe_enabled()) return read_infos(path);
    init_openvdb();
    check_vdb_file(path, "");
    std::vector<GridInfo> infos;
    read_in_child(path, "", {"--what", "info"}, ChildNeeds{}, [&](FdReader& in) {
        infos.resize(in.value<uint64_t>());
        for (GridInfo& g : infos) g = receive_info(in);
    });
    return infos;
}

int run_vdb_child(const VdbChildTask& task) {
    const ThreadLimit threads(task.threads);
    return run_reader_child(task.path, task.cpu_s, task.memory_bytes, [&](FdWriter& out) {
        // Everything is read and built before the mark: an error until then is a message.
        if (task.what == "info") {
            const std::vector<GridInfo> infos = read_infos(task.path);
            send_result_mark(out);
            out.value(uint64_t(infos.size()));
            for (const GridInfo& g : infos) send_info(g, out);
            return;
        }
        std::vector<std::unique_ptr<DensityGrid>> grids;
        uint64_t clamped = 0;
        if (task.what == "density") {
            grids.push_back(read_density(task.path, task.grid, ""));
        } else if (task.what == "colour") {
            for (auto& g : read_channels(task.path, task.grid, "", &clamped))
                grids.push_back(std::move(g));
        } else if (task.what == "velocity") {
            for (auto& g : read_velocity(task.path, task.grid, "")) grids.push_back(std::move(g));
        } else {
            throw std::logic_error("__probe-vdb: unknown --what '" + task.what + "'");
        }
        // OpenVDB's tree is gone, but its many small blocks stay in malloc's arenas: handed back
        // to the system, so that this process and its parent, receiving, do not hold both.
        malloc_trim(0);
        send_result_mark(out);
        out.value(clamped);
        for (const auto& g : grids) GridBuilder::send(*g, out);
    });
}

}  // namespace fogmap
