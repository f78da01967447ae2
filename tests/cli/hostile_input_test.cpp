// Hostile input through the fogmap command line: it never crashes, hangs or silently gives a
// wrong answer, and outputs are safe. One test (or a few) per class:
//   1. cost decided up front: non-regular and oversized input files, JSON too big for memory,
//      bench run counts, image memory, a VDB sampler over a huge active box, march steps per ray;
//   2. crashes: extreme transforms and voxel sizes, bit flips in a VDB's transform;
//   3. wrong results: truncated VDBs, overflowing light power, NaN references, empty grids,
//      non-finite exposure;
//   4/6. outputs: signals and file-size limits during the write, unwritable outputs found before
//      the work, outputs that are inputs, stale temps of killed runs, the VDB probe child;
//   5. messages: fogmap reasons instead of library text, one line for bad arguments, duplicate
//      keys, the thread count, -q keeping warnings.
// Files are made by the tests in a temp folder (volumes/plume.vdb is read, never changed).

#include "core/image.h"
#include "media/volume_gen.h"
#include "test_support.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <openvdb/openvdb.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <tbb/info.h>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace fogmap {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::RunResult;
using test::slurp;
using test::spit;

const std::string kPlume = std::string(FOGMAP_SOURCE_DIR) + "/volumes/plume.vdb";

class HostileInput : public ::testing::Test {
protected:
    RunResult run(const std::string& args, const std::string& shell_prefix = "") {
        return test::run_fogmap(args, dir_, shell_prefix);
    }

    std::string path(const std::string& name) const { return (dir_ / name).string(); }

    /// A small valid scene (a sun over a ground quad, 8 x 6 pixels, few photons) with `patch`
    /// merged in (RFC 7386: objects merge, arrays and values replace), written to `name`.
    std::string scene(const json& patch = json::object(), const std::string& name = "s.json") {
        json doc = json::parse(R"({
          "camera": {"position": [0, 1, 4], "look_at": [0, 0.5, 0], "width": 8, "height": 6},
          "lights": [{"type": "sun", "direction": [0.3, -1, 0.2], "irradiance": 3}],
          "materials": {"ground": {"type": "diffuse", "albedo": 0.5}},
          "shapes": [{"type": "quad", "corner": [-5, 0, -5], "edge_u": [0, 0, 10],
                      "edge_v": [10, 0, 0], "material": "ground"}],
          "photons": {"global": 100, "caustic": 0, "volume": 100},
          "render": {"integrator": "photon", "spp": 1}
        })");
        doc.merge_patch(patch);
        return tmp_.write(name, doc.dump(2));
    }

    /// The scene with one VDB medium read from `vdb`.
    std::string vdb_scene(const std::string& vdb, const std::string& name = "s.json") {
        return scene({{"media", json::array({{{"type", "vdb"}, {"file", vdb}}})}}, name);
    }

    /// Every file name in the test's folder.
    std::set<std::string> names() const {
        std::set<std::string> out;
        for (const auto& e : fs::directory_iterator(dir_)) out.insert(e.path().filename().string());
        return out;
    }

    /// Names in the folder that are temp files ("*.tmp-<pid>").
    std::vector<std::string> temps() const {
        std::vector<std::string> out;
        for (const std::string& n : names())
            if (n.find(".tmp-") != std::string::npos) out.push_back(n);
        return out;
    }

    test::TempDir tmp_{"fogmap_hostile"};
    const fs::path dir_ = tmp_.path();
};

