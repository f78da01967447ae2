#include "render/volume_guide.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace fogmap {

namespace {

/// vMF density on the sphere, κ / (2π (1 − e^{−2κ})) e^{κ (cos − 1)}: finite for large κ.
float vmf_pdf(float kappa, float cos) {
    return kappa / (kTwoPi * -std::expm1(-2.0f * kappa)) * std::exp(kappa * (cos - 1.0f));
}

/// A direction ~ vMF(axis, κ): cos = 1 + ln(ξ + (1 − ξ) e^{−2κ}) / κ (Wenzel Jakob's note).
Vec3 vmf_sample(const Vec3& axis, float kappa, Vec2 u) {
    const float cos = std::clamp(
        1.0f + std::log(u.x + (1.0f - u.x) * std::exp(-2.0f * kappa)) / kappa, -1.0f, 1.0f);
    const float sin = std::sqrt(std::max(0.0f, 1.0f - cos * cos));
    const float phi = kTwoPi * u.y;
    return glm::normalize(to_world(Vec3(sin * std::cos(phi), sin * std::sin(phi), cos), axis));
}

}  // namespace

VolumeGuide::VolumeGuide(const PhotonMap& map, const GuideSettings& settings)
    : map_(map), settings_(settings) {}

void VolumeGuide::prepare(const Vec3& x, const Vec3& dir, const PhaseMix& phase,
                          NeighborList& scratch, GuideLobes* lobes) const {
    lobes->axis.clear();
    lobes->cdf.clear();
    map_.tree.knn(x, settings_.k, settings_.radius, &scratch);
    const std::vector<Photon>& photons = map_.tree.records();
    float total = 0.0f;
    for (size_t i = 0; i < scratch.size(); ++i) {
        const Photon& p = photons[scratch[i].index];
        const Vec3 from = -p.direction();  // where this photon's light came from
        const float w = average(p.power()) * phase.eval(glm::dot(dir, from));
        if (!(w > 0.0f)) continue;
        total += w;
        lobes->axis.push_back(from);
        lobes->cdf.push_back(total);
    }
    if (!(total > 0.0f)) {
        lobes->axis.clear();
        lobes->cdf.clear();
        return;
    }
    for (float& c : lobes->cdf) c /= total;
}

float VolumeGuide::guide_pdf(const GuideLobes& lobes, const Vec3& w) const {
    float sum = 0.0f, previous = 0.0f;
    for (size_t j = 0; j < lobes.axis.size(); ++j) {
        sum += (lobes.cdf[j] - previous) * vmf_pdf(settings_.kappa, glm::dot(lobes.axis[j], w));
        previous = lobes.cdf[j];
    }
    return sum;
}

float VolumeGuide::pdf(const GuideLobes& lobes, const PhaseMix& phase, const Vec3& dir,
                       const Vec3& w) const {
    const float p_phase = phase.eval(glm::dot(dir, w));
    if (lobes.empty()) return p_phase;
    const float a = settings_.phase_fraction;
    return a * p_phase + (1.0f - a) * guide_pdf(lobes, w);
}

Vec3 VolumeGuide::sample(const GuideLobes& lobes, const PhaseMix& phase, const Vec3& dir, Rng& rng,
                         float* pdf_out) const {
    Vec3 w;
    if (lobes.empty() || rng.uniform() < settings_.phase_fraction) {
        float unused;
        w = phase.sample(dir, rng, &unused);
    } else {
        const float u = rng.uniform();
        const size_t j = std::min<size_t>(
            std::lower_bound(lobes.cdf.begin(), lobes.cdf.end(), u) - lobes.cdf.begin(),
            lobes.axis.size() - 1);
        w = vmf_sample(lobes.axis[j], settings_.kappa, Vec2(rng.uniform(), rng.uniform()));
    }
    *pdf_out = pdf(lobes, phase, dir, w);
    return w;
}

AdjointGrid::AdjointGrid(const PhotonMap& map, const std::vector<Medium>& media, float cell) {
    Box3 bounds;
    for (const Medium& m : media) bounds.extend(m.world_bounds());
    if (bounds.empty() || !(cell > 0.0f) || map.tree.empty()) return;
    const Vec3 extent = bounds.extent();
    cell_ = capped_cell(extent, cell, kMaxCells);
    for (;;) {  // the cells' ceilings may still exceed the cap
        for (int a = 0; a < 3; ++a) dims_[a] = std::max(1, int(std::ceil(extent[a] / cell_)));
        if (size_t(dims_[0]) * dims_[1] * dims_[2] <= kMaxCells) break;
        cell_ *= 1.05f;
    }
    origin_ = bounds.lo;
    const size_t cells = size_t(dims_[0]) * dims_[1] * dims_[2];
    std::vector<Color> power(cells, Color(0.0f));
    std::vector<int> count(cells, 0);
    mean_dir_.assign(cells, Vec3(0.0f));
    for (const Photon& p : map.tree.records()) {
        size_t i;
        if (!cell_of(p.position(), &i)) continue;
        power[i] += p.power();
        mean_dir_[i] += average(p.power()) * p.direction();
        ++count[i];
    }
    values_.assign(cells, Color(0.0f));
    const float volume = cell_ * cell_ * cell_;
    constexpr int kCellPoints = kPoints * kPoints * kPoints;
    // Each cell on its own: the same values whatever the threads.
    tbb::parallel_for(tbb::blocked_range<size_t>(0, cells), [&](const auto& range) {
        std::vector<Medium::Sampler> samplers;
        for (const Medium& m : media) samplers.emplace_back(m);
        for (size_t i = range.begin(); i != range.end(); ++i) {
            if (count[i] < kMinPhotons) continue;
            const Vec3 corner(float(i % dims_[0]), float(i / dims_[0] % dims_[1]),
                              float(i / (size_t(dims_[0]) * dims_[1])));
            Color sigma_s(0.0f);
            for (int o = 0; o < kCellPoints; ++o) {
                const Vec3 in_cell(o % kPoints, o / kPoints % kPoints, o / (kPoints * kPoints));
                sigma_s += sigma_s_at(
                    samplers, origin_ + cell_ * (corner + (in_cell + 0.5f) / float(kPoints)));
            }
            sigma_s *= 1.0f / float(kCellPoints);
            if (average(power[i]) > 0.0f) mean_dir_[i] /= average(power[i]);
            for (int c = 0; c < 3; ++c)
                if (sigma_s[c] > 0.0f)
                    values_[i][c] =
                        power[i][c] * map.photon_power * kInvFourPi / (volume * sigma_s[c]);
        }
    });
    const size_t counted =
        size_t(std::count_if(count.begin(), count.end(), [](int n) { return n >= kMinPhotons; }));
    evaluations_ = counted * kCellPoints * media.size();
}

bool AdjointGrid::cell_of(const Vec3& x, size_t* index) const {
    const Vec3 u = (x - origin_) / cell_;
    int c[3];
    for (int a = 0; a < 3; ++a) {
        if (!(u[a] >= 0.0f)) return false;
        c[a] = int(u[a]);
        if (c[a] >= dims_[a]) return false;
    }
    *index = (size_t(c[2]) * dims_[1] + c[1]) * dims_[0] + c[0];
    return true;
}

Color AdjointGrid::at(const Vec3& x, const Vec3& dir, const PhaseMix& phase) const {
    size_t i;
    if (values_.empty() || !cell_of(x, &i)) return Color(0.0f);
    return values_[i] *
           std::max(0.0f, 1.0f + 3.0f * phase.legendre(1) * glm::dot(-dir, mean_dir_[i]));
}

}  // namespace fogmap
