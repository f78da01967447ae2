// Frame ranges and the three frame-pattern spellings users bring from Houdini, Blender and
// printf, against hand-written expansions.

#include "core/frames.h"

#include "core/error.h"
#include "test_support.h"

#include <gtest/gtest.h>

namespace fogmap {
namespace {

TEST(Frames, PatternsExpandToTheFrameNumber) {
    EXPECT_EQ(expand_frame("smoke.####.vdb", 7), "smoke.0007.vdb");
    EXPECT_EQ(expand_frame("smoke.#.vdb", 12), "smoke.12.vdb");
    EXPECT_EQ(expand_frame("smoke.$F4.vdb", 7), "smoke.0007.vdb");
    EXPECT_EQ(expand_frame("smoke.$F.vdb", 7), "smoke.7.vdb");
    EXPECT_EQ(expand_frame("smoke.%04d.vdb", 7), "smoke.0007.vdb");
    EXPECT_EQ(expand_frame("smoke.%d.vdb", 7), "smoke.7.vdb");
    EXPECT_EQ(expand_frame("a/###/b_##.vdb", 3), "a/003/b_03.vdb") << "every pattern";
    EXPECT_EQ(expand_frame("smoke.####.vdb", 123456), "smoke.123456.vdb") << "wider than padding";
    EXPECT_EQ(expand_frame("smoke.####.vdb", -3), "smoke.-0003.vdb");
    EXPECT_EQ(expand_frame("plain.vdb", 3), "plain.vdb");
    EXPECT_EQ(expand_frame("50%.vdb", 3), "50%.vdb") << "a lone % is no pattern";
    EXPECT_TRUE(has_frame_pattern("x.####.exr"));
    EXPECT_TRUE(has_frame_pattern("x.$F4.exr"));
    EXPECT_TRUE(has_frame_pattern("x.%04d.exr"));
    EXPECT_FALSE(has_frame_pattern("x.0001.exr"));
    EXPECT_FALSE(has_frame_pattern("50%.exr"));
}

TEST(Frames, RangesListTheirFrames) {
    EXPECT_EQ(parse_frame_range("1-5", "--frames").frames(), (std::vector<int>{1, 2, 3, 4, 5}));
    EXPECT_EQ(parse_frame_range("1-10:4", "--frames").frames(), (std::vector<int>{1, 5, 9}));
    EXPECT_EQ(parse_frame_range("12", "--frames").frames(), (std::vector<int>{12}));
    EXPECT_EQ(parse_frame_range("-2-1", "--frames").frames(), (std::vector<int>{-2, -1, 0, 1}));
}

TEST(Frames, BadRangesAreInputErrors) {
    for (const char* bad :
         {"", "a-b", "5-1", "1-5:0", "1-5:-1", "1-", "1-5:", "1..5", "1-5x", "1-9999999999"}) {
        SCOPED_TRACE(bad);
        const InputError e = test::catch_input_error([&] { parse_frame_range(bad, "--frames"); });
        EXPECT_EQ(e.field, "--frames");
        EXPECT_NE(e.reason.find("expected FIRST-LAST"), std::string::npos) << e.reason;
    }
}

// A range of more than kMaxFrameCount frames is refused with its count, before any list of them
// is made; a pattern padded to more digits than any frame has is refused, and expand_frame never
// pads beyond kMaxFrameDigits (a pattern's width is no allocation size).
TEST(Frames, AbsurdCountsAndWidthsAreRefusedWithTheirNumbers) {
    const InputError many =
        test::catch_input_error([] { parse_frame_range("1-99999999", "--frames"); });
    EXPECT_NE(many.reason.find("99999999 frames; at most 100000"), std::string::npos)
        << many.reason;
    EXPECT_EQ(parse_frame_range("1-200000:2", "--frames").frames().size(), 100000u);
    for (const char* wide :
         {"o.$F999999999.exr", "o.%0123456789d.exr", "o.$F10.exr", "o.##########.exr"}) {
        SCOPED_TRACE(wide);
        const InputError e = test::catch_input_error([&] { check_frame_pattern(wide, "", "-o"); });
        EXPECT_EQ(e.field, "-o");
        EXPECT_NE(e.reason.find("more than 9 digits"), std::string::npos) << e.reason;
        EXPECT_LE(expand_frame(wide, 7).size(), std::string(wide).size() + 9);
    }
    check_frame_pattern("o.$F9.exr", "", "-o");  // nine digits: fine
    EXPECT_EQ(expand_frame("o.$F9.exr", 7), "o.000000007.exr");
    // An error line never echoes a long input whole.
    const InputError e =
        test::catch_input_error([] { parse_frame_range(std::string(1 << 20, '7'), "--frames"); });
    EXPECT_LT(std::string(e.what()).size(), 8192u);
}

}  // namespace
}  // namespace fogmap
