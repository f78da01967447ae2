// `fogmap validate slab`: fogmap's photon transport against the radiative-transfer literature.
// Checks the arguments (InputError → exit 2), runs photon/slab.h and prints Rd, T unscattered, Td
// and Tt with their standard errors as text or JSON on stdout.
#include "app/commands.h"
#include "core/error.h"
#include "media/ray_march.h"
#include "photon/slab.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <string>

namespace fogmap {

namespace {

struct SlabArgs {
    std::string tau;
    double albedo = 0.0;
    double g = 0.0;
    std::string photons = "100000";
    std::string method = "march";
    float step_voxels = 1.0f;
    uint64_t seed = 1;
    int max_bounces = PhotonDesc{}.max_bounces;
    int voxels = 32;
    bool json = false;
};

constexpr double kMaxPhotons = 1e9;

/// A whole string as a double (strtod: accepts "inf", "1e6"); InputError naming the option.
double parse_number(const std::string& text, const std::string& option) {
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (text.empty() || end != text.c_str() + text.size())
        throw InputError("", option, "found '" + text + "'; expected a number");
    return v;
}

std::string number(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.6g", v);
    return buf;
}

SlabSettings check(const SlabArgs& a) {
    SlabSettings s;
    s.tau = parse_number(a.tau, "--tau");
    if (std::isnan(s.tau) || s.tau < 0.0)
        throw InputError("", "--tau",
                         "found " + a.tau + "; expected an optical thickness >= 0, or inf");
    s.albedo = a.albedo;
    if (!(a.albedo >= 0.0 && a.albedo <= 1.0))
        throw InputError("", "--albedo", "found " + number(a.albedo) + "; expected 0 .. 1");
    s.g = a.g;
    if (!(std::abs(a.g) < 1.0))
        throw InputError("", "--g", "found " + number(a.g) + "; expected -1 < g < 1");
    const double photons = parse_number(a.photons, "--photons");
    if (!(photons >= 1.0 && photons <= kMaxPhotons) || photons != std::floor(photons))
        throw InputError("", "--photons",
                         "found " + a.photons + "; expected a whole number 1 .. 1e9");
    s.photons = static_cast<uint64_t>(photons);
    if (a.method == "march")
        s.method = FreePathMethod::March;
    else if (a.method == "delta")
        s.method = FreePathMethod::Delta;
    else
        throw InputError("", "--method", "found '" + a.method + "'; expected march, delta");
    s.step_voxels = a.step_voxels;
    if (!(a.step_voxels > 0.0f) || !std::isfinite(a.step_voxels))
        throw InputError("", "--step-voxels",
                         "found " + number(a.step_voxels) + "; expected a positive number");
    s.seed = a.seed;
    s.max_bounces = a.max_bounces;
    if (a.max_bounces < 1 || a.max_bounces > 100000000)
        throw InputError("", "--max-bounces",
                         "found " + std::to_string(a.max_bounces) + "; expected 1 .. 1e8");
    s.voxels = a.voxels;
    if (a.voxels < 1 || a.voxels > 4096)
        throw InputError("", "--voxels",
                         "found " + std::to_string(a.voxels) + "; expected 1 .. 4096");
    return s;
}

std::string free_paths(const SlabSettings& s, const SlabResult& r) {
    if (s.method == FreePathMethod::Delta) return "delta tracking";
    std::string text = "ray marching, step " + number(s.step_voxels) + " voxel";
    if (r.delta_in_march)
        text += "; stiff (majorant optical depth per step " +
                number(r.tau_per_voxel * s.step_voxels) + " > " +
                number(RayMarcher::kMaxTauPerStep) + "): delta tracking";
    return text;
}

/// Exit code: 1 (with the figure on stderr) when --max-bounces cut more than 0.1% of the power,
/// which biases Rd and Tt low by about that much; else 0.
int capped_check(const SlabSettings& s, const SlabResult& r) {
    if (r.bounce_cap_power <= kCapWarnShare) return 0;
    std::cout.flush();  // the report first, then the verdict
    std::fprintf(stderr,
                 "fogmap: error: --max-bounces %d cut %llu photon paths carrying %s%% of the power "
                 "(more than 0.1%%): Rd and Tt are biased low; raise --max-bounces\n",
                 s.max_bounces, static_cast<unsigned long long>(r.bounce_cap),
                 number(100.0 * r.bounce_cap_power).c_str());
    return 1;
}

nlohmann::json estimate_json(const SlabEstimate& e) {
    return {{"mean", e.mean}, {"standard_error", e.standard_error}};
}

int run_slab_command(const SlabArgs& args) {
    const SlabSettings s = check(args);
    const SlabResult r = run_slab(s);
    const bool semi = std::isinf(s.tau);
    const double expected_unscattered = semi ? 0.0 : std::exp(-s.tau);
    if (args.json) {
        nlohmann::json j = {{"tau", semi ? nlohmann::json(nullptr) : nlohmann::json(s.tau)},
                            {"semi_infinite", semi},
                            {"tau_model", r.tau_model},
                            {"albedo", s.albedo},
                            {"g", s.g},
                            {"method", args.method},
                            {"step_voxels", s.step_voxels},
                            {"voxels", s.voxels},
                            {"tau_per_voxel", r.tau_per_voxel},
                            {"free_paths", free_paths(s, r)},
                            {"photons", s.photons},
                            {"seed", s.seed},
                            {"max_bounces", s.max_bounces},
                            {"rd", estimate_json(r.rd)},
                            {"unscattered", estimate_json(r.unscattered)},
                            {"unscattered_expected", expected_unscattered},
                            {"td", estimate_json(r.td)},
                            {"tt", estimate_json(r.tt)},
                            {"absorbed", r.absorbed},
                            {"bounce_cap", r.bounce_cap},
                            {"bounce_cap_power", r.bounce_cap_power},
                            {"edge", r.edge},
                            {"interactions", r.interactions},
                            {"steps", r.steps},
                            {"time_s", r.time_s}};
        std::cout << j.dump(2) << "\n";
        return capped_check(s, r);
    }
    auto line = [](const char* name, const SlabEstimate& e) {
        char buf[96];
        std::snprintf(buf, sizeof buf, "  %-14s %.5f ± %.5f\n", name, e.mean, e.standard_error);
        return std::string(buf);
    };
    const std::string traced =
        r.tau_model != s.tau ? " (traced as " + number(r.tau_model) + ": semi-infinite)" : "";
    std::cout << "slab: tau " << (semi ? "inf" : number(s.tau)) << traced << ", albedo "
              << number(s.albedo) << ", g " << number(s.g)
              << ", index-matched (n = 1), collimated beam at normal incidence\n"
              << "free paths: " << free_paths(s, r) << " (" << s.voxels
              << " voxels across, optical depth " << number(r.tau_per_voxel) << " per voxel)\n"
              << "photons: " << s.photons << " (seed " << s.seed << "), max bounces "
              << s.max_bounces << "\n"
              << line("Rd", r.rd) << line("T unscattered", r.unscattered)
              << "                 (exp(-tau) = " << number(expected_unscattered) << ")\n"
              << line("Td", r.td) << line("Tt", r.tt) << "absorbed " << r.absorbed
              << ", bounce cap " << r.bounce_cap << " (" << number(100.0 * r.bounce_cap_power)
              << "% of the power lost)"
              << ", edge " << r.edge << "\n"
              << "work: " << r.interactions << " interactions, " << r.steps << " medium steps ("
              << number(double(r.steps) / double(s.photons)) << " per photon)\n"
              << "time " << number(r.time_s) << " s\n";
    return capped_check(s, r);
}

}  // namespace

Subcommand add_validate_command(CLI::App& app) {
    CLI::App* sub =
        app.add_subcommand("validate", "check photon transport against published values");
    sub->require_subcommand(1);
    auto args = std::make_shared<SlabArgs>();
    CLI::App* slab = sub->add_subcommand(
        "slab", "constant-density VDB slab under a normal collimated beam: Rd, Td, Tt ± SE");
    slab->add_option("--tau", args->tau, "optical thickness, >= 0, or inf (semi-infinite)")
        ->required();
    slab->add_option("--albedo", args->albedo, "single-scattering albedo, 0 .. 1")->required();
    slab->add_option("--g", args->g, "Henyey-Greenstein asymmetry, -1 < g < 1")->required();
    slab->add_option("--photons", args->photons, "photons traced, 1 .. 1e9 (default 1e5)");
    slab->add_option("--method", args->method, "free paths: march (default) or delta");
    slab->add_option("--step-voxels", args->step_voxels, "march step in voxels (default 1)");
    slab->add_option("--seed", args->seed, "random seed (default 1)")->check(seed_check());
    slab->add_option("--max-bounces", args->max_bounces,
                     "interactions per photon, a safety limit (default as the photon pass's "
                     "photons.max_bounces); more than 0.1% of the power cut exits 1");
    slab->add_option("--voxels", args->voxels, "voxels across the thickness (default 32)");
    slab->add_flag("--json", args->json, "print the result as JSON");
    return {sub, [args](Ranks*) { return run_slab_command(*args); }};
}

}  // namespace fogmap
