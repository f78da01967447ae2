#include "render/volume_map_end.h"

#include "core/error.h"
#include "photon/estimators.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace fogmap {

namespace {

// σ_s L_i / σ̄_s per channel; 0 where σ̄_s is 0 (no photon can be there).
Color divide(const Color& collisions, const Color& density) {
    Color out(0.0f);
    for (int c = 0; c < 3; ++c)
        if (density[c] > 0.0f) out[c] = collisions[c] / density[c];
    return out;
}

// Capacity for n elements in a vector kept between iterations, twice n when it must grow: the
// grids grow as the radius shrinks (as i^(1/3) over progressive iterations), and memory reserved
// is only faulted in where written.
template <class T>
void reserve_recycled(std::vector<T>* v, size_t n) {
    if (v->capacity() < n) v->reserve(2 * n);
}

// Every medium's |g| lets the lookups read a grid of moments (fits_moment_grid).
bool moment_grid_fits(const std::vector<Medium>& media) {
    return std::all_of(media.begin(), media.end(),
                       [](const Medium& m) { return fits_moment_grid(m.params().g); });
}

}  // namespace

KernelDensity::KernelDensity(const std::vector<Medium>& media, float radius, Buffers* recycle) {
    Box3 bounds;
    for (const Medium& m : media) bounds.extend(m.world_bounds());
    if (bounds.empty() || !(radius > 0.0f)) return;
    // The cube of the ball's volume, averaged over 3 points per axis.
    const float edge = equal_volume_edge(radius);
    const Vec3 extent = bounds.extent() + Vec3(4.0f * edge);
    cell_ = capped_cell(extent, edge / 3.0f, kMaxCells);
    origin_ = bounds.lo - Vec3(2.0f * edge);
    for (int a = 0; a < 3; ++a) dims_[a] = static_cast<int>(std::ceil(extent[a] / cell_)) + 1;
    const size_t nx = dims_[0], ny = dims_[1], nz = dims_[2];
    // Every point and value is written below: resizing recycled vectors keeps their pages.
    std::vector<Color> points;
    if (recycle) {
        points = std::move(recycle->points);
        values_ = std::move(recycle->values);
        reserve_recycled(&points, nx * ny * nz);
        reserve_recycled(&values_, nx * ny * nz);
    }
    points.resize(nx * ny * nz);
    tbb::parallel_for(0, dims_[2], [&](int k) {
        std::vector<Medium::Sampler> samplers;
        for (const Medium& m : media) samplers.emplace_back(m);
        for (size_t j = 0; j < ny; ++j)
            for (size_t i = 0; i < nx; ++i) {
                const Vec3 p = origin_ + cell_ * Vec3(float(i), float(j), float(k));
                points[(k * ny + j) * nx + i] = sigma_s_at(samplers, p);
            }
    });
    // Separable 3-point box average (three passes: the last writes values_); outside the grid,
    // two cube edges beyond the media, σ_s is 0.
    values_.resize(points.size());
    const size_t stride[3] = {1, nx, nx * ny};
    for (int a = 0; a < 3; ++a) {
        std::vector<Color>& from = a % 2 == 0 ? points : values_;
        std::vector<Color>& to = a % 2 == 0 ? values_ : points;
        tbb::parallel_for(size_t(0), from.size(), [&](size_t n) {
            const size_t c = (n / stride[a]) % dims_[a];
            Color s = from[n];
            if (c > 0) s += from[n - stride[a]];
            if (c + 1 < size_t(dims_[a])) s += from[n + stride[a]];
            to[n] = s / 3.0f;
        });
    }
    if (recycle) recycle->points = std::move(points);
}

