#include "render/photon_integrator.h"

#include "core/timer.h"
#include "media/henyey_greenstein.h"
#include "photon/estimators.h"
#include "render/camera.h"
#include "core/sampling.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace fogmap {

namespace {

constexpr float kGatherNormalCos = 0.9f;  // irradiance points count only on like-facing surfaces

}  // namespace

// Irradiance at every fourth global photon, with the photon's surface normal (Christensen 1999).
struct IrradiancePoint {
    float pos[3];
    uint16_t normal_oct;
    uint8_t split_axis;
    uint8_t pad;
    float e[3];
    Vec3 position() const { return Vec3(pos[0], pos[1], pos[2]); }
    int axis() const { return split_axis; }
    void set_axis(int a) { split_axis = static_cast<uint8_t>(a); }
};

struct PhotonIntegrator::Irradiance {
    KdTree<IrradiancePoint> tree;
};

PhotonIntegrator::PhotonIntegrator(const Scene& scene, const PhotonMaps& maps,
                                   const GatherParams& gather, const MarchSettings& march,
                                   int max_depth)
    : scene_(scene),
      maps_(maps),
      gather_(gather),
      marcher_(scene.media, march),
      max_depth_(max_depth) {
    const Timer timer;
    if (gather.estimator == VolumeEstimator::Beam && maps.volume)
        beam_ = std::make_unique<BeamTree>(*maps.volume, estimator_k(gather.volume),
                                           gather.volume.radius);
    if (beam_) precompute_s_ = timer.seconds();
    if (!gather.final_gather || !maps.global || maps.global->tree.empty()) return;
    const std::vector<Photon>& photons = maps.global->tree.records();
    std::vector<IrradiancePoint> points((photons.size() + 3) / 4);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, points.size()), [&](const auto& r) {
        NeighborList scratch;
        for (size_t i = r.begin(); i != r.end(); ++i) {
            const Photon& p = photons[4 * i];
            const Color e =
                surface_irradiance(*maps.global, p.position(), p.direction(),
                                   estimator_k(gather.global), gather.global.radius, 0.0f, 0, scratch);
            points[i] =
                IrradiancePoint{{p.pos[0], p.pos[1], p.pos[2]}, p.dir_oct, 3, 0, {e.x, e.y, e.z}};
        }
    });
    irradiance_ = std::make_unique<Irradiance>();
    irradiance_->tree = KdTree<IrradiancePoint>(std::move(points));
    precompute_s_ = timer.seconds();
}

PhotonIntegrator::~PhotonIntegrator() = default;

PhotonIntegrator::ThreadState PhotonIntegrator::make_state() const {
    ThreadState ts;
    for (const Medium& m : scene_.media) ts.media.emplace_back(m);
    return ts;
}

Color PhotonIntegrator::shadow_transmittance(const Ray& ray, float t_max, Rng& rng,
                                             ThreadState& ts) const {
    if (scene_.surfaces) {
        ++ts.rays;
        if (scene_.surfaces->occluded(ray, 0.0f, t_max)) return Color(0.0f);
    }
    return ts.media.empty() ? Color(1.0f) : ratio_track(ts.media, ray, t_max, rng);
}

Color PhotonIntegrator::direct_surface(const Vec3& p, const Vec3& n, const Color& albedo, Rng& rng,
                                       ThreadState& ts) const {
    const Vec3 origin = offset_point(p, n, scene_.offset_floor);
    Color sum(0.0f);
    for (const Light& light : scene_.lights) {
        const Vec2 u(rng.uniform(), rng.uniform());
        LightSample s;
        if (light.type == LightType::Environment) {
            // A constant sky seen from a surface: cosine sampling matches the integrand.
            s.wi = sample_cosine_hemisphere(n, u);
            s.Li = light.radiance;
            s.pdf = std::max(glm::dot(n, s.wi), 0.0f) * kInvPi;
        } else {
            s = sample_light(light, origin, u);
        }
        const float cos = glm::dot(n, s.wi);
        if (s.pdf <= 0.0f || cos <= 0.0f || max_component(s.Li) <= 0.0f) continue;
        const Color T = shadow_transmittance(Ray{origin, s.wi}, s.dist * (1.0f - 1e-4f), rng, ts);
        sum += s.Li * T * (cos / s.pdf);
    }
    return albedo * kInvPi * sum;
}

