#include "media/medium.h"

#include "core/error.h"
#include "core/rng.h"

#include <glm/gtc/matrix_inverse.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace fogmap {

namespace {

Mat4 to_float(const DMat4& m) { return Mat4(m); }

Box3 transform_box(const Mat4& m, const Box3& b) {
    Box3 out;
    for (int c = 0; c < 8; ++c) {
        const Vec3 p((c & 1) ? b.hi.x : b.lo.x, (c & 2) ? b.hi.y : b.lo.y,
                     (c & 4) ? b.hi.z : b.lo.z);
        out.extend(transform_point(m, p));
    }
    return out;
}

// -ln(1 - u) in double: the optical depth to the next event of a unit-rate Poisson process.
double sample_optical_depth(Rng& rng) { return -std::log1p(-rng.uniform_double()); }

}  // namespace

Medium Medium::homogeneous(const MediumParams& params, const Box3& bounds_world) {
    Medium m;
    m.params_ = params;
    m.sigma_t_max_ = max_component(m.sigma_t());
    m.world_bounds_ = bounds_world;
    return m;
}

Medium Medium::heterogeneous(const MediumParams& params, std::shared_ptr<const DensityGrid> grid,
                             const Mat4& scene_transform) {
    Medium m;
    m.params_ = params;
    m.sigma_t_max_ = max_component(m.sigma_t());
    m.index_to_world_ = scene_transform * to_float(grid->index_to_world());
    m.world_to_index_ = glm::inverse(m.index_to_world_);
    m.voxel_world_ =
        std::min({glm::length(Vec3(m.index_to_world_[0])), glm::length(Vec3(m.index_to_world_[1])),
                  glm::length(Vec3(m.index_to_world_[2]))});
    if (!grid->empty()) m.world_bounds_ = transform_box(m.index_to_world_, grid->index_bounds());
    m.index_support_ = grid->index_bounds();
    m.grid_ = std::move(grid);
    return m;
}

namespace {

/// `m` with each cell's max (and min) over the cells within `reach` of it along every axis, on a
/// grid grown by `reach` cells each side (min 0 there: empty space): separable, one axis a pass.
MajorantGrid widen(const MajorantGrid& m, int reach) {
    MajorantGrid out;
    out.cell = m.cell;
    for (int a = 0; a < 3; ++a) {
        out.origin[a] = m.origin[a] - reach * m.cell;
        out.dims[a] = m.dims[a] + 2 * reach;
    }
    const size_t n = size_t(out.dims[0]) * out.dims[1] * out.dims[2];
    out.max_density.assign(n, 0.0f);
    out.min_density.assign(n, 0.0f);
    for (int k = 0; k < m.dims[2]; ++k)
        for (int j = 0; j < m.dims[1]; ++j)
            for (int i = 0; i < m.dims[0]; ++i) {
                const size_t at = out.index(i + reach, j + reach, k + reach);
                out.max_density[at] = m.at(i, j, k);
                out.min_density[at] = m.min_at(i, j, k);
            }
    std::vector<float> hi(n), lo(n);
    for (int a = 0; a < 3; ++a) {
        const size_t stride = a == 0   ? 1
                              : a == 1 ? size_t(out.dims[0])
                                       : size_t(out.dims[0]) * out.dims[1];
        for (size_t c = 0; c < n; ++c) {
            const int x = a == 0   ? int(c % out.dims[0])
                          : a == 1 ? int((c / out.dims[0]) % out.dims[1])
                                   : int(c / (size_t(out.dims[0]) * out.dims[1]));
            float h = 0.0f, l = std::numeric_limits<float>::infinity();
            for (int d = std::max(0, x - reach); d <= std::min(out.dims[a] - 1, x + reach); ++d) {
                const size_t o = c + (ptrdiff_t(d) - x) * ptrdiff_t(stride);
                h = std::max(h, out.max_density[o]);
                l = std::min(l, out.min_density[o]);
            }
            hi[c] = h;
            lo[c] = l;
        }
        out.max_density.swap(hi);
        out.min_density.swap(lo);
    }
    return out;
}

}  // namespace

