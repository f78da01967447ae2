#pragma once
// KdTree<Record>: a balanced kd-tree over records stored in one array without pointers. Contract on
// Record: `Vec3 position() const`, `int axis() const` and `void set_axis(int)` (a 2-bit slot);
// enforced by a static_assert. Built once (parallel), then queried const from any number of
// threads. Queries: k nearest within a max radius (bounded max-heap, pruning by the current k-th
// distance), and all records within a radius.
// Layout (Hooley): a range [lo, hi) of more than 8 records stores its node at the median
// m = lo + (hi - lo) / 2, split on the axis of largest bounding-box extent; the left subtree is
// [lo, m) with coordinates <= the node's, the right [m + 1, hi) with coordinates >= it. Ranges of
// at most 8 records are leaves (axis slot 3) scanned linearly. Distances are squared, in float.

#include "core/math.h"

#include <cstdint>
#include <type_traits>
#include <utility>
#include <vector>

namespace fogmap {

struct Neighbor {
    uint32_t index;  ///< into KdTree::records()
    float dist2;     ///< squared distance to the query point
};

/// Result of a k-nearest query: at most k neighbours within the radius, as a max-heap on dist2.
class NeighborList {
public:
    void clear() { items_.clear(); }
    size_t size() const { return items_.size(); }
    bool empty() const { return items_.empty(); }
    const Neighbor& operator[](size_t i) const { return items_[i]; }
    /// Largest squared distance in the list (the k-th nearest when full); 0 when empty.
    float max_dist2() const { return items_.empty() ? 0.0f : items_.front().dist2; }
    std::vector<Neighbor>& items() { return items_; }

private:
    std::vector<Neighbor> items_;
};

template <class Record>
class KdTree {
    static_assert(std::is_same<decltype(std::declval<const Record&>().position()), Vec3>::value,
                  "KdTree Record needs `Vec3 position() const`");
    static_assert(std::is_convertible<decltype(std::declval<const Record&>().axis()), int>::value,
                  "KdTree Record needs `int axis() const` (the 2-bit split-axis slot)");
    static_assert(std::is_void<decltype(std::declval<Record&>().set_axis(0))>::value,
                  "KdTree Record needs `void set_axis(int)`");

public:
    KdTree() = default;
    /// Builds the tree; records are reordered. Thread-parallel for large inputs.
    explicit KdTree(std::vector<Record> records);

    size_t size() const { return records_.size(); }
    bool empty() const { return records_.empty(); }
    const std::vector<Record>& records() const { return records_; }
    /// Memory held: records plus any index structure, in bytes.
    size_t bytes() const;

    /// The min(k, n) nearest records with squared distance <= r_max², into `out` (cleared first;
    /// unordered, a max-heap). k >= 1; r_max >= 0 (0 finds only records exactly at p); of records
    /// tied at the k-th distance any may be returned. Allocation-free once `out` has capacity k.
    void knn(const Vec3& p, int k, float r_max, NeighborList* out) const;

    /// Calls f(const Record&, float dist2) for every record with squared distance <= r².
    template <class F>
    void for_each_in_radius(const Vec3& p, float r, F&& f) const;

private:
    static constexpr uint32_t kLeafSize = 8;           ///< ranges this small are leaves
    static constexpr uint32_t kLeafAxis = 3;           ///< axis slot value of leaf records
    static constexpr uint32_t kParallelGrain = 16384;  ///< build subtrees larger than this in tasks
    static constexpr int kMaxDepth = 64;               ///< > depth of any tree of < 2^32 records

    /// Makes [lo, hi) a subtree (recursively, in parallel above kParallelGrain).
    void build(uint32_t lo, uint32_t hi);
    /// The shared descent: calls visit(index, dist2) for every record with dist2 < *limit, visiting
    /// near children first and skipping cells whose lower-bound distance² is >= *limit; visit may
    /// lower *limit.
    template <class Visit>
    void search(const Vec3& p, float* limit, Visit&& visit) const;

    std::vector<Record> records_;
};

}  // namespace fogmap

#include "photon/kd_tree_impl.h"