bool KernelDensity::corners(const Vec3& x, Corners* out) const {
    if (values_.empty()) return false;
    const Vec3 u = (x - origin_) / cell_;
    int c[3];
    float f[3];
    for (int a = 0; a < 3; ++a) {
        if (!(u[a] >= 0.0f) || u[a] >= float(dims_[a] - 1)) return false;
        c[a] = static_cast<int>(u[a]);
        f[a] = u[a] - float(c[a]);
    }
    const size_t nx = dims_[0], ny = dims_[1];
    const float inv = 1.0f / cell_;
    for (int n = 0; n < 8; ++n) {
        const int dx = n & 1, dy = (n >> 1) & 1, dz = n >> 2;
        const float wx = dx ? f[0] : 1.0f - f[0], wy = dy ? f[1] : 1.0f - f[1],
                    wz = dz ? f[2] : 1.0f - f[2];
        const float gx = dx ? inv : -inv, gy = dy ? inv : -inv, gz = dz ? inv : -inv;
        out->weight[n] = wx * wy * wz;
        out->gradient[n] = Vec3(gx * wy * wz, wx * gy * wz, wx * wy * gz);
        out->node[n] = ((c[2] + dz) * ny + c[1] + dy) * nx + c[0] + dx;
    }
    return true;
}

Color KernelDensity::at(const Vec3& x) const {
    Corners c;
    if (!corners(x, &c)) return Color(0.0f);
    Color s(0.0f);
    for (int n = 0; n < 8; ++n) s += c.weight[n] * values_[c.node[n]];
    return s;
}

KernelDensity::Slope KernelDensity::slope(const Corners& c) const {
    Slope out;
    for (int n = 0; n < 8; ++n) {
        const Color& v = values_[c.node[n]];
        const float sum = v.x + v.y + v.z;
        out.gradient += sum * c.gradient[n];
        out.value += c.weight[n] * sum;
        for (int axis = 0; axis < 3; ++axis) {
            const float d = c.gradient[n][axis];  // ±(the other axes' weights) / cell
            (d > 0.0f ? out.upper : out.lower)[axis] += sum * std::abs(d);
        }
    }
    return out;
}

Vec3 KernelDensity::node_position(size_t n) const {
    const size_t nx = dims_[0], ny = dims_[1];
    return origin_ + cell_ * Vec3(float(n % nx), float((n / nx) % ny), float(n / (nx * ny)));
}

SigmaTable::SigmaTable(const std::vector<Medium>& media, float margin) {
    Box3 bounds;
    float voxel = kInfinity;
    for (const Medium& m : media) {
        bounds.extend(m.world_bounds());
        if (m.voxel_world() > 0.0f) voxel = std::min(voxel, m.voxel_world());
    }
    if (bounds.empty()) return;
    origin_ = bounds.lo - Vec3(margin);
    const Vec3 extent = bounds.extent() + Vec3(2.0f * margin);
    cell_ =
        capped_cell(extent, voxel < kInfinity ? voxel : max_component(extent) / 128.0f, kMaxCells);
    for (int a = 0; a < 3; ++a) dims_[a] = static_cast<int>(std::ceil(extent[a] / cell_)) + 1;
    const size_t nx = dims_[0], ny = dims_[1], nz = dims_[2];
    // sums_[(k ny + j) nx + i] = ∫ σ_s over [origin, origin + cell (i, j, k)]: the cells' values
    // (σ_s at their centres × cell volume) at index + 1, then prefix sums along x, y and z.
    sums_.assign(nx * ny * nz, DVec3(0.0));
    const double cell_volume = double(cell_) * cell_ * cell_;
    tbb::parallel_for(size_t(1), nz, [&](size_t k) {
        std::vector<Medium::Sampler> samplers;
        for (const Medium& m : media) samplers.emplace_back(m);
        for (size_t j = 1; j < ny; ++j)
            for (size_t i = 1; i < nx; ++i) {
                const Vec3 p = origin_ + cell_ * (Vec3(float(i), float(j), float(k)) - 0.5f);
                sums_[(k * ny + j) * nx + i] = DVec3(sigma_s_at(samplers, p)) * cell_volume;
            }
    });
    tbb::parallel_for(size_t(0), ny * nz, [&](size_t row) {  // along x
        for (size_t i = 1; i < nx; ++i) sums_[row * nx + i] += sums_[row * nx + i - 1];
    });
    tbb::parallel_for(size_t(0), nz, [&](size_t k) {  // along y
        for (size_t j = 1; j < ny; ++j)
            for (size_t i = 0; i < nx; ++i)
                sums_[(k * ny + j) * nx + i] += sums_[(k * ny + j - 1) * nx + i];
    });
    tbb::parallel_for(size_t(0), ny, [&](size_t j) {  // along z
        for (size_t k = 1; k < nz; ++k)
            for (size_t i = 0; i < nx; ++i)
                sums_[(k * ny + j) * nx + i] += sums_[((k - 1) * ny + j) * nx + i];
    });
}

