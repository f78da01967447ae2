#include "render/photon_integrator.h"

#include "core/rng.h"
#include "core/sampling.h"
#include "core/timer.h"
#include "photon/estimators.h"
#include "render/camera.h"
#include "scene/shadow.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace fogmap {

namespace {

constexpr float kGatherNormalCos = 0.9f;  // irradiance points count only on like-facing surfaces

// The volume map's hierarchy for `estimator` (BeamTree for beam, PhotonBeams for photon_beams)
// when that estimate is asked for and there is a volume map; adds its build time to *seconds.
template <class Hierarchy>
std::unique_ptr<Hierarchy> build_for(VolumeEstimator estimator, const PhotonMaps& maps,
                                     const GatherParams& gather, double* seconds) {
    if (gather.estimator != estimator || !maps.volume) return nullptr;
    const Timer timer;
    auto built = std::make_unique<Hierarchy>(
        *maps.volume, gather.volume.fixed_radius ? 0 : gather.volume.k, gather.volume.radius);
    *seconds += timer.seconds();
    return built;
}

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
                                   int max_depth, bool photon_batches)
    : scene_(scene),
      maps_(maps),
      gather_(gather),
      max_depth_(max_depth),
      photon_batches_(photon_batches),
      beam_(build_for<BeamTree>(VolumeEstimator::Beam, maps, gather, &precompute_s_)),
      beams_(build_for<PhotonBeams>(VolumeEstimator::PhotonBeams, maps, gather, &precompute_s_)),
      volume_(scene, march, gather, maps.volume ? &*maps.volume : nullptr, beam_.get(),
              beams_.get()) {
    for (const Medium& m : scene.media) emissive_ |= m.emission() != nullptr;
    const Timer timer;
    if (!gather.final_gather || !maps.global || maps.global->tree.empty()) return;
    const std::vector<Photon>& photons = maps.global->tree.records();
    std::vector<IrradiancePoint> points((photons.size() + 3) / 4);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, points.size()), [&](const auto& r) {
        NeighborList scratch;
        for (size_t i = r.begin(); i != r.end(); ++i) {
            const Photon& p = photons[4 * i];
            const Color e = surface_irradiance(*maps.global, p.position(), p.direction(),
                                               estimator_k(gather.global), gather.global.radius,
                                               0.0f, 0, scratch);
            points[i] =
                IrradiancePoint{{p.pos[0], p.pos[1], p.pos[2]}, p.dir_oct, 3, 0, {e.x, e.y, e.z}};
        }
    });
    irradiance_ = std::make_unique<Irradiance>();
    irradiance_->tree = KdTree<IrradiancePoint>(std::move(points));
    precompute_s_ += timer.seconds();
}

PhotonIntegrator::~PhotonIntegrator() = default;

PhotonIntegrator::ThreadState PhotonIntegrator::make_state() const {
    ThreadState ts;
    static_cast<VolumeGather::State&>(ts) = volume_.make_state();
    return ts;
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
        if (emissive_) {  // the media's light reaching p directly (the map's photons at p are not
                          // used here); the camera segment's march is done with, so st is free
            volume_.march(ray, hit ? hit->t : kInfinity, Color(1.0f), rng.uniform(), ts);
            sum += ts.emitted;
        }
        if (!hit || hit->material < 0) continue;  // lights and sky are direct light, counted at p
        const Material& mat = scene_.materials[hit->material];
        if (mat.type != MaterialType::Diffuse) continue;  // gather stops at specular surfaces
        const Vec3 n2 = glm::dot(ray.d, hit->ng) < 0.0f ? hit->ng : -hit->ng;
        Color L2 = direct_diffuse(scene_, ts.media, hit->p, n2, mat.albedo, rng, &ts.rays) +
                   mat.albedo * kInvPi * global_irradiance(hit->p, n2, ts);
        if (!ts.media.empty()) L2 *= ratio_track(ts.media, ray, hit->t, rng);
        sum += L2;
    }
    return sum / static_cast<float>(rays);
}