/// The rejection contract: exit `code`, not killed by a signal, exactly one line
/// "fogmap: error: ..." of printable characters, containing every one of `names`.
void expect_one_error(const RunResult& r, int code, const std::vector<std::string>& names) {
    EXPECT_FALSE(r.signaled) << "killed by a signal: " << r.err;
    EXPECT_EQ(r.code, code) << r.err;
    EXPECT_EQ(r.err.rfind("fogmap: error: ", 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line: " << r.err;
    for (const char c : r.err)
        ASSERT_TRUE(c == '\n' || (static_cast<unsigned char>(c) >= 0x20 && c != 0x7f))
            << "printable: " << r.err;
    for (const std::string& n : names)
        EXPECT_NE(r.err.find(n), std::string::npos) << "names '" << n << "': " << r.err;
}

/// Bytes of volumes/plume.vdb with `byte` XOR-ed into position `at`.
std::string plume_flipped(size_t at, unsigned char byte) {
    std::string bytes = slurp(kPlume);
    bytes.at(at) = static_cast<char>(static_cast<unsigned char>(bytes[at]) ^ byte);
    return bytes;
}

/// Offset of the first double of plume.vdb's UniformScaleMap (its scale, 0.035).
size_t plume_transform_offset() {
    const std::string bytes = slurp(kPlume);
    const std::string name = "UniformScaleMap";
    const size_t at = bytes.find(name);
    EXPECT_NE(at, std::string::npos);
    return at + name.size();
}

// ---- 1. Cost decided before the work -----------------------------------------------------------

TEST_F(HostileInput, InputsThatAreNotRegularFilesAreRefusedWithoutOpening) {
    const std::string fifo = path("pipe");
    ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
    // `timeout` turns a regression (open() blocking on the FIFO) into exit 124, not a hang.
    const std::string guard = "timeout 60 ";
    expect_one_error(run("render -q /dev/zero -o " + path("o.exr"), guard), 2,
                     {"/dev/zero", "character device"});
    expect_one_error(run("render -q " + dir_.string() + " -o " + path("o.exr"), guard), 2,
                     {"folder"});
    expect_one_error(run("render -q " + fifo + " -o " + path("o.exr"), guard), 2, {"FIFO"});
    expect_one_error(run("render -q " + vdb_scene(fifo) + " -o " + path("o.exr"), guard), 2,
                     {"pipe", "/media/0", "FIFO"});
    const std::string fifo_obj = path("pipe.obj");
    ASSERT_EQ(mkfifo(fifo_obj.c_str(), 0600), 0);
    const std::string mesh =
        scene({{"shapes",
                json::array({{{"type", "mesh"}, {"file", fifo_obj}, {"material", "ground"}}})}});
    expect_one_error(run("render -q " + mesh + " -o " + path("o.exr"), guard), 2,
                     {"/shapes/0/file", "FIFO"});
    expect_one_error(
        run("render -q " + scene() + " -o " + path("o.exr") + " --reference " + fifo, guard), 2,
        {"FIFO"});
    expect_one_error(run("info " + fifo, guard), 2, {"FIFO"});
}

TEST_F(HostileInput, OversizedInputFilesAreRefusedBeforeReading) {
    // Sparse files: 200 MB and 1.1 GB of holes take no disk and no time to make.
    const std::string big = tmp_.write("big.json", "");
    fs::resize_file(big, 200u << 20);
    expect_one_error(run("render -q " + big + " -o " + path("o.exr")), 2,
                     {"big.json", "200 MB", "at most 16 MB"});
    const std::string obj = tmp_.write("big.obj", "");
    fs::resize_file(obj, (1u << 30) + (100u << 20));
    const std::string mesh = scene(
        {{"shapes", json::array({{{"type", "mesh"}, {"file", obj}, {"material", "ground"}}})}});
    expect_one_error(run("render -q " + mesh + " -o " + path("o.exr")), 2,
                     {"big.obj", "/shapes/0/file", "at most 1024 MB"});
}

TEST_F(HostileInput, JsonTooBigForTheMemoryLimitIsOutOfMemoryNotAnAbort) {
    // 15 MB of empty arrays: under the size cap, but ~400 MB as nlohmann::json (16-byte nodes,
    // 48 bytes per array, 32 per element slot). With 400 MB of address space (the binary and its
    // libraries take ~100 MB of it) the parse cannot fit: exit 1 and one line, never SIGABRT.
    std::string text = "{\"render\": {\"spp\": 2}, \"x\": [[]";
    text.reserve(15u << 20);
    while (text.size() < (15u << 20)) text += ",[]";
    const std::string file = tmp_.write("huge.json", text + "]}");
    const RunResult r = run("render -q " + file + " -o " + path("o.exr"), "ulimit -v 400000; ");
    expect_one_error(r, 1, {"huge.json"});
    EXPECT_TRUE(std::regex_search(r.err, std::regex("out of memory \\(needed about [0-9]+ MB\\)")))
        << r.err;
}

TEST_F(HostileInput, BenchCountsItsRunsBeforeAnyWork) {
    std::string hundred;
    for (int i = 1; i <= 100; ++i) hundred += (i > 1 ? "," : "") + std::to_string(i);
    const std::string keys[] = {"render.spp", "render.seed", "render.max_depth", "global.k",
                                "caustic.k"};
    std::string sweeps;
    for (const std::string& k : keys) sweeps += " --sweep " + k + "=" + hundred;
    const std::string outputs = " --csv " + path("out/b.csv") + " --plot " + path("out/b.svg");
    // 100^5 = 1e10 runs: refused at once (a regression would build 1e10 scene descriptions).
    expect_one_error(
        run("bench -q " + scene() + " --reference-spp 4" + sweeps + outputs, "timeout 60 "), 2,
        {"--sweep",
         "100 x 100 x 100 x 100 x 100 = " + std::to_string(100ull * 100 * 100 * 100 * 100) +
             " runs",
         "at most 1000"});
    // An exact count: 11^3 sweep runs and the 4 default path tracer runs.
    std::string eleven;
    for (int i = 1; i <= 11; ++i) eleven += (i > 1 ? "," : "") + std::to_string(i);
    const int expected = 11 * 11 * 11;
    expect_one_error(
        run("bench -q " + scene() + " --reference-spp 4 --sweep render.spp=" + eleven +
            " --sweep render.seed=" + eleven + " --sweep global.k=" + eleven + outputs),
        2, {"11 x 11 x 11 = " + std::to_string(expected) + " runs", "plus 4 path"});
    EXPECT_FALSE(fs::exists(path("out"))) << "nothing written";
}

TEST_F(HostileInput, ImageMemoryIsEstimatedBeforeRendering) {
    // 16384^2 pixels x ((beauty, 6 layers, 8 batches, the maps' variance and 4 bias halves) x 2
    // films x 12 bytes + the variance and samples layers' 2 x 12 + the error estimate's 9 x 12 +
    // 6 bytes of PNG) = 158208 MB of images; under an 8 GB address-space limit the run is refused
    // with that estimate, before the work.
    const double images_mb =
        16384.0 * 16384.0 * ((7 + 8 + 1 + 4) * 2 * 12 + (2 + 9) * 12 + 6) / (1 << 20);
    ASSERT_EQ(images_mb, 158208.0);
    const RunResult r = run("render -q " + scene() + " -o " + path("o.exr") +
                                " --set camera.width=16384 --set camera.height=16384",
                            "ulimit -v 8000000; timeout 60 ");
    expect_one_error(r, 2, {"/camera/width", "16384 x 16384", "images 158208 MB", "available"});
}

TEST_F(HostileInput, AGridTooBigForTheMemoryIsRefusedFromItsMetadataBeforeItIsRead) {
    // An 8^3 grid whose metadata (file_mem_bytes, which OpenVDB writes with every grid: its tree's
    // size in memory) says 10^12 bytes: refused from the metadata before the file is read, with
    // the tree's size in MB (10^12 / 2^20, rounded up: 953675) beside the sampler's.
    openvdb::initialize();
    openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(0.0f);
    grid->setName("density");
    for (int n = 0; n < 512; ++n)
        grid->tree().setValue(openvdb::Coord(n >> 6, (n >> 3) & 7, n & 7), 1.0f);
    grid->insertMeta("file_mem_bytes", openvdb::Int64Metadata(1000000000000));
    grid->insertMeta("file_bbox_min", openvdb::Vec3IMetadata(openvdb::Vec3i(0, 0, 0)));
    grid->insertMeta("file_bbox_max", openvdb::Vec3IMetadata(openvdb::Vec3i(7, 7, 7)));
    const std::string vdb = path("huge.vdb");
    openvdb::io::File file(vdb);
    file.setGridStatsMetadataEnabled(false);  // keeps the metadata set above
    file.write({grid});
    file.close();
    const RunResult r = run("render -q " + vdb_scene(vdb) + " -o " + path("o.exr"), "timeout 60 ");
    expect_one_error(r, 2,
                     {"huge.vdb", "/media/0", "reading it takes about 953675 MB", "OpenVDB's tree",
                      "density sampler", "available"});
}

TEST_F(HostileInput, ADryRunPredictsThePeakWithoutRenderingOrWriting) {
    // scenes/smoke.json (480 x 270, paths ending in the volume map): images of (beauty, 6 layers,
    // 8 batches, the maps' variance, 4 bias halves) x 2 films x 12 bytes, the variance and samples
    // layers' 2 x 12, the error estimate's 9 x 12, the PNG's 6 bytes and adaptive sampling's 56
    // bytes a pixel: 83.3 MB, said rounded up.
    const double images =
        480.0 * 270.0 * ((7 + 8 + 1 + 4) * 2 * 12 + (2 + 9) * 12 + 6 + 56) / (1 << 20);
    const RunResult r = run("render " + std::string(FOGMAP_SOURCE_DIR) +
                            "/scenes/smoke.json --dry-run -o " + path("o.exr"));
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.out.find("images " + std::to_string(int(std::ceil(images))) + " MB"),
              std::string::npos)
        << r.out;
    EXPECT_NE(r.out.find("work: 4147200 camera samples (480 x 270 x 32 spp)"), std::string::npos)
        << r.out;
    EXPECT_FALSE(fs::exists(path("o.exr")));
    EXPECT_FALSE(fs::exists(path("o.png")));
}

TEST_F(HostileInput, ADryRunsPredictedPeakBoundsTheRunsOwn) {
    // Camera paths ending in a volume map of 2 000 000 photon attempts at 64 x 36: its lookup
    // grids (about 1.2 M moment points), not the image, set the peak. The run's own peak
    // resident memory (getrusage of the finished child) is the independent value: the
    // prediction must be at least it, and within 2x (it said 177 MB of a 341 MB peak before it
    // counted the grids).
    const std::string args = "render " + std::string(FOGMAP_SOURCE_DIR) +
                             "/scenes/smoke.json --spp 16 --set photons.volume=2000000 --set "
                             "camera.width=64 --set camera.height=36 -o " +
                             path("o.exr");
    const RunResult dry = run(args + " --dry-run");
    ASSERT_EQ(dry.code, 0) << dry.err;
    const std::string key = "predicted peak memory: about ";
    const size_t at = dry.out.find(key);
    ASSERT_NE(at, std::string::npos) << dry.out;
    const double predicted_mb = std::stod(dry.out.substr(at + key.size()));
    const RunResult real = run(args + " -q");
    ASSERT_EQ(real.code, 0) << real.err;
    rusage usage{};
    ASSERT_EQ(getrusage(RUSAGE_CHILDREN, &usage), 0);
    const double peak_mb = double(usage.ru_maxrss) / 1024.0;  // KiB, the largest child's
    std::cout << "[ memory   ] predicted " << predicted_mb << " MB, peak " << peak_mb << " MB\n";
    EXPECT_GE(predicted_mb, peak_mb);
    EXPECT_LE(predicted_mb, 2.0 * peak_mb);
}

TEST_F(HostileInput, ADryRunSaysTheIntegratorTheRunReports) {
    // The run's own report is the independent value: the dry run's integrator line (method, why,
    // schedule and adaptive sampling) must be the one the render then prints.
    const auto integrator_line = [](const std::string& out) {
        const size_t at = out.find("integrator: ");
        return at == std::string::npos ? std::string() : out.substr(at, out.find('\n', at) - at);
    };
    const std::string scene = std::string(FOGMAP_SOURCE_DIR) + "/scenes/smoke.json" +
                              " --set camera.width=48 --set camera.height=27";
    const RunResult dry = run("render " + scene + " --dry-run -o " + path("o.exr"));
    const RunResult real = run("render " + scene + " -o " + path("o.exr"));
    ASSERT_EQ(dry.code, 0) << dry.err;
    ASSERT_EQ(real.code, 0) << real.err;
    const std::string line = integrator_line(dry.out);
    EXPECT_NE(line.find("adaptive sampling: a first pass of 8 spp"), std::string::npos) << line;
    EXPECT_EQ(line, integrator_line(real.out + real.err));
}

TEST_F(HostileInput, VdbWhoseActiveTileSpansTheIndexSpaceIsRefusedUpFront) {
    // A 600-byte file: one active tile at the root level (4096^3 voxels) at voxel size 0.001.
    // The sampler's cells cover the active box: 512^3 cells, ~6 GB, minutes of work.
    openvdb::initialize();
    openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(0.0f);
    grid->setName("density");
    grid->tree().addTile(3, openvdb::Coord(0), 1.0f, true);
    grid->setTransform(openvdb::math::Transform::createLinearTransform(0.001));
    const std::string vdb = path("tile.vdb");
    openvdb::io::File(vdb).write({grid});
    ASSERT_LT(fs::file_size(vdb), 2000u);
    const auto start = std::chrono::steady_clock::now();
    const RunResult r = run("render -q " + vdb_scene(vdb) + " -o " + path("o.exr"), "timeout 60 ");
    expect_one_error(r, 2, {"tile.vdb", "/media/0", "4096 x 4096 x 4096", "MB", "cells"});
    // A bound on the refusal itself, not a timing assertion on fogmap's speed: the estimate needs
    // no loop over the box (a regression runs for minutes or is killed by `timeout`).
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(50));
}