// Within a cell σ_s is constant, so the integral from the origin is trilinear in the corner:
// interpolating the lattice's sums is exact.
DVec3 SigmaTable::integral_to(const Vec3& u) const {
    int c[3];
    double f[3];
    for (int a = 0; a < 3; ++a) {
        const float top = float(dims_[a] - 1);
        const float v = std::clamp(u[a], 0.0f, top);
        c[a] = std::min(static_cast<int>(v), dims_[a] - 2);
        f[a] = double(v) - c[a];
    }
    const size_t nx = dims_[0], ny = dims_[1];
    DVec3 sum(0.0);
    for (int n = 0; n < 8; ++n) {
        const int dx = n & 1, dy = (n >> 1) & 1, dz = n >> 2;
        const double w =
            (dx ? f[0] : 1.0 - f[0]) * (dy ? f[1] : 1.0 - f[1]) * (dz ? f[2] : 1.0 - f[2]);
        sum += w * sums_[((c[2] + dz) * ny + c[1] + dy) * nx + c[0] + dx];
    }
    return sum;
}

Color SigmaTable::cube_average(const Vec3& x, float edge) const {
    if (sums_.empty() || !(edge > 0.0f)) return Color(0.0f);
    const Vec3 lo = (x - origin_ - 0.5f * edge) / cell_, hi = (x - origin_ + 0.5f * edge) / cell_;
    DVec3 sum(0.0);
    for (int n = 0; n < 8; ++n) {  // inclusion–exclusion over the box's corners
        const Vec3 corner((n & 1) ? hi.x : lo.x, (n & 2) ? hi.y : lo.y, (n & 4) ? hi.z : lo.z);
        const int lows = !(n & 1) + !(n & 2) + !(n & 4);
        sum += (lows % 2 ? -1.0 : 1.0) * integral_to(corner);
    }
    return Color(glm::max(sum, DVec3(0.0)) / (double(edge) * edge * edge));
}

VolumeMapEnd::VolumeMapEnd(const PhotonMap& map, const std::vector<Medium>& media, float radius,
                           int depth, float k, float max_tau, Buffers* recycle, PhotonParts parts)
    : recycle_(recycle),
      map_(map),
      radius_(radius),
      depth_(depth),
      density_(media, radius, recycle ? &recycle->density : nullptr),
      phase_fits_(moment_grid_fits(media)),
      k_(k),
      max_tau_(max_tau),
      parts_(parts) {
    if (recycle) {  // given back whole by the destructor, whatever is built here
        slot_ = std::move(recycle->slot);
        moments_ = std::move(recycle->moments);
        counts_ = std::move(recycle->counts);
        batch_power_ = std::move(recycle->batch_power);
        slot_.clear();  // empty until built: no moments, no counts, no batches
        counts_.clear();
        batch_power_.clear();
    }
    // Without moments the grid is for AdaptiveRadius's counts alone.
    if (density_.nodes() == 0 || density_.cell() > 0.6f * radius || (!phase_fits_ && !(k > 0.0f)))
        return;
    if (!assign_slots()) return;
    add_photons();
    for (BatchSums& b : batch_power_)  // κ without a table (set_table: each point's own)
        for (float& v : b.inner) v *= kBallKappa;
    crowded_anywhere_ =
        k_ > 0.0f && std::any_of(moments_.begin(), moments_.end(),
                                 [&](const Moments& m) { return m.count > 2.0f * k_; });
    if (crowded_anywhere_ && max_tau_ > 0.0f) {
        counts_.resize(moments_.size());
        for (size_t i = 0; i < moments_.size(); ++i) counts_[i] = moments_[i].count;
    }
}

double VolumeMapEnd::memory_bound(double budget) {
    // Measured: 27 bytes a density grid point, 165 a moment point; 400 bytes a budget photon at
    // the least budget (10^5), growing as budget^0.7 beyond (the radius shrinks, the points
    // spread over less medium than the photons' count grows).
    constexpr double kDensityBytes = 27.0, kMomentBytes = 165.0, kLeast = 1e5;
    const double caps =
        kDensityBytes * double(KernelDensity::kMaxCells) + kMomentBytes * double(kMaxMomentNodes);
    const double grids =
        400.0 * (budget <= kLeast ? budget : kLeast * std::pow(budget / kLeast, 0.7));
    return std::min(grids, caps) + sizeof(DVec3) * double(SigmaTable::kMaxCells);
}

