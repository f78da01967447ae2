#include "photon/photon_pass.h"

#include "core/progress.h"
#include "core/ranks.h"
#include "core/sampling.h"
#include "core/timer.h"
#include "core/world_range.h"
#include "media/phase.h"
#include "media/ray_march.h"
#include "photon/streams.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <type_traits>

namespace fogmap {

namespace {

constexpr uint64_t kBatch = 1u << 15;  // attempts of the fastest stream per round
constexpr uint64_t kChunk = 512;
constexpr uint64_t kPilot = 8192;      // attempts per stream before the allocation
constexpr uint64_t kFirstRound = 256;  // the pilot's first round, kept whole by every map
constexpr double kGlobalShare = 0.25;  // see PhotonPass::close_global_with_volume
constexpr double kFloorShare = 0.05;   // see stream_proportions

constexpr int kGlobal = static_cast<int>(PhotonMapId::Global);
constexpr int kCaustic = static_cast<int>(PhotonMapId::Caustic);
constexpr int kVolume = static_cast<int>(PhotonMapId::Volume);

}  // namespace

// ---------------------------------------------------------------------------------------------
// PhotonTracer

/// One photon path's state while PhotonTracer::trace follows it.
struct PhotonTracer::Walk {
    Walk(Ray a_ray, Color a_power, Rng& a_rng, std::vector<Medium::Sampler>& a_samplers,
         uint32_t a_index, std::vector<TaggedPhoton>* a_out, std::vector<TaggedBeam>* a_beams,
         const std::array<bool, 3>& a_store, PhotonSource a_source)
        : ray(a_ray),
          power(a_power),
          rng(a_rng),
          samplers(a_samplers),
          index(a_index),
          out(a_out),
          beams(a_beams),
          store(a_store),
          source(a_source),
          // Emission photons have no shadow rays to leave their first interaction to.
          stored_from(a_source == PhotonSource::Emission ? 0 : 1) {}

    Ray ray;
    Color power;
    Rng& rng;
    std::vector<Medium::Sampler>& samplers;
    uint32_t index;
    std::vector<TaggedPhoton>* out;
    std::vector<TaggedBeam>* beams;  ///< null unless the tracer keeps beams
    std::array<bool, 3> store;       ///< the maps this path may deposit into
    PhotonSource source;
    int stored_from;             ///< the first interaction (depth) that stores photons
    bool owned = false;          ///< the bounce stream owns the rest of its volume photons
    bool met_media = false;      ///< some segment entered the media's bounds
    bool specular_chain = true;  ///< every interaction so far was specular

