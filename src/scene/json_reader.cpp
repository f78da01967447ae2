#include "scene/json_reader.h"

#include "core/memory_budget.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <new>
#include <set>

namespace fogmap {

namespace {

std::string join(const std::vector<std::string>& items) {
    std::string s;
    for (const auto& item : items) s += (s.empty() ? "" : ", ") + item;
    return s;
}

[[noreturn]] void throw_type(const nlohmann::json& v, const std::string& file,
                             const std::string& pointer, const std::string& expected) {
    throw InputError(file, pointer, "expected " + expected + ", found " + describe_json(v));
}

// Accepts any JSON number; rejects NaN/Inf (possible in documents built in code) and values
// beyond the float range, which would silently become Inf.
float number_to_float(const nlohmann::json& v, const std::string& file, const std::string& pointer,
                      const std::string& expected) {
    if (!v.is_number()) throw_type(v, file, pointer, expected);
    const double d = v.get<double>();
    if (!std::isfinite(d) || std::abs(d) > double(std::numeric_limits<float>::max())) {
        throw InputError(file, pointer,
                         "expected a finite number (within the float range), "
                         "found " +
                             v.dump());
    }
    return float(d);
}

// Integers may be written as 64 or 64.0 but not 64.5.
bool integral_value(const nlohmann::json& v, long double* out) {
    if (v.is_number_unsigned()) {
        *out = (long double)v.get<uint64_t>();
    } else if (v.is_number_integer()) {
        *out = (long double)v.get<int64_t>();
    } else if (v.is_number_float()) {
        const double d = v.get<double>();
        if (!std::isfinite(d) || std::floor(d) != d) return false;
        *out = d;
    } else {
        return false;
    }
    return true;
}

/// About the memory nlohmann::json takes for `text`, in bytes: a 16-byte node per value, 48 bytes
/// per array or object, a 16-byte slot (doubled by vector growth) per array element and ~80
/// bytes (map node, key string, value) per object member, plus the text of the strings.
/// Structural characters are counted outside strings.
uint64_t json_memory_estimate(const std::string& text) {
    uint64_t containers = 0, separators = 0, members = 0;
    bool quoted = false, escaped = false;
    for (const char c : text) {
        if (quoted) {
            if (escaped)
                escaped = false;
            else if (c == '\\')
                escaped = true;
            else if (c == '"')
                quoted = false;
            continue;
        }
        quoted = c == '"';
        containers += c == '[' || c == '{';
        separators += c == ',';
        members += c == ':';
    }
    return 48 * containers + 32 * (separators + 1) + 80 * members + text.size();
}

/// Finds keys given twice in one object (nlohmann keeps the last silently): the parser callback
/// follows the JSON pointer of the current value and remembers the first duplicate.
class DuplicateKeys {
public:
    bool on_event(nlohmann::json::parse_event_t event, const nlohmann::json& parsed) {
        using E = nlohmann::json::parse_event_t;
        switch (event) {
            case E::object_start:
            case E::array_start:
                frames_.push_back({event == E::array_start, 0, "", {}});
                break;
            case E::key: {
                Frame& top = frames_.back();
                top.key = parsed.get<std::string>();
                if (!top.keys.insert(top.key).second && first_.empty()) {
                    first_ = pointer();
                    key_ = top.key;
                }
                break;
            }
            case E::object_end:
            case E::array_end:
                frames_.pop_back();
                next_element();
                break;
            case E::value:
                next_element();
                break;
        }
        return true;
    }
    /// JSON pointer of the first duplicate key, "" if none.
    const std::string& first() const { return first_; }
    const std::string& key() const { return key_; }

private:
    struct Frame {
        bool array;
        size_t index;
        std::string key;
        std::set<std::string> keys;
    };
    void next_element() {
        if (!frames_.empty() && frames_.back().array) ++frames_.back().index;
    }
    std::string pointer() const {
        std::string p;
        for (const Frame& f : frames_)
            p = json_pointer_append(p, f.array ? std::to_string(f.index) : f.key);
        return p;
    }
    std::vector<Frame> frames_;
    std::string first_, key_;
};

}  // namespace

std::string describe_json(const nlohmann::json& value) {
    switch (value.type()) {
        case nlohmann::json::value_t::null:
            return "null";
        case nlohmann::json::value_t::boolean:
            return std::string("boolean ") + (value.get<bool>() ? "true" : "false");
        case nlohmann::json::value_t::string: {
            std::string s = value.dump();
            if (s.size() > 60) s = s.substr(0, 56) + "...\"";
            return "string " + s;
        }
        case nlohmann::json::value_t::array:
            return "array of " + std::to_string(value.size()) +
                   (value.size() == 1 ? " element" : " elements");
        case nlohmann::json::value_t::object:
            return "object";
        case nlohmann::json::value_t::number_integer:
        case nlohmann::json::value_t::number_unsigned:
        case nlohmann::json::value_t::number_float:
            return "number " + value.dump();
        default:
            return "unsupported value";
    }
}

std::string json_pointer_append(const std::string& pointer, const std::string& token) {
    std::string s = pointer + "/";
    for (char c : token) {
        if (c == '~') {
            s += "~0";
        } else if (c == '/') {
            s += "~1";
        } else {
            s += c;
        }
    }
    return s;
}

float json_to_float(const nlohmann::json& v, const std::string& file, const std::string& pointer) {
    return number_to_float(v, file, pointer, "a number");
}

Vec3 json_to_vec3(const nlohmann::json& v, const std::string& file, const std::string& pointer) {
    if (!v.is_array() || v.size() != 3) throw_type(v, file, pointer, "[x, y, z] (3 numbers)");
    Vec3 r;
    for (int i = 0; i < 3; ++i) {
        r[i] = json_to_float(v[size_t(i)], file, json_pointer_append(pointer, std::to_string(i)));
    }
    return r;
}

Vec3 json_to_vec3_or_number(const nlohmann::json& v, const std::string& file,
                            const std::string& pointer) {
    if (v.is_number()) return Vec3(number_to_float(v, file, pointer, "a number"));
    if (!v.is_array() || v.size() != 3) throw_type(v, file, pointer, "a number or [x, y, z]");
    return json_to_vec3(v, file, pointer);
}

JsonReader::JsonReader(const nlohmann::json& object, std::string file, std::string pointer)
    : object_(object), file_(std::move(file)), pointer_(std::move(pointer)) {
    if (!object_.is_object()) throw_type(object_, file_, pointer_, "an object");
}

std::string JsonReader::pointer(const std::string& key) const {
    return json_pointer_append(pointer_, key);
}

bool JsonReader::has(const std::string& key) { return find(key) != nullptr; }

const nlohmann::json* JsonReader::find(const std::string& key) {
    known_.insert(key);
    const auto it = object_.find(key);
    return it == object_.end() ? nullptr : &*it;
}

bool JsonReader::read(const std::string& key, float* out) {
    const nlohmann::json* v = find(key);
    if (v) *out = json_to_float(*v, file_, pointer(key));
    return v != nullptr;
}

bool JsonReader::read(const std::string& key, int* out) {
    const nlohmann::json* v = find(key);
    if (!v) return false;
    long double x = 0;
    if (!integral_value(*v, &x)) throw_type(*v, file_, pointer(key), "an integer");
    if (x < std::numeric_limits<int>::min() || x > std::numeric_limits<int>::max()) {
        fail(pointer(key),
             "expected an integer in [" + std::to_string(std::numeric_limits<int>::min()) + ", " +
                 std::to_string(std::numeric_limits<int>::max()) + "], found " + v->dump());
    }
    *out = int(x);
    return true;
}

bool JsonReader::read(const std::string& key, uint64_t* out) {
    const nlohmann::json* v = find(key);
    if (!v) return false;
    if (v->is_number_unsigned()) {
        *out = v->get<uint64_t>();
        return true;
    }
    long double x = 0;
    if (!integral_value(*v, &x)) throw_type(*v, file_, pointer(key), "a non-negative integer");
    if (x < 0 || x > (long double)std::numeric_limits<uint64_t>::max()) {
        fail(pointer(key), "expected a non-negative integer (64 bits), found " + v->dump());
    }
    *out = uint64_t(x);
    return true;
}

bool JsonReader::read(const std::string& key, bool* out) {
    const nlohmann::json* v = find(key);
    if (!v) return false;
    if (!v->is_boolean()) throw_type(*v, file_, pointer(key), "true or false");
    *out = v->get<bool>();
    return true;
}

bool JsonReader::read(const std::string& key, std::string* out) {
    const nlohmann::json* v = find(key);
    if (!v) return false;
    if (!v->is_string()) throw_type(*v, file_, pointer(key), "a string");
    *out = v->get<std::string>();
    return true;
}

bool JsonReader::read_vec3(const std::string& key, Vec3* out) {
    const nlohmann::json* v = find(key);
    if (v) *out = json_to_vec3(*v, file_, pointer(key));
    return v != nullptr;
}

bool JsonReader::read_color(const std::string& key, Color* out) {
    const nlohmann::json* v = find(key);
    if (!v) return false;
    if (!v->is_number() && !(v->is_array() && v->size() == 3)) {
        throw_type(*v, file_, pointer(key), "a number or [r, g, b]");
    }
    *out = json_to_vec3_or_number(*v, file_, pointer(key));
    return true;
}

int JsonReader::read_choice(const std::string& key, const std::vector<std::string>& names,
                            const char* what, bool required) {
    const nlohmann::json* v = find(key);
    const std::string expected = "one of: " + join(names) + " (" + what + ")";
    if (!v && required) fail(pointer(key), "missing key '" + key + "'; expected " + expected);
    if (!v) return -1;
    if (!v->is_string()) throw_type(*v, file_, pointer(key), expected);
    const std::string s = v->get<std::string>();
    for (size_t i = 0; i < names.size(); ++i) {
        if (names[i] == s) return int(i);
    }
    fail(pointer(key),
         "unknown " + std::string(what) + " '" + s + "'; expected one of: " + join(names));
}

void JsonReader::require(const std::string& key, const std::string& expected) {
    if (!has(key)) fail(pointer(key), "missing key '" + key + "'; expected " + expected);
}

void JsonReader::fail(const std::string& pointer, const std::string& reason) const {
    throw InputError(file_, pointer, reason);
}

void JsonReader::finish() const {
    for (const auto& item : object_.items()) {
        if (known_.count(item.key())) continue;
        fail(pointer(item.key()), "unknown key '" + item.key() + "'; known keys: " +
                                      join(std::vector<std::string>(known_.begin(), known_.end())));
    }
}

/// nlohmann reports the byte index of the last character read; line and column are counted
/// from the text so that they point at that character (1-based; tabs count as one column).
nlohmann::json parse_json_document(const std::string& text, const std::string& path) {
    // Decided before parsing: a document that cannot fit fails here, naming its estimate.
    const uint64_t needed = json_memory_estimate(text);
    if (needed > memory_budget_bytes()) throw OutOfMemory(path, needed);
    try {
        DuplicateKeys duplicates;
        nlohmann::json doc = nlohmann::json::parse(
            text, [&](int, nlohmann::json::parse_event_t event, nlohmann::json& parsed) {
                return duplicates.on_event(event, parsed);
            });
        if (!duplicates.first().empty())
            throw InputError(path, duplicates.first(),
                             "key '" + duplicates.key() +
                                 "' appears twice in one object; expected each key once");
        return doc;
    } catch (const std::bad_alloc&) {
        throw OutOfMemory(path, needed);
    } catch (const nlohmann::json::parse_error& e) {
        const size_t offending = std::min(e.byte > 0 ? e.byte - 1 : 0, text.size());
        size_t line = 1, line_start = 0;
        for (size_t i = 0; i < offending; ++i) {
            if (text[i] == '\n') {
                ++line;
                line_start = i + 1;
            }
        }
        // Keep nlohmann's description but drop its own "[json.exception...] ... column N: ".
        std::string detail = e.what();
        const size_t column_at = detail.find("column ");
        const size_t colon = detail.find(": ", column_at == std::string::npos ? 0 : column_at);
        if (colon != std::string::npos) detail = detail.substr(colon + 2);
        throw InputError(path, "",
                         "invalid JSON at line " + std::to_string(line) + ", column " +
                             std::to_string(offending - line_start + 1) + ": " + detail);
    } catch (const nlohmann::json::exception& e) {  // e.g. out_of_range 406: number overflow
        std::string detail = e.what();
        const size_t bracket = detail.find("] ");
        if (bracket != std::string::npos) detail = detail.substr(bracket + 2);
        throw InputError(path, "", "invalid JSON: " + detail);
    }
}

}  // namespace fogmap