double Medium::max_speed(const std::array<std::shared_ptr<const DensityGrid>, 6>& parts,
                         const Mat4& scene_transform) {
    const Mat3 linear(scene_transform);
    double speed2 = 0.0, stretch2 = 0.0;
    for (int c = 0; c < 3; ++c) {
        const double a = std::max(parts[2 * c]->max_density(), parts[2 * c + 1]->max_density());
        speed2 += a * a;
        stretch2 += double(glm::dot(linear[c], linear[c]));
    }
    return std::sqrt(speed2 * stretch2);
}

void Medium::set_velocity(std::array<std::shared_ptr<const DensityGrid>, 6> parts,
                          const Mat4& scene_transform, float max_seconds) {
    velocity_ = std::move(parts);
    world_to_velocity_index_ =
        glm::inverse(scene_transform * to_float(velocity_[0]->index_to_world()));
    velocity_to_world_ = Mat3(scene_transform);
    max_shift_ = float(max_speed(velocity_, scene_transform) * max_seconds);
    if (!(max_shift_ > 0.0f) || !grid_ || grid_->empty()) return;
    // A lookup moves at most max_shift_: the density anywhere within it of a point bounds the
    // point's at every time.
    const float voxels = std::ceil(max_shift_ / voxel_world_);
    const MajorantGrid& own = grid_->majorants();
    moved_majorants_ = widen(own, int(std::ceil(voxels / float(own.cell))));
    index_support_ = grid_->index_bounds();
    index_support_.lo -= Vec3(voxels);
    index_support_.hi += Vec3(voxels);
    world_bounds_ = transform_box(index_to_world_, index_support_);
}