    void deposit(int map, const Photon& photon) {
        out->push_back({index, static_cast<PhotonMapId>(map), photon});
    }
    TracedPath ended(PathEnd end, int depth) const {
        return TracedPath{end, ray, power, depth, met_media};
    }
};

PhotonTracer::PhotonTracer(const Scene& scene, const MarchSettings& march, int max_bounces)
    : scene_(scene),
      marcher_(scene.media, march),
      method_(march.method),
      max_bounces_(max_bounces) {
    for (const Medium& m : scene.media) media_bounds_.extend(m.world_bounds());
}

TracedPath PhotonTracer::trace(Ray ray, Color power, Rng& rng,
                               std::vector<Medium::Sampler>& samplers, uint32_t index,
                               std::vector<TaggedPhoton>* out, PhotonSource source,
                               std::vector<TaggedBeam>* beams) const {
    // A bounce-stream photon has had its interaction (the surface it leaves) and stores volume
    // photons only; a sun or sky path whose next segment after a first, diffuse, interaction
    // belongs to the bounce stream stores no volume photons (photon/streams.h).
    const bool bounce = source == PhotonSource::Bounce;
    const std::array<bool, 3> store =
        bounce ? std::array<bool, 3>{false, false, store_[kVolume]} : store_;
    Walk w(ray, power, rng, samplers, index, out, beams_ ? beams : nullptr, store, source);
    const bool has_media = !samplers.empty();
    for (int depth = bounce ? 1 : 0; depth < max_bounces_; ++depth) {
        std::optional<SurfaceHit> hit;
        float t_max = kInfinity;
        if (scene_.surfaces) {
            hit = scene_.surfaces->intersect(w.ray, 0.0f, kInfinity);
            if (hit) t_max = hit->t;
        }
        if (has_media) {
            const Collision c = cross_media(w, t_max, depth);
            if (c == Collision::Absorbed) return w.ended(PathEnd::Absorbed, depth + 1);
            if (c == Collision::Scattered) continue;
        }
        if (!hit) return w.ended(PathEnd::Escaped, depth);
        if (hit->material < 0) return w.ended(PathEnd::Absorbed, depth);
        if (!leave_surface(w, *hit, depth)) return w.ended(PathEnd::Absorbed, depth + 1);
    }
    return w.ended(PathEnd::BounceCap, max_bounces_);
}

PhotonTracer::Collision PhotonTracer::cross_media(Walk& w, float t_max, int depth) const {
    float enter, leave;
    w.met_media = w.met_media || (!media_bounds_.empty() &&
                                  intersect_box(media_bounds_, w.ray, 0.0f, t_max, &enter, &leave));
    const bool volume_store = depth >= w.stored_from && w.store[kVolume] && !w.owned;
    const bool with_beam = w.beams && volume_store;
    Vec3 x;
    if (method_ == FreePathMethod::March) {
        const RayMarcher::FreePath fp = marcher_.sample_free_path(w.samplers, w.ray, t_max, w.rng);
        if (with_beam) leave_beam(w, fp.collided ? fp.t : t_max);
        w.power *= fp.weight;
        if (!fp.collided) return Collision::None;
        x = fp.x;
        // Russian roulette on the albedo; power changes only by channel ratios. Only scattering
        // events are stored (absorptions would count σ_t, not σ_s).
        const double p = (double(fp.sigma_s.x) + fp.sigma_s.y + fp.sigma_s.z) /
                         (double(fp.sigma_t.x) + fp.sigma_t.y + fp.sigma_t.z);
        if (w.rng.uniform() >= p) return Collision::Absorbed;
        w.power *= fp.sigma_s / (fp.sigma_t * static_cast<float>(p));
    } else {
        Color beta(1.0f);
        const TrackResult tr = delta_track(w.samplers, w.ray, t_max, w.rng, &beta);
        if (with_beam) leave_beam(w, tr.event == TrackEvent::Escaped ? t_max : tr.t);
        w.power *= beta;
        if (tr.event == TrackEvent::Absorbed) return Collision::Absorbed;
        if (tr.event != TrackEvent::Scattered) return Collision::None;
        x = w.ray.at(tr.t);
    }
    if (volume_store) w.deposit(kVolume, Photon(x, w.ray.d, w.power));
    float pdf;
    w.ray = Ray{x, PhaseMix(w.samplers, x).sample(w.ray.d, w.rng, &pdf)};
    w.specular_chain = false;
    return Collision::Scattered;
}

bool PhotonTracer::leave_surface(Walk& w, const SurfaceHit& hit, int depth) const {
    const Material& mat = scene_.materials[hit.material];
    if (mat.is_specular()) {
        const SpecularScatter sc = scatter_specular(mat, w.ray.d, hit.p, hit.ng, w.rng.uniform(),
                                                    Transport::Importance, scene_.offset_floor);
        // Russian roulette keeps the power constant (docs/design.md, Photon emission and
        // streams): survive with the mean weight, carry on reweighted by the channel ratios.
        const float p = average(sc.weight);
        if (p < 1.0f) {
            if (w.rng.uniform() >= p) return false;
            w.power *= sc.weight / p;
        }
        w.ray = sc.ray;
        return true;
    }
    const Vec3 n = glm::dot(w.ray.d, hit.ng) < 0.0f ? hit.ng : -hit.ng;  // faces the photon
    if (depth >= w.stored_from) {
        // Surface photons keep the normal of the side they arrived on (Lambertian surfaces need
        // no direction; see photon.h). L S+ D: specular bounces only, at least one.
        const bool caustic = w.specular_chain && depth > 0;
        if (w.store[kGlobal])
            w.deposit(kGlobal, Photon(hit.p, n, w.power, caustic ? Photon::kCaustic : 0));
        if (caustic && w.store[kCaustic]) w.deposit(kCaustic, Photon(hit.p, n, w.power));
    }
    const float p = average(mat.albedo);
    if (w.rng.uniform() >= p) return false;
    w.power *= mat.albedo / p;
    w.ray = Ray{offset_point(hit.p, n, scene_.offset_floor),
                sample_cosine_hemisphere(n, Vec2(w.rng.uniform(), w.rng.uniform()))};
    w.specular_chain = false;
    if (depth == 0 && bounce_owner_ && w.source == PhotonSource::SunOrSky)
        w.owned = bounce_owner_->owns_bounce(scene_, w.ray);
    return true;
}

// The part of the segment (w.ray on [0, end)) within the media's bounds, as a beam.
void PhotonTracer::leave_beam(Walk& w, float end) const {
    float enter, leave;
    if (intersect_box(media_bounds_, w.ray, 0.0f, end, &enter, &leave) && leave > enter)
        w.beams->push_back({w.index, PhotonBeam(w.ray.at(enter), w.ray.at(leave), w.power)});
}

// ---------------------------------------------------------------------------------------------
// The pass's rules as pure functions

std::vector<double> stream_proportions(const std::vector<double>& power,
                                       const std::vector<std::array<double, 3>>& deposit,
                                       const std::array<bool, 3>& open,
                                       const std::vector<double>& cost) {
    const size_t n = power.size();
    double max_power = 0.0;
    for (double p : power) max_power = std::max(max_power, p);
    std::array<double, 3> map_power{0.0, 0.0, 0.0};
    for (size_t s = 0; s < n; ++s)
        for (int m = 0; m < 3; ++m) map_power[m] += deposit[s][m];
    std::vector<double> rate(n, 0.0);
    double max_rate = 0.0;
    for (size_t s = 0; s < n; ++s) {
        double g = 0.0;
        for (int m = 0; m < 3; ++m)
            if (open[m] && map_power[m] > 0.0) g += deposit[s][m] / (map_power[m] * map_power[m]);
        rate[s] = std::sqrt(power[s] * g / cost[s]);
        max_rate = std::max(max_rate, rate[s]);
    }
    for (size_t s = 0; s < n; ++s)
        rate[s] =
            std::max(max_rate > 0.0 ? rate[s] / max_rate : 0.0, kFloorShare * power[s] / max_power);
    return rate;
}

std::vector<uint64_t> round_counts(const std::vector<double>& rate, uint64_t batch, uint64_t left) {
    std::vector<uint64_t> count(rate.size(), 0);
    uint64_t planned = 0;
    for (size_t s = 0; s < rate.size(); ++s)
        planned += count[s] = static_cast<uint64_t>(std::ceil(batch * rate[s]));
    if (planned > left) {  // the last round: what the cap leaves, in the same proportions
        uint64_t scaled = 0;
        for (uint64_t& c : count) scaled += c = c * left / planned;
        if (scaled == 0) count[0] = left;
    }
    return count;
}

// ---------------------------------------------------------------------------------------------
// PhotonPass: chunks, and what crosses between ranks

/// A range of one stream's attempts, traced as a unit (by one thread, on one rank).
struct PhotonPass::Job {
    size_t stream;
    uint64_t begin, end;
};

/// What one chunk of one stream's attempts produced.
struct PhotonPass::ChunkOut {
    std::vector<TaggedPhoton> photons;
    std::vector<TaggedBeam> beams;
    uint64_t accepted = 0;      ///< attempts that yielded a photon
    uint64_t met_media = 0;     ///< photon paths that entered the media's bounds
    uint64_t interactions = 0;  ///< the work traced (a deterministic cost measure)
    uint64_t longest = 0;       ///< the most interactions of one path
    uint64_t steps = 0;         ///< medium density evaluations and tentative collisions
    uint64_t capped = 0;
    double capped_power = 0.0;  ///< Σ average(relative power) of paths the bounce limit cut