Color PhotonIntegrator::scatter_light(const Light& light, const Vec3& x, const Vec3& dir, float g,
                                      Rng& rng, ThreadState& ts) const {
    const LightSample s = sample_light(light, x, Vec2(rng.uniform(), rng.uniform()));
    if (s.pdf <= 0.0f || max_component(s.Li) <= 0.0f) return Color(0.0f);
    const Color T = shadow_transmittance(Ray{x, s.wi}, s.dist * (1.0f - 1e-4f), rng, ts);
    return hg_phase(glm::dot(dir, s.wi), g) * s.Li * T / s.pdf;
}

// g at x for the volume estimate: the σ_s-weighted mean of the media present (exact for one).
float PhotonIntegrator::phase_g(ThreadState& ts, const Vec3& x) const {
    if (ts.media.size() == 1) return ts.media[0].medium().params().g;
    float sum = 0.0f, gsum = 0.0f;
    for (Medium::Sampler& s : ts.media) {
        const float w = s.density(x) * average(s.medium().params().sigma_s);
        sum += w;
        gsum += w * s.medium().params().g;
    }
    return sum > 0.0f ? gsum / sum : 0.0f;
}

Color PhotonIntegrator::global_irradiance(const Vec3& p, const Vec3& n, ThreadState& ts) const {
    if (irradiance_) {
        irradiance_->tree.knn(p, 8, gather_.global.radius, &ts.neighbors);
        float best = kInfinity;
        const IrradiancePoint* found = nullptr;
        for (size_t i = 0; i < ts.neighbors.size(); ++i) {
            const IrradiancePoint& q = irradiance_->tree.records()[ts.neighbors[i].index];
            if (ts.neighbors[i].dist2 < best &&
                glm::dot(decode_oct16(q.normal_oct), n) > kGatherNormalCos) {
                best = ts.neighbors[i].dist2;
                found = &q;
            }
        }
        if (found) return Color(found->e[0], found->e[1], found->e[2]);
    }
    return surface_irradiance(*maps_.global, p, n, estimator_k(gather_.global),
                              gather_.global.radius, 0.0f, 0, ts.neighbors);
}

Color PhotonIntegrator::final_gather(const Vec3& p, const Vec3& n, Rng& rng,
                                     ThreadState& ts) const {
    const int rays = gather_.gather_rays;
    const Vec3 origin = offset_point(p, n, scene_.offset_floor);
    Color sum(0.0f);
    for (int j = 0; j < rays; ++j) {
        // Stratified in the first dimension, cosine-distributed: each ray's weight is L2 itself.
        const Vec2 u((j + rng.uniform()) / rays, rng.uniform());
        const Ray ray{origin, sample_cosine_hemisphere(n, u)};
        ++ts.rays;
        const std::optional<SurfaceHit> hit = scene_.surfaces->intersect(ray, 0.0f, kInfinity);
        if (!hit || hit->material < 0) continue;  // lights and sky are direct light, counted at p
        const Material& mat = scene_.materials[hit->material];
        if (mat.type != MaterialType::Diffuse) continue;  // gather stops at specular surfaces
        const Vec3 n2 = glm::dot(ray.d, hit->ng) < 0.0f ? hit->ng : -hit->ng;
        Color L2 = direct_surface(hit->p, n2, mat.albedo, rng, ts) +
                   mat.albedo * kInvPi * global_irradiance(hit->p, n2, ts);
        if (!ts.media.empty()) L2 *= ratio_track(ts.media, ray, hit->t, rng);
        sum += L2;
    }
    return sum / static_cast<float>(rays);
}