void Medium::set_emission(Emission emission, const Mat4& scene_transform) {
    emission_ = std::move(emission);
    const DensityGrid* eg = emission_->grid();
    if (eg)
        world_to_emission_index_ = glm::inverse(scene_transform * to_float(eg->index_to_world()));
    emission_cells_.clear();
    emission_cell_begin_.assign(1, 0);
    emission_cdf_.clear();
    unit_local_.clear();
    unit_bounds_.clear();
    unit_cdf_.clear();
    emitted_power_ = emission_bound_power_ = 0.0;
    const float sigma_a_max = max_component(params_.sigma_a);
    double total = 0.0;
    if (!grid_) {  // one cell, one unit: the box, where the bound is exact
        if (world_bounds_.empty()) return;
        const Vec3 e = world_bounds_.extent();
        unit_volume_ = double(e.x) * e.y * e.z;
        const float bound = sigma_a_max * emission_->average_bound(0.0f);
        if (!(bound > 0.0f)) return;
        emission_cells_.push_back(0);
        unit_local_.push_back(0);
        unit_bounds_.push_back(bound);
        unit_cdf_.push_back(bound);
        emission_cell_begin_.push_back(1);
        emission_cdf_.push_back(total = double(bound) * unit_volume_);
    } else {
        if (grid_->empty()) return;
        Sampler s(*this);
        const MajorantGrid& maj = majorants();
        unit_volume_ = std::abs(double(glm::determinant(index_to_world_)));
        const Mat4 index_to_emission = world_to_emission_index_ * index_to_world_;
        // Bound of average(L_e) over the unit cell at density index `lo`: the emission voxels
        // around its image (a trilinear sample is a convex combination of those), or, when that
        // image spans many emission voxels, the emission majorant cells it overlaps.
        auto emission_bound = [&](const Vec3& lo) {
            if (!eg) return emission_->average_bound(0.0f);
            const Box3 b = transform_box(index_to_emission, Box3{lo, lo + Vec3(1.0f)});
            std::array<int, 3> v0{}, v1{};
            double lattice = 1.0;
            for (int a = 0; a < 3; ++a) {
                const float lo_a = std::floor(b.lo[a]), hi_a = std::ceil(b.hi[a]);
                if (!(hi_a >= -2e9f && lo_a <= 2e9f)) return 0.0f;  // far outside any grid
                v0[a] = static_cast<int>(lo_a);
                v1[a] = static_cast<int>(hi_a);
                lattice *= double(v1[a] - v0[a] + 1);
            }
            float v_max = 0.0f;
            if (lattice <= 512.0) {
                for (int z = v0[2]; z <= v1[2]; ++z)
                    for (int y = v0[1]; y <= v1[1]; ++y)
                        for (int x = v0[0]; x <= v1[0]; ++x)
                            v_max = std::max(v_max, s.emission_sampler_->density(Vec3(x, y, z)));
                return emission_->average_bound(v_max);
            }
            const MajorantGrid& em = eg->majorants();
            std::array<int, 3> c0{}, c1{};
            for (int a = 0; a < 3; ++a) {
                c0[a] = std::max(0, (v0[a] - em.origin[a]) / em.cell - 1);
                c1[a] = std::min(em.dims[a] - 1, (v1[a] - em.origin[a]) / em.cell + 1);
                if (c0[a] > c1[a]) return 0.0f;
            }
            for (int k = c0[2]; k <= c1[2]; ++k)
                for (int j = c0[1]; j <= c1[1]; ++j)
                    for (int i = c0[0]; i <= c1[0]; ++i) v_max = std::max(v_max, em.at(i, j, k));
            return emission_->average_bound(v_max);
        };
        constexpr int kC = DensityGrid::kMajorantCell, kE = kC + 1;
        std::array<float, kE * kE * kE> d;  // density at the cell's 9³ voxels
        uint32_t n = 0;
        for (int k = 0; k < maj.dims[2]; ++k)
            for (int j = 0; j < maj.dims[1]; ++j)
                for (int i = 0; i < maj.dims[0]; ++i, ++n) {
                    if (!(maj.max_density[n] > 0.0f)) continue;
                    const Vec3 o(maj.origin[0] + kC * i, maj.origin[1] + kC * j,
                                 maj.origin[2] + kC * k);
                    for (int z = 0; z < kE; ++z)
                        for (int y = 0; y < kE; ++y)
                            for (int x = 0; x < kE; ++x)
                                d[(z * kE + y) * kE + x] =
                                    s.grid_sampler_->density(o + Vec3(x, y, z));
                    float cell_sum = 0.0f;
                    for (int u = 0; u < kC * kC * kC; ++u) {
                        const int x = u % kC, y = (u / kC) % kC, z = u / (kC * kC);
                        // Trilinear inside the unit cell: a convex combination of its corners.
                        float d_max = 0.0f;
                        for (int c = 0; c < 8; ++c)
                            d_max = std::max(
                                d_max,
                                d[((z + (c >> 2)) * kE + y + ((c >> 1) & 1)) * kE + x + (c & 1)]);
                        if (!(d_max > 0.0f)) continue;
                        const float bound = d_max * sigma_a_max * emission_bound(o + Vec3(x, y, z));
                        if (!(bound > 0.0f)) continue;
                        unit_local_.push_back(static_cast<uint16_t>(u));
                        unit_bounds_.push_back(bound);
                        unit_cdf_.push_back(cell_sum += bound);
                    }
                    if (unit_local_.size() == emission_cell_begin_.back()) continue;
                    emission_cells_.push_back(n);
                    emission_cell_begin_.push_back(static_cast<uint32_t>(unit_local_.size()));
                    emission_cdf_.push_back(total += double(cell_sum) * unit_volume_);
                }
    }
    emission_bound_power_ = 4.0 * kPi * total;
    if (emission_cells_.empty()) return;
    // The power: the bound × the mean acceptance probability over kSamples tentative points.
    constexpr int kSamples = 65536;
    Sampler s(*this);
    double accepted = 0.0;
    for (int i = 0; i < kSamples; ++i) {
        Rng rng(stream::kEmissionPower, static_cast<uint64_t>(i));
        float bound;
        const Vec3 p = s.emission_point(rng, &bound);
        accepted += average(s.density(p) * params_.sigma_a * s.emission(p)) / double(bound);
    }
    emitted_power_ = emission_bound_power_ * accepted / kSamples;
}

