#include "media/light_depth.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace fogmap {

LightDepth::LightDepth(const Medium& medium, const Vec3& to_light, float spacing,
                       size_t max_nodes) {
    w_ = glm::normalize(to_light);
    const Vec3 a = std::abs(w_.x) < 0.6f ? Vec3(1, 0, 0) : Vec3(0, 1, 0);
    u_ = glm::normalize(glm::cross(w_, a));
    v_ = glm::cross(w_, u_);
    const Box3& box = medium.world_bounds();
    if (box.empty()) {  // no density anywhere: depth 0
        h_ = 1.0f;
        n_[0] = n_[1] = n_[2] = 2;
        columns_.assign(4, Column{});
        return;
    }
    Vec3 lo(kInfinity), hi(-kInfinity);  // the box in light space
    for (int c = 0; c < 8; ++c) {
        const Vec3 p((c & 1) ? box.hi.x : box.lo.x, (c & 2) ? box.hi.y : box.lo.y,
                     (c & 4) ? box.hi.z : box.lo.z);
        const Vec3 q(glm::dot(p, u_), glm::dot(p, v_), glm::dot(p, w_));
        lo = glm::min(lo, q);
        hi = glm::max(hi, q);
    }
    // Start where the node count fits (no int overflow for a tiny spacing), then grow to fit.
    const double volume = double(hi.x - lo.x) * (hi.y - lo.y) * (hi.z - lo.z);
    h_ = std::max(spacing, float(std::cbrt(volume / double(max_nodes))));
    for (;;) {
        size_t total = 1;
        for (int d = 0; d < 3; ++d) {
            n_[d] = std::max(2, int(std::ceil((hi[d] - lo[d]) / h_)) + 1);
            total *= size_t(n_[d]);
        }
        if (total <= max_nodes) break;
        h_ *= 1.26f;
    }
    origin_ = lo.x * u_ + lo.y * v_ + lo.z * w_;

    // Each column stores only the nodes along its chord through the box: above it the depth is
    // 0, below it the whole chord's (the first node stored). About the box's volume / h³ nodes.
    const int nk = n_[2];
    const auto line = [&](int col) {
        return Ray{origin_ + float(col % n_[0]) * h_ * u_ + float(col / n_[0]) * h_ * v_, w_};
    };
    columns_.assign(size_t(n_[0]) * n_[1], Column{});
    tbb::parallel_for(0, n_[0] * n_[1], [&](int col) {
        float enter, leave;  // where the column's line crosses the box (light-space w)
        if (!intersect_box(box, line(col), 0.0f, float(nk - 1) * h_, &enter, &leave)) return;
        const int k_top = std::min(nk - 1, int(std::ceil(leave / h_)));
        const int k_low = std::max(0, int(std::floor(enter / h_)));
        columns_[col].k0 = k_low;
        columns_[col].count = std::max(0, k_top - k_low);
    });
    size_t stored = 0;
    for (Column& c : columns_) {
        c.first = stored;
        stored += size_t(c.count);
    }
    depth_.assign(stored, 0.0f);

    // Past this depth every channel's transmittance is below e^-40: the column stops growing.
    const float cap =
        40.0f /
        std::max(std::min({medium.sigma_t().x, medium.sigma_t().y, medium.sigma_t().z}), 1e-30f);
    tbb::parallel_for(
        tbb::blocked_range<int>(0, n_[0] * n_[1]), [&](const tbb::blocked_range<int>& r) {
            Medium::Sampler sampler(medium);
            for (int col = r.begin(); col != r.end(); ++col) {
                const Column& c = columns_[col];
                const Ray ray = line(col);
                float* tau = &depth_[c.first] - c.k0;  // tau[k], k in [k0, k0 + count)
                double sum = 0.0;
                int k = c.k0 + c.count - 1;
                for (; k >= c.k0 && sum < cap; --k) {
                    sum += h_ * double(sampler.density(ray.at((float(k) + 0.5f) * h_)));
                    tau[k] = float(sum);
                }
                for (; k >= c.k0; --k) tau[k] = float(sum);  // past the cap
            }
        });
}

float LightDepth::depth(const Vec3& x) const {
    const Vec3 p = x - origin_;
    const float a = glm::dot(p, u_) / h_, b = glm::dot(p, v_) / h_;
    if (!(a >= 0.0f && b >= 0.0f && a <= float(n_[0] - 1) && b <= float(n_[1] - 1))) return 0.0f;
    const float c = std::clamp(glm::dot(p, w_) / h_, 0.0f, float(n_[2] - 1));
    const int i = std::min(int(a), n_[0] - 2), j = std::min(int(b), n_[1] - 2),
              k = std::min(int(c), n_[2] - 2);
    const float fa = a - float(i), fb = b - float(j), fc = c - float(k);
    const auto at = [&](int di, int dj) {
        const Column& col = columns_[size_t(j + dj) * n_[0] + (i + di)];
        const auto node = [&](int kk) {  // 0 above the chord, the whole chord's below it
            const int d = kk - col.k0;
            return col.count == 0 || d >= col.count ? 0.0f : depth_[col.first + std::max(d, 0)];
        };
        const float t0 = node(k);
        return t0 + fc * (node(k + 1) - t0);
    };
    const float x0 = at(0, 0) + fa * (at(1, 0) - at(0, 0));
    const float x1 = at(0, 1) + fa * (at(1, 1) - at(0, 1));
    return x0 + fb * (x1 - x0);
}

}  // namespace fogmap