TEST_F(HostileInput, AbsurdMarchStepIsRefusedWithItsEstimate) {
    const std::string s = vdb_scene(kPlume);
    expect_one_error(
        run("render -q " + s + " -o " + path("o.exr") + " --set march.step_voxels=1e-9"), 2,
        {"/march/step_voxels", "steps per camera ray", "1e-09"});
    // A fine but sane step (~12000 steps across the plume) still renders.
    const RunResult ok =
        run("render -q " + s + " -o " + path("o.exr") + " --set march.step_voxels=0.01");
    EXPECT_EQ(ok.code, 0) << ok.err;
}

// ---- 2. Crashes --------------------------------------------------------------------------------

TEST_F(HostileInput, ExtremeTransformsAreInputErrorsNotEmbreeAborts) {
    // Unchecked, each aborts in Embree's ray.valid() assertion (SIGABRT) or renders nothing.
    expect_one_error(run("render -q " +
                         scene({{"media", json::array({{{"type", "vdb"},
                                                        {"file", kPlume},
                                                        {"transform", {{"scale", 1e18}}}}})}}) +
                         " -o " + path("o.exr")),
                     2, {"/media/0/transform", "axis scales 1e+18"});
    expect_one_error(
        run("render -q " +
            scene({{"shapes", json::array({{{"type", "box"},
                                            {"material", "ground"},
                                            {"transform", {{"scale", {1, 0, 1}}}}}})}}) +
            " -o " + path("o.exr")),
        2, {"/shapes/0/transform", "1 x 0 x 1"});
    // A mesh whose vertex is far outside the world range.
    const std::string obj = tmp_.write("far.obj", "v 0 0 0\nv 1 0 0\nv 0 1e30 0\nf 1 2 3\n");
    expect_one_error(
        run("render -q " +
            scene({{"shapes",
                    json::array({{{"type", "mesh"}, {"file", obj}, {"material", "ground"}}})}}) +
            " -o " + path("o.exr")),
        2, {"/shapes/0/transform", "far.obj", "1e+30"});
}