Medium::Sampler::Sampler(const Medium& medium) : medium_(&medium) {
    if (medium.grid_) grid_sampler_.emplace(*medium.grid_);
    if (medium.emission_ && medium.emission_->grid())
        emission_sampler_.emplace(*medium.emission_->grid());
    for (size_t c = 0; c < 3 && medium.colour_[c]; ++c)
        colour_sampler_[c].emplace(*medium.colour_[c]);
    for (size_t c = 0; c < 6 && medium.velocity_[c]; ++c)
        if (medium.velocity_[c]->max_density() > 0.0f) {
            velocity_sampler_[c].emplace(*medium.velocity_[c]);
            moving_ = true;
        }
}

Vec3 Medium::Sampler::velocity(const Vec3& p_world) {
    const Vec3 q = transform_point(medium_->world_to_velocity_index_, p_world);
    Vec3 v(0.0f);
    for (int c = 0; c < 6; ++c)
        if (velocity_sampler_[size_t(c)])
            v[c / 2] += (c % 2 ? -1.0f : 1.0f) * velocity_sampler_[size_t(c)]->density(q);
    return medium_->velocity_to_world_ * v;
}

Color Medium::Sampler::coloured_sigma_s(const Vec3& p_world) {
    const Vec3 q = transform_point(medium_->world_to_colour_index_, moved(p_world));
    const Color colour(colour_sampler_[0]->density(q), colour_sampler_[1]->density(q),
                       colour_sampler_[2]->density(q));
    return medium_->params_.sigma_s * colour;
}

void Medium::set_colour(std::array<std::shared_ptr<const DensityGrid>, 3> channels,
                        const Mat4& scene_transform) {
    colour_ = std::move(channels);
    world_to_colour_index_ = glm::inverse(scene_transform * to_float(colour_[0]->index_to_world()));
}

float Medium::Sampler::density(const Vec3& p_world) {
    ++steps_;
    if (!grid_sampler_) return medium_->world_bounds_.contains(p_world) ? 1.0f : 0.0f;
    return grid_sampler_->density(transform_point(medium_->world_to_index_, moved(p_world)));
}

Color Medium::Sampler::emission(const Vec3& p_world) {
    const Medium& m = *medium_;
    if (!m.emission_) return Color(0.0f);
    if (!emission_sampler_) return m.emission_->radiance_of_value(0.0f);
    return m.emission_->radiance_of_value(
        emission_sampler_->density(transform_point(m.world_to_emission_index_, moved(p_world))));
}

Vec3 Medium::Sampler::emission_point(Rng& rng, float* bound) {
    const Medium& m = *medium_;
    const auto pick = [](auto begin, auto end, double u) {  // the first entry above u
        return static_cast<size_t>(std::min(std::upper_bound(begin, end, u), end - 1) - begin);
    };
    const size_t cell = pick(m.emission_cdf_.begin(), m.emission_cdf_.end(),
                             rng.uniform_double() * m.emission_cdf_.back());
    const auto units = m.unit_cdf_.begin() + m.emission_cell_begin_[cell];
    const auto units_end = m.unit_cdf_.begin() + m.emission_cell_begin_[cell + 1];
    const size_t unit = m.emission_cell_begin_[cell] +
                        pick(units, units_end, rng.uniform_double() * *(units_end - 1));
    *bound = m.unit_bounds_[unit];
    const Vec3 q(rng.uniform(), rng.uniform(), rng.uniform());
    if (!m.grid_) return m.world_bounds_.lo + q * m.world_bounds_.extent();
    const MajorantGrid& maj = m.majorants();
    const uint32_t n = m.emission_cells_[cell];
    const int u = m.unit_local_[unit], kC = maj.cell;
    const Vec3 cell_index(n % maj.dims[0], (n / maj.dims[0]) % maj.dims[1],
                          n / (uint32_t(maj.dims[0]) * maj.dims[1]));
    const Vec3 p_index = Vec3(maj.origin[0], maj.origin[1], maj.origin[2]) +
                         float(kC) * cell_index + Vec3(u % kC, (u / kC) % kC, u / (kC * kC)) + q;
    return transform_point(m.index_to_world_, p_index);
}

