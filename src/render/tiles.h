#pragma once
// The render pass's parallel loop: 16x16 tiles over TBB (as many workers as the run's
// ThreadLimit allows), one thread state per tile and a progress bar; and the pixels' keys and
// shuffles. Pixels depend only on their own indices, so the image is the same for any thread
// count. render/film.h builds the per-pixel sample loop on these (positions: render/batches.h).

#include "core/math.h"
#include "core/progress.h"
#include "core/rng.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cstdint>

namespace fogmap {

class Ranks;

/// A bijection of [0, n) chosen by key, every order about equally likely: for n ≤ 4 one of the
/// n! orders drawn by the key; above, rounds of bijections of [0, 2^b) (b bits for n − 1) — xor
/// and add of key bits, odd multiplies, xor-shifts by small amounts —, cycle-walked into [0, n).
/// Multiplies and adds alone are affine maps, 8 of the 24 orders of four, the same few for every
/// key: the strata of different keys' orders would line up (render/batches.h).
inline uint32_t permute(uint32_t i, uint32_t n, uint64_t key) {
    if (n <= 1) return 0;
    if (n <= 4) {  // a few strata (the first vertex's groups of 4): one of the n! orders, exactly
        uint64_t code = mix64(key) >> 32;    // a 32-bit fraction, each pick its leading digit
        uint32_t items = 0x3210, value = 0;  // the strata left, a nibble each
        for (uint32_t j = 0; j <= i; ++j) {
            const uint32_t left = n - j;
            code *= left;
            const uint32_t pick = uint32_t(code >> 32);
            code &= 0xFFFFFFFFu;
            value = (items >> (4 * pick)) & 0xF;
            const uint32_t low = items & ((1u << (4 * pick)) - 1);
            items = low | ((items >> (4 * pick + 4)) << (4 * pick));  // remove nibble `pick`
        }
        return value;
    }
    uint32_t mask = 1;
    while (mask < n - 1) mask = (mask << 1) | 1;
    const uint64_t k0 = mix64(key), k1 = mix64(~key);
    do {  // each step is a bijection of [0, mask]
        for (int round = 0; round < 8; ++round) {
            const int r = 8 * round;  // k0 rotated by r bits
            const uint64_t k =
                (r ? (k0 >> r | k0 << (64 - r)) : k0) ^ (k1 * (2 * uint64_t(round) + 1));
            i ^= static_cast<uint32_t>(k) & mask;
            i = (i * (static_cast<uint32_t>(k >> 32) | 1u)) & mask;
            i ^= i >> 1;
            i = (i + static_cast<uint32_t>(k >> 16)) & mask;
            i ^= i >> 2;
            i = (i * 0x2C1B3C6Du) & mask;
            i ^= i >> 3;
        }
    } while (i >= n);
    return i;
}

/// The key of a pixel's row shuffle: its own stream, apart from the pixel's sample streams.
inline uint64_t pixel_key(uint64_t seed, uint64_t pixel) {
    return mix64(mix64(seed + stream::kPixelRows) ^ ~pixel);
}

/// The tiles one process renders: t ≡ index (mod count), rows of tiles in turn, so ranks sharing
/// a render (render/pipeline.h) get alike shares of a picture's busy and empty parts.
struct TileShare {
    int index = 0, count = 1;
    /// The processes rendering the other shares, where they exchange sums (MPI ranks: adaptive
    /// sampling's image-wide sums); null alone, or where they cannot (--part).
    Ranks* ranks = nullptr;
};

inline constexpr int kTile = 16;  ///< tiles are kTile × kTile pixels

/// The tiles of a width × height image.
inline int tile_count(int width, int height) {
    return ((width + kTile - 1) / kTile) * ((height + kTile - 1) / kTile);
}

/// The pixels [x0, x1) × [y0, y1) of tile `tile` of a width × height image, its tiles numbered
/// row by row (the last ones clipped to the image).
struct TileRect {
    int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};
inline TileRect tile_rect(int width, int height, int tile) {
    const int tiles_x = (width + kTile - 1) / kTile;
    const int x0 = (tile % tiles_x) * kTile, y0 = (tile / tiles_x) * kTile;
    return {x0, y0, std::min(x0 + kTile, width), std::min(y0 + kTile, height)};
}

/// Calls shade_pixel(x, y, state) for every pixel of a width x height image in `share`'s tiles,
/// with state = make_state() made once per tile, and end_tile(state) on the worker after each;
/// progress on stderr as `what` unless quiet. Returns the number of pixels shaded.
template <class MakeState, class ShadePixel, class EndTile>
uint64_t render_tiles(int width, int height, TileShare share, bool quiet, MakeState&& make_state,
                      ShadePixel&& shade_pixel, EndTile&& end_tile, const char* what = "render") {
    const int mine = (tile_count(width, height) - share.index + share.count - 1) / share.count;
    Progress progress(what, static_cast<uint64_t>(std::max(mine, 0)), quiet);
    std::atomic<uint64_t> pixels{0};
    tbb::parallel_for(tbb::blocked_range<int>(0, std::max(mine, 0), 1), [&](const auto& range) {
        for (int t = range.begin(); t != range.end(); ++t) {
            const int tile = share.index + t * share.count;
            auto state = make_state();
            const auto [x0, y0, x1, y1] = tile_rect(width, height, tile);
            for (int y = y0; y < y1; ++y)
                for (int x = x0; x < x1; ++x) shade_pixel(x, y, state);
            end_tile(state);
            pixels += static_cast<uint64_t>(x1 - x0) * static_cast<uint64_t>(y1 - y0);
            progress.add();
        }
    });
    progress.finish();
    return pixels.load();
}

}  // namespace fogmap
