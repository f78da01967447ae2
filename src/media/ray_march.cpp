#include "media/ray_march.h"

namespace fogmap {

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
    }
}

RayMarcher::FreePath RayMarcher::sample_free_path(std::vector<Medium::Sampler>& samplers,
                                                  const Ray& ray, float t_max, Rng& rng) const {
    const double target = -std::log1p(-rng.uniform_double());
    const float jitter = rng.uniform();
    double tau = 0.0;  // along the channel average
    DVec3 tau_c(0.0);  // per channel
    FreePath fp;
    march(samplers, ray, t_max, jitter, [&](const MarchStep& s) {
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
    if (!fp.collided) fp.weight = Color(glm::exp(DVec3(tau) - tau_c));
    return fp;
}

}  // namespace fogmap