    /// Appends the chunk as bytes, for the ranks sharing a pass (the same machine's layout on
    /// every rank: the ranks of one job run one build).
    void put(std::vector<uint8_t>* bytes) const;
    /// Reads back what put wrote, advancing *at.
    static ChunkOut get(const uint8_t** at);
};

namespace {

template <class T>
void put_values(std::vector<uint8_t>* bytes, const T* values, size_t n) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* p = reinterpret_cast<const uint8_t*>(values);
    bytes->insert(bytes->end(), p, p + n * sizeof(T));
}

template <class T>
void get_values(const uint8_t** at, T* values, size_t n) {
    std::memcpy(values, *at, n * sizeof(*values));
    *at += n * sizeof(*values);
}

}  // namespace

void PhotonPass::ChunkOut::put(std::vector<uint8_t>* bytes) const {
    const uint64_t n = photons.size(), nb = beams.size();
    const uint64_t counts[] = {accepted, met_media, interactions, longest, capped, n, nb, steps};
    put_values(bytes, counts, 8);
    put_values(bytes, &capped_power, 1);
    put_values(bytes, photons.data(), n);
    put_values(bytes, beams.data(), nb);
}

PhotonPass::ChunkOut PhotonPass::ChunkOut::get(const uint8_t** at) {
    uint64_t counts[8];
    get_values(at, counts, 8);
    ChunkOut o;
    o.accepted = counts[0];
    o.met_media = counts[1];
    o.interactions = counts[2];
    o.longest = counts[3];
    o.capped = counts[4];
    o.steps = counts[7];
    get_values(at, &o.capped_power, 1);
    o.photons.resize(counts[5]);
    get_values(at, o.photons.data(), o.photons.size());
    o.beams.resize(counts[6]);
    get_values(at, o.beams.data(), o.beams.size());
    return o;
}

