#include "core/frames.h"

#include "core/error.h"

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
    if (name[i] == '#') {
        size_t k = i;
        while (k < name.size() && name[k] == '#') ++k;
        *width = static_cast<int>(k - i);
        return k - i;
    }
    if (name.compare(i, 2, "$F") == 0) {
        const size_t k = digits_from(i + 2);
        *width = k > i + 2 ? std::atoi(name.substr(i + 2, k - i - 2).c_str()) : 0;
        return k - i;
    }
    if (name[i] == '%') {
        const size_t k = digits_from(i + 1);
        if (k < name.size() && name[k] == 'd') {
            *width = k > i + 1 ? std::atoi(name.substr(i + 1, k - i - 1).c_str()) : 0;
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
                         "found '" + text +
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
    return FrameRange{static_cast<int>(first), static_cast<int>(last), static_cast<int>(step)};
}

bool has_frame_pattern(const std::string& name) {
    int width;
    for (size_t i = 0; i < name.size(); ++i)
        if (pattern_at(name, i, &width) > 0) return true;
    return false;
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
        out += padded(frame, width);
        i += n;
    }
    return out;
}

}  // namespace fogmap
