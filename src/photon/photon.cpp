// Photon record encodings: Ward's shared-exponent RGBE (Graphics Gems II, "Real Pixels") with
// round-to-nearest mantissas, and the 8+8-bit octahedral direction code (Cigolle et al. 2014,
// "A Survey of Efficient Representations for Independent Unit Vectors", the "precise" variant).

#include "photon/photon.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace fogmap {
namespace {

/// Largest exponent byte: values up to 255 * 2^(255 - 136) ≈ 1.7e38 are representable.
constexpr int kExpBias = detail::kRgbeExpBias;
constexpr int kMaxExpByte = 255;

/// Non-negative finite part of a channel: NaN and negatives become 0, +Inf the largest float.
float sanitize(float v) {
    if (!(v > 0.0f)) return 0.0f;
    return std::fmin(v, std::numeric_limits<float>::max());
}

/// Octahedral projection of a unit vector onto [-1, 1]²: the lower hemisphere folds outwards.
Vec2 oct_project(const Vec3& v) {
    const float l1 = std::fabs(v.x) + std::fabs(v.y) + std::fabs(v.z);
    Vec2 p(v.x / l1, v.y / l1);
    if (v.z < 0.0f) {
        p = Vec2((1.0f - std::fabs(p.y)) * detail::sign_not_zero(p.x),
                 (1.0f - std::fabs(p.x)) * detail::sign_not_zero(p.y));
    }
    return p;
}

uint16_t pack_oct(int qx, int qy) {
    return static_cast<uint16_t>(static_cast<uint32_t>(qx + 128) |
                                 (static_cast<uint32_t>(qy + 128) << 8));
}

}  // namespace

uint32_t encode_rgbe(const Color& c) {
    const float r = sanitize(c.x), g = sanitize(c.y), b = sanitize(c.z);
    const float max_c = std::fmax(r, std::fmax(g, b));
    if (max_c == 0.0f) return 0u;
    // max_c = m 2^e with m in [0.5, 1): the largest mantissa lands in [128, 256) after scaling by
    // 2^(8 - e). Rounding (instead of Ward's truncation) halves the error and keeps 1 and powers
    // of two exact; a mantissa that rounds up to 256 moves to the next exponent.
    int e = 0;
    std::frexp(max_c, &e);
    if (std::nearbyint(std::ldexp(max_c, 8 - e)) >= 256.0f) ++e;
    if (e + kExpBias < 1) return 0u;  // below 2^-128: too small to matter, stored as black
    if (e + kExpBias > kMaxExpByte) return 0xFFFFFFFFu;  // above ~1.7e38 (or +Inf): saturate
    const auto mantissa = [e](float v) {
        return static_cast<uint32_t>(std::nearbyint(std::ldexp(v, 8 - e)));
    };
    const uint32_t exp_byte = static_cast<uint32_t>(e + kExpBias);
    return mantissa(r) | (mantissa(g) << 8) | (mantissa(b) << 16) | (exp_byte << 24);
}

uint16_t encode_oct16(const Vec3& dir) {
    const float l1 = std::fabs(dir.x) + std::fabs(dir.y) + std::fabs(dir.z);
    if (!(l1 > 0.0f) || !std::isfinite(l1)) return pack_oct(0, 0);  // degenerate input: +z
    const Vec3 v = dir / l1;
    const Vec2 p = oct_project(v);
    // Precise encoding: of the 4 grid points around p, keep the one whose decoded direction is
    // closest to v (plain rounding is up to ~1.6x worse near the folds).
    const int x0 = static_cast<int>(std::floor(p.x * detail::kOctScale));
    const int y0 = static_cast<int>(std::floor(p.y * detail::kOctScale));
    const Vec3 v_unit = glm::normalize(v);
    int best_x = 0, best_y = 0;
    float best_cos = -2.0f;
    for (int dy = 0; dy <= 1; ++dy) {
        for (int dx = 0; dx <= 1; ++dx) {
            const int qx = std::min(x0 + dx, 127), qy = std::min(y0 + dy, 127);
            const float cos_angle = glm::dot(detail::oct_unproject(qx, qy), v_unit);
            if (cos_angle > best_cos) {
                best_cos = cos_angle;
                best_x = qx;
                best_y = qy;
            }
        }
    }
    return pack_oct(best_x, best_y);
}

}  // namespace fogmap
