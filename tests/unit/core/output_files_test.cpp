// Output files are written whole and together (core/output_files.h): nothing replaces a target
// before commit, a failed write (a full disk simulated by a file-size limit, a folder that cannot
// take the file) leaves the older file byte for byte and no temp file, a fatal signal removes the
// staged temps, and temps of dead processes are cleaned up; output paths are checked before work.

#include "core/output_files.h"

#include "core/error.h"
#include "core/image.h"
#include "test_support.h"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <set>
#include <string>

namespace fogmap {
namespace {

namespace fs = std::filesystem;
using test::slurp;
using test::spit;

class OutputFilesTest : public ::testing::Test {
protected:
    std::string path(const std::string& name) const { return (tmp_.path() / name).string(); }
    /// Every file name in the folder.
    std::set<std::string> names() const {
        std::set<std::string> out;
        for (const auto& e : fs::directory_iterator(tmp_.path()))
            out.insert(e.path().filename().string());
        return out;
    }
    test::TempDir tmp_{"fogmap_output_files"};
};

/// A noisy image: its EXR does not compress much, so a size limit cuts it mid-write.
Image noisy(int w, int h) {
    Image img(w, h);
    uint32_t x = 12345;
    for (Color& c : img.pixels)
        for (int i = 0; i < 3; ++i) {
            x = x * 1664525u + 1013904223u;
            c[i] = static_cast<float>(x >> 8) / 16777216.0f;
        }
    return img;
}

/// Sets RLIMIT_FSIZE (bytes) with SIGXFSZ ignored, as fogmap's main does; restores both.
class FileSizeLimit {
public:
    explicit FileSizeLimit(rlim_t bytes) {
        getrlimit(RLIMIT_FSIZE, &old_);
        old_handler_ = std::signal(SIGXFSZ, SIG_IGN);
        const rlimit limit{bytes, old_.rlim_max};
        setrlimit(RLIMIT_FSIZE, &limit);
    }
    ~FileSizeLimit() {
        setrlimit(RLIMIT_FSIZE, &old_);
        std::signal(SIGXFSZ, old_handler_);
    }

private:
    rlimit old_{};
    void (*old_handler_)(int) = nullptr;
};

TEST_F(OutputFilesTest, NothingIsReplacedBeforeCommit) {
    spit(path("a.csv"), "old a");
    spit(path("b.svg"), "old b");
    {
        OutputFiles out;
        write_staged_text(out.stage(path("a.csv")), "new a");
        write_staged_text(out.stage(path("b.svg")), "new b");
        EXPECT_EQ(slurp(path("a.csv")), "old a");
        EXPECT_EQ(names().size(), 4u) << "two targets and two temps";
    }  // no commit: the temps go, the targets stay
    EXPECT_EQ(slurp(path("a.csv")), "old a");
    EXPECT_EQ(slurp(path("b.svg")), "old b");
    EXPECT_EQ(names(), (std::set<std::string>{"a.csv", "b.svg"}));

    OutputFiles out;
    write_staged_text(out.stage(path("a.csv")), "new a");
    write_staged_text(out.stage(path("b.svg")), "new b");
    out.commit();
    EXPECT_EQ(slurp(path("a.csv")), "new a");
    EXPECT_EQ(slurp(path("b.svg")), "new b");
    EXPECT_EQ(names(), (std::set<std::string>{"a.csv", "b.svg"}));
}

TEST_F(OutputFilesTest, AFailedPngKeepsTheOldExrToo) {
    // The EXR is written first and completes; the PNG then fails (its folder is gone): neither
    // target may change, as in `fogmap render -o x.exr --png y.png`.
    spit(path("x.exr"), "old exr");
    const Image image = noisy(16, 8);
    try {
        OutputFiles out;
        write_exr(out.stage(path("x.exr")), image);
        write_png(out.stage(path("gone/y.png")), image);
        out.commit();
        FAIL() << "the PNG write should fail";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("gone/y.png"), std::string::npos) << e.what();
    }
    EXPECT_EQ(slurp(path("x.exr")), "old exr");
    EXPECT_EQ(names(), std::set<std::string>{"x.exr"});
}

TEST_F(OutputFilesTest, FullDiskFailsTheExrWriteAndKeepsTheOldFile) {
    const Image image = noisy(64, 48);
    write_exr(path("probe.exr"), image);
    const uintmax_t size = fs::file_size(path("probe.exr"));
    fs::remove(path("probe.exr"));
    ASSERT_GT(size, 4096u);
    spit(path("out.exr"), "an older render");
    spit(path("out.png"), "an older preview");
    // One byte short fails the very last write (OpenEXR writes its line-offset table from its
    // destructor, which swallows errors); half fails mid-way; 10 bytes fails in the header.
    for (const uintmax_t limit : {size - 1, size / 2, uintmax_t(10)}) {
        SCOPED_TRACE("limit " + std::to_string(limit) + " of " + std::to_string(size) + " bytes");
        const FileSizeLimit full(static_cast<rlim_t>(limit));
        try {
            write_exr(path("out.exr"), image);
            ADD_FAILURE() << "write_exr succeeded past the size limit";
        } catch (const std::runtime_error& e) {
            EXPECT_NE(std::string(e.what()).find("out.exr"), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("File too large"), std::string::npos) << e.what();
        }
        EXPECT_THROW(write_png(path("out.png"), noisy(256, 256)), std::runtime_error);
        EXPECT_EQ(slurp(path("out.exr")), "an older render");
        EXPECT_EQ(slurp(path("out.png")), "an older preview");
        EXPECT_EQ(names(), (std::set<std::string>{"out.exr", "out.png"}));
    }
    // With room, the same write replaces the file with a complete one.
    write_exr(path("out.exr"), image);
    EXPECT_EQ(read_exr(path("out.exr")).width, 64);
}

TEST_F(OutputFilesTest, FatalSignalRemovesStagedTempsAndStillKills) {
    for (const int sig : {SIGINT, SIGTERM, SIGHUP}) {
        SCOPED_TRACE("signal " + std::to_string(sig));
        spit(path("out.exr"), "an older render");
        const pid_t child = fork();
        ASSERT_GE(child, 0);
        if (child == 0) {
            install_output_signal_handlers();
            OutputFiles out;
            write_staged_text(out.stage(path("out.exr")), "half a file");
            raise(sig);
            _exit(0);  // not reached: the handler re-raises with the default action
        }
        int status = 0;
        ASSERT_EQ(waitpid(child, &status, 0), child);
        EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == sig) << status;
        EXPECT_EQ(slurp(path("out.exr")), "an older render");
        EXPECT_EQ(names(), std::set<std::string>{"out.exr"}) << "the temp was removed";
    }
}

