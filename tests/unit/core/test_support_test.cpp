// The rule for tests that need ../shared/volumes (tests/test_support.h): a missing volume is a
// skip on a developer's machine but a failure when the environment variable CI is "true".

#include "test_support.h"

#include <gtest/gtest-spi.h>
#include <gtest/gtest.h>

#include <cstdlib>

namespace fogmap {
namespace {

TEST(TestSupport, MissingSharedVolumeFailsWhenCiIsTrue) {
    const char* old = std::getenv("CI");
    const std::string saved = old ? old : "";
    setenv("CI", "true", 1);
    EXPECT_NONFATAL_FAILURE(test::missing_shared_volume("/nowhere/smoke1.vdb"),
                            "CI=true requires ../shared/volumes");
    if (old)
        setenv("CI", saved.c_str(), 1);
    else
        unsetenv("CI");
}

}  // namespace
}  // namespace fogmap
