#include "render/volume_gather.h"

#include "core/sampling.h"
#include "media/phase.h"
#include "photon/estimators.h"
#include "scene/shadow.h"

#include <algorithm>
#include <cmath>
#include <optional>

namespace fogmap {

namespace {

// The step holding t, or the first step after t (t in a gap between media); null past the last.
const MarchedStep* step_at(const std::vector<MarchedStep>& steps, float t) {
    const auto it = std::upper_bound(steps.begin(), steps.end(), t,
                                     [](float v, const MarchedStep& s) { return v < s.t1; });
    return it == steps.end() ? nullptr : &*it;
}

}  // namespace

VolumeGather::VolumeGather(const Scene& scene, const MarchSettings& march,
                           const GatherParams& gather, const PhotonMap* map, const BeamTree* beam,
                           const PhotonBeams* beams)
    : scene_(scene),
      marcher_(scene.media, march),
      map_(map),
      beam_(gather.estimator == VolumeEstimator::Beam ? beam : nullptr),
      beams_(gather.estimator == VolumeEstimator::PhotonBeams ? beams : nullptr),
      k_(gather.volume.fixed_radius ? 0 : gather.volume.k),
      radius_(gather.volume.radius),
      lookups_per_ray_(gather.lookups_per_ray),
      light_samples_(gather.light_samples) {}

VolumeGather::State VolumeGather::make_state() const {
    State st;
    for (const Medium& m : scene_.media) st.media.emplace_back(m);
    return st;
}

Color VolumeGather::march(const Ray& ray, float t_max, const Color& beta, float jitter,
                          State& st) const {
    Color tau(0.0f);
    st.steps.clear();
    st.emitted = Color(0.0f);
    marcher_.march(st.media, ray, t_max, jitter, [&](const MarchStep& s) {
        const float h = s.t1 - s.t0;
        st.steps.push_back({s.t0, s.t1, s.x, tau, s.sigma_t, s.sigma_s,
                            beta * exp_neg(tau) * step_weight(s.sigma_t, h)});
        st.emitted += st.steps.back().weight * s.emission;
        tau += s.sigma_t * h;
        return max_component(exp_neg(tau)) > 1e-6f;  // nothing visible beyond
    });
    return tau;
}

Color VolumeGather::scatter_light(const Light& light, const Vec3& x, const Vec3& dir, Rng& rng,
                                  State& st) const {
    const LightSample s = sample_light(light, x, Vec2(rng.uniform(), rng.uniform()));
    if (s.pdf <= 0.0f || max_component(s.Li) <= 0.0f) return Color(0.0f);
    const Color T = shadow_transmittance(scene_, st.media, Ray{x, s.wi},
                                         s.dist * (1.0f - kShadowRayEpsilon), rng, &st.rays);
    return PhaseMix(st.media, x).eval(glm::dot(dir, s.wi)) * s.Li * T / s.pdf;
}

// ∫ β T(t) σ_s(t) L_s(t) dt with σ held constant per step, from light_samples points per light and
// strategy: (a) a step drawn ∝ q_k = luminance(weight_k σ_s,k) by stratified sampling, then t
// within it ∝ e^{−σ̄ (t − t0)}; (b) for point and spot lights, t drawn equi-angularly, pdf
// D / ((θ_b − θ_a)(D² + (t − Δ)²)) — the 1/r² of a light inside or beside the medium, where (a)
// puts few points near the light. Balance heuristic: each point weighs f / (m Σ_s p_s).
// 0 samples: a shadow ray at every step.
Color VolumeGather::single_scattering(const Ray& ray, const Color& beta, Rng& rng,
                                      State& st) const {
    const std::vector<MarchedStep>& steps = st.steps;
    Color sum(0.0f);
    if (steps.empty()) return sum;
    const int m = light_samples_;
    if (m == 0) {
        for (const MarchedStep& s : steps) {
            if (max_component(s.sigma_s) <= 0.0f) continue;
            for (const Light& light : scene_.lights)
                sum += s.weight * s.sigma_s * scatter_light(light, s.x, ray.d, rng, st);
        }
        return sum;
    }
    std::vector<double>& cdf = st.cdf;
    cdf.clear();
    double total = 0.0;
    for (const MarchedStep& s : steps) cdf.push_back(total += luminance(s.weight * s.sigma_s));
    if (!(total > 0.0)) return sum;

    auto within_pdf = [](const MarchedStep& s, float t) {
        const float sigma = average(s.sigma_t), h = s.t1 - s.t0;
        return sigma * h < 1e-4f ? 1.0f / h
                                 : sigma * std::exp(-sigma * (t - s.t0)) / -std::expm1(-sigma * h);
    };
    auto steps_pdf = [&](const MarchedStep& s, float t) {
        const size_t k = static_cast<size_t>(&s - steps.data());
        const double q = cdf[k] - (k > 0 ? cdf[k - 1] : 0.0);
        return static_cast<float>(q / total) * within_pdf(s, t);
    };
    auto radiance_at = [&](const Light& light, const MarchedStep& s, float t) {
        const Vec3 x = ray.o + t * ray.d;
        const Color T = exp_neg(s.tau0 + s.sigma_t * (t - s.t0));
        return beta * T * s.sigma_s * scatter_light(light, x, ray.d, rng, st);
    };
    const float ta = steps.front().t0, tb = steps.back().t1;
    for (const Light& light : scene_.lights) {
        std::optional<EquiAngular> equi;
        if (light.type == LightType::Point || light.type == LightType::Spot) {
            equi.emplace(ray, light.position, ta, tb);
            if (!equi->valid()) equi.reset();
        }
        auto equi_pdf = [&](float t) { return equi ? equi->pdf(t) : 0.0f; };
        for (int j = 0; j < m; ++j) {
            const double target = (j + rng.uniform()) * total / m;
            const size_t k = std::min<size_t>(
                std::lower_bound(cdf.begin(), cdf.end(), target) - cdf.begin(), steps.size() - 1);
            const MarchedStep& s = steps[k];
            const float sigma = average(s.sigma_t), h = s.t1 - s.t0, u = rng.uniform();
            float t = sigma * h < 1e-4f ? s.t0 + u * h
                                        : s.t0 - std::log1p(u * std::expm1(-sigma * h)) / sigma;
            t = std::clamp(t, s.t0, s.t1);
            const float p = steps_pdf(s, t) + equi_pdf(t);
            if (p > 0.0f) sum += radiance_at(light, s, t) / (m * p);
            if (!equi) continue;
            const float te = equi->sample((j + rng.uniform()) / m);
            const MarchedStep* it = step_at(steps, te);
            if (!it || te < it->t0) continue;  // in a gap without medium
            const float pe = steps_pdf(*it, te) + equi_pdf(te);
            if (pe > 0.0f) sum += radiance_at(light, *it, te) / (m * pe);
        }
    }
    return sum;
}

Color VolumeGather::multiple_scattering(const Ray& ray, const Color& beta, Rng& rng, State& st,
                                        BatchSums* batches) const {
    if (st.steps.empty() || !map_) return Color(0.0f);
    if (beams_) return beta * photon_beam_estimate(ray, st);
    return beam_ ? beta * beam_estimate(ray, st, batches)
                 : sphere_estimate(ray.d, rng, st, batches);
}

// The sphere estimate (smooth along the ray): m = lookups_per_ray volume-map lookups at steps
// drawn by stratified importance sampling ∝ q_k = luminance(weight) over the steps with σ_s > 0 —
// the transmittance-weighted step length, not σ_s(x_k): the estimate is a blurred density,
// nonzero where σ_s(x_k) is small, and weighting by σ_s(x_k) made such steps rare and their picks
// bright. Each pick weighs Q / (m q_k), so the expectation is the full march sum.
Color VolumeGather::sphere_estimate(const Vec3& dir, Rng& rng, State& st,
                                    BatchSums* batches) const {
    Color sum(0.0f);
    auto gather = [&](const MarchedStep& s, float factor) {
        ++st.lookups;
        BatchSums parts;
        const Color c = factor * s.weight *
                        volume_inscattered(*map_, s.x, -dir, PhaseMix(st.media, s.x), k_, radius_,
                                           st.neighbors, batches ? &parts : nullptr);
        sum += c;
        st.gathered += st.neighbors.size();
        if (batches) batches->add_scaled(parts, average(c), kBallKappa);  // in the sum's unit
    };
    const std::vector<MarchedStep>& steps = st.steps;
    const size_t m = static_cast<size_t>(lookups_per_ray_);
    std::vector<double>& cdf = st.cdf;
    cdf.clear();
    double total = 0.0;
    for (const MarchedStep& s : steps)
        cdf.push_back(total += max_component(s.sigma_s) > 0.0f ? luminance(s.weight) : 0.0);
    if (m == 0 || steps.size() <= m) {
        for (const MarchedStep& s : steps)
            if (max_component(s.sigma_s) > 0.0f) gather(s, 1.0f);
        return sum;
    }
    if (!(total > 0.0)) return sum;
    for (size_t j = 0; j < m; ++j) {
        const double target = (j + rng.uniform()) * total / m;
        const size_t k = std::min<size_t>(
            std::lower_bound(cdf.begin(), cdf.end(), target) - cdf.begin(), steps.size() - 1);
        const double q = cdf[k] - (k > 0 ? cdf[k - 1] : 0.0);
        if (q > 0.0) gather(steps[k], static_cast<float>(total / (m * q)));
    }
    return sum;
}

// Σ_p p(θ_p) ΔΦ_p T(0, t_p) K(d_p) over the photons whose spheres the marched segment crosses,
// T from the march's own optical-depth table (the heterogeneous medium itself).
Color VolumeGather::beam_estimate(const Ray& ray, State& st, BatchSums* batches) const {
    const std::vector<MarchedStep>& depth = st.steps;
    const float t0 = depth.front().t0, t1 = depth.back().t1;
    const bool one_medium = st.media.size() == 1;
    const PhaseMix single(st.media, ray.o);  // with one medium the same everywhere
    Color sum(0.0f);
    // With the kernel over r/√2 for RadiusBias, wanted or not (a call apart was not inlined).
    beam_->for_each_hit<true>(
        ray, t0, t1, [&](const BeamTree::Record& p, float t, float kernel, float inner) {
            ++st.lookups;
            // τ stays at the previous step's end in the gap before a step.
            const MarchedStep* it = step_at(depth, t);
            if (!it) return;
            const Color tau = it->tau0 + it->sigma_t * std::max(0.0f, t - it->t0);
            const float phase =
                one_medium ? single.eval(glm::dot(p.direction, -ray.d))
                           : PhaseMix(st.media, p.position).eval(glm::dot(p.direction, -ray.d));
            const Color c = phase * kernel * exp_neg(tau) * p.power;
            sum += c;
            if (batches)  // RadiusBias: the photon's kernel over r/√2, normalised (κ 1)
                batches->add(p.batch, average(c), average(c) * inner / kernel);
        });
    return sum * map_->photon_power;
}

// Σ_b Φ_b σ_s(t_b) f(θ_b) T(0, t_b) chord_b / (π r²) over the beam pieces whose cylinders the
// marched segment crosses (photon/photon_beams.h), t_b the chord's point closest to the beam, σ_s
// and T from the march's own table (σ held constant per step; nothing scatters in the gaps
// between media).
Color VolumeGather::photon_beam_estimate(const Ray& ray, State& st) const {
    const std::vector<MarchedStep>& depth = st.steps;
    const float t0 = depth.front().t0, t1 = depth.back().t1;
    const bool one_medium = st.media.size() == 1;
    const PhaseMix single(st.media, ray.o);  // with one medium the same everywhere
    Color sum(0.0f);
    beams_->for_each_hit(ray, t0, t1, [&](const PhotonBeams::Piece& p, float t, float kernel) {
        ++st.lookups;
        const MarchedStep* it = step_at(depth, t);
        if (!it || t < it->t0) return;  // past the march, or in a gap between media
        const Color tau = it->tau0 + it->sigma_t * (t - it->t0);
        const float cos_theta = glm::dot(p.dir, -ray.d);
        const float phase = one_medium ? single.eval(cos_theta)
                                       : PhaseMix(st.media, ray.o + t * ray.d).eval(cos_theta);
        sum += phase * kernel * it->sigma_s * exp_neg(tau) * p.power;
    });
    return sum * map_->photon_power;
}

}  // namespace fogmap