TEST_F(OutputFilesTest, StaleTempsOfDeadProcessesAreRemoved) {
    const pid_t dead = fork();
    ASSERT_GE(dead, 0);
    if (dead == 0) _exit(0);
    ASSERT_EQ(waitpid(dead, nullptr, 0), dead);  // reaped: the pid names no process now
    const std::string dead_temp = "out.exr.tmp-" + std::to_string(dead);
    const std::string live_temp = "out.exr.tmp-" + std::to_string(getpid());
    for (const std::string& name : {dead_temp, live_temp, "other.exr.tmp-" + std::to_string(dead),
                                    std::string("out.exr.tmp-x1")})
        spit(path(name), "left over");
    remove_stale_temps(path("out.exr"));
    EXPECT_EQ(names(), (std::set<std::string>{live_temp, "other.exr.tmp-" + std::to_string(dead),
                                              "out.exr.tmp-x1"}));
}

TEST_F(OutputFilesTest, OutputPathsAreCheckedWithoutCreatingAnything) {
    fs::create_directories(path("folder.exr"));
    spit(path("file"), "a file");
    const std::pair<std::string, std::string> bad[] = {
        {path("folder.exr"), "is a folder"},
        {path("file/sub/x.exr"), "is a file; expected a folder"},
        {path(std::string(250, 'n') + ".exr"), "bytes; this file system allows"},
        {path("deep/" + std::string(300, 'd') + "/x.exr"), "bytes; this file system allows"},
    };
    for (const auto& [p, reason] : bad) {
        SCOPED_TRACE(p);
        const InputError e = test::catch_input_error([&] { check_output_path(p, "-o"); });
        EXPECT_EQ(e.file, p);
        EXPECT_EQ(e.field, "-o");
        EXPECT_NE(e.reason.find(reason), std::string::npos) << e.reason;
    }
    EXPECT_NO_THROW(check_output_path(path("new/folders/x.exr"), "-o"));
    EXPECT_NO_THROW(check_output_path(path("x.exr"), "-o"));
    EXPECT_EQ(names(), (std::set<std::string>{"folder.exr", "file"})) << "nothing created";
}

}  // namespace
}  // namespace fogmap