// ---------------------------------------------------------------------------------------------
// PhotonPass: set-up and the run

PhotonPass::PhotonPass(const Scene& scene, const Plan& plan, const PhotonSettings& settings,
                       const MarchSettings& march, uint64_t seed, bool quiet, Ranks* ranks)
    : scene_(scene),
      plan_(plan),
      settings_(settings),
      march_(march),
      seed_(seed),
      quiet_(quiet),
      ranks_(ranks),
      n_ranks_(ranks ? size_t(ranks->size()) : 1),
      my_rank_(ranks ? size_t(ranks->rank()) : 0) {}

PhotonPassResult PhotonPass::run() {
    const Timer timer;
    if (!open_maps() || !make_streams_and_tracer()) return std::move(result_);
    set_cap();
    Progress progress("photons", 1000, quiet_);
    pilot();
    allocated_rounds(progress);
    progress.finish();
    result_.emitted = total_attempts();
    for (int m = 0; m < 3; ++m)
        if (maps_[m]) weigh_map(m);
    report_streams();
    result_.time_s = timer.seconds();
    return std::move(result_);
}

bool PhotonPass::open_maps() {
    if (plan_.global_map.on) maps_[kGlobal] = &result_.global.emplace();
    if (plan_.caustic_map.on) maps_[kCaustic] = &result_.caustic.emplace();
    if (plan_.volume_map.on) maps_[kVolume] = &result_.volume.emplace();
    const std::array<uint64_t, 3> budgets{settings_.global, settings_.caustic, settings_.volume};
    for (int m = 0; m < 3; ++m) {
        if (!maps_[m]) continue;
        maps_[m]->budget = budgets[m];
        maps_[m]->photons.reserve(budgets[m] + 64);
        largest_ = std::max(largest_, budgets[m]);
    }
    return largest_ > 0;
}