// Single scattering over the marched segment, ∫ β T(t) σ_s(t) L_s(t) dt with σ held constant per
// step, from volume.light_samples points per light and strategy: (a) a step drawn ∝ q_k =
// luminance(weight_k σ_s,k) by stratified sampling, then t within it ∝ e^{−σ̄ (t − t0)}; (b) for
// point and spot lights, t drawn equi-angularly, pdf D / ((θ_b − θ_a)(D² + (t − Δ)²)) — the
// 1/r² of a light inside or beside the medium, where (a) puts few points near the light.
// Balance heuristic: each point weighs f / (m Σ_s p_s). 0 samples: a shadow ray at every step.
Color PhotonIntegrator::single_scattering(const Ray& ray, const Color& beta, Rng& rng,
                                          ThreadState& ts) const {
    const std::vector<MarchedStep>& steps = ts.steps;
    const int m = gather_.light_samples;
    Color sum(0.0f);
    if (m == 0) {
        for (const MarchedStep& st : steps) {
            if (max_component(st.sigma_s) <= 0.0f) continue;
            const float g = phase_g(ts, st.x);
            for (const Light& light : scene_.lights)
                sum += st.weight * st.sigma_s * scatter_light(light, st.x, ray.d, g, rng, ts);
        }
        return sum;
    }
    std::vector<double>& cdf = ts.cdf;
    cdf.clear();
    double total = 0.0;
    for (const MarchedStep& st : steps) cdf.push_back(total += luminance(st.weight * st.sigma_s));
    if (!(total > 0.0)) return sum;

    auto within_pdf = [](const MarchedStep& st, float t) {
        const float s = average(st.sigma_t), h = st.t1 - st.t0;
        return s * h < 1e-4f ? 1.0f / h : s * std::exp(-s * (t - st.t0)) / -std::expm1(-s * h);
    };
    auto steps_pdf = [&](const MarchedStep& st, float t) {
        const size_t k = static_cast<size_t>(&st - steps.data());
        const double q = cdf[k] - (k > 0 ? cdf[k - 1] : 0.0);
        return static_cast<float>(q / total) * within_pdf(st, t);
    };
    auto radiance_at = [&](const Light& light, const MarchedStep& st, float t) {
        const Vec3 x = ray.o + t * ray.d;
        const Color T = exp_neg(st.tau0 + st.sigma_t * (t - st.t0));
        return beta * T * st.sigma_s * scatter_light(light, x, ray.d, phase_g(ts, x), rng, ts);
    };
    const float ta = steps.front().t0, tb = steps.back().t1;
    for (const Light& light : scene_.lights) {
        // Equi-angular set-up: Δ = the ray's closest approach to the light, D its distance.
        const bool point = light.type == LightType::Point || light.type == LightType::Spot;
        const float delta = point ? glm::dot(light.position - ray.o, ray.d) : 0.0f;
        const float D = point ? glm::length(light.position - (ray.o + delta * ray.d)) : 0.0f;
        const float th_a = std::atan2(ta - delta, D), th_b = std::atan2(tb - delta, D);
        const bool equi = point && D > 1e-4f * (tb - ta) && th_b > th_a;
        auto equi_pdf = [&](float t) {
            const float u = t - delta;
            return equi ? D / ((th_b - th_a) * (D * D + u * u)) : 0.0f;
        };
        for (int j = 0; j < m; ++j) {
            const double target = (j + rng.uniform()) * total / m;
            const size_t k = std::min<size_t>(
                std::lower_bound(cdf.begin(), cdf.end(), target) - cdf.begin(), steps.size() - 1);
            const MarchedStep& st = steps[k];
            const float s = average(st.sigma_t), h = st.t1 - st.t0, u = rng.uniform();
            float t =
                s * h < 1e-4f ? st.t0 + u * h : st.t0 - std::log1p(u * std::expm1(-s * h)) / s;
            t = std::clamp(t, st.t0, st.t1);
            const float p = steps_pdf(st, t) + equi_pdf(t);
            if (p > 0.0f) sum += radiance_at(light, st, t) / (m * p);
            if (!equi) continue;
            const float th = th_a + (j + rng.uniform()) / m * (th_b - th_a);
            const float te = std::clamp(delta + D * std::tan(th), ta, tb);
            const auto it =
                std::upper_bound(steps.begin(), steps.end(), te,
                                 [](float v, const MarchedStep& x) { return v < x.t1; });
            if (it == steps.end() || te < it->t0) continue;  // in a gap without medium
            const float pe = steps_pdf(*it, te) + equi_pdf(te);
            if (pe > 0.0f) sum += radiance_at(light, *it, te) / (m * pe);
        }
    }
    return sum;
}

