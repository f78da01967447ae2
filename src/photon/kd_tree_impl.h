#pragma once
// Template implementation of KdTree<Record> (included at the bottom of photon/kd_tree.h only).
// Build: median split by std::nth_element on the axis of largest extent, subtrees in parallel with
// tbb::parallel_invoke; the result depends only on the input order, not on the thread count.
// Queries: an iterative descent with an explicit stack, near child first; cells are pruned by the
// distance² from the query to the cell (Arya & Mount 1993, "Algorithms for fast vector
// quantization": the per-axis offsets to the splitting planes crossed so far).

#include "photon/kd_tree.h"

#include "core/error.h"

#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace fogmap {
namespace detail {

/// |v|², the one formula used for both record distances and cell lower bounds. Float rounding is
/// monotone, so a cell's bound never exceeds the computed dist2 of a record inside it.
inline float norm2(const Vec3& v) { return v.x * v.x + v.y * v.y + v.z * v.z; }

/// Smallest float above r² (inf stays inf), so that `dist2 < limit` means `dist2 <= r²`.
inline float inclusive_limit(float r) {
    return std::nextafter(r * r, std::numeric_limits<float>::infinity());
}

}  // namespace detail

template <class Record>
KdTree<Record>::KdTree(std::vector<Record> records) : records_(std::move(records)) {
    FOGMAP_ASSERT(records_.size() < std::numeric_limits<uint32_t>::max(),
                  "KdTree holds fewer than 2^32 - 1 records (Neighbor::index is 32-bit)");
    build(0, static_cast<uint32_t>(records_.size()));
}

template <class Record>
size_t KdTree<Record>::bytes() const {
    return records_.capacity() * sizeof(Record);
}

template <class Record>
void KdTree<Record>::build(uint32_t lo, uint32_t hi) {
    if (hi - lo <= kLeafSize) {
        for (uint32_t i = lo; i < hi; ++i) records_[i].set_axis(kLeafAxis);
        return;
    }
    Box3 box;
    for (uint32_t i = lo; i < hi; ++i) box.extend(records_[i].position());
    const Vec3 extent = box.extent();
    const int axis = (extent.x >= extent.y && extent.x >= extent.z) ? 0
                     : (extent.y >= extent.z)                       ? 1
                                                                    : 2;
    const uint32_t m = lo + (hi - lo) / 2;
    const auto begin = records_.begin();
    std::nth_element(begin + lo, begin + m, begin + hi, [axis](const Record& a, const Record& b) {
        return a.position()[axis] < b.position()[axis];
    });
    records_[m].set_axis(axis);
    if (hi - lo > kParallelGrain) {
        tbb::parallel_invoke([this, lo, m] { build(lo, m); }, [this, m, hi] { build(m + 1, hi); });
    } else {
        build(lo, m);
        build(m + 1, hi);
    }
}

template <class Record>
template <class Visit>
void KdTree<Record>::search(const Vec3& p, float* limit, Visit&& visit) const {
    struct Pending {
        uint32_t lo, hi;
        float cell_dist2;  ///< lower bound of the distance² from p to the subtree's cell
        Vec3 offset;       ///< per-axis distance from p to that cell
    };
    Pending stack[kMaxDepth];
    int depth = 0;
    const Record* records = records_.data();
    uint32_t lo = 0, hi = static_cast<uint32_t>(records_.size());
    Vec3 offset(0.0f);
    for (;;) {
        while (hi - lo > kLeafSize) {
            const uint32_t m = lo + (hi - lo) / 2;
            const Record& node = records[m];
            const Vec3 diff = p - node.position();
            const float dist2 = detail::norm2(diff);
            if (dist2 < *limit) visit(m, dist2);
            const int axis = node.axis();
            const float delta = diff[axis];  // signed distance from the split plane to p
            Vec3 far_offset = offset;
            far_offset[axis] = delta;
            const float far_dist2 = detail::norm2(far_offset);
            const bool left_is_near = delta <= 0.0f;
            if (far_dist2 < *limit) {
                FOGMAP_DASSERT(depth < kMaxDepth, "kd-tree deeper than 64 levels");
                stack[depth++] = left_is_near ? Pending{m + 1, hi, far_dist2, far_offset}
                                              : Pending{lo, m, far_dist2, far_offset};
            }
            if (left_is_near) {
                hi = m;
            } else {
                lo = m + 1;
            }
        }
        for (uint32_t i = lo; i < hi; ++i) {
            const float dist2 = detail::norm2(p - records[i].position());
            if (dist2 < *limit) visit(i, dist2);
        }
        // Resume at the nearest-pending far child that the (possibly shrunk) limit still admits.
        do {
            if (depth == 0) return;
            --depth;
        } while (!(stack[depth].cell_dist2 < *limit));
        lo = stack[depth].lo;
        hi = stack[depth].hi;
        offset = stack[depth].offset;
    }
}

template <class Record>
void KdTree<Record>::knn(const Vec3& p, int k, float r_max, NeighborList* out) const {
    FOGMAP_DASSERT(k >= 1 && r_max >= 0.0f, "knn needs k >= 1 and r_max >= 0");
    std::vector<Neighbor>& heap = out->items();
    heap.clear();
    if (records_.empty() || k < 1) return;
    const size_t k_max = static_cast<size_t>(k);
    heap.reserve(std::min(k_max, records_.size()));
    const auto closer = [](const Neighbor& a, const Neighbor& b) { return a.dist2 < b.dist2; };
    // Until the heap holds k candidates the bound is r_max² (inclusive), then the k-th distance²
    // (exclusive: an equally distant record would not improve the answer).
    float limit = detail::inclusive_limit(r_max);
    search(p, &limit, [&](uint32_t index, float dist2) {
        if (heap.size() < k_max) {
            heap.push_back(Neighbor{index, dist2});
            std::push_heap(heap.begin(), heap.end(), closer);
            if (heap.size() == k_max) limit = heap.front().dist2;
            return;
        }
        // Full: the new record (closer than the root, by the limit) replaces the root, which
        // sifts down — one pass instead of pop_heap + push_heap.
        Neighbor* h = heap.data();
        const size_t n = heap.size();
        size_t i = 0;
        for (;;) {
            size_t child = 2 * i + 1;
            if (child >= n) break;
            if (child + 1 < n && h[child + 1].dist2 > h[child].dist2) ++child;
            if (!(h[child].dist2 > dist2)) break;
            h[i] = h[child];
            i = child;
        }
        h[i] = Neighbor{index, dist2};
        limit = h[0].dist2;
    });
}

template <class Record>
template <class F>
void KdTree<Record>::for_each_in_radius(const Vec3& p, float r, F&& f) const {
    if (records_.empty()) return;
    float limit = detail::inclusive_limit(r);
    search(p, &limit, [&](uint32_t index, float dist2) { f(records_[index], dist2); });
}

}  // namespace fogmap