bool Medium::Sampler::sample_emission(Rng& rng, Vec3* p_world, Color* color) {
    const Medium& m = *medium_;
    if (m.emission_cells_.empty()) return false;
    float bound;
    const float time = time_s_;
    time_s_ = 0.0f;  // the tables bound the medium at rest
    const Vec3 p = emission_point(rng, &bound);
    const Color f = density(p) * m.params_.sigma_a * emission(p);
    time_s_ = time;
    const float a = average(f);
    if (!(a > 0.0f) || rng.uniform() * bound >= a) return false;
    *p_world = moving_ && time != 0.0f ? p + velocity(p) * time : p;
    *color = f / a;
    return true;
}

bool Medium::Sampler::begin_walk(const Ray& ray, float t0, float t1, bool residual) {
    walking_ = false;
    exhausted_ = false;
    tentatives_ = 0;
    residual_ = residual;
    control_length_ = 0.0;
    const Medium& m = *medium_;
    if (m.sigma_t_max_ <= 0.0f || m.world_bounds_.empty()) return false;
    if (!grid_sampler_) {  // density 1 in the box: min = max = 1
        float te, tx;
        if (!intersect_box(m.world_bounds_, ray, t0, t1, &te, &tx)) return false;
        seg_t0_ = te;
        seg_t1_ = tx;
        seg_maj_ = residual ? 0.0f : m.sigma_t_max_;
        seg_min_ = 1.0f;
        if (residual) control_length_ = double(tx) - double(te);
        return true;
    }
    // Heterogeneous: walk the majorant cells in index space; t is shared with world space
    // because the map is affine.
    const MajorantGrid& maj = m.majorants();
    const Ray r{transform_point(m.world_to_index_, ray.o),
                transform_vector(m.world_to_index_, ray.d)};
    Box3 cells;
    for (int a = 0; a < 3; ++a) {
        cells.lo[a] = static_cast<float>(maj.origin[a]);
        cells.hi[a] = static_cast<float>(maj.origin[a] + maj.dims[a] * maj.cell);
    }
    // The walk covers the density's support (active bbox grown by one voxel), not whole cells:
    // boundary cells reach up to 7 voxels beyond it, where the density is 0 but the cell's
    // majorant is not, and at high density (scale 1e9) that empty stretch alone costs ~1e9 null
    // collisions per ray.
    float te, tx;
    if (!intersect_box(m.index_support_, r, t0, t1, &te, &tx)) return false;
    const Vec3 p = r.at(0.5f * (te + std::min(tx, te + 1e-3f)));  // a point inside the first cell
    for (int a = 0; a < 3; ++a) {
        const float rel = (p[a] - cells.lo[a]) / static_cast<float>(maj.cell);
        cell_[a] = std::clamp(static_cast<int>(std::floor(rel)), 0, maj.dims[a] - 1);
        if (r.d[a] > 0.0f) {
            step_[a] = 1;
            t_next_[a] = (double(cells.lo[a]) + (cell_[a] + 1) * maj.cell - r.o[a]) / r.d[a];
            t_delta_[a] = maj.cell / double(r.d[a]);
        } else if (r.d[a] < 0.0f) {
            step_[a] = -1;
            t_next_[a] = (double(cells.lo[a]) + cell_[a] * maj.cell - r.o[a]) / r.d[a];
            t_delta_[a] = -maj.cell / double(r.d[a]);
        } else {
            step_[a] = 0;
            t_next_[a] = std::numeric_limits<double>::infinity();
            t_delta_[a] = std::numeric_limits<double>::infinity();
        }
    }
    seg_t1_ = te;  // next_segment() starts where the previous segment ended
    t_end_ = tx;
    walking_ = true;
    return next_segment();
}