// Multiple scattering (smooth along the ray): m = volume.lookups_per_ray volume-map lookups at
// steps drawn by stratified importance sampling ∝ q_k = luminance(weight) over the steps with
// σ_s > 0 — the transmittance-weighted step length, not σ_s(x_k): the estimate is a blurred
// density, nonzero where σ_s(x_k) is small, and weighting by σ_s(x_k) made such steps rare and
// their picks bright. Each pick weighs Q / (m q_k), so the expectation is the full march sum.
Color PhotonIntegrator::multiple_scattering(const Vec3& dir, Rng& rng, ThreadState& ts) const {
    Color sum(0.0f);
    auto gather = [&](const MarchedStep& st, float factor) {
        sum += factor * st.weight *
               volume_inscattered(*maps_.volume, st.x, -dir, phase_g(ts, st.x),
                                  estimator_k(gather_.volume), gather_.volume.radius, ts.neighbors);
    };
    const std::vector<MarchedStep>& steps = ts.steps;
    const size_t m = static_cast<size_t>(gather_.lookups_per_ray);
    std::vector<double>& cdf = ts.cdf;
    cdf.clear();
    double total = 0.0;
    for (const MarchedStep& st : steps)
        cdf.push_back(total += max_component(st.sigma_s) > 0.0f ? luminance(st.weight) : 0.0);
    if (m == 0 || steps.size() <= m) {
        for (const MarchedStep& st : steps)
            if (max_component(st.sigma_s) > 0.0f) gather(st, 1.0f);
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
Color PhotonIntegrator::beam_estimate(const Ray& ray, ThreadState& ts) const {
    const std::vector<MarchedStep>& depth = ts.steps;
    const float t0 = depth.front().t0, t1 = depth.back().t1;
    const bool one_medium = ts.media.size() == 1;
    Color sum(0.0f);
    beam_->for_each_hit(ray, t0, t1, [&](const BeamTree::Record& p, float t, float kernel) {
        // The step holding t (or the gap before it: τ stays at the previous step's end).
        const auto it = std::upper_bound(depth.begin(), depth.end(), t,
                                         [](float v, const MarchedStep& s) { return v < s.t1; });
        if (it == depth.end()) return;
        const Color tau = it->tau0 + it->sigma_t * std::max(0.0f, t - it->t0);
        const float g = one_medium ? ts.media[0].medium().params().g : phase_g(ts, p.position);
        sum += hg_phase(glm::dot(p.direction, -ray.d), g) * kernel * exp_neg(tau) * p.power;
    });
    return sum * maps_.volume->photon_power;
}

FilmSample PhotonIntegrator::radiance(const Ray& camera_ray, Rng& rng, ThreadState& ts) const {
    FilmSample out;
    Ray ray = camera_ray;
    Color beta(1.0f);
    int depth = 0;
    for (; depth < max_depth_; ++depth) {
        std::optional<SurfaceHit> hit;
        float t_max = kInfinity;
        if (scene_.surfaces) {
            ++ts.rays;
            hit = scene_.surfaces->intersect(ray, 0.0f, kInfinity);
            if (hit) t_max = hit->t;
        }
        if (!ts.media.empty()) {
            Color tau(0.0f);
            ts.steps.clear();
            marcher_.march(ts.media, ray, t_max, rng.uniform(), [&](const MarchStep& s) {
                const float h = s.t1 - s.t0;
                ts.steps.push_back({s.t0, s.t1, s.x, tau, s.sigma_t, s.sigma_s,
                                    beta * exp_neg(tau) * step_weight(s.sigma_t, h)});
                tau += s.sigma_t * h;
                return max_component(exp_neg(tau)) > 1e-6f;  // nothing visible beyond
            });
            if (!ts.steps.empty()) {
                out[Layer::VolumeSingle] += single_scattering(ray, beta, rng, ts);
                if (beam_)
                    out[Layer::VolumeMultiple] += beta * beam_estimate(ray, ts);
                else if (maps_.volume)
                    out[Layer::VolumeMultiple] += multiple_scattering(ray.d, rng, ts);
            }
            beta *= exp_neg(tau);
            if (max_component(beta) <= 0.0f) break;
        }
        if (!hit) {
            for (const Light& light : scene_.lights)
                if (light.is_infinite()) out[Layer::Direct] += beta * escaped_radiance(light, ray.d);
            break;
        }
        if (hit->light >= 0) {
            out[Layer::Direct] += beta * quad_radiance(scene_.lights[hit->light], ray.d);
            break;
        }
        if (hit->material < 0) break;
        const Material& mat = scene_.materials[hit->material];
        if (mat.is_specular()) {
            const SpecularScatter sc = scatter_specular(mat, ray.d, hit->p, hit->ng, rng.uniform(),
                                                        Transport::Radiance, scene_.offset_floor);
            beta *= sc.weight;
            ray = sc.ray;
            continue;
        }
        const Vec3 n = glm::dot(ray.d, hit->ng) < 0.0f ? hit->ng : -hit->ng;
        out[Layer::Direct] += beta * direct_surface(hit->p, n, mat.albedo, rng, ts);
        if (maps_.caustic)
            out[Layer::Caustic] += beta * mat.albedo * kInvPi *
                                   surface_irradiance(*maps_.caustic, hit->p, n,
                                                      estimator_k(gather_.caustic),
                                                      gather_.caustic.radius, gather_.cone_filter,
                                                      0, ts.neighbors);
        if (maps_.global) {
            if (gather_.final_gather)
                out[Layer::Indirect] += beta * mat.albedo * final_gather(hit->p, n, rng, ts);
            else
                out[Layer::Indirect] += beta * mat.albedo * kInvPi *
                                        surface_irradiance(*maps_.global, hit->p, n,
                                                           estimator_k(gather_.global),
                                                           gather_.global.radius, 0.0f,
                                                           Photon::kCaustic, ts.neighbors);
        }
        break;
    }
    if (depth == max_depth_) ++ts.capped;  // a specular chain ran into the cap
    return out;
}

Film render_photon(const Scene& scene, const PhotonMaps& maps, const GatherParams& gather,
                   const MarchSettings& march, const RenderSettings& settings, bool quiet,
                   RenderStats* stats, double* precompute_s) {
    const PhotonIntegrator integrator(scene, maps, gather, march, settings.max_depth);
    if (precompute_s) *precompute_s = integrator.precompute_s();
    return render_film(
        Camera(scene.camera), settings.spp, settings.seed, /*layered=*/true, quiet, stats,
        [&] { return integrator.make_state(); },
        [&](const Ray& ray, Rng& rng, PhotonIntegrator::ThreadState& ts) {
            return integrator.radiance(ray, rng, ts);
        });
}

}  // namespace fogmap
