// check_format_line (core/format_line.h): the current format passes; every older one is refused
// as an older fogmap's, naming its number and the remedy; anything else as not the kind of file.

#include "core/format_line.h"

#include <gtest/gtest.h>

namespace fogmap {
namespace {

/// The reason check_format_line gives for `head` (format 3 of "fogmap thing "), or "" for none.
std::string refusal(const std::string& head) {
    try {
        check_format_line("f.bin", head, "fogmap thing ", 3, "a fogmap thing", "make it again");
    } catch (const InputError& e) {
        EXPECT_EQ(e.file, "f.bin");
        EXPECT_EQ(e.field, "format");
        return e.reason;
    }
    return "";
}

TEST(FormatLine, OlderFormatsAreNamedAndOthersAreNotTheKind) {
    EXPECT_EQ(format_line("fogmap thing ", 3), "fogmap thing 3\n");
    EXPECT_EQ(refusal("fogmap thing 3\n\x01\x02"), "");
    EXPECT_EQ(refusal("fogmap thing 1\nabc"),
              "written by an older fogmap (format 1); make it again");
    EXPECT_EQ(refusal("fogmap thing 2\n"), "written by an older fogmap (format 2); make it again");
    const std::string other = "not a fogmap thing (its first line is not \"fogmap thing 3\")";
    EXPECT_EQ(refusal("fogmap thing 4\n"), other);   // a newer fogmap's is not this one's either
    EXPECT_EQ(refusal("fogmap thing 31\n"), other);  // the number ends the line
    EXPECT_EQ(refusal("fogmap thing 3"), other);     // cut before the line's end
    EXPECT_EQ(refusal(""), other);
}

}  // namespace
}  // namespace fogmap