TEST_F(HostileInput, VoxelSizesOutOfRangeAreRefusedOnWriteAndOnRead) {
    expect_one_error(run("volume plume --resolution 16 --voxel-size 1e30 -o " + path("v.vdb")), 2,
                     {"--voxel-size", "1e+30"});
    expect_one_error(run("volume plume --resolution 1024 --voxel-size 1e5 -o " + path("v.vdb")), 2,
                     {"--voxel-size", "world units"});
    EXPECT_FALSE(fs::exists(path("v.vdb")));
    // The same grid written by OpenVDB directly.
    const std::string vdb = path("huge_voxels.vdb");
    write_float_grid(
        vdb, "density", 4, 4, 4, [](int, int, int) { return 1.0f; }, Vec3(1e30f));
    expect_one_error(run("render -q " + vdb_scene(vdb) + " -o " + path("o.exr")), 2,
                     {"huge_voxels.vdb", "/media/0", "voxel sizes 1e+30"});
}

TEST_F(HostileInput, AVolumeTooBigForTheMemoryIsRefusedBeforeItIsMade) {
    // 4096^3 of cloud is about 4 billion active voxels: tens of GB, estimated from the grids
    // made at 64^3 and 128^3, against a 2 GB address space. One error, exit 2, no file; the
    // resolution's range itself is 2 .. 4096.
    expect_one_error(
        run("volume cloud --resolution 4096 -o " + path("v.vdb"), "ulimit -v 2000000; "), 2,
        {"--resolution", "4096 makes grids of about", "memory available"});
    EXPECT_FALSE(fs::exists(path("v.vdb")));
    expect_one_error(run("volume cloud --resolution 4097 -o " + path("v.vdb")), 2,
                     {"--resolution", "2 .. 4096"});
}

TEST_F(HostileInput, BitFlipsInTheVdbTransformNeverAbort) {
    const size_t at = plume_transform_offset();
    // The map stores five Vec3d (scale, voxel size, inverse scale, its square, half of it): the
    // top byte (sign and exponent) of the first double of each, two bits each.
    for (int k = 0; k < 15; k += 3) {
        for (const unsigned char bit : {0x40, 0x20}) {
            const size_t byte = at + 8 * k + 7;
            SCOPED_TRACE("byte " + std::to_string(byte) + " ^ " + std::to_string(bit));
            spit(path("flip.vdb"), plume_flipped(byte, bit));
            const RunResult r =
                run("render -q " + vdb_scene(path("flip.vdb")) + " -o " + path("o.exr"));
            EXPECT_FALSE(r.signaled) << r.err;
            EXPECT_TRUE(r.code == 0 || r.code == 2) << r.code << ": " << r.err;
            if (r.code == 2) expect_one_error(r, 2, {"flip.vdb"});
            // The scale's exponent makes 0.035 into ~1e152 (unchecked: SIGABRT) or singular.
            if (k == 0) expect_one_error(r, 2, {"flip.vdb", "/media/0"});
        }
    }
}

// ---- 3. Wrong results --------------------------------------------------------------------------

TEST_F(HostileInput, TruncatedVdbIsAnErrorNotAnEmptyGrid) {
    const std::string bytes = slurp(kPlume);
    // 1480 bytes ends inside the transform (unchecked, it reads as an empty grid, exit 0); the rest
    // cut the voxel data.
    for (const size_t keep : {size_t(1480), bytes.size() / 4, bytes.size() / 2, bytes.size() - 1}) {
        SCOPED_TRACE("kept " + std::to_string(keep) + " bytes");
        spit(path("cut.vdb"), bytes.substr(0, keep));
        expect_one_error(run("render -q " + vdb_scene(path("cut.vdb")) + " -o " + path("o.exr")), 2,
                         {"cut.vdb", "/media/0", "truncated"});
        expect_one_error(run("info " + path("cut.vdb")), 2, {"cut.vdb", "truncated"});
    }
    EXPECT_FALSE(fs::exists(path("o.exr")));
}

TEST_F(HostileInput, LightPowerThatOverflowsFloatIsRefused) {
    // Unchecked, 1e36 W/m^2 drops half the samples and the sun without a word.
    expect_one_error(run("render -q " +
                         scene({{"lights", json::array({{{"type", "sun"},
                                                         {"direction", {0.3, -1, 0.2}},
                                                         {"irradiance", 1e36}}})}}) +
                         " -o " + path("o.exr")),
                     2, {"/lights/0/irradiance", "1e+36"});
    // 1e19 W/m^2 passes on its own; over a ground 2 km wide (bounding radius ~700 m) its power
    // π r² E is ~1.5e25 W: refused when the scene's size is known.
    const RunResult r =
        run("render -q " +
            scene({{"lights",
                    json::array(
                        {{{"type", "sun"}, {"direction", {0.3, -1, 0.2}}, {"irradiance", 1e19}}})},
                   {"shapes", json::array({{{"type", "quad"},
                                            {"corner", {-500, 0, -500}},
                                            {"edge_u", {0, 0, 1000}},
                                            {"edge_v", {1000, 0, 0}},
                                            {"material", "ground"}}})}}) +
            " -o " + path("o.exr"));
    expect_one_error(r, 2, {"/lights/0/irradiance", "bounding sphere", "expected at most 1e+20"});
}

TEST_F(HostileInput, ReferenceWithANanPixelIsRefused) {
    Image ref(8, 6);
    for (Color& c : ref.pixels) c = Color(0.25f);
    ref.at(3, 2).y = std::numeric_limits<float>::quiet_NaN();
    write_exr(path("ref.exr"), ref);
    expect_one_error(
        run("render -q " + scene() + " -o " + path("o.exr") + " --reference " + path("ref.exr")), 2,
        {"ref.exr", "pixel (3, 2)", "nan"});
    expect_one_error(run("bench -q " + scene() + " --reference " + path("ref.exr") +
                         " --sweep render.spp=1 --path-spp none --csv " + path("b.csv") +
                         " --plot " + path("b.svg")),
                     2, {"ref.exr", "pixel (3, 2)"});
    EXPECT_EQ(names(), (std::set<std::string>{"ref.exr", "s.json", "stdout.txt", "stderr.txt"}));
}

TEST_F(HostileInput, EmptyGridRendersWithAWarningNamingFileAndGrid) {
    write_float_grid(path("empty.vdb"), "density", 4, 4, 4, [](int, int, int) { return 0.0f; });
    const RunResult r = run("render -q " + vdb_scene(path("empty.vdb")) + " -o " + path("o.exr"));
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("fogmap: warning: " + path("empty.vdb") + ": grid 'density'"),
              std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find("no medium"), std::string::npos) << r.err;
}

TEST_F(HostileInput, NonFiniteExposureIsRefused) {
    for (const char* v : {"nan", "inf", "-inf"}) {
        SCOPED_TRACE(v);
        expect_one_error(run("render -q " + scene() + " -o " + path("o.exr") + " --exposure " + v),
                         2, {"--exposure", "finite"});
    }
    EXPECT_FALSE(fs::exists(path("o.exr")));
}