bool Medium::Sampler::next_segment() {
    if (!walking_ || seg_t1_ >= t_end_) return walking_ = false;
    const MajorantGrid& maj = medium_->majorants();
    int axis = 0;
    if (t_next_[1] < t_next_[axis]) axis = 1;
    if (t_next_[2] < t_next_[axis]) axis = 2;
    seg_t0_ = seg_t1_;
    seg_t1_ = std::min(std::max(t_next_[axis], seg_t0_), t_end_);
    const float d_max = maj.at(cell_[0], cell_[1], cell_[2]);
    if (residual_) {
        seg_min_ = maj.min_at(cell_[0], cell_[1], cell_[2]);
        seg_maj_ = (d_max - seg_min_) * medium_->sigma_t_max_;
        control_length_ += double(seg_min_) * (seg_t1_ - seg_t0_);
    } else {
        seg_maj_ = d_max * medium_->sigma_t_max_;
    }
    cell_[axis] += step_[axis];
    t_next_[axis] += t_delta_[axis];
    if (cell_[axis] < 0 || cell_[axis] >= maj.dims[axis]) t_end_ = seg_t1_;  // left the grid
    return true;
}

bool Medium::Sampler::next_tentative(Rng& rng, float* t, float* sigma_maj) {
    ++steps_;
    if (++tentatives_ > kMaxTentatives) {  // bounded work; see kMaxTentatives
        if (!exhausted_) ++exhausted_walks_;
        exhausted_ = true;
        walking_ = false;
        return false;
    }
    double tau = sample_optical_depth(rng);
    for (;;) {
        if (seg_maj_ > 0.0f) {
            const double dt = tau / seg_maj_;
            if (seg_t0_ + dt < seg_t1_) {
                seg_t0_ += dt;
                *t = static_cast<float>(seg_t0_);
                *sigma_maj = seg_maj_;
                return true;
            }
            tau -= static_cast<double>(seg_maj_) * (seg_t1_ - seg_t0_);
        }
        if (!next_segment()) return false;
    }
}

MergedWalks::MergedWalks(std::vector<Medium::Sampler>& media, const Ray& ray, float t0, float t1,
                         Rng& rng)
    : n(static_cast<int>(media.size())) {
    FOGMAP_ASSERT(n <= kMaxMedia, "too many media");
    for (int i = 0; i < n; ++i) {
        t_next[i] = kInfinity;
        if (media[i].begin_walk(ray, t0, t1) && !media[i].next_tentative(rng, &t_next[i], &mu[i]))
            t_next[i] = kInfinity;
    }
}

int MergedWalks::next() const {
    int i = -1;
    for (int k = 0; k < n; ++k)
        if (t_next[k] < kInfinity && (i < 0 || t_next[k] < t_next[i])) i = k;
    return i;
}

TrackResult delta_track(std::vector<Medium::Sampler>& media, const Ray& ray, float t_max, Rng& rng,
                        Color* beta, Collision collision, Color* emitted) {
    MergedWalks w(media, ray, 0.0f, t_max, rng);
    auto& t_next = w.t_next;
    auto& mu = w.mu;
    for (;;) {
        const int i = w.next();
        if (i < 0) return {};
        const float t = t_next[i];
        const MediumParams& p = media[i].medium().params();
        const Vec3 x = ray.at(t);
        const float d = media[i].density(x);
        // Absorption gains the scattering a colour takes (0 without one: the same bits).
        const Color s_unit = media[i].sigma_s_unit(x);
        const Color sigma_s = d * s_unit, sigma_a = d * (p.sigma_a + (p.sigma_s - s_unit));
        const float m = mu[i];
        if (emitted && d > 0.0f && media[i].medium().emission())
            *emitted += *beta * (d * p.sigma_a) * media[i].emission(x) / m;
        const float u = rng.uniform();
        float p_null;
        if (collision == Collision::Analog) {
            const float p_a = average(sigma_a) / m, p_s = average(sigma_s) / m;
            if (u < p_a) return {TrackEvent::Absorbed, t, i};
            if (u < p_a + p_s) {
                *beta *= sigma_s / (m * p_s);
                return {TrackEvent::Scattered, t, i};
            }
            p_null = 1.0f - p_a - p_s;
        } else {
            const float p_t = average(sigma_s + sigma_a) / m;
            if (u < p_t) {
                *beta *= sigma_s / (m * p_t);  // the albedo, per channel
                return {TrackEvent::Scattered, t, i};
            }
            p_null = 1.0f - p_t;
        }
        // Null collision: weight (μ − σ_t)/(μ p_n), exactly 1 for grey media.
        if (p_null > 0.0f)
            *beta *= glm::max(Color(m) - sigma_s - sigma_a, Color(0.0f)) / (m * p_null);
        if (!media[i].next_tentative(rng, &t_next[i], &mu[i])) {
            if (media[i].exhausted()) return {TrackEvent::Absorbed, t, i};  // opaque: see header
            t_next[i] = kInfinity;
        }
    }
}