bool PhotonPass::make_streams_and_tracer() {
    set_ = make_streams(scene_, maps_[kCaustic] != nullptr, maps_[kVolume] != nullptr);
    for (const Light& l : scene_.lights)
        result_.total_power += average(light_power(l, scene_.bounds));
    result_.total_power += static_cast<float>(emitted_power(scene_));
    if (set_.streams.empty()) {
        result_.warnings.push_back("no light emits power: no photons traced");
        return false;
    }
    n_streams_ = set_.streams.size();
    MarchSettings free_paths = march_;
    if (settings_.volume_beams) free_paths.method = FreePathMethod::Delta;
    tracer_.emplace(scene_, free_paths, settings_.max_bounces);
    tracer_->set_bounce_owner(&set_);
    tracer_->set_beams(settings_.volume_beams && maps_[kVolume]);
    for (int m = 0; m < 3; ++m) open_[m] = maps_[m] && maps_[m]->budget > 0;
    tracer_->set_store(open_);
    attempts_.assign(n_streams_, 0);
    interactions_.assign(n_streams_, 0);
    result_.streams.resize(n_streams_);
    for (size_t s = 0; s < n_streams_; ++s) result_.streams[s].name = set_.streams[s].name;
    pairs_.resize(n_streams_);
    return true;
}

// ---------------------------------------------------------------------------------------------
// PhotonPass: allocation rules

void PhotonPass::pilot() {
    for (uint64_t n = kFirstRound; any_open();) {
        const uint64_t round = std::min({n, kPilot - attempts_[0], attempts_left() / n_streams_});
        if (round == 0) break;
        emit(std::vector<uint64_t>(n_streams_, round));
        n *= 2;
    }
}

void PhotonPass::allocated_rounds(Progress& progress) {
    uint64_t shown = 0;
    while (any_open()) {
        close_global_with_volume();
        if (!any_open()) break;
        const std::vector<double> rate = allocation();
        const uint64_t left = attempts_left();
        if (left == 0) break;
        emit(round_counts(rate, kBatch, left));
        double fill = 1.0;
        for (int m = 0; m < 3; ++m)
            if (maps_[m] && maps_[m]->budget > 0)
                fill = std::min(fill, double(maps_[m]->photons.size()) / double(maps_[m]->budget));
        const uint64_t now = static_cast<uint64_t>(
            1000.0 * std::min(1.0, std::max(fill, double(total_attempts()) / double(cap_))));
        if (now > shown) progress.add(now - shown), shown = now;
    }
}

double PhotonPass::deposit_rate(size_t s, int m) const {
    return set_.streams[s].region_power * pairs_[s][m].power / behind(s, m);
}

std::vector<double> PhotonPass::allocation() const {
    std::vector<double> power(n_streams_), cost(n_streams_);
    std::vector<std::array<double, 3>> deposit(n_streams_);
    for (size_t s = 0; s < n_streams_; ++s) {
        power[s] = set_.streams[s].region_power;
        for (int m = 0; m < 3; ++m) deposit[s][m] = deposit_rate(s, m);
        cost[s] = 1.0 + double(interactions_[s]) / double(std::max<uint64_t>(1, attempts_[s]));
    }
    return stream_proportions(power, deposit, open_, cost);
}

// ---------------------------------------------------------------------------------------------
// PhotonPass: closing rules

// Why the volume attempts rule: the volume map's share of the error falls as 1/photons and the
// camera's as 1/samples, so the photons that balance the pass's cost against the render's grow in
// proportion to the samples. Calibrated on smoke1 over a 10 km ground (64 spp): the rule leaves
// its relMSE × time as it was (0.35 attempts per sample fill 100 000 photons; 0.00160 against
// 0.00159, 4 seeds), where the same smoke at a tenth of its σ spent 2.4 million attempts and 83%
// of the render on 100 000 photons, 6.1× the path tracer's relMSE × time; closed at 0.25 per
// sample, 1.4×.
void PhotonPass::set_cap() {
    cap_ = settings_.max_emitted > 0 ? settings_.max_emitted : 100 * largest_;
    volume_rule_ = settings_.volume_attempts > 0 && open_[kVolume] && !open_[kGlobal] &&
                   !open_[kCaustic] && settings_.volume_attempts < cap_;
    if (volume_rule_) cap_ = settings_.volume_attempts;
}

uint64_t PhotonPass::attempts_left() const {
    const uint64_t total = total_attempts();
    return cap_ > total ? cap_ - total : 0;
}