// ---- 4 and 6. Outputs --------------------------------------------------------------------------

/// fogmap started in the background (stdout and stderr to files in `dir`), for signals.
pid_t spawn_fogmap(const std::vector<std::string>& args, const fs::path& dir) {
    std::vector<std::string> all = {FOGMAP_BINARY};
    all.insert(all.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (std::string& a : all) argv.push_back(a.data());
    argv.push_back(nullptr);
    const std::string out = (dir / "bg_stdout.txt").string(),
                      err = (dir / "bg_stderr.txt").string();
    const pid_t pid = fork();
    if (pid == 0) {
        const int o = open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        const int e = open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (o < 0 || e < 0 || dup2(o, 1) < 0 || dup2(e, 2) < 0) _exit(127);
        execv(argv[0], argv.data());
        _exit(127);
    }
    return pid;
}

/// Polls until `file` holds at least `bytes` bytes (true), or `child` exits or 60 s pass (false).
bool wait_for_bytes(const fs::path& file, uintmax_t bytes, pid_t child) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (std::chrono::steady_clock::now() < end) {
        std::error_code ec;
        if (fs::file_size(file, ec) >= bytes && !ec) return true;
        if (waitpid(child, nullptr, WNOHANG) == child) return false;
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return false;
}

/// One path-traced sample per pixel of a diffuse ground under a wide quad light, filling the image:
/// no warnings, and noise that ZIP barely compresses (a 1024^2 EXR takes about a second to write).
std::string noisy_scene(const test::TempDir& tmp, int size) {
    json doc = json::parse(R"({
      "camera": {"position": [0, 3, 0.01], "look_at": [0, 0, 0], "fov_deg": 60},
      "lights": [{"type": "quad", "corner": [-20, 4, -20], "edge_u": [40, 0, 0],
                  "edge_v": [0, 0, 40], "radiance": 1}],
      "materials": {"ground": {"type": "diffuse", "albedo": 0.5}},
      "shapes": [{"type": "quad", "corner": [-50, 0, -50], "edge_u": [0, 0, 100],
                  "edge_v": [100, 0, 0], "material": "ground"}],
      "render": {"integrator": "path", "spp": 1, "max_depth": 1}
    })");
    doc["camera"]["width"] = doc["camera"]["height"] = size;
    return tmp.write("noisy" + std::to_string(size) + ".json", doc.dump(2));
}

TEST_F(HostileInput, SignalDuringTheWriteKeepsTheOldOutputsAndLeavesNoTemp) {
    const std::string slow = noisy_scene(tmp_, 1024);
    for (const int sig : {SIGINT, SIGTERM, SIGHUP, SIGQUIT}) {
        SCOPED_TRACE("signal " + std::to_string(sig));
        spit(path("out.exr"), "an older render");
        spit(path("out.png"), "an older preview");
        const pid_t pid = spawn_fogmap({"render", "-q", slow, "-o", path("out.exr")}, dir_);
        ASSERT_GT(pid, 0);
        // The EXR's temp file has its first bytes: the render is done and the write under way.
        const bool writing = wait_for_bytes(path("out.exr.tmp-" + std::to_string(pid)), 1, pid);
        ASSERT_TRUE(writing) << "the write was not seen: " << slurp(dir_ / "bg_stderr.txt");
        kill(pid, sig);
        int status = 0;
        ASSERT_EQ(waitpid(pid, &status, 0), pid);
        EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == sig) << "status " << status;
        EXPECT_EQ(slurp(path("out.exr")), "an older render");
        EXPECT_EQ(slurp(path("out.png")), "an older preview");
        EXPECT_TRUE(temps().empty()) << temps().front();
    }
}

TEST_F(HostileInput, KilledRunsTempIsRemovedByTheNextRun) {
    spit(path("out.exr"), "an older render");
    const pid_t pid =
        spawn_fogmap({"render", "-q", noisy_scene(tmp_, 1024), "-o", path("out.exr")}, dir_);
    const std::string temp = "out.exr.tmp-" + std::to_string(pid);
    ASSERT_TRUE(wait_for_bytes(path(temp), 1, pid)) << slurp(dir_ / "bg_stderr.txt");
    kill(pid, SIGKILL);  // cannot be handled: the temp stays behind
    ASSERT_EQ(waitpid(pid, nullptr, 0), pid);
    EXPECT_TRUE(fs::exists(path(temp)));
    EXPECT_EQ(slurp(path("out.exr")), "an older render");
    // A temp of a live process (this test) beside the output is not touched.
    const std::string live = "out.exr.tmp-" + std::to_string(getpid());
    spit(path(live), "being written");
    const RunResult r = run("render -q " + scene() + " -o " + path("out.exr"));
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_FALSE(fs::exists(path(temp))) << "the dead run's temp is removed";
    EXPECT_TRUE(fs::exists(path(live)));
    EXPECT_EQ(read_exr(path("out.exr")).width, 8);
}

TEST_F(HostileInput, FileSizeLimitDuringTheWriteKeepsTheOldOutputs) {
    // The EXR this scene makes, written once to learn its size.
    const std::string s = noisy_scene(tmp_, 128);
    ASSERT_EQ(run("render -q " + s + " -o " + path("probe.exr")).code, 0);
    const uintmax_t size = fs::file_size(path("probe.exr"));
    fs::remove(path("probe.exr"));
    fs::remove(path("probe.png"));
    spit(path("out.exr"), "an older render");
    spit(path("out.png"), "an older preview");
    // A file-size limit (prlimit takes bytes; `ulimit -f` blocks differ between shells) of one
    // byte less than the file fails its last bytes (unchecked, the final flush fails silently:
    // exit 0, "wrote", a truncated EXR over the old one); 20 KB fails it early.
    for (const uintmax_t limit : {size - 1, uintmax_t(20000)}) {
        SCOPED_TRACE("limit " + std::to_string(limit) + " of " + std::to_string(size) + " bytes");
        ASSERT_LT(limit, size);
        const RunResult r = run("render -q " + s + " -o " + path("out.exr"),
                                "prlimit --fsize=" + std::to_string(limit) + " ");
        expect_one_error(r, 1, {"out.exr", "File too large"});
        EXPECT_EQ(r.out.find("wrote"), std::string::npos) << r.out;
        EXPECT_EQ(slurp(path("out.exr")), "an older render");
        EXPECT_EQ(slurp(path("out.png")), "an older preview");
        EXPECT_TRUE(temps().empty()) << temps().front();
    }
}

