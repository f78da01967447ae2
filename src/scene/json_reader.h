#pragma once
// JsonReader: checked, typed reads from one JSON object of a scene file. Every read names the
// key's JSON pointer in its InputError; each key asked for (present or not) becomes a known key,
// and finish() rejects the keys nobody asked for, listing the known ones. Absent keys leave the
// caller's default untouched. Not thread-safe; one reader per object, used by scene/ only.

#include "core/error.h"
#include "core/math.h"

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <set>
#include <string>
#include <vector>

namespace fogmap {

/// Parses a whole JSON document read from `file`. Throws InputError{file, "", "invalid JSON at
/// line L, column C: ..."} for a syntax error, InputError{file, pointer, ...} for a key given
/// twice in one object (the parser would keep the last silently), and OutOfMemory{file, estimate}
/// when the document's memory, estimated from its text before parsing, exceeds the memory budget
/// (core/memory_budget.h) or the parser runs out of memory.
nlohmann::json parse_json_document(const std::string& text, const std::string& file);

/// "found string \"abc\"", "found number 1.5", "found array of 2 elements", ... for messages.
std::string describe_json(const nlohmann::json& value);

/// Appends one reference token to a JSON pointer, escaping '~' and '/' (RFC 6901).
std::string json_pointer_append(const std::string& pointer, const std::string& token);

class JsonReader {
public:
    /// Reads `object` found at `pointer` in `file`. Throws InputError if it is not an object.
    JsonReader(const nlohmann::json& object, std::string file, std::string pointer);

    const std::string& file() const { return file_; }
    const std::string& pointer() const { return pointer_; }
    /// The JSON pointer of `key` inside this object.
    std::string pointer(const std::string& key) const;
    /// True if the key is present (and marks it known).
    bool has(const std::string& key);
    /// The raw value of a present key (marks it known); nullptr when absent.
    const nlohmann::json* find(const std::string& key);

    /// Typed reads: return true and set *out if the key is present; leave *out alone otherwise.
    /// Throw InputError on a wrong type, a NaN/Inf (or a number out of float/int range).
    bool read(const std::string& key, float* out);
    bool read(const std::string& key, int* out);
    bool read(const std::string& key, uint64_t* out);
    bool read(const std::string& key, bool* out);
    bool read(const std::string& key, std::string* out);
    /// [x, y, z].
    bool read_vec3(const std::string& key, Vec3* out);
    /// A number (all three channels) or [r, g, b].
    bool read_color(const std::string& key, Color* out);

    /// A string that must equal to_string(v) for one of `values`; the error lists all choices.
    /// `what` names the option set in messages ("light type"). A `required` key that is absent
    /// throws InputError too.
    template <class E, size_t N>
    bool read_enum(const std::string& key, const std::array<E, N>& values, const char* what, E* out,
                   bool required = false) {
        std::vector<std::string> names;
        for (E v : values) names.emplace_back(to_string(v));
        const int i = read_choice(key, names, what, required);
        if (i >= 0) *out = values[size_t(i)];
        return i >= 0;
    }

    /// Throws InputError{file, pointer(key), "missing key ..."} if the key is absent.
    void require(const std::string& key, const std::string& expected);
    /// Throws InputError{file, pointer, reason}.
    [[noreturn]] void fail(const std::string& pointer, const std::string& reason) const;

    /// Rejects keys that no read asked for: "unknown key 'x'; known keys: a, b, c".
    void finish() const;

private:
    int read_choice(const std::string& key, const std::vector<std::string>& names, const char* what,
                    bool required);

    const nlohmann::json& object_;
    std::string file_;
    std::string pointer_;
    std::set<std::string> known_;
};

/// Element reads for values that are not object members (array elements, nested vectors).
/// Each throws InputError{file, pointer, reason} on a wrong type or a non-finite number.
float json_to_float(const nlohmann::json& v, const std::string& file, const std::string& pointer);
Vec3 json_to_vec3(const nlohmann::json& v, const std::string& file, const std::string& pointer);
/// A number (all three channels) or [x, y, z].
Vec3 json_to_vec3_or_number(const nlohmann::json& v, const std::string& file,
                            const std::string& pointer);

}  // namespace fogmap
