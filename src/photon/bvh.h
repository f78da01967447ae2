#pragma once
// A bounding-volume hierarchy over items kept in one array by its owner (BeamTree's photon
// spheres, PhotonBeams' beam pieces): median splits of the items' centres along the widest axis
// down to leaves of at most kLeaf items (the items are reordered so that each leaf is a range),
// bounds fitted bottom up once the owner knows its items' extents, and a stack traversal that
// visits the leaves whose bounds a ray segment crosses. Immutable after fit(); queries are
// thread-safe.

#include "core/math.h"

#include <algorithm>
#include <cstdint>
#include <vector>

namespace fogmap {

class Bvh {
public:
    static constexpr uint32_t kLeaf = 8;

    struct Node {
        Box3 bounds;           ///< of the items below
        uint32_t begin, end;   ///< leaf: range of items; inner: end = 0
        uint32_t left, right;  ///< children (inner)
    };

    /// Builds the hierarchy over items (reordered), split at the median of centre(item).
    template <class T, class Centre>
    void build(std::vector<T>& items, const Centre& centre) {
        nodes_.clear();
        if (items.empty()) return;
        nodes_.reserve(2 * (items.size() / kLeaf + 1));
        split(items, 0, static_cast<uint32_t>(items.size()), centre);
    }

    /// Fits every node's bounds: item_bounds(i) is item i's box (children come after their parent).
    template <class ItemBounds>
    void fit(const ItemBounds& item_bounds) {
        for (size_t i = nodes_.size(); i-- > 0;) {
            Node& node = nodes_[i];
            node.bounds = Box3{};
            if (node.end != 0) {
                for (uint32_t j = node.begin; j < node.end; ++j) node.bounds.extend(item_bounds(j));
            } else {
                node.bounds.extend(nodes_[node.left].bounds);
                node.bounds.extend(nodes_[node.right].bounds);
            }
        }
    }

    /// Calls f(begin, end) for each leaf whose bounds the segment o + t d, t in [t0, t1], crosses.
    template <class F>
    void for_each_leaf(const Ray& ray, float t0, float t1, F&& f) const {
        if (nodes_.empty() || !(t1 > t0)) return;
        uint32_t stack[64];
        int top = 0;
        stack[top++] = 0;
        while (top > 0) {
            const Node& node = nodes_[stack[--top]];
            float te, tx;
            if (!intersect_box(node.bounds, ray, t0, t1, &te, &tx)) continue;
            if (node.end == 0) {
                stack[top++] = node.left;
                stack[top++] = node.right;
            } else {
                f(node.begin, node.end);
            }
        }
    }

    const std::vector<Node>& nodes() const { return nodes_; }
    size_t bytes() const { return nodes_.capacity() * sizeof(Node); }

private:
    template <class T, class Centre>
    uint32_t split(std::vector<T>& items, uint32_t begin, uint32_t end, const Centre& centre) {
        const uint32_t index = static_cast<uint32_t>(nodes_.size());
        nodes_.push_back(Node{});
        if (end - begin <= kLeaf) {
            nodes_[index].begin = begin;
            nodes_[index].end = end;
            return index;
        }
        Box3 centres;
        for (uint32_t i = begin; i < end; ++i) centres.extend(centre(items[i]));
        const Vec3 e = centres.extent();
        const int axis = (e.x >= e.y && e.x >= e.z) ? 0 : (e.y >= e.z ? 1 : 2);
        const uint32_t mid = begin + (end - begin) / 2;
        std::nth_element(items.begin() + begin, items.begin() + mid, items.begin() + end,
                         [&](const T& a, const T& b) { return centre(a)[axis] < centre(b)[axis]; });
        const uint32_t left = split(items, begin, mid, centre);
        const uint32_t right = split(items, mid, end, centre);
        nodes_[index].begin = begin;
        nodes_[index].end = 0;
        nodes_[index].left = left;
        nodes_[index].right = right;
        return index;
    }

    std::vector<Node> nodes_;
};

}  // namespace fogmap