bool PhotonPass::full(int m) const { return maps_[m]->photons.size() >= maps_[m]->budget; }

bool PhotonPass::any_open() const { return open_[0] || open_[1] || open_[2]; }

void PhotonPass::close_now(int m) {
    open_[m] = false;
    for (size_t u = 0; u < n_streams_; ++u) {
        pairs_[u][m].closed = true;
        pairs_[u][m].stop_at = attempts_[u];
    }
}

void PhotonPass::close_at(int m, size_t s, uint64_t e, const std::vector<uint64_t>& count) {
    open_[m] = false;
    for (size_t u = 0; u < n_streams_; ++u) {
        pairs_[u][m].closed = true;
        pairs_[u][m].stop_at = u < s ? attempts_[u] + count[u] : u == s ? e + 1 : attempts_[u];
    }
}

void PhotonPass::close_full_after_first_round() {
    for (int m = 0; m < 3; ++m)
        if (open_[m] && full(m)) close_now(m);
}

// Why the global map may close with the volume map: light that surfaces get only through the
// media (an open ground under smoke) would otherwise drive the whole pass — smoke1 over a 10 km
// ground: 4.4M attempts for the global map against 2.75M for the volume map; closing with it took
// the render from 3.9 to 3.1 s at the same relMSE.
void PhotonPass::close_global_with_volume() {
    if (global_checked_ || !maps_[kGlobal] || !maps_[kVolume] || open_[kVolume] || !open_[kGlobal])
        return;
    global_checked_ = true;
    double global_power = 0.0, volume_power = 0.0;
    for (size_t s = 0; s < n_streams_; ++s) {
        global_power += deposit_rate(s, kGlobal);
        volume_power += deposit_rate(s, kVolume);
    }
    if (!(global_power < kGlobalShare * volume_power)) return;
    close_now(kGlobal);
    tracer_->set_store(open_);
    char text[160];
    std::snprintf(text, sizeof text,
                  "closed with the volume map: its photons carry %.0f%% of the volume map's "
                  "power",
                  100.0 * global_power / volume_power);
    maps_[kGlobal]->stopped = text;
}

bool PhotonPass::mine(size_t chunk) const { return chunk % n_ranks_ == my_rank_; }

void PhotonPass::exchange(size_t n_jobs, std::vector<ChunkOut>* out) {
    const Timer exchange;
    std::vector<uint8_t> bytes;
    for (size_t j = my_rank_; j < n_jobs; j += n_ranks_) (*out)[j].put(&bytes);
    const std::vector<std::vector<uint8_t>> all = ranks_->all_gather(bytes);
    for (size_t q = 0; q < n_ranks_; ++q) {
        const uint8_t* at = all[q].data();
        for (size_t j = q; j < n_jobs; j += n_ranks_) (*out)[j] = ChunkOut::get(&at);
    }
    result_.exchange_s += exchange.seconds();
}

// ---------------------------------------------------------------------------------------------
// PhotonPass: a round

void PhotonPass::emit(const std::vector<uint64_t>& count) {
    const bool first = attempts_[0] == 0;
    std::vector<Job> jobs;
    for (size_t s = 0; s < n_streams_; ++s)
        for (uint64_t b = 0; b < count[s]; b += kChunk)
            jobs.push_back({s, attempts_[s] + b, attempts_[s] + std::min(count[s], b + kChunk)});
    std::vector<ChunkOut> out(jobs.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, jobs.size(), 1), [&](const auto& r) {
        std::vector<Medium::Sampler> samplers;
        for (const Medium& m : scene_.media) samplers.emplace_back(m);
        for (size_t j = r.begin(); j != r.end(); ++j)
            if (mine(j)) trace_chunk(jobs[j], samplers, &out[j]);
    });
    if (n_ranks_ > 1) exchange(jobs.size(), &out);
    for (size_t j = 0; j < jobs.size(); ++j) merge(jobs[j], out[j], first, count);
    for (size_t s = 0; s < n_streams_; ++s) attempts_[s] += count[s];
    if (first) close_full_after_first_round();
    tracer_->set_store(open_);
}