TEST_F(HostileInput, UnwritableOutputsAreFoundBeforeAnyWork) {
    fs::create_directories(path("folder.exr"));
    fs::create_directories(path("folder.png"));
    spit(path("file"), "a file");
    spit(path("old.exr"), "an older render");
    const std::string s = scene();
    const std::string long_name = path(std::string(250, 'n') + ".exr");
    // Without -q: the plan would be printed if any work began; the error must be all there is.
    const std::pair<std::string, std::vector<std::string>> cases[] = {
        {"-o " + path("folder.exr"), {"folder.exr", "-o", "is a folder"}},
        {"-o " + path("file/x.exr"), {"-o", "is a file; expected a folder"}},
        {"-o " + long_name, {"-o", "this file system allows"}},
        {"-o " + path("old.exr") + " --png " + path("folder.png"), {"--png", "is a folder"}},
    };
    for (const auto& [outputs, expected] : cases) {
        SCOPED_TRACE(outputs);
        expect_one_error(run("render " + s + " " + outputs), 2, expected);
    }
    fs::create_directories(path("folder.csv"));
    expect_one_error(run("bench " + s + " --reference-spp 4 --sweep render.spp=1 --csv " +
                         path("folder.csv") + " --plot " + path("b.svg")),
                     2, {"--csv", "is a folder"});
    EXPECT_EQ(slurp(path("old.exr")), "an older render");
    EXPECT_FALSE(fs::exists(path("old.png")));
    EXPECT_TRUE(temps().empty());
}

TEST_F(HostileInput, OutputThatIsAnInputIsRefused) {
    const std::string text = slurp(scene());
    const std::string scene_exr = tmp_.write("scene.exr", text);  // a scene file named .exr
    expect_one_error(run("render -q " + scene_exr + " -o " + scene_exr), 2,
                     {"-o", "is the scene file"});
    EXPECT_EQ(slurp(scene_exr), text);
    Image ref(8, 6);
    write_exr(path("ref.exr"), ref);
    const std::string ref_bytes = slurp(path("ref.exr"));
    // The same file by another spelling of its path.
    expect_one_error(run("render -q " + scene() + " -o " + dir_.string() + "/./ref.exr" +
                         " --reference " + path("ref.exr")),
                     2, {"-o", "is the reference image"});
    EXPECT_EQ(slurp(path("ref.exr")), ref_bytes);
    const std::string scene_csv = tmp_.write("scene.csv", text);
    expect_one_error(run("bench -q " + scene_csv + " --reference " + path("ref.exr") +
                         " --sweep render.spp=1 --csv " + scene_csv + " --plot " + path("b.svg")),
                     2, {"--csv", "is the scene file"});
    EXPECT_EQ(slurp(scene_csv), text);
}

/// The fields of /proc/PID/stat after the command name: state, then the parent's pid.
bool proc_state(pid_t pid, char* state, pid_t* ppid) {
    std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
    std::string line;
    if (!std::getline(in, line)) return false;
    const size_t close = line.rfind(')');
    if (close == std::string::npos) return false;
    std::istringstream rest(line.substr(close + 2));
    return static_cast<bool>(rest >> *state >> *ppid);
}

/// The pid of a child of `parent` whose command line contains `needle`, or 0.
pid_t find_child(pid_t parent, const std::string& needle) {
    for (const auto& e : fs::directory_iterator("/proc")) {
        const std::string name = e.path().filename().string();
        if (name.find_first_not_of("0123456789") != std::string::npos) continue;
        const pid_t pid = static_cast<pid_t>(std::stol(name));
        char state = 0;
        pid_t ppid = 0;
        if (!proc_state(pid, &state, &ppid) || ppid != parent) continue;
        std::string cmdline = slurp(e.path() / "cmdline");
        std::replace(cmdline.begin(), cmdline.end(), '\0', ' ');
        if (cmdline.find(needle) != std::string::npos) return pid;
    }
    return 0;
}

