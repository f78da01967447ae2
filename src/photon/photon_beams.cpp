#include "photon/photon_beams.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace fogmap {

namespace {

constexpr uint32_t kPieceLeaf = 8;
constexpr size_t kRadiusSamples = 4096;  // beams whose midpoints set the radius

}  // namespace

float PhotonBeams::map_radius(const PhotonMap& map, int k, float r_max) {
    const std::vector<PhotonBeam>& beams = map.beams;
    if (k <= 0 || map.tree.size() < static_cast<size_t>(k) || beams.empty()) return r_max;
    const size_t n = std::min(kRadiusSamples, beams.size());
    std::vector<float> r(n);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 64), [&](const auto& range) {
        NeighborList scratch;
        for (size_t i = range.begin(); i != range.end(); ++i) {
            const PhotonBeam& b = beams[i * beams.size() / n];
            map.tree.knn(0.5f * (b.start() + b.end()), k, r_max, &scratch);
            r[i] = static_cast<int>(scratch.size()) == k ? std::sqrt(scratch.max_dist2()) : r_max;
        }
    });
    std::nth_element(r.begin(), r.begin() + n / 2, r.end());
    return std::clamp(r[n / 2], 1e-6f * r_max, r_max);
}

PhotonBeams::PhotonBeams(const PhotonMap& map, int k, float r_max)
    : radius_(map_radius(map, k, r_max)) {
    const std::vector<PhotonBeam>& beams = map.beams;
    // Pieces of at most kPieceRadii radii, per beam in parallel, then joined in beam order.
    const float longest = kPieceRadii * radius_;
    std::vector<std::vector<Piece>> cut(beams.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, beams.size(), 256), [&](const auto& range) {
        for (size_t i = range.begin(); i != range.end(); ++i) {
            const Vec3 a = beams[i].start(), e = beams[i].end();
            const float length = glm::length(e - a);
            if (!(length > 0.0f)) continue;
            const Vec3 w = (e - a) / length;
            const Color power = beams[i].power();
            const int n = static_cast<int>(std::ceil(length / longest));
            for (int j = 0; j < n; ++j) {
                const float s0 = length * j / n, s1 = j + 1 == n ? length : length * (j + 1) / n;
                cut[i].push_back(Piece{a + s0 * w, s1 - s0, w, radius_, power});
            }
        }
    });
    size_t n = 0;
    for (const auto& c : cut) n += c.size();
    pieces_.reserve(n);
    for (auto& c : cut) pieces_.insert(pieces_.end(), c.begin(), c.end());
    if (pieces_.empty()) return;
    nodes_.reserve(2 * (n / kPieceLeaf + 1));
    build(0, static_cast<uint32_t>(n));
    // Bounds of the capsules, bottom up (children come after their parent).
    for (size_t i = nodes_.size(); i-- > 0;) {
        Node& node = nodes_[i];
        node.bounds = Box3{};
        if (node.end != 0) {
            for (uint32_t j = node.begin; j < node.end; ++j) {
                const Piece& p = pieces_[j];
                const Vec3 b = p.start + p.length * p.dir;
                node.bounds.extend(glm::min(p.start, b) - Vec3(p.r));
                node.bounds.extend(glm::max(p.start, b) + Vec3(p.r));
            }
        } else {
            node.bounds.extend(nodes_[node.left].bounds);
            node.bounds.extend(nodes_[node.right].bounds);
        }
    }
}

// The hierarchy over the pieces' midpoints (median split along the widest axis).
uint32_t PhotonBeams::build(uint32_t begin, uint32_t end) {
    const uint32_t index = static_cast<uint32_t>(nodes_.size());
    nodes_.push_back(Node{});
    if (end - begin <= kPieceLeaf) {
        nodes_[index].begin = begin;
        nodes_[index].end = end;
        return index;
    }
    auto mid_point = [](const Piece& p) { return p.start + 0.5f * p.length * p.dir; };
    Box3 centres;
    for (uint32_t i = begin; i < end; ++i) centres.extend(mid_point(pieces_[i]));
    const Vec3 e = centres.extent();
    const int axis = (e.x >= e.y && e.x >= e.z) ? 0 : (e.y >= e.z ? 1 : 2);
    const uint32_t mid = begin + (end - begin) / 2;
    std::nth_element(
        pieces_.begin() + begin, pieces_.begin() + mid, pieces_.begin() + end,
        [&](const Piece& a, const Piece& b) { return mid_point(a)[axis] < mid_point(b)[axis]; });
    const uint32_t left = build(begin, mid);
    const uint32_t right = build(mid, end);
    nodes_[index].begin = begin;
    nodes_[index].end = 0;
    nodes_[index].left = left;
    nodes_[index].right = right;
    return index;
}

size_t PhotonBeams::bytes() const {
    return pieces_.capacity() * sizeof(Piece) + nodes_.capacity() * sizeof(Node);
}

}  // namespace fogmap