InscatterPick ratio_track_pick(std::vector<Medium::Sampler>& media, const Ray& ray, float t_max,
                               Rng& rng, Color* emitted) {
    MergedWalks w(media, ray, 0.0f, t_max, rng);
    auto& t_next = w.t_next;
    auto& mu = w.mu;
    InscatterPick pick;
    Color& T = pick.transmittance;
    Color a_pick(0.0f);
    float sum = 0.0f;  // Σ average(a_j)
    for (;;) {
        const int i = w.next();
        if (i < 0) break;
        const float t = t_next[i], m = mu[i];
        const MediumParams& p = media[i].medium().params();
        const float d = media[i].density(ray.at(t));
        if (d > 0.0f) {
            if (emitted && media[i].medium().emission())
                *emitted += T * d * p.sigma_a * media[i].emission(ray.at(t)) / m;
            const Color a = T * d * media[i].sigma_s_unit(ray.at(t)) / m;
            const float wa = average(a);
            if (wa > 0.0f) {
                sum += wa;
                if (rng.uniform() * sum < wa) {  // reservoir: t_i kept with probability wa / sum
                    a_pick = a;
                    pick.t = t;
                    pick.medium = i;
                }
            }
            T *= glm::max(Color(1.0f) - (d / m) * (p.sigma_s + p.sigma_a), Color(0.0f));
            const float tmax = max_component(T);
            if (tmax <= 0.0f) break;
            if (tmax < 0.1f) {  // Russian roulette, as ratio_track
                if (rng.uniform() < 0.5f) {
                    T = Color(0.0f);
                    break;
                }
                T *= 2.0f;
            }
        }
        if (!media[i].next_tentative(rng, &t_next[i], &mu[i])) {
            if (media[i].exhausted()) {  // opaque at every resolved scale: see header
                T = Color(0.0f);
                break;
            }
            t_next[i] = kInfinity;
        }
    }
    if (pick.medium >= 0) pick.weight = a_pick * (sum / average(a_pick));
    return pick;
}

Color ratio_track(std::vector<Medium::Sampler>& media, const Ray& ray, float t_max, Rng& rng) {
    Color T(1.0f);     // the residual's ratio-tracking product
    DVec3 tau_c(0.0);  // the control's optical depth, exact
    for (Medium::Sampler& s : media) {
        if (!s.begin_walk(ray, 0.0f, t_max, /*residual=*/true)) continue;
        const Color sigma_t_unit = s.medium().sigma_t();
        float t, m;
        while (s.next_tentative(rng, &t, &m)) {
            // Residual σ_t − σ_c against its majorant m = (d_max − d_min) · max σ_t.
            const float residual = s.density(ray.at(t)) - s.control_density();
            T *= glm::max(Color(1.0f) - (residual / m) * sigma_t_unit, Color(0.0f));
            const float tmax = max_component(T);
            if (tmax <= 0.0f) return Color(0.0f);
            if (tmax < 0.1f) {  // Russian roulette keeps thick media affordable, unbiased
                if (rng.uniform() < 0.5f) return Color(0.0f);
                T *= 2.0f;
            }
        }
        if (s.exhausted()) return Color(0.0f);  // opaque at every resolved scale: see header
        tau_c += DVec3(sigma_t_unit) * s.control_density_length();
    }
    return T * Color(glm::exp(-tau_c));
}

Color sigma_s_at(std::vector<Medium::Sampler>& media, const Vec3& p) {
    Color s(0.0f);
    for (Medium::Sampler& m : media) s += m.density(p) * m.sigma_s_unit(p);
    return s;
}

}  // namespace fogmap