TEST_F(HostileInput, VdbProbeChildDiesWithItsParent) {
    // The root node's tile count (after the 15 doubles of the transform, the buffer count and the
    // background) made 2^30: OpenVDB loops over a billion tiles, so the probe child reads for
    // about 10 CPU-seconds (its own limit) before it would fail.
    const size_t tiles = plume_transform_offset() + 15 * 8 + 4 + 4;
    spit(path("slow.vdb"), plume_flipped(tiles + 3, 0x40));
    const pid_t parent =
        spawn_fogmap({"render", "-q", vdb_scene(path("slow.vdb")), "-o", path("o.exr")}, dir_);
    pid_t child = 0;
    for (int i = 0; i < 2000 && child == 0; ++i) {
        child = find_child(parent, "__probe-vdb");
        if (child == 0) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ASSERT_NE(child, 0) << "no probe child seen: " << slurp(dir_ / "bg_stderr.txt");
    kill(parent, SIGKILL);
    ASSERT_EQ(waitpid(parent, nullptr, 0), parent);
    // PR_SET_PDEATHSIG: the child gets SIGKILL with its parent (a zombie until reaped, or gone).
    char state = 'R';
    pid_t ppid = 0;
    for (int i = 0; i < 500; ++i) {
        if (!proc_state(child, &state, &ppid) || state == 'Z') break;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    EXPECT_TRUE(!proc_state(child, &state, &ppid) || state == 'Z')
        << "the probe child " << child << " still runs (state " << state << ")";
}

// The probe child is limited by CPU time, never by wall time: a valid file whose probe is held
// up (here: stopped for longer than its whole CPU budget, as on a node that gives it a sliver of
// a core) passes; a file OpenVDB loops on is refused once the child has used its CPU seconds.
// FOGMAP_PROBE_CPU_SECONDS=1 makes the budget 2-3 s for these small files (media/vdb_probe.cpp:
// 1 s, and what their size and their samplers add).
TEST_F(HostileInput, VdbProbeIsLimitedByCpuTimeNotWallTime) {
    setenv("FOGMAP_PROBE_CPU_SECONDS", "1", 1);
    const size_t tiles = plume_transform_offset() + 15 * 8 + 4 + 4;
    spit(path("slow.vdb"), plume_flipped(tiles + 3, 0x40));
    RunResult r = run("render -q " + vdb_scene(path("slow.vdb")) + " -o " + path("o.exr"));
    EXPECT_EQ(r.code, 2) << r.err;
    const size_t at = r.err.find("did not finish it within ");
    ASSERT_NE(at, std::string::npos) << r.err;
    EXPECT_LE(std::atoi(r.err.c_str() + at + 25), 3) << r.err;  // 1 s, and its file's and sampler's
    // A valid plume large enough that its probe is caught running, stopped 3 s, then let go.
    ASSERT_EQ(run("volume plume --resolution 160 -o " + path("big.vdb")).code, 0);
    bool caught = false;
    for (int attempt = 0; attempt < 5 && !caught; ++attempt) {
        const pid_t parent = spawn_fogmap(
            {"render", "-q", vdb_scene(path("big.vdb")), "--spp", "1", "-o", path("big.exr")},
            dir_);
        pid_t child = 0;
        for (int i = 0; i < 20000 && child == 0; ++i) {
            child = find_child(parent, "__probe-vdb");
            if (child == 0) std::this_thread::sleep_for(std::chrono::microseconds(200));
        }
        char state = 'R';
        pid_t ppid = 0;
        if (child != 0 && kill(child, SIGSTOP) == 0) {
            std::this_thread::sleep_for(std::chrono::milliseconds(50));
            caught = proc_state(child, &state, &ppid) && state == 'T';  // stopped, not exited
            std::this_thread::sleep_for(std::chrono::seconds(3));
            kill(child, SIGCONT);
        }
        int status = 0;
        ASSERT_EQ(waitpid(parent, &status, 0), parent);
        if (caught)
            EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0)
                << slurp(dir_ / "bg_stderr.txt");
    }
    unsetenv("FOGMAP_PROBE_CPU_SECONDS");
    EXPECT_TRUE(caught) << "the probe child was never seen running";
}

// A medium emits at most what a light may (10^20 W): a larger emission.scale is refused at load
// with the power it would give, for every integrator, before any sample; a bright but bounded
// one renders finite pixels.
TEST_F(HostileInput, EmissionBeyondALightsPowerIsRefusedAtLoad) {
    const std::string fire = std::string(FOGMAP_SOURCE_DIR) + "/scenes/fire.json";
    const std::string small = " --set camera.width=24 --set camera.height=14 --spp 2 -o ";
    for (const char* integrator : {"photon", "path"}) {
        for (const char* scale : {"1e20", "3e38"}) {
            SCOPED_TRACE(std::string(integrator) + " " + scale);
            const RunResult r = run("render -q " + fire + small + path("f.exr") +
                                    " --set media.0.emission.scale=" + scale +
                                    " --set render.integrator=\"" + integrator + "\"");
            EXPECT_EQ(r.code, 2) << r.err;
            EXPECT_NE(r.err.find("/media/0/emission/scale: the medium would emit"),
                      std::string::npos)
                << r.err;
            EXPECT_FALSE(fs::exists(path("f.exr")));
        }
        const RunResult ok = run("render -q " + fire + small + path("f.exr") +
                                 " --set media.0.emission.scale=1e15 --set render.integrator=\"" +
                                 integrator + "\"");
        ASSERT_EQ(ok.code, 0) << ok.err;
        for (const Color& c : read_exr(path("f.exr")).pixels)
            ASSERT_TRUE(std::isfinite(c.x) && std::isfinite(c.y) && std::isfinite(c.z));
        fs::remove(path("f.exr"));
    }
}

// A blackbody on a grid that is not in kelvin glows in no visible colour: the warning names the
// grid, the temperature it reaches (its maximum, read here with OpenVDB, × the scale) and a scale
// that maps the maximum to 2000 K.
TEST_F(HostileInput, BlackbodyOnAGridNotInKelvinIsNamedWithAMapping) {
    const std::string fireball = std::string(FOGMAP_SOURCE_DIR) + "/volumes/fireball.vdb";
    openvdb::initialize();
    openvdb::io::File file(fireball);
    file.open();
    const auto grid = openvdb::gridPtrCast<openvdb::FloatGrid>(file.readGrid("temperature"));
    file.close();
    float lo = 0.0f, hi = 0.0f;
    grid->evalMinMax(lo, hi);
    for (const double scale : {0.1, 1.0}) {
        SCOPED_TRACE(scale);
        nlohmann::json doc = nlohmann::json::parse(R"({
          "camera": {"position": [0, 1, 5], "look_at": [0, 1, 0], "width": 12, "height": 8},
          "media": [{"type": "vdb", "sigma_s": 1, "sigma_a": 1,
                     "emission": {"grid": "temperature", "kind": "blackbody"}}],
          "render": {"spp": 1, "integrator": "path"}})");
        doc["media"][0]["file"] = fireball;
        doc["media"][0]["emission"]["temperature_scale"] = scale;
        const RunResult r =
            run("render -q " + tmp_.write("bb.json", doc.dump()) + " -o " + path("bb.exr"));
        ASSERT_EQ(r.code, 0) << r.err;
        const bool dark = hi * scale < 798.0;
        char reaches[64], mapping[64];
        std::snprintf(reaches, sizeof reaches, "reaches only %.3g K", hi * scale);
        std::snprintf(mapping, sizeof mapping, "temperature_scale %.3g puts its maximum at 2000 K",
                      2000.0 / hi);
        EXPECT_EQ(r.err.find("blackbody from grid 'temperature' " + std::string(reaches)) !=
                      std::string::npos,
                  dark)
            << r.err;
        EXPECT_EQ(r.err.find(mapping) != std::string::npos, dark) << r.err;
    }
}

// A negative seed is refused by every command that takes one (an unsigned option would read -1
// as 2^64 - 1); an OBJ vertex of NaN or infinity (which the OBJ reader would read as 0 or as a
// huge number) is refused naming the vertex.
TEST_F(HostileInput, NegativeSeedsAndNonFiniteObjVerticesAreRefused) {
    for (const std::string& cmd :
         {"volume plume --resolution 8 -o " + path("x.vdb") + " --seed -1",
          std::string("validate slab --tau 1 --albedo 0.5 --g 0 --photons 100 --seed -1")}) {
        SCOPED_TRACE(cmd);
        const RunResult r = run(cmd);
        EXPECT_EQ(r.code, 2) << r.err;
        EXPECT_NE(r.err.find("--seed: found '-1'; expected a non-negative integer"),
                  std::string::npos)
            << r.err;
    }
    EXPECT_FALSE(fs::exists(path("x.vdb")));
    for (const char* bad : {"nan", "-inf", "INF", "1e999"}) {
        SCOPED_TRACE(bad);
        spit(path("m.obj"), std::string("v 0 0 0\nv 1 0 0\nv 0 1 ") + bad + "\nf 1 2 3\n");
        const std::string scene = tmp_.write("m.json", R"({
          "camera": {"width": 8, "height": 6},
          "lights": [{"type": "sun", "direction": [0, -1, 0], "irradiance": 1}],
          "materials": {"m": {"type": "diffuse"}},
          "shapes": [{"type": "mesh", "file": "m.obj", "material": "m"}], "render": {"spp": 1}})");
        const RunResult r = run("render -q " + scene + " -o " + path("m.exr"));
        EXPECT_EQ(r.code, 2) << r.err;
        EXPECT_NE(r.err.find("m.obj: /shapes/0/file: vertex 3"), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("non-finite coordinate"), std::string::npos) << r.err;
    }
}

