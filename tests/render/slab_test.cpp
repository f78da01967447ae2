// Slab validation (`fogmap validate slab`): the photon pass's tracer in a constant-density VDB
// slab against published and independent values — van de Hulst's MCML case, exact identities
// (albedo 1: Rd + Tt = 1; albedo 0: Tt = exp(−τ)), Chandrasekhar's semi-infinite Rd and an
// independent analog Monte Carlo (slab_reference.h) — for both free-path methods, ray marching at
// its default step included; stiff slabs (τ = 100, 1000) included. Tolerance: 3 combined standard
// errors, sqrt(SE_fogmap² + SE_reference²), each SE from its estimator (per-photon sample
// variance; binomial for the analog reference; 0 for exact values). Fixed seeds. ~1e5 photons
// here; tests/render/slab_heavy_test.cpp repeats the comparisons with 1e6+ (label heavy).

#include "slab_checks.h"

#include "core/parallel.h"
#include "media/ray_march.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>

namespace fogmap {
namespace {

using namespace slab_checks;

constexpr uint64_t kPhotons = 100000;
constexpr uint64_t kReferencePhotons = 400000;

TEST(SlabValidation, McmlSlabMatchesVanDeHulst) {
    for (FreePathMethod method : kMethods) check_mcml(method, kPhotons);
}

TEST(SlabValidation, ConservativeSlabLosesNothing) {
    check_conservative(1.0, 0.5, kPhotons, kReferencePhotons);
    check_conservative(2.0, -0.5, kPhotons, kReferencePhotons);
}

TEST(SlabValidation, BlackSlabTransmitsExpMinusTau) {
    for (FreePathMethod method : kMethods) {
        check_black(1.0, method, kPhotons);
        check_black(0.1, method, kPhotons);
    }
}

TEST(SlabValidation, IsotropicThinSlabMatchesAnalogMonteCarlo) {
    check_against_analog(1.0, 0.99, 0.0, kPhotons, kReferencePhotons);
}

TEST(SlabValidation, ForwardScatteringSlabMatchesAnalogMonteCarlo) {
    check_against_analog(2.0, 0.95, 0.9, kPhotons, kReferencePhotons);
}

TEST(SlabValidation, SemiInfiniteMatchesChandrasekharH) {
    for (FreePathMethod method : kMethods) check_semi_infinite(kInf, 0.9, method, kPhotons);
    check_semi_infinite(kInf, 0.5, FreePathMethod::Delta, kPhotons);
}

TEST(SlabValidation, StiffSlabMatchesSemiInfiniteAtDefaultMarchStep) {
    for (double tau : {100.0, 1000.0})
        check_semi_infinite(tau, 0.9, FreePathMethod::March, kPhotons);
}

// The adding-doubling reference itself reproduces published values: MCML's validation slab (van de
// Hulst 1980 via Wang et al. 1995), Prahl's semi-infinite isotropic slab at albedo 0.8 (iadpython
// test suite, UR1 = 0.28525), Chandrasekhar's H-function at albedo 0.9 and 0.99, and R + T = 1
// for a conservative slab.
TEST(AddingDoubling, ReproducesPublishedValues) {
    const slab_reference::SlabValues mcml = slab_reference::adding_doubling(2.0, 0.9, 0.75);
    EXPECT_NEAR(mcml.rd.mean, 0.09739, 1e-5);
    EXPECT_NEAR(mcml.tt.mean, 0.66096, 1e-5);
    EXPECT_NEAR(slab_reference::adding_doubling(kInf, 0.8, 0.0).rd.mean, 0.28525, 1e-5);
    for (double a : {0.9, 0.99})
        EXPECT_NEAR(slab_reference::adding_doubling(kInf, a, 0.0).rd.mean,
                    slab_reference::semi_infinite_isotropic_rd(a), 1e-5);
    const slab_reference::SlabValues white = slab_reference::adding_doubling(4.0, 1.0, 0.5);
    EXPECT_NEAR(white.rd.mean + white.tt.mean, 1.0, 1e-6);
}

// Issue 15: high albedo, thick, semi-infinite, forward and backward g — with default flags (the
// default bounce limit once cut 90% of the photons at tau 100, albedo 0.999, g 0.99). A finite
// but huge tau is the semi-infinite medium (float positions cannot resolve its free paths, so it
// is traced as the semi-infinite stand-in).
TEST(SlabValidation, HighAlbedoThickSlabsMatchAddingDoublingWithDefaultFlags) {
    check_adding_doubling(10.0, 0.99, 0.75, 40000);
    check_adding_doubling(100.0, 0.999, 0.99, 20000);
    check_adding_doubling(10.0, 0.999, -0.5, 40000);
}

TEST(SlabValidation, SemiInfiniteHighAlbedoSlabsMatchAddingDoublingWithDefaultFlags) {
    check_adding_doubling(kInf, 0.99, -0.9, 20000);
    check_adding_doubling(kInf, 0.999, 0.875, 5000);
    check_adding_doubling(1e15, 0.9, 0.75, 20000);
}

// Hardening: a finite but huge tau (1e15, 1e30) is traced as the semi-infinite stand-in
// (semi_infinite_tau: at albedo 0.9 no photon gets deeper than ~900 with probability above 1e-26),
// so it finishes in the work of tau = inf: the same interactions and medium steps, bit for bit.
// Independent values: Rd against adding-doubling's semi-infinite slab (3 combined SEs, its own
// ~1e-5 as its SE), Tt = 0; interactions per photon at most 1/(1 − albedo) + 3 SE, the mean of
// the geometric count that Russian roulette on the albedo allows (SE sqrt(albedo)/(1 − albedo)
// / sqrt(N)). Medium steps per photon: 50 measured; the null collisions in the slab's density ramps
// grow as sqrt(tau) (1220 when the stand-in was 1e6), so 200 bounds them independently of tau.
TEST(SlabValidation, HugeTauIsTheSemiInfiniteSlabWithBoundedWork) {
    constexpr double kAlbedo = 0.9, kG = 0.75;
    constexpr uint64_t kN = 20000;
    const double rd_ref = slab_reference::adding_doubling(kInf, kAlbedo, kG).rd.mean;
    const double interactions_bound =
        1.0 / (1.0 - kAlbedo) + 3.0 * std::sqrt(kAlbedo) / (1.0 - kAlbedo) / std::sqrt(double(kN));
    for (FreePathMethod method : kMethods) {
        const SlabResult inf = run_slab(settings(kInf, kAlbedo, kG, method, kN));
        for (double tau : {1e15, 1e30}) {
            const SlabSettings s = settings(tau, kAlbedo, kG, method, kN);
            const SlabResult r = run_slab(s);
            EXPECT_TRUE(std::isfinite(r.rd.mean) && std::isfinite(r.rd.standard_error) &&
                        std::isfinite(r.tt.mean) && std::isfinite(r.tt.standard_error))
                << label(s, "finite");
            EXPECT_EQ(r.bounce_cap, 0u) << label(s, "bounce cap");
            EXPECT_EQ(r.tt.mean, 0.0) << label(s, "Tt");
            expect_match(r.rd, {rd_ref, 1e-5}, label(s, "Rd vs semi-infinite adding-doubling"));
            EXPECT_EQ(r.tau_model, inf.tau_model) << label(s, "stand-in");
            EXPECT_EQ(r.interactions, inf.interactions) << label(s, "interactions as tau = inf");
            EXPECT_EQ(r.steps, inf.steps) << label(s, "medium steps as tau = inf");
            EXPECT_LE(double(r.interactions) / double(kN), interactions_bound)
                << label(s, "interactions per photon");
            EXPECT_LE(double(r.steps) / double(kN), 200.0) << label(s, "medium steps per photon");
        }
    }
}

// The cap drops photons still alive after max_bounces interactions; in a conservative slab their
// power is exactly what Rd + Tt miss.
TEST(SlabValidation, BounceCapIsCountedAndIsAllThatIsLost) {
    SlabSettings s = settings(10.0, 1.0, 0.0, FreePathMethod::Delta, 20000);
    s.max_bounces = 8;
    const SlabResult r = run_slab(s);
    EXPECT_GT(r.bounce_cap, 1000u);
    EXPECT_EQ(r.absorbed, 0u);
    EXPECT_NEAR(r.rd.mean + r.tt.mean + double(r.bounce_cap) / double(r.photons), 1.0, 1e-6);
}

TEST(SlabValidation, ResultDoesNotDependOnThreadCount) {
    const SlabSettings s = settings(2.0, 0.9, 0.75, FreePathMethod::March, 20000);
    SlabResult one, two;
    {
        const ThreadLimit limit(1);
        one = run_slab(s);
    }
    {
        const ThreadLimit limit(2);
        two = run_slab(s);
    }
    EXPECT_EQ(one.rd.mean, two.rd.mean);
    EXPECT_EQ(one.tt.mean, two.tt.mean);
    EXPECT_EQ(one.tt.standard_error, two.tt.standard_error);
    EXPECT_EQ(one.absorbed, two.absorbed);
}

// A medium is stiff when its majorant optical depth per step exceeds the bound; a stiff medium the
// ray never meets leaves the marched free path bit for bit as it was.
TEST(RayMarcher, StiffMediaAreDeltaTrackedOthersMarchUnchanged) {
    MediumParams thin;
    thin.sigma_s = Color(0.8f);
    thin.sigma_a = Color(0.2f);
    MediumParams dense = thin;
    dense.sigma_s = Color(800.0f);
    const Box3 here{Vec3(-1.0f), Vec3(1.0f)}, away{Vec3(10.0f), Vec3(12.0f)};
    const std::vector<Medium> alone{Medium::homogeneous(thin, here)};
    const std::vector<Medium> both{Medium::homogeneous(thin, here),
                                   Medium::homogeneous(dense, away)};
    MarchSettings ms;
    ms.step_world = 0.05f;  // thin: 0.05 per step; dense: 40 per step
    const RayMarcher a(alone, ms), b(both, ms);
    EXPECT_FALSE(a.any_stiff());
    EXPECT_FALSE(b.stiff(0));
    EXPECT_TRUE(b.stiff(1));
    std::vector<Medium::Sampler> sa, sb;  // move-only: no initializer lists
    sa.emplace_back(alone[0]);
    for (const Medium& m : both) sb.emplace_back(m);
    for (uint64_t i = 0; i < 2000; ++i) {
        Rng ra(3, i), rb(3, i);
        const Ray ray{Vec3(0.0f, -2.0f, 0.0f), Vec3(0.0f, 1.0f, 0.0f)};  // misses `away`
        const RayMarcher::FreePath fa = a.sample_free_path(sa, ray, kInfinity, ra);
        const RayMarcher::FreePath fb = b.sample_free_path(sb, ray, kInfinity, rb);
        ASSERT_EQ(fa.collided, fb.collided);
        ASSERT_EQ(fa.t, fb.t);
    }
}

// Bad arguments are InputErrors: exit code 2 and a message naming the option.
TEST(ValidateCli, BadArgumentsExitWithCode2) {
    const std::filesystem::path binary(FOGMAP_BINARY);
    if (!std::filesystem::exists(binary)) GTEST_SKIP() << "build the fogmap target first";
    const std::string base = std::string(FOGMAP_BINARY) + " validate slab ";
    const std::string quiet = " >/dev/null 2>&1";
    for (const std::string args :
         {"--tau -1 --albedo 0.5 --g 0", "--tau nan --albedo 0.5 --g 0",
          "--tau 1 --albedo 1.5 --g 0", "--tau 1 --albedo -0.1 --g 0", "--tau 1 --albedo 0.5 --g 1",
          "--tau 1 --albedo 0.5 --g -1", "--tau 1 --albedo 0.5 --g 0 --photons 0",
          "--tau 1 --albedo 0.5 --g 0 --photons 2e9", "--tau 1 --albedo 0.5 --g 0 --method rk4",
          "--tau 1 --albedo 0.5 --g 0 --step-voxels 0", "--tau 1 --albedo 0.5"}) {
        const int status = std::system((base + args + quiet).c_str());
        EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 2) << args;
    }
    const int ok =
        std::system((base + "--tau 0.5 --albedo 0.5 --g 0 --photons 100" + quiet).c_str());
    EXPECT_TRUE(WIFEXITED(ok) && WEXITSTATUS(ok) == 0);
}

}  // namespace
}  // namespace fogmap