bool PhotonPass::start_photon(int s, std::vector<Medium::Sampler>& samplers, Rng& rng, Ray* ray,
                              Color* power, PhotonSource* source) const {
    const PhotonStream& st = set_.streams[s];
    if (s == set_.bounce) {
        *source = PhotonSource::Bounce;
        return sample_bounce(set_, s, scene_, samplers, rng, ray, power);
    }
    if (st.medium >= 0) {
        *source = PhotonSource::Emission;
        return sample_emission_stream(set_, s, samplers, rng, ray, power);
    }
    *source =
        scene_.lights[st.light].is_infinite() ? PhotonSource::SunOrSky : PhotonSource::LocalLight;
    return sample_stream(set_, s, scene_, rng, ray);
}

void PhotonPass::trace_chunk(const Job& job, std::vector<Medium::Sampler>& samplers,
                             ChunkOut* o) const {
    const PhotonStream& st = set_.streams[job.stream];
    uint64_t steps_before = 0;
    for (const Medium::Sampler& m : samplers) steps_before += m.steps();
    const std::optional<ShutterDesc>& shutter = scene_.camera.shutter;
    for (uint64_t i = job.begin; i < job.end; ++i) {
        Rng rng(seed_, i, st.key);
        // The photon's time within the shutter, from a stream of its own.
        if (shutter)
            set_time(samplers, shutter->seconds(
                                   Rng(derive_seed(seed_, stream::kShutter, st.key), i).uniform()));
        Ray ray;
        Color power = st.color;
        PhotonSource source;
        if (!start_photon(static_cast<int>(job.stream), samplers, rng, &ray, &power, &source))
            continue;
        ++o->accepted;
        const TracedPath path =
            tracer_->trace(ray, power, rng, samplers, static_cast<uint32_t>(i - job.begin),
                           &o->photons, source, &o->beams);
        o->met_media += path.met_media ? 1 : 0;
        o->interactions += static_cast<uint64_t>(path.interactions);
        o->longest = std::max<uint64_t>(o->longest, path.interactions);
        if (path.end == PathEnd::BounceCap) {
            ++o->capped;
            o->capped_power += average(path.power);
        }
    }
    for (const Medium::Sampler& m : samplers) o->steps += m.steps();
    o->steps -= steps_before;
}

void PhotonPass::merge(const Job& job, const ChunkOut& o, bool first,
                       const std::vector<uint64_t>& count) {
    const size_t s = job.stream;
    StreamReport& sr = result_.streams[s];
    sr.photons += o.accepted;
    sr.met_media += o.met_media;
    sr.capped += o.capped;
    sr.capped_power += o.capped_power;
    sr.longest = std::max(sr.longest, o.longest);
    interactions_[s] += o.interactions;
    result_.steps += o.steps;
    result_.interactions += o.interactions;
    for (const TaggedPhoton& t : o.photons) {
        const int m = static_cast<int>(t.map);
        Pair& p = pairs_[s][m];
        const uint64_t e = job.begin + t.index;
        if (p.closed && e >= p.stop_at) continue;
        maps_[m]->photons.push_back(t.photon);
        maps_[m]->photons.back().set_batch(static_cast<int>(mix64(mix64(s) ^ e)));
        photon_stream_[m].push_back(static_cast<uint16_t>(s));
        ++p.stored;
        p.power += average(t.photon.power());
        if (!first && open_[m] && full(m)) close_at(m, s, e, count);
    }
    // Beams go with the volume map's photons: those of the attempts it still takes.
    for (const TaggedBeam& t : o.beams) {
        const Pair& p = pairs_[s][kVolume];
        if (p.closed && job.begin + t.index >= p.stop_at) continue;
        maps_[kVolume]->beams.push_back(t.beam);
        beam_stream_.push_back(static_cast<uint16_t>(s));
    }
}

// ---------------------------------------------------------------------------------------------
// PhotonPass: weights and the report

uint64_t PhotonPass::total_attempts() const {
    uint64_t n = 0;
    for (uint64_t a : attempts_) n += a;
    return n;
}