bool VolumeMapEnd::assign_slots() {
    std::vector<size_t> scratch;
    std::vector<size_t>& nodes = recycle_ ? recycle_->nodes : scratch;
    nodes.clear();
    for (size_t n = 0; n < density_.nodes(); ++n)
        if (max_component(density_.node_value(n)) > 0.0f) nodes.push_back(n);
    if (nodes.size() > kMaxMomentNodes) return false;
    if (recycle_) {
        reserve_recycled(&slot_, density_.nodes());
        reserve_recycled(&moments_, nodes.size());
    }
    slot_.assign(density_.nodes(), -1);
    for (size_t i = 0; i < nodes.size(); ++i) slot_[nodes[i]] = static_cast<int32_t>(i);
    moments_.assign(nodes.size(), Moments{});
    if (batched() && phase_fits_) {
        if (recycle_) reserve_recycled(&batch_power_, nodes.size());
        batch_power_.assign(nodes.size(), BatchSums{});
    }
    return true;
}

// The density grid's points and the radius photons reach.
struct VolumeMapEnd::Lattice {
    std::array<int, 3> dims;
    Vec3 origin;
    float cell, radius;
    // Grid points [*lo, *hi] along axis a within the radius of coordinate v; false: none.
    bool range(float v, int a, int* lo, int* hi) const {
        const float top = float(dims[a] - 1);
        *lo = static_cast<int>(std::clamp(std::ceil((v - radius - origin[a]) / cell), 0.0f, top));
        *hi = static_cast<int>(std::clamp(std::floor((v + radius - origin[a]) / cell), -1.0f, top));
        return *lo <= *hi;
    }
};

// Each photon adds to the grid points within r of it. Per layer of grid points (z), its photons
// in the map's order: each point's sums are the same whatever the thread count.
void VolumeMapEnd::add_photons() {
    const Lattice g{density_.dims(), density_.node_position(0), density_.cell(), radius_};
    const std::vector<Photon>& photons = map_.tree.records();
    std::vector<std::vector<uint32_t>> layers(g.dims[2]);
    for (uint32_t n = 0; n < photons.size(); ++n) {
        int lo, hi;
        if (g.range(photons[n].position().z, 2, &lo, &hi))
            for (int k = lo; k <= hi; ++k) layers[k].push_back(n);
    }
    tbb::parallel_for(0, g.dims[2], [&](int k) {
        for (const uint32_t n : layers[k]) add_photon(photons[n], g, k);
    });
}

void VolumeMapEnd::add_photon(const Photon& p, const Lattice& g, int k) {
    int i0, i1, j0, j1;
    if (!g.range(p.position().x, 0, &i0, &i1) || !g.range(p.position().y, 1, &j0, &j1)) return;
    const Color c = p.power();
    const Vec3 w = p.direction();
    const std::array<Color, 3> m1{w.x * c, w.y * c, w.z * c};
    const std::array<Color, 6> m2{w.x * m1[0], w.y * m1[1], w.z * m1[2],
                                  w.y * m1[0], w.z * m1[0], w.z * m1[1]};
    const Vec3 q = p.position() - g.origin;
    const float r2 = g.radius * g.radius;
    for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i) {
            const int32_t s = slot_[(size_t(k) * g.dims[1] + j) * g.dims[0] + i];
            if (s < 0) continue;
            const Vec3 d = g.cell * Vec3(float(i), float(j), float(k)) - q;
            if (glm::dot(d, d) > r2) continue;
            Moments& m = moments_[s];
            m.count += 1.0f;
            if (!phase_fits_) continue;  // the kd-tree's lookups want only counts
            m.m0 += c;
            for (int a = 0; a < 3; ++a) m.m1[a] += m1[a];
            for (int a = 0; a < 6; ++a) m.m2[a] += m2[a];
            if (!batch_power_.empty()) batch_power_[s].add(p, c, glm::dot(d, d), r2);
        }
}