// Many lights make next-event estimation, not the samples, the work: above 1000 lights the run
// says so before it starts, with the number of shadow rays it takes at least (samples x lights).
TEST_F(HostileInput, ManyLightsAreSaidUpFrontWithTheirShadowRays) {
    for (const int n : {1000, 1001}) {
        SCOPED_TRACE(n);
        nlohmann::json doc = nlohmann::json::parse(R"({
          "camera": {"position": [0, 1, 4], "look_at": [0, 0, 0], "width": 4, "height": 3},
          "materials": {"g": {"type": "diffuse", "albedo": 0.5}},
          "shapes": [{"type": "quad", "corner": [-5, 0, -5], "edge_u": [0, 0, 10],
                      "edge_v": [10, 0, 0], "material": "g"}],
          "render": {"spp": 1, "integrator": "path"}})");
        for (int i = 0; i < n; ++i)
            doc["lights"].push_back(
                {{"type", "point"}, {"intensity", 0.01}, {"position", {0.01 * i, 3, 0}}});
        const RunResult r =
            run("render -q " + tmp_.write("many.json", doc.dump()) + " -o " + path("m.exr"));
        ASSERT_EQ(r.code, 0) << r.err;
        const std::string said = std::to_string(n) +
                                 " lights: every camera vertex takes a "
                                 "shadow ray to each, so this run traces at least " +
                                 std::to_string(12 * n) + " shadow rays (12 samples x " +
                                 std::to_string(n) + " lights)";
        EXPECT_EQ(r.err.find(said) != std::string::npos, n > 1000) << r.err;
    }
}

// ---- 5. Messages -------------------------------------------------------------------------------

TEST_F(HostileInput, CorruptVdbMessagesAreFogmapReasonsNotLibraryText) {
    const std::string bytes = slurp(kPlume);
    const size_t map = plume_transform_offset();
    const size_t type = bytes.find("Tree_float");
    ASSERT_NE(type, std::string::npos);
    // Unmapped, each of these gives OpenVDB's own text: "Grid type Tree_float... is not
    // registered", "Map ... is not registered", "ArithmeticError: Tried to initialize an affine
    // transform from a nearly singular matrix", "Expected to decompress N bytes, got
    // 18446744073709551615 bytes".
    const std::pair<size_t, unsigned char> flips[] = {
        {type + 11, 0x01},        {map - 5, 0x02},          {map + 7, 0x20},
        {bytes.size() / 2, 0xff}, {bytes.size() / 3, 0xff}, {bytes.size() * 2 / 3, 0xff}};
    const char* raw[] = {"Error: ",  "not registered", "18446744073709551615",
                         "max_size", "std::",          "Tried to"};
    for (size_t i = 0; i < std::size(flips); ++i) {
        const auto [at, bit] = flips[i];
        SCOPED_TRACE("byte " + std::to_string(at) + " ^ " + std::to_string(bit));
        spit(path("bad.vdb"), plume_flipped(at, bit));
        for (const bool render : {false, true}) {
            const RunResult r =
                run(render ? "render -q " + vdb_scene(path("bad.vdb")) + " -o " + path("o.exr")
                           : "info " + path("bad.vdb"));
            EXPECT_FALSE(r.signaled) << r.err;
            // The header flips must stop a render (`info` lists a singular map without using
            // it); a flipped voxel value may stay a valid float.
            if (render && i < 3) {
                EXPECT_EQ(r.code, 2) << r.err;
            }
            if (r.code == 0) continue;
            expect_one_error(r, 2, {"bad.vdb"});
            for (const char* fragment : raw)
                EXPECT_EQ(r.err.find(fragment), std::string::npos) << r.err;
        }
    }
}

TEST_F(HostileInput, BadArgumentsAreOneLine) {
    const std::string s = scene();
    const std::pair<std::string, std::string> cases[] = {
        {"", "subcommand"},
        {"render", "scene"},
        {"render " + s + " --spp abc", "--spp"},
        {"render " + s + " --bogus", "--bogus"},
        {"frobnicate", "subcommand"},
        {"bench " + s + " --csv", "--csv"},
    };
    for (const auto& [args, names] : cases) {
        SCOPED_TRACE(args);
        expect_one_error(run(args), 2, {"<command line>", names});
    }
    const RunResult help = run("render --help");
    EXPECT_EQ(help.code, 0);
    EXPECT_NE(help.out.find("--exposure"), std::string::npos) << help.out;
}

TEST_F(HostileInput, DuplicateJsonKeyIsAnErrorNamingTheKey) {
    const std::string text = slurp(scene());
    const size_t at = text.find("\"width\"");
    ASSERT_NE(at, std::string::npos);
    const std::string twice = text.substr(0, at) + "\"width\": 16, " + text.substr(at);
    expect_one_error(run("render -q " + tmp_.write("dup.json", twice) + " -o " + path("o.exr")), 2,
                     {"dup.json", "/camera/width", "key 'width' appears twice"});
}

TEST_F(HostileInput, ThreadsAboveTheCoresWarnHowManyAreUsed) {
    const int cores = tbb::info::default_concurrency();
    const RunResult r = run("render -q " + scene() + " -o " + path("o.exr") + " --threads 1000");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("fogmap: warning: render.threads = 1000 is more than the " +
                         std::to_string(cores) + " cores this process may use; using " +
                         std::to_string(cores)),
              std::string::npos)
        << r.err;
    EXPECT_NE(r.out.find(std::to_string(cores) + " threads"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("warning: render.threads = 1000"), std::string::npos) << "in the report";
}

TEST_F(HostileInput, QuietHidesProgressButKeepsWarnings) {
    const std::string s = vdb_scene(path("empty.vdb"));
    write_float_grid(path("empty.vdb"), "density", 2, 2, 2, [](int, int, int) { return 0.0f; });
    const RunResult quiet = run("render -q " + s + " -o " + path("o.exr") + " --threads 1000");
    ASSERT_EQ(quiet.code, 0) << quiet.err;
    EXPECT_NE(quiet.err.find("fogmap: warning: render.threads"), std::string::npos) << quiet.err;
    EXPECT_NE(quiet.err.find("fogmap: warning: " + path("empty.vdb")), std::string::npos)
        << quiet.err;
    EXPECT_EQ(quiet.err.find("render ["), std::string::npos) << "no progress bar: " << quiet.err;
    EXPECT_EQ(quiet.err.find("Embree scene:"), std::string::npos) << "no plan: " << quiet.err;
    const RunResult loud = run("render " + s + " -o " + path("o.exr"));
    ASSERT_EQ(loud.code, 0) << loud.err;
    EXPECT_NE(loud.err.find("Embree scene:"), std::string::npos) << loud.err;
}

}  // namespace
}  // namespace fogmap
