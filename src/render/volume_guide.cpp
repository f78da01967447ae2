#include "render/volume_guide.h"

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

}  // namespace fogmap
