#include "media/ray_march.h"

#include <limits>

namespace fogmap {

namespace {

// σ_s and σ_t of all media at x (density is 0 outside a medium).
void sigma_at(std::vector<Medium::Sampler>& samplers, const Vec3& x, Color* sigma_s,
              Color* sigma_t) {
    *sigma_s = *sigma_t = Color(0.0f);
    for (Medium::Sampler& sampler : samplers) {
        const float d = sampler.density(x);
        if (d <= 0.0f) continue;
        *sigma_s += d * sampler.sigma_s_unit(x);
        *sigma_t += d * sampler.medium().sigma_t();
    }
}

double channel_average(const Color& c) { return (double(c.x) + c.y + c.z) / 3.0; }

/// A free path on [t0, t1) by ray marching with steps of at most h0 whose optical depth stays
/// within kMaxTauPerStep: a step shrinks until the largest σ_t sampled at its ends and at its
/// jittered point, times its length, is within the bound (or it reaches float resolution). σ is
/// held at the jittered sample over the step, as in march(). Work: about log(τ_step / bound)
/// halvings where σ jumps, then one step per kMaxTauPerStep of optical depth; at most
/// kMaxBoundedSteps steps (then the path is treated as escaping: a safety valve, never reached
/// in the tests). Multiplies fp->weight by the chromatic factors, as sample_free_path.
void bounded_march_free_path(std::vector<Medium::Sampler>& samplers,
                             const std::vector<Medium>& media, const Ray& ray, float t0, float t1,
                             float h0, Rng& rng, RayMarcher::FreePath* fp) {
    constexpr int kMaxBoundedSteps = 1000000;
    constexpr double kBound = RayMarcher::kMaxTauPerStep;
    double t_end = t0;  // where the ray leaves the last medium box
    for (const Medium& m : media) {
        float enter, leave;
        if (!m.world_bounds().empty() &&
            intersect_box(m.world_bounds(), ray, t0, t1, &enter, &leave))
            t_end = std::max(t_end, double(leave));
    }
    const double target = -std::log1p(-rng.uniform_double());
    const double jitter = rng.uniform();
    double tau = 0.0, t = t0, h = h0;
    DVec3 tau_c(0.0);
    Color sigma_s_a, sigma_t_a, sigma_s_b, sigma_t_b, sigma_s_m, sigma_t_m;
    sigma_at(samplers, ray.at(t0), &sigma_s_a, &sigma_t_a);
    for (int step = 0; step < kMaxBoundedSteps && t < t_end; ++step) {
        h = std::min({2.0 * h, double(h0), t_end - t});  // regrow after a dense stretch
        for (;;) {
            sigma_at(samplers, ray.at(float(t + h)), &sigma_s_b, &sigma_t_b);
            sigma_at(samplers, ray.at(float(t + jitter * h)), &sigma_s_m, &sigma_t_m);
            const double peak = std::max(
                {max_component(sigma_t_a), max_component(sigma_t_b), max_component(sigma_t_m)});
            const double floor = 4.0 * std::numeric_limits<float>::epsilon() * std::max(1.0, t);
            if (peak * h <= kBound || h <= floor) break;
            h = std::max(floor, h * std::max(0.25, 0.9 * kBound / (peak * h)));
        }
        const double sigma = channel_average(sigma_t_m);
        if (tau + sigma * h >= target && sigma > 0.0) {
            const double dt = (target - tau) / sigma;
            tau_c += DVec3(sigma_t_m) * dt;
            fp->collided = true;
            fp->t = float(t + dt);
            fp->x = ray.at(fp->t);
            fp->sigma_s = sigma_s_m;
            fp->sigma_t = sigma_t_m;
            fp->weight *= Color(DVec3(sigma_t_m) / sigma * glm::exp(DVec3(target) - tau_c));
            return;
        }
        tau += sigma * h;
        tau_c += DVec3(sigma_t_m) * h;
        t += h;
        sigma_s_a = sigma_s_b;
        sigma_t_a = sigma_t_b;
    }
    fp->weight *= Color(glm::exp(DVec3(tau) - tau_c));
}

/// Delta tracking of a free path through all media on [t0, t1): tentative collisions of each
/// medium's majorant process (Poisson superposition: the nearest is processed), each real with
/// probability p = avg(σ_t)/μ (PBRT-v4, ch. 11.2). Chromatic media keep the free path on the
/// channel average and reweight by σ_t,c/(μ p) at the collision and (μ − σ_t,c)/(μ (1 − p)) at
/// null collisions: exactly 1 for grey media. On return fp->weight holds these factors times
/// what it held before. A majorant far above σ_t (a boundary voxel of a very dense grid ramps
/// from 0 to full density under one majorant) costs about sqrt(τ_voxel) null collisions, so after
/// kMaxNullCollisions the rest of the free path is marched with bounded steps instead: the path
/// beyond a point it reached without a real collision is independent of how it got there.
void delta_free_path(std::vector<Medium::Sampler>& samplers, const std::vector<Medium>& media,
                     const Ray& ray, float t0, float t1, float h0, Rng& rng,
                     RayMarcher::FreePath* fp) {
    constexpr int kMaxNullCollisions = 128;
    MergedWalks w(samplers, ray, t0, t1, rng);
    auto& t_next = w.t_next;
    auto& mu = w.mu;
    for (int nulls = 0;; ++nulls) {
        const int i = w.next();
        if (i < 0) return;
        const float t = t_next[i];
        if (nulls == kMaxNullCollisions) {
            bounded_march_free_path(samplers, media, ray, t, t1, h0, rng, fp);
            return;
        }
        const Vec3 x = ray.at(t);
        const float d = samplers[i].density(x);
        const Color sigma_t = d * samplers[i].medium().sigma_t();
        const float m = mu[i];
        const float p = std::min(1.0f, average(sigma_t) / m);
        if (rng.uniform() < p) {
            fp->collided = true;
            fp->t = t;
            fp->x = x;
            fp->weight *= sigma_t / (m * p);
            fp->sigma_s = d * samplers[i].sigma_s_unit(x);
            fp->sigma_t = sigma_t;
            return;
        }
        if (p > 0.0f) fp->weight *= glm::max(Color(m) - sigma_t, Color(0.0f)) / (m * (1.0f - p));
        if (!samplers[i].next_tentative(rng, &t_next[i], &mu[i])) t_next[i] = kInfinity;
    }
}

}  // namespace

RayMarcher::RayMarcher(const std::vector<Medium>& media, const MarchSettings& settings)
    : media_(&media) {
    for (const Medium& m : media) {
        float h;
        if (m.voxel_world() > 0.0f) {
            h = settings.step_voxels * m.voxel_world();
        } else if (settings.step_world > 0.0f) {
            h = settings.step_world;
        } else {
            h = m.world_bounds().empty() ? kInfinity
                                         : glm::length(m.world_bounds().extent()) / 128.0f;
        }
        step_.push_back(h > 0.0f ? h : kInfinity);
        // The medium's majorant of σ_t (max density × max channel) times its step, in double:
        // an infinite step through a medium with σ_t > 0 is stiff too.
        const double majorant =
            double(max_component(m.sigma_t())) * (m.grid() ? m.grid()->max_density() : 1.0f);
        const bool stiff = !m.world_bounds().empty() && majorant > 0.0 &&
                           majorant * double(step_.back()) > double(kMaxTauPerStep);
        stiff_.push_back(stiff);
        any_stiff_ = any_stiff_ || stiff;
    }
}

RayMarcher::FreePath RayMarcher::sample_free_path(std::vector<Medium::Sampler>& samplers,
                                                  const Ray& ray, float t_max, Rng& rng) const {
    bool meets = false;
    for (const Medium& m : *media_) {
        float t_enter, t_exit;
        meets = meets || (!m.world_bounds().empty() &&
                          intersect_box(m.world_bounds(), ray, 0.0f, t_max, &t_enter, &t_exit));
    }
    if (!meets) return FreePath{};
    const double target = -std::log1p(-rng.uniform_double());
    const float jitter = rng.uniform();
    // Marching stops where the ray first enters a stiff medium; delta tracking goes on from there.
    float t_march = t_max;
    if (any_stiff_) {
        for (size_t i = 0; i < stiff_.size(); ++i) {
            float t_enter, t_exit;
            if (stiff_[i] &&
                intersect_box((*media_)[i].world_bounds(), ray, 0.0f, t_march, &t_enter, &t_exit))
                t_march = std::min(t_march, t_enter);
        }
    }
    double tau = 0.0;  // along the channel average
    DVec3 tau_c(0.0);  // per channel
    FreePath fp;
    march(samplers, ray, t_march, jitter, [&](const MarchStep& s) {
        // Average in double: exact for grey media, so their weights are exactly 1.
        const double sigma = (double(s.sigma_t.x) + s.sigma_t.y + s.sigma_t.z) / 3.0;
        const double h = s.t1 - s.t0;
        if (tau + sigma * h < target) {
            tau += sigma * h;
            tau_c += DVec3(s.sigma_t) * h;
            return true;
        }
        const double dt = (target - tau) / sigma;  // interpolate within the step
        tau_c += DVec3(s.sigma_t) * dt;
        fp.collided = true;
        fp.t = static_cast<float>(s.t0 + dt);
        fp.x = ray.at(fp.t);
        fp.sigma_s = s.sigma_s;
        fp.sigma_t = s.sigma_t;
        // pdf of this collision along the average: σ̄ e^{−τ̄}; per channel σ_t,c e^{−τ_c}.
        const DVec3 w = DVec3(s.sigma_t) / sigma * glm::exp(DVec3(target) - tau_c);
        fp.weight = Color(w);
        return false;
    });
    if (fp.collided) return fp;
    fp.weight = Color(glm::exp(DVec3(tau) - tau_c));
    if (t_march < t_max) {
        const float h0 = *std::min_element(step_.begin(), step_.end());
        delta_free_path(samplers, *media_, ray, t_march, t_max, h0, rng, &fp);
    }
    return fp;
}

}  // namespace fogmap