FilmSample PhotonIntegrator::radiance(const Ray& camera_ray, Rng& rng, ThreadState& ts,
                                      float map_weight) const {
    const bool maps = map_weight > 0.0f;
    FilmSample out;
    // PhotonBatches and RadiusBias (render/volume_map_end.h): a map term's part from each batch
    // alone, and each photon half's estimate of its bias (κ: BatchSums::bias's, for its lookup).
    BatchSums parts;
    BatchSums* const batches = photon_batches_ ? &parts : nullptr;
    const auto add = [&](Layer layer, const Color& term, float kappa) {
        out[layer] += term;
        if (!batches) return;
        add_photon_delta(term, parts.shares(), &out.photon_delta);
        const std::array<float, 2> bias = parts.bias(kappa);
        for (size_t h = 0; h < 2; ++h) out.bias_half[h] += bias[h] * term;
        out.batched = true;
        parts = BatchSums{};
    };
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
            const Color tau = volume_.march(ray, t_max, beta, rng.uniform(), ts);
            out[Layer::Emission] += ts.emitted;
            out[Layer::VolumeSingle] += volume_.single_scattering(ray, beta, rng, ts);
            if (maps)
                add(Layer::VolumeMultiple,
                    map_weight * volume_.multiple_scattering(ray, beta, rng, ts, batches),
                    1.0f);  // its sums hold κ (VolumeGather)
            beta *= exp_neg(tau);
            if (max_component(beta) <= 0.0f) break;
        }
        if (!hit) {
            for (const Light& light : scene_.lights)
                if (light.is_infinite())
                    out[Layer::Direct] += beta * escaped_radiance(light, ray.d);
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
        out[Layer::Direct] +=
            beta * direct_diffuse(scene_, ts.media, hit->p, n, mat.albedo, rng, &ts.rays);
        if (!maps) break;
        if (maps_.caustic)
            add(Layer::Caustic,
                map_weight * beta * mat.albedo * kInvPi *
                    surface_irradiance(*maps_.caustic, hit->p, n, estimator_k(gather_.caustic),
                                       gather_.caustic.radius, gather_.cone_filter, 0, ts.neighbors,
                                       batches),
                kDiscKappa);
        if (maps_.global) {
            if (gather_.final_gather)
                out[Layer::Indirect] +=
                    map_weight * beta * mat.albedo * final_gather(hit->p, n, rng, ts);
            else
                add(Layer::Indirect,
                    map_weight * beta * mat.albedo * kInvPi *
                        surface_irradiance(*maps_.global, hit->p, n, estimator_k(gather_.global),
                                           gather_.global.radius, 0.0f, Photon::kCaustic,
                                           ts.neighbors, batches),
                    kDiscKappa);
        }
        break;
    }
    if (depth == max_depth_) ++ts.capped;  // a specular chain ran into the cap
    return out;
}

int map_step(int spp, int map_spp) { return map_spp > 0 ? std::max(1, spp / map_spp) : 1; }

float map_weight(const PixelSample& ps, int step) {
    if (step == 1) return 1.0f;
    const int offset = static_cast<int>(mix64(ps.key ^ stream::kMapSamples) % uint64_t(step));
    const int blocks = (ps.spp + step - 1) / step, block = ps.s / step;
    const int shift = block % kBatches * step / std::min(blocks, kBatches);
    return (ps.s + offset + shift) % step == 0 ? static_cast<float>(step) : 0.0f;
}

Film render_photon(const Scene& scene, const PhotonMaps& maps, const GatherParams& gather,
                   const MarchSettings& march, const RenderSettings& settings, bool quiet,
                   RenderStats* stats, double* precompute_s, TileShare tiles, PhotonParts parts,
                   GivenSamples given) {
    const PhotonIntegrator integrator(scene, maps, gather, march, settings.max_depth,
                                      keeps_bias(parts));
    if (precompute_s) *precompute_s = integrator.precompute_s();
    const int step = map_step(settings.spp, settings.map_spp);
    return render_film(
        Camera(scene.camera), settings.spp, settings.seed, tiles, /*layered=*/true, parts, step,
        settings.adaptive, quiet, stats, [&] { return integrator.make_state(); },
        [&](const Ray& ray, Rng& rng, PhotonIntegrator::ThreadState& ts, const PixelSample& ps) {
            set_time(ts.media, ps.time);
            return integrator.radiance(ray, rng, ts, map_weight(ps, step));
        },
        given);
}

}  // namespace fogmap