double PhotonPass::behind(size_t s, int m) const {
    return double(pairs_[s][m].closed ? pairs_[s][m].stop_at : attempts_[s]);
}

namespace {

/// Rescales each record's power (photons or beams) to its stream's weight / the map's unit.
template <class Records>
void reweigh(Records& records, const std::vector<uint16_t>& stream_of,
             const std::vector<double>& weight, float photon_power) {
    for (size_t i = 0; i < records.size(); ++i) {
        const double w = weight[stream_of[i]] / photon_power;
        if (w != 1.0)
            records[i].power_rgbe = encode_rgbe(records[i].power() * static_cast<float>(w));
    }
}

}  // namespace

void PhotonPass::weigh_map(int m) {
    StoredPhotons& map = *maps_[m];
    std::vector<double> weight(n_streams_, 0.0);
    for (size_t s = 0; s < n_streams_; ++s) {
        map.emitted += static_cast<uint64_t>(behind(s, m));
        weight[s] = set_.streams[s].region_power / std::max(1.0, behind(s, m));
        map.photon_power = std::max(map.photon_power, static_cast<float>(weight[s]));
        result_.streams[s].stored[m] = pairs_[s][m].stored;
    }
    reweigh(map.photons, photon_stream_[m], weight, map.photon_power);
    reweigh(map.beams, beam_stream_, weight, map.photon_power);
    if (map.photons.size() >= map.budget) return;
    if (m == kVolume && volume_rule_)
        map.stopped = "closed after " + std::to_string(result_.emitted) + " attempts (" +
                      g_text(kVolumeAttemptsPerSample) + " per camera sample, at least its budget)";
    static const char* kNames[3] = {"global", "caustic", "volume"};
    if (map.stopped.empty())
        result_.warnings.push_back(
            std::string(kNames[m]) + " map: " + std::to_string(map.photons.size()) + " of " +
            std::to_string(map.budget) + " photons stored after " +
            std::to_string(result_.emitted) + " emitted (photons.max_emitted reached)");
}

void PhotonPass::report_streams() {
    double capped_power = 0.0;
    for (size_t s = 0; s < n_streams_; ++s) {
        StreamReport& sr = result_.streams[s];
        sr.attempts = attempts_[s];
        result_.capped += sr.capped;
        capped_power += sr.capped_power * set_.streams[s].region_power /
                        double(std::max<uint64_t>(1, attempts_[s]));
    }
    const float total = result_.total_power;
    result_.capped_power = total > 0.0f ? capped_power / total : 0.0;
    if (result_.capped_power > kCapWarnShare) {
        char text[200];
        std::snprintf(text, sizeof text,
                      "photons.max_bounces = %d cut %llu photon paths carrying %.2g%% of the "
                      "emitted power; raise it (the photon maps miss that light)",
                      settings_.max_bounces, static_cast<unsigned long long>(result_.capped),
                      100.0 * result_.capped_power);
        result_.warnings.push_back(text);
    }
}

PhotonPassResult trace_photons(const Scene& scene, const Plan& plan, const PhotonSettings& settings,
                               const MarchSettings& march, uint64_t seed, bool quiet,
                               Ranks* ranks) {
    return PhotonPass(scene, plan, settings, march, seed, quiet, ranks).run();
}

// ---------------------------------------------------------------------------------------------
// Trees

PhotonMaps build_trees(PhotonPassResult&& pass) {
    PhotonMaps maps;
    auto build = [&](std::optional<StoredPhotons>& in, std::optional<PhotonMap>& out) {
        if (!in) return;
        const Timer timer;
        PhotonMap m;
        m.emitted = in->emitted;
        m.photon_power = in->photon_power;
        m.stopped = std::move(in->stopped);
        m.beams = std::move(in->beams);
        in->photons.shrink_to_fit();
        m.tree = KdTree<Photon>(std::move(in->photons));
        m.build_s = timer.seconds();
        out = std::move(m);
    };
    tbb::parallel_invoke([&] { build(pass.global, maps.global); },
                         [&] { build(pass.caustic, maps.caustic); },
                         [&] { build(pass.volume, maps.volume); });
    return maps;
}

}  // namespace fogmap
