#include "render/part_file.h"

#include "core/error.h"
#include "core/format_line.h"
#include "core/hash.h"
#include "core/input_file.h"
#include "scene/scene_desc_json.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <utility>

namespace fogmap {

namespace {

constexpr char kPrefix[] = "fogmap part ";
/// The format (its first line's number); older ones are refused by name. What each added: 2 each
/// pixel's samples to progressive sums, 3 its samples per batch (iterations weighed by them), 4
/// iteration 1's own error estimate.
constexpr int kFormat = 4;
const std::string kMagic = format_line(kPrefix, kFormat);
constexpr uint64_t kMaxPartBytes = uint64_t(1) << 40;   ///< a bound before reading; sizes follow
constexpr uint64_t kMaxJsonBytes = uint64_t(64) << 20;  ///< the description (settings, report)

/// Fails unless `head` starts with the part file's first line.
void check_magic(const std::string& path, const std::string& head) {
    check_format_line(path, head, kPrefix, kFormat, "a fogmap part file",
                      "render the parts again with this one");
}

template <class T>
void put(std::string* out, const T& v) {
    out->append(reinterpret_cast<const char*>(&v), sizeof v);
}

/// The part's report before the run's end (PartSums::report): what merged_report reads.
nlohmann::json report_json_of_part(const Report& r) {
    nlohmann::json phases = nlohmann::json::array(), maps = nlohmann::json::array(),
                   iterations = nlohmann::json::array();
    for (const auto& [name, s] : r.phases_s) phases.push_back({name, s});
    for (const MapReport& m : r.maps)
        maps.push_back({m.name, m.stored, m.emitted, m.bytes, m.build_s, m.stopped, m.beams});
    for (const IterationReport& it : r.iterations)
        iterations.push_back({it.index, it.elapsed_s, it.radii.global, it.radii.caustic,
                              it.radii.volume, it.volume_k, it.rel_mse, it.photon_bytes});
    return {
        {"phases", phases},
        {"threads", r.threads},
        {"render_s", r.render_s},
        {"work", {r.photon_steps, r.photon_interactions, r.precompute_nodes, r.estimate_events}},
        {"plan_text", r.plan_text},
        {"plan", r.plan},
        {"maps", maps},
        {"streams", r.streams},
        {"photons_capped_power", r.photons_capped_power},
        {"iterations", iterations},
        {"warnings", r.warnings}};
}

/// The inverse of report_json_of_part. Throws nlohmann's exceptions on other JSON.
Report part_report_of_json(const nlohmann::json& j) {
    Report r;
    for (const nlohmann::json& p : j.at("phases"))
        r.phases_s.emplace_back(p.at(0).get<std::string>(), p.at(1).get<double>());
    r.threads = j.at("threads").get<int>();
    r.render_s = j.at("render_s").get<double>();
    const nlohmann::json& w = j.at("work");
    r.photon_steps = w.at(0).get<uint64_t>();
    r.photon_interactions = w.at(1).get<uint64_t>();
    r.precompute_nodes = w.at(2).get<uint64_t>();
    r.estimate_events = w.at(3).get<uint64_t>();
    r.plan_text = j.at("plan_text").get<std::string>();
    r.plan = j.at("plan");
    for (const nlohmann::json& m : j.at("maps"))
        r.maps.push_back({m.at(0).get<std::string>(), m.at(1).get<uint64_t>(),
                          m.at(2).get<uint64_t>(), m.at(3).get<uint64_t>(), m.at(4).get<double>(),
                          m.at(5).get<std::string>(), m.at(6).get<uint64_t>()});
    r.streams = j.at("streams");
    r.photons_capped_power = j.at("photons_capped_power").get<double>();
    for (const nlohmann::json& i : j.at("iterations")) {
        IterationReport it;
        it.index = i.at(0).get<int>();
        it.elapsed_s = i.at(1).get<double>();
        it.radii = {i.at(2).get<float>(), i.at(3).get<float>(), i.at(4).get<float>()};
        it.volume_k = i.at(5).get<float>();
        it.rel_mse = i.at(6).get<double>();
        it.photon_bytes = i.at(7).get<size_t>();
        r.iterations.push_back(it);
    }
    r.warnings = j.at("warnings").get<std::vector<std::string>>();
    return r;
}

/// `values` with each run of zeros as (its length, the count of values after it up to the next
/// run of zeros, those values): a plain render's part is zero outside its own tiles.
void put_values(std::string* out, const std::vector<int64_t>& values) {
    put(out, uint64_t(values.size()));
    for (size_t at = 0; at < values.size();) {
        size_t zeros = 0, literal = 0;
        while (at + zeros < values.size() && values[at + zeros] == 0) ++zeros;
        while (at + zeros + literal < values.size() && values[at + zeros + literal] != 0) ++literal;
        put(out, uint64_t(zeros));
        put(out, uint64_t(literal));
        out->append(reinterpret_cast<const char*>(values.data() + at + zeros),
                    literal * sizeof(int64_t));
        at += zeros + literal;
    }
}

/// Reads a checked file's fields in order; every read is bounds-checked.
class Reader {
public:
    Reader(const std::string& path, const std::string& bytes, size_t end)
        : path_(path), bytes_(bytes), end_(end) {}
    uint64_t next(const char* field) {
        uint64_t v;
        take(&v, sizeof v, field);
        return v;
    }
    void take(void* to, size_t n, const char* field) {
        if (n > end_ - at_) throw InputError(path_, field, "ends early: the file is cut short");
        std::memcpy(to, bytes_.data() + at_, n);
        at_ += n;
    }
    std::string text(size_t n, const char* field) {
        std::string s(n, '\0');
        take(s.data(), n, field);
        return s;
    }
    bool done() const { return at_ == end_; }

private:
    const std::string& path_;
    const std::string& bytes_;
    const size_t end_;
    size_t at_ = kMagic.size();
};

/// The film's values, `want` of them.
std::vector<int64_t> get_values(const std::string& path, Reader* in, size_t want) {
    const uint64_t n = in->next("values");
    if (n != want)
        throw InputError(
            path, "values",
            std::to_string(n) + " film values; its run's film has " + std::to_string(want));
    std::vector<int64_t> values;
    values.reserve(size_t(n));
    while (values.size() < n) {
        const uint64_t zeros = in->next("values"), literal = in->next("values");
        if (zeros > n - values.size() || literal > n - values.size() - zeros ||
            zeros + literal == 0)
            throw InputError(path, "values",
                             "a run of values beyond the film's; the file is corrupt");
        values.resize(values.size() + size_t(zeros), 0);
        const size_t at = values.size();
        values.resize(at + size_t(literal));
        in->take(values.data() + at, size_t(literal) * sizeof(int64_t), "values");
    }
    return values;
}

/// Iteration 1's estimate, where the part holds one (its count of values 0 where not).
std::optional<ErrorEstimate> get_estimate(const std::string& path, Reader* in,
                                          const CameraDesc& camera) {
    const uint64_t n = in->next("estimate");
    if (n == 0) return std::nullopt;
    const size_t want = estimate_value_count(camera.width, camera.height);
    if (n != want)
        throw InputError(
            path, "estimate",
            std::to_string(n) + " estimate values; its run's estimate has " + std::to_string(want));
    std::vector<int64_t> values(want);
    for (int64_t& v : values) v = int64_t(in->next("estimate"));
    std::optional<ErrorEstimate> e = estimate_of_values(values, camera.width, camera.height);
    if (!e)
        throw InputError(path, "estimate",
                         "its values are not an error estimate's; the file is corrupt");
    return e;
}

/// The run and film shape of a part's JSON block.
void parse_json(const std::string& path, const std::string& text, PartFile* part) {
    try {
        const nlohmann::json j = nlohmann::json::parse(text);
        PartRun& run = part->run;
        run.index = j.at("part").get<int>();
        run.count = j.at("parts").get<int>();
        run.seed = j.at("seed").get<uint64_t>();
        run.settings = j.at("settings_fingerprint").get<uint64_t>();
        run.inputs = j.at("inputs_fingerprint").get<uint64_t>();
        run.setup.run = scene_desc_from_json(j.at("run"), j.at("scene").get<std::string>());
        validate(run.setup.run);
        run.setup.method = method_of(run.setup.run);
        run.setup.progressive = j.at("progressive").get<bool>();
        const nlohmann::json& film = j.at("film");
        PartSums::FilmShape& shape = part->sums.shape;
        shape.map_variance = film.at("map_variance").get<bool>();
        shape.bias_halves = film.at("bias_halves").get<int>();
        shape.batch_share = film.at("batch_share").get<std::array<double, kBatches>>();
        part->sums.report = part_report_of_json(j.at("report"));
    } catch (const nlohmann::json::exception& e) {
        throw InputError(path, "run",
                         std::string("its description is not what fogmap writes (") + e.what() +
                             "); the file is corrupt");
    }
    const PartRun& run = part->run;
    if (run.count < 1 || run.index < 1 || run.index > run.count)
        throw InputError(path, "run",
                         "part " + std::to_string(run.index) + " of " + std::to_string(run.count) +
                             "; expected 1 <= part <= parts");
    if (part->sums.shape.bias_halves < 0 || part->sums.shape.bias_halves > 4)
        throw InputError(path, "run",
                         "a film of " + std::to_string(part->sums.shape.bias_halves) +
                             " bias halves; expected 0 to 4");
}

}  // namespace

uint64_t part_settings_fingerprint(const RunSetup& setup) {
    nlohmann::json j = to_json(setup.run);
    j["render"].erase("threads");  // a farm's machines differ; the image does not
    return fnv1a(j.dump() + (setup.progressive ? " progressive" : " plain"));
}

std::string part_bytes(const PartFile& part) {
    const PartRun& run = part.run;
    const PartSums& sums = part.sums;
    const nlohmann::json j = {{"part", run.index},
                              {"parts", run.count},
                              {"seed", run.seed},
                              {"settings_fingerprint", run.settings},
                              {"inputs_fingerprint", run.inputs},
                              {"scene", run.setup.run.path},
                              {"run", to_json(run.setup.run)},
                              {"progressive", run.setup.progressive},
                              {"film",
                               {{"map_variance", sums.shape.map_variance},
                                {"bias_halves", sums.shape.bias_halves},
                                {"batch_share", sums.shape.batch_share}}},
                              {"report", report_json_of_part(sums.report)}};
    const std::string text = j.dump();
    std::string out(kMagic);
    put(&out, uint64_t(text.size()));
    out += text;
    put(&out, uint64_t(sums.counts.size()));
    for (int64_t v : sums.counts) put(&out, v);
    put_values(&out, sums.values);
    const std::vector<int64_t> first = estimate_values(sums.first);
    put(&out, uint64_t(first.size()));
    for (int64_t v : first) put(&out, v);
    put(&out, fnv1a(out));
    return out;
}

PartRun read_part_run(const std::string& path) {
    const uint64_t size = check_input_file(path, "size", "part file", kMaxPartBytes);
    std::ifstream in(path, std::ios::binary);
    std::string head(kMagic.size() + 8, '\0');
    in.read(head.data(), std::streamsize(head.size()));
    check_magic(path, head.substr(0, size_t(in.gcount())));
    uint64_t json_bytes = 0;
    if (size_t(in.gcount()) == head.size())
        std::memcpy(&json_bytes, head.data() + kMagic.size(), 8);
    if (json_bytes == 0 || json_bytes > std::min<uint64_t>(size, kMaxJsonBytes))
        throw InputError(path, "run", "its description's length is not that of a part file");
    std::string text(size_t(json_bytes), '\0');
    in.read(text.data(), std::streamsize(text.size()));
    if (size_t(in.gcount()) != text.size())
        throw InputError(path, "run", "ends early: the file is cut short");
    PartFile part;
    parse_json(path, text, &part);
    return part.run;
}

PartFile read_part(const std::string& path) {
    const std::string bytes = read_input_file(path, "size", "part file", kMaxPartBytes);
    check_magic(path, bytes);
    const size_t end = bytes.size() - 8;
    uint64_t sum = 0;
    if (bytes.size() >= kMagic.size() + 8) std::memcpy(&sum, bytes.data() + end, 8);
    if (bytes.size() < kMagic.size() + 8 || sum != fnv1a(bytes.substr(0, end)))
        throw InputError(path, "checksum",
                         "its contents do not match their checksum: the file is corrupt or cut "
                         "short");
    Reader in(path, bytes, end);
    PartFile part;
    const uint64_t json_bytes = in.next("run");
    if (json_bytes > std::min<uint64_t>(end, kMaxJsonBytes))
        throw InputError(path, "run", "its description's length is not that of a part file");
    parse_json(path, in.text(size_t(json_bytes), "run"), &part);
    const uint64_t counts = in.next("counts");
    if (counts != kRunCounts)
        throw InputError(
            path, "counts",
            std::to_string(counts) + " counts; expected " + std::to_string(kRunCounts));
    for (size_t k = 0; k < kRunCounts; ++k) {
        part.sums.counts.push_back(int64_t(in.next("counts")));
        if (part.sums.counts.back() < 0)
            throw InputError(path, "counts", "a negative count; the file is corrupt");
    }
    part.sums.values = get_values(path, &in, part_value_count(part.run.setup, part.sums.shape));
    part.sums.first = get_estimate(path, &in, part.run.setup.run.camera);
    if (!in.done())
        throw InputError(path, "estimate", "bytes after the estimate; the file is corrupt");
    return part;
}

}  // namespace fogmap
