#include "core/frames.h"

#include "core/error.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <string>

namespace fogmap {

namespace {

constexpr long kMaxFrame = 100000000;

/// The frame number zero-padded to `width` digits (the sign ahead of the padding).
std::string padded(int frame, int width) {
    std::string digits = std::to_string(frame < 0 ? -static_cast<long>(frame) : frame);
    if (static_cast<int>(digits.size()) < width)
        digits.insert(0, static_cast<size_t>(width) - digits.size(), '0');
    return (frame < 0 ? "-" : "") + digits;
}

/// At name[i], the length of a frame pattern and its padding width (0 when none starts there).
size_t pattern_at(const std::string& name, size_t i, int* width) {
    const auto digits_from = [&](size_t j) {
        size_t k = j;
        while (k < name.size() && std::isdigit(static_cast<unsigned char>(name[k]))) ++k;
        return k;
    };
    // A width of many digits is "more than any frame needs" (kMaxFrameDigits + 1), not a number.
    const auto width_of = [&](size_t from, size_t to) {
        if (to - from > 3) return kMaxFrameDigits + 1;
        return from == to ? 0 : std::atoi(name.substr(from, to - from).c_str());
    };
    if (name[i] == '#') {
        size_t k = i;
        while (k < name.size() && name[k] == '#') ++k;
        *width = static_cast<int>(std::min<size_t>(k - i, kMaxFrameDigits + 1));
        return k - i;
    }
    if (name.compare(i, 2, "$F") == 0) {
        const size_t k = digits_from(i + 2);
        *width = width_of(i + 2, k);
        return k - i;
    }
    if (name[i] == '%') {
        const size_t k = digits_from(i + 1);
        if (k < name.size() && name[k] == 'd') {
            *width = width_of(i + 1, k);
            return k + 1 - i;
        }
    }
    return 0;
}

}  // namespace

std::vector<int> FrameRange::frames() const {
    std::vector<int> out;
    for (long f = first; f <= last; f += step) out.push_back(static_cast<int>(f));
    return out;
}

FrameRange parse_frame_range(const std::string& text, const std::string& option) {
    const auto fail = [&](const std::string& why) {
        throw InputError("", option,
                         "found '" + InputError::clip(text, 64) +
                             "'; expected FIRST-LAST or FIRST-LAST:STEP (e.g. "
                             "1-48 or 1-48:2)" +
                             (why.empty() ? "" : ": " + why));
    };
    // Numbers: an optional sign, digits; the range's dash follows the first number.
    size_t i = 0;
    const auto number = [&](long* value) {
        const size_t start = i;
        if (i < text.size() && (text[i] == '-' || text[i] == '+')) ++i;
        const size_t digits = i;
        while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) ++i;
        if (i == digits || i - digits > 9) fail("");
        *value = std::strtol(text.substr(start, i - start).c_str(), nullptr, 10);
    };
    long first = 0, last = 0, step = 1;
    number(&first);
    last = first;
    if (i < text.size() && text[i] == '-') {
        ++i;
        number(&last);
    }
    if (i < text.size() && text[i] == ':') {
        ++i;
        number(&step);
    }
    if (i != text.size()) fail("");
    if (std::labs(first) > kMaxFrame || std::labs(last) > kMaxFrame)
        fail("frames must lie within ±" + std::to_string(kMaxFrame));
    if (first > last) fail("the first frame is after the last");
    if (step < 1) fail("the step must be >= 1");
    const long count = (last - first) / step + 1;
    if (count > kMaxFrameCount)
        fail("that is " + std::to_string(count) + " frames; at most " +
             std::to_string(kMaxFrameCount) + " per run");
    return FrameRange{static_cast<int>(first), static_cast<int>(last), static_cast<int>(step)};
}

bool has_frame_pattern(const std::string& name) {
    int width;
    for (size_t i = 0; i < name.size(); ++i)
        if (pattern_at(name, i, &width) > 0) return true;
    return false;
}

void check_frame_pattern(const std::string& name, const std::string& file,
                         const std::string& field) {
    int width = 0;
    for (size_t i = 0; i < name.size(); ++i)
        if (pattern_at(name, i, &width) > 0 && width > kMaxFrameDigits)
            throw InputError(file, field,
                             "a frame pattern padded to more than " +
                                 std::to_string(kMaxFrameDigits) +
                                 " digits; expected at most that (frames lie within ±1e8)");
}

std::string expand_frame(const std::string& name, int frame) {
    std::string out;
    for (size_t i = 0; i < name.size();) {
        int width = 0;
        const size_t n = pattern_at(name, i, &width);
        if (n == 0) {
            out += name[i++];
            continue;
        }
        out += padded(frame, std::min(width, kMaxFrameDigits));
        i += n;
    }
    return out;
}

}  // namespace fogmap