VolumeMapEnd::~VolumeMapEnd() {
    if (!recycle_) return;
    density_.give_back(&recycle_->density);
    recycle_->slot = std::move(slot_);
    recycle_->moments = std::move(moments_);
    recycle_->counts = std::move(counts_);
    recycle_->batch_power = std::move(batch_power_);
}

bool VolumeMapEnd::interpolate(const Vec3& x, Color* density, Moments* m,
                               KernelDensity::Corners* corners, bool batches) const {
    KernelDensity::Corners local;
    KernelDensity::Corners& c = corners ? *corners : local;
    if (!density_.corners(x, &c)) return false;
    *density = Color(0.0f);
    for (int n = 0; n < 8; ++n) {
        const float w = c.weight[n];
        *density += w * density_.node_value(c.node[n]);
        const int32_t s = slot_.empty() ? -1 : slot_[c.node[n]];
        if (s < 0) continue;
        if (batches) {  // 40 bytes: maybe two cache lines
            __builtin_prefetch(&batch_power_[size_t(s)]);
            __builtin_prefetch(reinterpret_cast<const char*>(&batch_power_[size_t(s)] + 1) - 1);
        }
        const Moments& q = moments_[s];
        m->count += w * q.count;
        m->m0 += w * q.m0;
        for (int a = 0; a < 3; ++a) m->m1[a] += w * q.m1[a];
        for (int a = 0; a < 6; ++a) m->m2[a] += w * q.m2[a];
    }
    return true;
}

float VolumeMapEnd::count_at(const Vec3& x) const {
    KernelDensity::Corners c;
    if (counts_.empty() || !density_.corners(x, &c)) return 0.0f;
    float count = 0.0f;
    for (int n = 0; n < 8; ++n) {
        const int32_t s = slot_[c.node[n]];
        if (s >= 0) count += c.weight[n] * counts_[s];
    }
    return count;
}

// FineEnough's decision (header): with the radius AdaptiveRadius would take for the photon count
// of the grid's balls about the 8 points kDecisionOffset r along each axis away, on average.
float VolumeMapEnd::optical_radius(const Vec3& x) const {
    const float sigma = max_component(density_.at(x));  // 0 beyond the grid
    // The smaller radius can only shorten it: decided without the counts.
    if (!table_ || !(k_ > 0.0f) || sigma * radius_ <= max_tau_) return sigma * radius_;
    const float h = kDecisionOffset * radius_;
    float count = 0.0f;
    for (int c = 0; c < 8; ++c)
        count += count_at(x + Vec3((c & 1) ? h : -h, (c & 2) ? h : -h, (c & 4) ? h : -h));
    count /= 8.0f;
    const float r = crowded(count) ? radius_ * std::cbrt(k_ / count) : radius_;
    return sigma * r;
}

// Σ ΔΦ f(ω·ω_o) = (1/4π) Σ_l (2l+1) a_l Σ ΔΦ P_l(ω·ω_o), P_1 = c, P_2 = (3c² − 1)/2, times 4π.
Color VolumeMapEnd::phase_sum(const Moments& m, const Vec3& o, const PhaseMix& phase) {
    const Color s1 = o.x * m.m1[0] + o.y * m.m1[1] + o.z * m.m1[2];
    const Color s2 = o.x * o.x * m.m2[0] + o.y * o.y * m.m2[1] + o.z * o.z * m.m2[2] +
                     2.0f * (o.x * o.y * m.m2[3] + o.x * o.z * m.m2[4] + o.y * o.z * m.m2[5]);
    const float a1 = phase.legendre(1), a2 = phase.legendre(2);
    return m.m0 + 3.0f * a1 * s1 + 2.5f * a2 * (3.0f * s2 - m.m0);
}

