// Part files (render/part_file.h): a hand-built part survives part_bytes and read_part with every
// field the merge reads — the run, the film's shape, the counts, values with runs of zeros at the
// start, middle and end, the unfinished report — and read_part_run reads the same run from the
// first bytes alone; iteration 1's error estimate, where the part holds one, round-trips and is
// refused by name where its values are not an estimate's; a file cut short anywhere or with any
// byte changed is refused with an InputError naming the file.

#include "render/part_file.h"

#include "core/error.h"
#include "scene/scene_desc.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <cstring>
#include <string>

namespace fogmap {
namespace {

/// A 3 x 2 plain render's part (map variance and 4 bias halves in its film): values with zeros at
/// both ends and in runs between distinct, extreme and negative ones.
PartFile hand_built() {
    SceneDesc desc;
    desc.path = "scenes/x.json";
    desc.camera.width = 3;
    desc.camera.height = 2;
    LightDesc sun;
    sun.type = LightType::Sun;
    desc.lights.push_back(sun);
    desc.render.integrator = Integrator::Photon;
    desc.render.seed = 12345678901ull;
    PartFile p;
    p.run.index = 2;
    p.run.count = 3;
    p.run.seed = desc.render.seed;
    p.run.setup = resolve_run(desc);
    p.run.settings = part_settings_fingerprint(p.run.setup);
    p.run.inputs = 0xFEDCBA9876543210ull;
    PartSums& s = p.sums;
    s.shape.map_variance = true;
    s.shape.bias_halves = 4;
    for (int b = 0; b < kBatches; ++b) s.shape.batch_share[size_t(b)] = 1.0 / 3.0 + b;
    for (size_t i = 0; i < kRunCounts; ++i) s.counts.push_back(int64_t(i) << (4 * i));
    s.values.assign(part_value_count(p.run.setup, s.shape), 0);
    for (size_t i = 5; i + 3 < s.values.size(); ++i)
        if (i % 7 < 3) s.values[i] = int64_t(uint64_t(i) * 0x9E3779B97F4A7C15ull);
    s.values[9] = INT64_MIN;
    s.values[10] = -1;
    Report& r = s.report;
    r.phases_s = {{"load", 0.25}, {"render", 1.0 / 3.0}, {"build volume", 2.5}};
    r.threads = 7;
    r.render_s = 1.0 / 3.0;
    r.photon_steps = 11;
    r.photon_interactions = 12;
    r.precompute_nodes = 13;
    r.estimate_events = 14;
    r.plan_text = "plan: \"quoted\"\nline two\n";
    r.plan = {{"volume", true}};
    r.maps = {{"volume", 100, 200, 300, 0.5, "closed by rule", 7}};
    r.streams = nlohmann::json::array({{{"name", "sun"}}});
    r.photons_capped_power = 1e-9;
    IterationReport it;
    it.index = 2;
    it.elapsed_s = 1.5;
    it.radii = {0.1f, 0.2f, 0.3f};
    it.volume_k = 4.5f;
    it.rel_mse = -1.0;
    it.photon_bytes = 999;
    r.iterations = {it};
    r.warnings = {"one", "two"};
    return p;
}

TEST(PartFile, RoundTripKeepsEveryFieldTheMergeReads) {
    const test::TempDir dir("fogmap_part");
    const PartFile p = hand_built();
    const std::string path = dir.write("p.fogpart", part_bytes(p));
    for (const PartRun& run : {read_part(path).run, read_part_run(path)}) {
        EXPECT_EQ(run.index, 2);
        EXPECT_EQ(run.count, 3);
        EXPECT_EQ(run.seed, p.run.seed);
        EXPECT_EQ(run.settings, p.run.settings);
        EXPECT_EQ(run.inputs, p.run.inputs);
        EXPECT_EQ(part_settings_fingerprint(run.setup), p.run.settings);
        EXPECT_EQ(run.setup.method, p.run.setup.method);
        EXPECT_EQ(run.setup.progressive, p.run.setup.progressive);
    }
    const PartSums r = read_part(path).sums;
    const PartSums& s = p.sums;
    EXPECT_EQ(r.counts, s.counts);
    EXPECT_EQ(r.values, s.values);
    EXPECT_EQ(r.shape.map_variance, s.shape.map_variance);
    EXPECT_EQ(r.shape.bias_halves, s.shape.bias_halves);
    EXPECT_EQ(r.shape.batch_share, s.shape.batch_share);
    EXPECT_EQ(r.report.phases_s, s.report.phases_s);
    EXPECT_EQ(r.report.threads, 7);
    EXPECT_EQ(r.report.render_s, s.report.render_s);
    EXPECT_EQ(r.report.photon_steps, 11u);
    EXPECT_EQ(r.report.photon_interactions, 12u);
    EXPECT_EQ(r.report.precompute_nodes, 13u);
    EXPECT_EQ(r.report.estimate_events, 14u);
    EXPECT_EQ(r.report.plan_text, s.report.plan_text);
    EXPECT_EQ(r.report.plan, s.report.plan);
    ASSERT_EQ(r.report.maps.size(), 1u);
    EXPECT_EQ(r.report.maps[0].stopped, "closed by rule");
    EXPECT_EQ(r.report.maps[0].beams, 7u);
    EXPECT_EQ(r.report.streams, s.report.streams);
    EXPECT_EQ(r.report.photons_capped_power, 1e-9);
    ASSERT_EQ(r.report.iterations.size(), 1u);
    EXPECT_EQ(r.report.iterations[0].radii.caustic, 0.2f);
    EXPECT_EQ(r.report.iterations[0].volume_k, 4.5f);
    EXPECT_EQ(r.report.iterations[0].photon_bytes, 999u);
    EXPECT_EQ(r.report.warnings, s.report.warnings);
}

/// hand_built() of a part that ran iteration 1 of a run that may end there: its estimate set.
PartFile with_estimate() {
    PartFile p = hand_built();
    ErrorEstimate& e = p.sums.first.emplace();
    e.valid = true;
    e.batches = 7;
    e.rel_mse = {3e-4, 2e-4, 5e-4};
    e.bias_valid = true;
    e.bias2 = {-1e-6, 0.0, 2e-6};  // a bias² estimate may fall below its interval's 0
    e.tail_share = 0.25;
    e.top_x = 2;
    e.top_y = 1;
    e.dof = 12.5;
    e.variance = Image(3, 2);
    for (size_t i = 0; i < e.variance.pixels.size(); ++i)
        e.variance.pixels[i] = Color(1e-9f * float(i), 0.0f, 7.0f);
    return p;
}

TEST(PartFile, IterationOnesEstimateRoundTrips) {
    const test::TempDir dir("fogmap_part");
    EXPECT_FALSE(read_part(dir.write("p.fogpart", part_bytes(hand_built()))).sums.first);
    const PartFile p = with_estimate();
    const PartSums r = read_part(dir.write("e.fogpart", part_bytes(p))).sums;
    ASSERT_TRUE(r.first.has_value());
    const ErrorEstimate &a = *p.sums.first, &b = *r.first;
    EXPECT_TRUE(b.valid);
    EXPECT_EQ(b.batches, 7);
    EXPECT_EQ(b.rel_mse.value, a.rel_mse.value);
    EXPECT_EQ(b.rel_mse.hi, a.rel_mse.hi);
    EXPECT_EQ(b.bias2.value, a.bias2.value);
    EXPECT_EQ(b.tail_share, a.tail_share);
    EXPECT_FALSE(b.tail);
    EXPECT_EQ(b.top_x, 2);
    EXPECT_EQ(b.top_y, 1);
    EXPECT_EQ(b.dof, 12.5);
    EXPECT_EQ(b.variance.pixels, a.variance.pixels);
    EXPECT_EQ(r.values, p.sums.values);
}

// The estimate stands last before the checksum: its count, its 14 fields (the first: valid), then
// the variance's 3 x 2 x 3 values, each 8 bytes.
TEST(PartFile, AnEstimateThatIsNotOneIsRefusedByName) {
    const test::TempDir dir("fogmap_part");
    const std::string good = part_bytes(with_estimate());
    const size_t valid = good.size() - 8 - 8 * (14 + 18);
    for (const double v : {0.0, 2.0}) {
        std::string bytes = good;
        std::memcpy(&bytes[valid], &v, 8);
        const uint64_t sum = test::fnv1a_64(bytes.substr(0, bytes.size() - 8));
        std::memcpy(&bytes[bytes.size() - 8], &sum, 8);
        const std::string path = dir.write("bad.fogpart", bytes);
        const InputError e = test::catch_input_error([&] { read_part(path); });
        EXPECT_EQ(e.file, path);
        EXPECT_EQ(e.field, "estimate") << e.what();
    }
}

TEST(PartFile, AllZeroAndNoZeroFilmsRoundTrip) {
    const test::TempDir dir("fogmap_part");
    for (const int64_t fill : {int64_t(0), int64_t(3)}) {
        PartFile p = hand_built();
        std::fill(p.sums.values.begin(), p.sums.values.end(), fill);
        EXPECT_EQ(read_part(dir.write("p.fogpart", part_bytes(p))).sums.values, p.sums.values);
    }
}

TEST(PartFile, AFileCutShortOrChangedAnywhereIsRefused) {
    const test::TempDir dir("fogmap_part");
    for (PartFile p : {hand_built(), with_estimate()}) {
        p.sums.report = Report{};  // a smaller file; every byte is tried
        const std::string bytes = part_bytes(p);
        for (size_t n = 0; n < bytes.size(); ++n) {
            SCOPED_TRACE("byte " + std::to_string(n) + " of " + std::to_string(bytes.size()));
            const std::string cut = dir.write("cut.fogpart", bytes.substr(0, n));
            EXPECT_EQ(test::catch_input_error([&] { read_part(cut); }).file, cut);
            std::string changed = bytes;
            changed[n] = char(changed[n] ^ 0x01);
            const std::string bad = dir.write("bad.fogpart", changed);
            EXPECT_EQ(test::catch_input_error([&] { read_part(bad); }).file, bad);
        }
    }
}

}  // namespace
}  // namespace fogmap
