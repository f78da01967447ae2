#pragma once
// Counter-based random numbers: a PCG32 stream seeded by hashing (seed, pixel, sample), so a
// sample's numbers depend only on its indices, never on which thread draws them.
// Rng is a small value type; copy one per task, never share between threads.

#include <cstdint>

namespace fogmap {

/// SplitMix64 finaliser: a bijective 64-bit mix, used to derive stream seeds from indices.
inline uint64_t mix64(uint64_t x) {
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
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