// LeanCorrection (header): ∂E/∂u by central differences of the grid's estimate half a radius
// either side, u the direction in which σ̄_s grows.
Color VolumeMapEnd::lean(const KernelDensity::Corners& c, const Vec3& x, const Color& density,
                         const Vec3& o, const PhaseMix& phase, float rho) const {
    const KernelDensity::Slope slope = density_.slope(c);  // of the channels' summed σ̄_s
    const Vec3& grad = slope.gradient;
    const float sum = slope.value;
    const float length = glm::length(grad);
    // Where the centroid moves less than kLeanMinOffset ρ, the correction is left out.
    if (!(sum > 0.0f) || (rho * rho / 5.0f) * length / sum < kLeanMinOffset * rho)
        return Color(0.0f);
    const Vec3 u = grad / length;
    const float h = 0.5f * radius_;
    Color dp, dm;
    Moments mp, mm;
    if (!interpolate(x + h * u, &dp, &mp) || !interpolate(x - h * u, &dm, &mm)) return Color(0.0f);
    const float volume = (4.0f / 3.0f) * kPi * radius_ * radius_ * radius_;
    const float scale = map_.photon_power * kInvFourPi / volume;
    const Color ep = divide(glm::max(phase_sum(mp, o, phase), Color(0.0f)) * scale, dp);
    const Color em = divide(glm::max(phase_sum(mm, o, phase), Color(0.0f)) * scale, dm);
    Color out(0.0f);
    for (int ch = 0; ch < 3; ++ch) {
        if (!(density[ch] > 0.0f)) continue;
        // The σ_s-weighted centroid's offset along u, at most a half ball's (3/8 ρ).
        const float offset = std::min(
            (rho * rho / 5.0f) * (dp[ch] - dm[ch]) / (2.0f * h) / density[ch], 0.375f * rho);
        out[ch] = (ep[ch] - em[ch]) / (2.0f * h) * offset;
    }
    return out;
}

Color VolumeMapEnd::inscattered(const Vec3& x, const Vec3& dir, const PhaseMix& phase,
                                NeighborList& scratch, Parts* parts) const {
    if (parts) {
        parts->shares.fill(1.0f);
        parts->bias.fill(0.0f);
    }
    // σ̄_s and the photon counts from the grid (its moments too where it holds them).
    Color density(0.0f);
    Moments m;
    KernelDensity::Corners c;
    if (!batched()) parts = nullptr;
    if (!interpolate(x, &density, &m, &c, parts && !batch_power_.empty())) return Color(0.0f);
    // The kd-tree's lookups (no moments) fill the photon halves' centroids for BlurCorrection.
    HalfCentroids halves;
    HalfCentroids* const centroids = interpolates() ? nullptr : &halves;
    // LeanCorrection (header) where the grid holds moments, bounded by half the estimate;
    // BlurCorrection (header) where the lookup searched the kd-tree.
    const auto corrected = [&](const Color& e, float rho) {
        if (!interpolates()) return e / blur_factor(rho, halves, c);
        return e - glm::clamp(lean(c, x, density, -dir, phase, rho), -0.5f * e, 0.5f * e);
    };
    BatchSums sums;
    if (crowded(m.count)) {
        const float rho = radius_ * std::cbrt(k_ / m.count);
        const Color e =
            smaller_ball(x, dir, phase, m.count, scratch, parts ? &sums : nullptr, centroids);
        if (parts) parts_of(sums, kappa(x, rho), parts);
        return corrected(e, rho);
    }
    // σ_s L_i from every photon within the radius (k = 0: the fixed-radius sphere estimate).
    Color collisions(0.0f);
    if (interpolates()) {
        const float volume = (4.0f / 3.0f) * kPi * radius_ * radius_ * radius_;
        collisions = glm::max(phase_sum(m, -dir, phase), Color(0.0f)) *
                     (map_.photon_power * kInvFourPi / volume);
        if (parts && !batch_power_.empty()) parts_of(grid_sums(c), 1.0f, parts);
    } else {
        collisions = volume_inscattered(map_, x, -dir, phase, 0, radius_, scratch,
                                        parts ? &sums : nullptr, centroids);
        if (parts) parts_of(sums, kappa(x, radius_), parts);
    }
    return corrected(divide(collisions, density), radius_);
}

// RadiusBias (header).
float VolumeMapEnd::kappa(const Vec3& x, float rho) const {
    const float inner =
        table_ ? average(table_->cube_average(x, equal_volume_edge(rho * float(M_SQRT1_2)))) : 0.0f;
    if (!(inner > 0.0f)) return kBallKappa;
    const float outer = average(table_->cube_average(x, equal_volume_edge(rho)));
    return kBallKappa * std::min(outer / inner, kMaxSigmaRatio);
}

