#pragma once
// Counter-based random numbers: a PCG32 stream seeded by hashing (seed, pixel, sample), so a
// sample's numbers depend only on its indices, never on which thread draws them; the keys of the
// other streams in one table (stream::), each distinct. Rng is a small value type; copy one per
// task, never share between threads.

#include <cstddef>
#include <cstdint>
#include <iterator>

namespace fogmap {

/// SplitMix64 finaliser: a bijective 64-bit mix, used to derive stream seeds from indices.
inline uint64_t mix64(uint64_t x) {
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}

/// The keys of the random streams apart from the pixels' samples, one per consumer, so no two
/// share numbers (docs/design.md, Determinism). The values are fixed: changing one changes images.
/// Most spell their consumer in ASCII.
namespace stream {
/// A pixel's N-rooks row shuffle, mix64(seed + key) (render/tiles.h, pixel_key).
inline constexpr uint64_t kPixelRows = 0x9E3779B97F4A7C15ull;
/// Photon streams (photon/streams.cpp), mixed into their Rng's third index: "BOUNCE", the diffuse
/// bounce; "STREA" + light · 0x100 + target + 1, a light's; "EMIT" · 0x100 + medium, emission's.
inline constexpr uint64_t kPhotonBounce = 0x424f554e4345ull;
inline constexpr uint64_t kPhotonLight = 0x5354524541ull;
inline constexpr uint64_t kPhotonEmission = 0x454d4954ull;
/// "EMISS": the tentative points that measure an emitting medium's power (media/medium.cpp).
inline constexpr uint64_t kEmissionPower = 0x454d495353ull;
/// The generated volumes' noise lattice, seed ^ key (media/volume_gen.cpp).
inline constexpr uint64_t kNoise = 0x5EEDF06ull;
/// "map_sp": which of a pixel's samples look up the photon maps (render/photon_integrator.h).
inline constexpr uint64_t kMapSamples = 0x6d61705f73707000ull;
/// "adjoint": the path tracer's pixel estimate, apart from the render's samples.
inline constexpr uint64_t kPixelEstimate = 0x61646a6f696e74ull;
/// "SLAB": the slab validation's photons (photon/slab.h).
inline constexpr uint64_t kSlab = 0x534C4142ull;
/// bench's reference render: the runs' seed + key, so it shares none of their samples.
inline constexpr uint64_t kBenchReference = 0x5eed5eedull;
/// "SHUTTER": the times of camera samples and photons within a shutter (motion blur).
inline constexpr uint64_t kShutter = 0x53485554544552ull;
/// "ADAPT": the dither that rounds adaptive sampling's per-pixel counts (render/adaptive.cpp).
inline constexpr uint64_t kAdaptive = 0x4144415054ull;

inline constexpr uint64_t kAll[] = {kPixelRows,     kPhotonBounce,   kPhotonLight, kPhotonEmission,
                                    kEmissionPower, kNoise,          kMapSamples,  kPixelEstimate,
                                    kSlab,          kBenchReference, kShutter,     kAdaptive};

/// Whether no two keys of kAll are equal.
constexpr bool all_distinct() {
    for (size_t i = 0; i < std::size(kAll); ++i)
        for (size_t j = 0; j < i; ++j)
            if (kAll[i] == kAll[j]) return false;
    return true;
}
static_assert(all_distinct(), "every random stream has its own key");
}  // namespace stream

/// Seed `index` of the stream `key` under the render seed `seed`: the seed is mixed before the
/// index joins it, so neighbouring seeds' derived seeds are unrelated (seed ^ (key + index) would
/// give seeds 2j and 2j + 1 the same pair, swapped).
inline uint64_t derive_seed(uint64_t seed, uint64_t key, uint64_t index) {
    return mix64(mix64(seed ^ key) ^ index);
}

/// PCG32 (O'Neill 2014): 64-bit state, 32-bit output, selectable stream.
class Rng {
public:
    /// A stream determined by (seed, a, b), e.g. (render seed, pixel index, sample index).
    Rng(uint64_t seed, uint64_t a, uint64_t b = 0) {
        state_ = 0;
        inc_ = (mix64(mix64(seed) ^ a) << 1u) | 1u;
        next_u32();
        state_ += mix64(mix64(seed + 0x632BE59BD9B4E019ull) ^ b ^ (a << 17));
        next_u32();
    }

    uint32_t next_u32() {
        const uint64_t old = state_;
        state_ = old * 6364136223846793005ull + inc_;
        const uint32_t xorshifted = static_cast<uint32_t>(((old >> 18u) ^ old) >> 27u);
        const uint32_t rot = static_cast<uint32_t>(old >> 59u);
        return (xorshifted >> rot) | (xorshifted << ((-rot) & 31u));
    }

    /// Uniform float in [0, 1), never 1 (24 random bits).
    float uniform() { return static_cast<float>(next_u32() >> 8) * (1.0f / 16777216.0f); }

    /// Uniform double in [0, 1) (53 random bits).
    double uniform_double() {
        const uint64_t hi = next_u32(), lo = next_u32();
        return static_cast<double>(((hi << 32) | lo) >> 11) * (1.0 / 9007199254740992.0);
    }

private:
    uint64_t state_;
    uint64_t inc_;
};

}  // namespace fogmap
