#pragma once
// The photon record: 20 bytes, pointer-free. Position as float[3]; power as shared-exponent RGBE
// relative to its map's photon power (grey photons store exactly 1, so the encoding adds no error
// there); a direction as a 16-bit octahedral code (see dir_oct); the kd-tree split axis; flags
// and the photon's batch. Plain data; thread-safe to read.

#include "core/math.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

namespace fogmap {

namespace detail {
/// RGBE's exponent bias: exponent byte e scales the 8-bit mantissas by 2^(e − kRgbeExpBias − 8).
constexpr int kRgbeExpBias = 128;
/// That scale for every exponent byte, 0 for e = 0 (black); exact (powers of two).
inline constexpr std::array<float, 256> kRgbeScale = [] {
    std::array<float, 256> scale{};
    for (int e = 1; e < 256; ++e) {
        float f = 1.0f;
        for (int p = e - kRgbeExpBias - 8; p > 0; --p) f *= 2.0f;
        for (int p = e - kRgbeExpBias - 8; p < 0; ++p) f *= 0.5f;
        scale[e] = f;
    }
    return scale;
}();
/// Snorm resolution of one octahedral coordinate: q in [-127, 127] stands for q / 127, so that 0
/// and ±1 (the axes) are exact.
constexpr float kOctScale = 127.0f;

/// 1 for v >= 0 (0 included), else -1: the octahedral folds' sign.
inline float sign_not_zero(float v) { return v >= 0.0f ? 1.0f : -1.0f; }

/// The unit vector of octahedral grid point (qx, qy), q in [-127, 127].
inline Vec3 oct_unproject(int qx, int qy) {
    const float px = static_cast<float>(qx) / kOctScale;
    const float py = static_cast<float>(qy) / kOctScale;
    Vec3 v(px, py, 1.0f - std::fabs(px) - std::fabs(py));
    if (v.z < 0.0f) {
        v.x = (1.0f - std::fabs(py)) * sign_not_zero(px);
        v.y = (1.0f - std::fabs(px)) * sign_not_zero(py);
    }
    return glm::normalize(v);
}
}  // namespace detail

/// Shared-exponent RGB (Ward): 8-bit mantissas, common 8-bit exponent. Non-negative finite input.
/// Decoding is inline: lookups decode every photon they gather.
uint32_t encode_rgbe(const Color& c);
inline Color decode_rgbe(uint32_t rgbe) {
    const float f = detail::kRgbeScale[rgbe >> 24];
    return Color(static_cast<float>(rgbe & 0xFFu) * f, static_cast<float>((rgbe >> 8) & 0xFFu) * f,
                 static_cast<float>((rgbe >> 16) & 0xFFu) * f);
}

/// Octahedral map of a unit vector to 8+8 bits (max angular error 0.65 degrees, axes exact).
uint16_t encode_oct16(const Vec3& dir);
inline Vec3 decode_oct16(uint16_t code) {
    const int qx = std::max(static_cast<int>(code & 0xFFu) - 128, -127);
    const int qy = std::max(static_cast<int>(code >> 8) - 128, -127);
    return detail::oct_unproject(qx, qy);
}

struct Photon {
    enum Flags : uint8_t {
        kCaustic = 1,  ///< global-map photon whose path is L S+ D (also in the caustic map)
    };
    /// Photon batches: every photon of one path is in the same one of kBatches (PhotonPass sets
    /// it from the path's stream and emission index), so a lookup summing one batch's photons
    /// reads a map of independent paths, kBatches times sparser (render/volume_map_end.h).
    static constexpr int kBatches = 8;
    static constexpr int kBatchShift = 1;  ///< flags' bits 1-3 hold the batch
    /// The photon half of batch b: 0 for batches 0 .. kBatches/2 − 1, 1 for the rest (two
    /// independent halves of a map: RadiusBias, BlurCorrection).
    static constexpr int half_of(int b) { return b * 2 / kBatches; }

    float pos[3];
    uint32_t power_rgbe;  ///< power relative to the map's photon power
    /// Volume map: the incoming travel direction (the phase function needs it). Surface maps:
    /// the surface normal on the side the photon arrived from — Lambertian surfaces need no
    /// direction, while the side test and Christensen's irradiance points need the normal.
    uint16_t dir_oct;
    uint8_t split_axis;  ///< kd-tree slot: 0, 1, 2 (3 = leaf)
    uint8_t flags;

    Photon() = default;
    Photon(const Vec3& p, const Vec3& dir, const Color& power, uint8_t flags_ = 0)
        : pos{p.x, p.y, p.z},
          power_rgbe(encode_rgbe(power)),
          dir_oct(encode_oct16(dir)),
          split_axis(3),
          flags(flags_) {}

    Vec3 position() const { return Vec3(pos[0], pos[1], pos[2]); }
    Color power() const { return decode_rgbe(power_rgbe); }
    Vec3 direction() const { return decode_oct16(dir_oct); }
    int batch() const { return (flags >> kBatchShift) & (kBatches - 1); }
    void set_batch(int b) {
        flags = static_cast<uint8_t>((flags & ~((kBatches - 1) << kBatchShift)) |
                                     ((b & (kBatches - 1)) << kBatchShift));
    }
    int axis() const { return split_axis; }
    void set_axis(int a) { split_axis = static_cast<uint8_t>(a); }
};

static_assert(sizeof(Photon) == 20, "photon record must stay 20 bytes");

/// A photon beam (Jarosz, Nowrouzezahrai, Sadeghi, Jensen 2011), short: the part inside the
/// media's bounds of one photon path segment, from where it starts to its next collision (or to
/// the surface or the bounds it reaches without one), carrying the power the photon carried along
/// it. Free paths are sampled ∝ transmittance, so the photon's flux through a point of the
/// segment at distance t is this power times T(t) / P(no collision before t) = this power (grey
/// media). 28 bytes; power relative to its map's photon power, as Photon's.
struct PhotonBeam {
    float a[3], b[3];  ///< start and end
    uint32_t power_rgbe;

    PhotonBeam() = default;
    PhotonBeam(const Vec3& start, const Vec3& end, const Color& power)
        : a{start.x, start.y, start.z}, b{end.x, end.y, end.z}, power_rgbe(encode_rgbe(power)) {}
    Vec3 start() const { return Vec3(a[0], a[1], a[2]); }
    Vec3 end() const { return Vec3(b[0], b[1], b[2]); }
    Color power() const { return decode_rgbe(power_rgbe); }
};

}  // namespace fogmap