void VolumeMapEnd::set_table(const SigmaTable* table) {
    FOGMAP_ASSERT(!table_ && table, "a map's table is set once");
    table_ = table;
    if (batch_power_.empty()) return;
    // κ weighs a point's inner power alone: where it holds none, κ is not needed.
    tbb::parallel_for(size_t(0), slot_.size(), [&](size_t n) {
        const int32_t s = slot_[n];
        if (s < 0) return;
        std::array<float, 2>& inner = batch_power_[size_t(s)].inner;
        if (inner[0] != 0.0f || inner[1] != 0.0f) {
            const float ratio = kappa(density_.node_position(n), radius_) / kBallKappa;
            for (float& v : inner) v *= ratio;
        }
    });
}

// PhotonBatches and RadiusBias (header): 2 (E_h(ρ) − E_h(ρ/√2)) over E, E_h(ρ) = E × 2 P_h / P.
void VolumeMapEnd::parts_of(const BatchSums& sums, float kappa, Parts* parts) {
    if (!(sums.total() > 0.0f)) return;
    parts->shares = sums.shares();
    parts->bias = sums.bias(kappa);
}

BatchSums VolumeMapEnd::grid_sums(const KernelDensity::Corners& c) const {
    BatchSums sums;
    for (int n = 0; n < 8; ++n) {
        const int32_t s = slot_[c.node[n]];
        if (s < 0) continue;
        const float w = c.weight[n];
        for (size_t b = 0; b < sums.all.size(); ++b) sums.all[b] += w * batch_power_[s].all[b];
        for (size_t h = 0; h < 2; ++h) sums.inner[h] += w * batch_power_[s].inner[h];
    }
    return sums;
}

// AdaptiveRadius (header): every photon within r (k / n)^⅓, over σ_s averaged on that radius's
// equal-volume cube.
Color VolumeMapEnd::smaller_ball(const Vec3& x, const Vec3& dir, const PhaseMix& phase, float n,
                                 NeighborList& scratch, BatchSums* parts,
                                 HalfCentroids* centroids) const {
    const float r = radius_ * std::cbrt(k_ / n);
    return divide(volume_inscattered(map_, x, -dir, phase, 0, r, scratch, parts, centroids),
                  table_->cube_average(x, equal_volume_edge(r)));
}

// BlurCorrection (header).
float VolumeMapEnd::blur_factor(float rho, const HalfCentroids& halves,
                                const KernelDensity::Corners& c) const {
    if (!(halves.power[0] > 0.0 && halves.power[1] > 0.0)) return 1.0f;
    // |a + b|² ρ² from the halves' centroids' product μ (in ball radii²): the centroid is
    // ρ g(s) along a + b, g(s) = s/5 − s³/175 + …, so s² = 25 μ (1 + 10 μ / 7) to fourth order.
    const double mu =
        glm::dot(halves.moment[0] / halves.power[0], halves.moment[1] / halves.power[1]) /
        (double(rho) * rho);
    const double s2 = 25.0 * mu * (1.0 + 10.0 * mu / 7.0);
    // a = ∇σ̄_s / σ̄_s (the channels summed) from the grid's cell about x: along each axis the
    // log of its two faces' ratio (their values interpolated as x's is) over the cell, exact for
    // an exponential σ_s (whose box averages vary as it does); where a face holds none, the
    // trilinear slope over the value at x.
    const KernelDensity::Slope slope = density_.slope(c);
    if (!(slope.value > 0.0f)) return 1.0f;
    Vec3 gradient = slope.gradient / slope.value;
    for (int axis = 0; axis < 3; ++axis)
        if (slope.upper[axis] > 0.0f && slope.lower[axis] > 0.0f)
            gradient[axis] = std::log(slope.upper[axis] / slope.lower[axis]) / density_.cell();
    const DVec3 a_e = DVec3(gradient * equal_volume_edge(rho));
    // The ball's mean of e^{s u_x} and the cube's of e^{a·u}, each to fourth order.
    double cube = 1.0;
    for (int axis = 0; axis < 3; ++axis) {
        const double t2 = a_e[axis] * a_e[axis] / 4.0;  // (a e / 2)²
        cube *= 1.0 + t2 / 6.0 + t2 * t2 / 120.0;
    }
    const double factor = (1.0 + s2 / 10.0 + s2 * s2 / 280.0) / cube;
    return float(std::clamp(factor, double(kBlurFactorMin), double(kBlurFactorMax)));
}

}  // namespace fogmap
