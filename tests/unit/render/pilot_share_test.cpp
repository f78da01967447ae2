// The pilot's share of an image (ShareLayout, render/pilot.h) against a brute force: the tiles of
// kTile × kTile pixels enumerated row by row, those with index % count == 0 kept, their pixels
// listed row by row inside each tile (the last tiles clipped to the image), numbered in that
// order. Widths and heights are not multiples of kTile, so that clipped tiles are in the share.

#include "render/pilot.h"

#include "render/tiles.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

namespace fogmap {
namespace {

constexpr int64_t kOut = -1;

// The compact index of every pixel (row-major over the image), kOut for pixels outside the share.
std::vector<int64_t> expected_indices(int width, int height, int count) {
    std::vector<int64_t> index(size_t(width) * size_t(height), kOut);
    int64_t next = 0, tile = 0;
    for (int ty = 0; ty * kTile < height; ++ty)
        for (int tx = 0; tx * kTile < width; ++tx, ++tile) {
            if (tile % count != 0) continue;
            for (int y = ty * kTile; y < std::min((ty + 1) * kTile, height); ++y)
                for (int x = tx * kTile; x < std::min((tx + 1) * kTile, width); ++x)
                    index[size_t(y) * size_t(width) + size_t(x)] = next++;
        }
    return index;
}

struct Size {
    int width, height;
};

TEST(ShareLayout, IndicesMatchBruteForceOnClippedTiles) {
    for (const Size s : {Size{50, 37}, Size{17, 1}, Size{1, 33}, Size{160, 90}, Size{33, 47},
                         Size{1, 1}, Size{16, 17}})
        for (const int count : {1, 2, 3, 7}) {
            const std::string where = std::to_string(s.width) + "x" + std::to_string(s.height) +
                                      " count " + std::to_string(count);
            const ShareLayout share(s.width, s.height, count);
            const std::vector<int64_t> expected = expected_indices(s.width, s.height, count);
            const int64_t size =
                expected.size() - std::count(expected.begin(), expected.end(), kOut);
            ASSERT_EQ(share.size(), size_t(size)) << where;
            std::vector<int> hits(share.size(), 0);  // index() must be a bijection onto [0, size)
            for (int y = 0; y < s.height; ++y)
                for (int x = 0; x < s.width; ++x) {
                    const int64_t e = expected[size_t(y) * size_t(s.width) + size_t(x)];
                    ASSERT_EQ(share.contains(x, y), e != kOut) << where << " at " << x << "," << y;
                    if (e == kOut) continue;
                    const size_t got = share.index(x, y);
                    ASSERT_EQ(got, size_t(e)) << where << " at " << x << "," << y;
                    ASSERT_LT(got, share.size()) << where;
                    ++hits[got];
                }
            for (size_t i = 0; i < hits.size(); ++i)
                ASSERT_EQ(hits[i], 1) << where << " index " << i;
        }
}

TEST(ShareLayout, GatherPutsEachPixelAtItsIndex) {
    for (const Size s : {Size{50, 37}, Size{17, 1}, Size{1, 33}, Size{160, 90}, Size{33, 47}})
        for (const int count : {1, 2, 3, 7}) {
            Image image(s.width, s.height);
            for (int y = 0; y < s.height; ++y)  // every pixel a different value, exact in float
                for (int x = 0; x < s.width; ++x)
                    image.at(x, y) = Color(float(x), float(y), float(y * s.width + x));
            const ShareLayout share(s.width, s.height, count);
            const std::vector<int64_t> expected = expected_indices(s.width, s.height, count);
            const std::vector<Color> got = share.gather(image);
            ASSERT_EQ(got.size(), share.size());
            for (int y = 0; y < s.height; ++y)
                for (int x = 0; x < s.width; ++x) {
                    const int64_t e = expected[size_t(y) * size_t(s.width) + size_t(x)];
                    if (e == kOut) continue;
                    ASSERT_EQ(got[size_t(e)], image.at(x, y))
                        << s.width << "x" << s.height << " count " << count << " at " << x << ","
                        << y;
                }
        }
}

}  // namespace
}  // namespace fogmap
