// `shrm analyze`: orders and error estimates (SHRM paper sec. 5.5) of a map, a BRDF, or both.
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "cli/cli_common.h"
#include "cli/commands.h"
#include "core/base/status_macros.h"
#include "core/brdf/brdf.h"
#include "core/brdf/brdf_projection.h"
#include "core/envmap/lighting.h"
#include "core/sh/sh.h"
#include "core/shrm/orders.h"
#include "core/shrm/prefilter.h"
#include "core/transform/sht.h"
#include "jobs/analyze_job.h"
#include "jobs/cli_validators.h"
#include "jobs/prefilter_job.h"
#include "jobs/report.h"

namespace shrm::cli {
namespace {

// Default cap on the degree of the lighting-only analysis (cost grows as F^2 H).
constexpr int kDefaultMaxDegree = 255;

struct AnalyzeArgs {
  EnvArgs env;
  std::string brdf;
  std::vector<double> epsilons = jobs::kDefaultAnalyzeEpsilons;
  int lmax = -1;
  int print_lmax = 2;
  int threads = 0;
  bool json = false;
  bool verbose = false;
  std::string server;
};

// Lighting only: coefficients, captured fraction per F, F_L per epsilon (eqs. 5.15-5.16).
absl::Status AnalyzeLighting(const AnalyzeArgs& a) {
  const int threads = ResolveThreads(a.threads);
  Progress progress(a.verbose);
  progress.Begin("decode");
  SHRM_ASSIGN_OR_RETURN(const jobs::EnvironmentSpec spec, EnvSpecFromArgs(a.env));
  SHRM_ASSIGN_OR_RETURN(EnvMap env, LoadEnv(spec));
  const Mat3 rot = jobs::EnvironmentRotation(spec);
  const double decode_ms = progress.End();
  const int native = env.NativeLatLongWidth();
  const int resolvable = ShtMaxDegree({native, native / 2, ShtGridKind::kEquiangular});
  int lmax = a.lmax;
  if (lmax == -1) lmax = std::min(resolvable, kDefaultMaxDegree);
  if (lmax < 0) return absl::InvalidArgumentError(absl::StrCat("--lmax must be >= 0, got ", lmax));
  progress.Begin("lighting coefficients");
  SHRM_ASSIGN_OR_RETURN(std::vector<double> coeffs, LightingCoefficients(env, lmax, rot, threads));
  const double sht_ms = progress.End();
  const std::array<double, 3> total = LightingEnergy(env);
  const std::vector<double> bands = BandEnergies(lmax, 3, coeffs);
  auto band = [&](int c) {
    std::vector<double> b(lmax + 1);
    for (int l = 0; l <= lmax; ++l) b[l] = bands[static_cast<size_t>(l) * 3 + c];
    return b;
  };
  std::vector<int> orders;
  for (double e : a.epsilons) {
    int worst = 0;
    for (int c = 0; c < 3 && worst >= 0; ++c) {
      const int f = OrderForTolerance(band(c), total[c], e);
      worst = f < 0 ? -1 : std::max(worst, f);
    }
    orders.push_back(worst);
  }
  const int print_lmax = std::min(a.print_lmax, lmax);
  if (a.json) {
    nlohmann::json j;
    j["map"] = a.env.files;
    j["layout"] = EnvLayoutName(env.layout());
    j["lmax"] = lmax;
    j["energy"] = total;
    nlohmann::json co = nlohmann::json::array();
    for (int l = 0; l <= print_lmax; ++l)
      for (int m = -l; m <= l; ++m) {
        const double* c = &coeffs[static_cast<size_t>(ShIndex(l, m)) * 3];
        co.push_back({{"l", l}, {"m", m}, {"rgb", {c[0], c[1], c[2]}}});
      }
    j["coefficients"] = co;
    nlohmann::json fl = nlohmann::json::array();
    for (size_t i = 0; i < orders.size(); ++i)
      fl.push_back({{"epsilon", a.epsilons[i]},
                    {"F_L", orders[i] >= 0 ? nlohmann::json(orders[i]) : nlohmann::json(nullptr)}});
    j["F_L"] = fl;
    j["timings"] = {{"decode_ms", decode_ms}, {"lighting_ms", sht_ms}};
    std::printf("%s\n", j.dump(2).c_str());
    return absl::OkStatus();
  }
  std::printf("map            %s (%s, %d x %d)\n", a.env.files[0].c_str(),
              EnvLayoutName(env.layout()), env.width(), env.height());
  std::printf("transform      degree %d, %d thread(s): decode %.1f ms, L_lm %.1f ms\n\n", lmax,
              threads, decode_ms, sht_ms);
  std::printf("SH lighting coefficients L_lm (real SH, SH frame: docs/conventions.md)\n");
  std::printf("  %3s %4s %14s %14s %14s\n", "l", "m", "R", "G", "B");
  for (int l = 0; l <= print_lmax; ++l)
    for (int m = -l; m <= l; ++m) {
      const double* c = &coeffs[static_cast<size_t>(ShIndex(l, m)) * 3];
      std::printf("  %3d %4d %14.6g %14.6g %14.6g\n", l, m, c[0], c[1], c[2]);
    }
  std::printf("\nEnergy (eq. 5.15): integral L^2 dw = %.6g %.6g %.6g (R G B)\n", total[0], total[1],
              total[2]);
  std::printf("Captured fraction sum_{l<=F} |L_lm|^2 / integral L^2 (eq. 5.16)\n");
  std::printf("  %4s %10s %10s %10s\n", "F", "R", "G", "B");
  std::vector<int> rows;
  for (int f : {0, 1, 2, 3, 4, 6, 8, 10, 15, 20, 30, 40, 60, 80, 100, 150, 200, 300, 400, 500})
    if (f < lmax) rows.push_back(f);
  rows.push_back(lmax);
  for (int f : rows) {
    std::printf("  %4d", f);
    for (int c = 0; c < 3; ++c) std::printf(" %10.6f", CapturedFraction(band(c), total[c], f));
    std::printf("\n");
  }
  std::printf(
      "\nOrder F_L for tolerance epsilon (smallest F capturing 1 - epsilon, max over RGB)\n");
  for (size_t i = 0; i < orders.size(); ++i) {
    if (orders[i] >= 0) {
      std::printf("  epsilon %-8g F_L = %d\n", a.epsilons[i], orders[i]);
    } else {
      std::printf("  epsilon %-8g F_L > %d (raise --lmax)\n", a.epsilons[i], lmax);
    }
  }
  return absl::OkStatus();
}

// BRDF only: (F_rho, P_rho) for each epsilon (eqs. 5.17/5.18, sec. 5.6.2).
absl::Status AnalyzeBrdf(const AnalyzeArgs& a, const Brdf& brdf) {
  nlohmann::json all = nlohmann::json::array();
  if (!a.json)
    std::printf("BRDF %s\n  %-10s %6s %6s %12s\n", brdf.spec().c_str(), "epsilon", "F_rho", "P_rho",
                "eps_brdf");
  for (double e : a.epsilons) {
    SHRM_ASSIGN_OR_RETURN(BrdfOrders o, SelectBrdfOrders(brdf, e));
    const double eps = 1 - o.captured;
    if (a.json) {
      all.push_back(jobs::BrdfOrdersJson(e, o.F, o.P, eps));
    } else {
      std::printf("  %-10g %6d %6d %12.6g\n", e, o.F, o.P, eps);
    }
  }
  if (a.json) {
    nlohmann::json j;
    j["brdf"] = brdf.spec();
    j["results"] = all;
    std::printf("%s\n", (all.size() == 1 ? all[0] : j).dump(2).c_str());
  }
  return absl::OkStatus();
}

// Map and BRDF: the full analysis for each epsilon.
absl::Status AnalyzeBoth(const AnalyzeArgs& a, const Brdf& brdf) {
  Progress progress(a.verbose);
  progress.Begin("decode");
  SHRM_ASSIGN_OR_RETURN(const jobs::EnvironmentSpec spec, EnvSpecFromArgs(a.env));
  SHRM_ASSIGN_OR_RETURN(EnvMap env, LoadEnv(spec));
  progress.End();
  nlohmann::json all = nlohmann::json::array();
  for (double e : a.epsilons) {
    jobs::PrefilterJob job;
    job.env = spec;
    jobs::UseEpsilonRule(&job, e);  // the analysis is the paper's (eq. 5.15-5.19)
    PrefilterOptions opt = jobs::CorePrefilterOptions(job, ResolveThreads(a.threads));
    opt.synthesize = false;
    SHRM_ASSIGN_OR_RETURN(PrefilterResult r, Prefilter(env, brdf, opt));
    nlohmann::json j = jobs::AnalysisJson(r.analysis);
    j["timings"] = jobs::TimingsJson(r.timings);
    if (a.json) {
      all.push_back(j);
      continue;
    }
    const ShrmAnalysis& an = r.analysis;
    std::printf("epsilon %g: F_L %s, (F_rho, P_rho) = (%d, %d), (F_B, P_B) = (%d, %d)\n", e,
                an.f_light >= 0 ? std::to_string(an.f_light).c_str() : "not reached", an.f_brdf,
                an.p_brdf, an.f_b, an.p_b);
    std::printf("  eps_light %.4g  eps_brdf %.4g  estimate min %.4g  bound (eq. 5.19) %.4g\n",
                an.eps_light, an.eps_brdf, an.eps_estimate, an.eps_bound);
    std::printf("  suggested S_B %d, T_B %d\n", an.suggested_face_size, an.suggested_view_size);
  }
  if (a.json) std::printf("%s\n", (all.size() == 1 ? all[0] : all).dump(2).c_str());
  return absl::OkStatus();
}

// --server: the analysis on shrmd (needs --brdf; the lighting-only analysis is embedded only).
absl::Status AnalyzeRemote(const AnalyzeArgs& a) {
#if !SHRM_CLI_HAS_CLIENT
  return RunWithClient();
#else
  if (a.brdf.empty()) {
    return absl::InvalidArgumentError(
        "--server needs --brdf (lighting-only analysis runs "
        "in-process only)");
  }
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<client::ShrmClient> client, ConnectServer(a.server));
  shrm::v1::AnalyzeRequest req;
  SHRM_ASSIGN_OR_RETURN(client::RemoteBrdf brdf, client::ResolveRemoteBrdf(a.brdf, client.get()));
  req.set_brdf(brdf.spec);
  req.set_brdf_blob_sha256(brdf.blob_sha256);
  req.set_brdf_display_spec(brdf.display_spec);
  for (double e : a.epsilons) req.add_epsilon(e);
  if (!a.env.files.empty()) {
    SHRM_ASSIGN_OR_RETURN(const jobs::EnvironmentSpec spec, EnvSpecFromArgs(a.env));
    SHRM_RETURN_IF_ERROR(client::UploadEnvironment(spec, client.get(), req.mutable_environment()));
  }
  absl::StatusOr<shrm::v1::AnalyzeResponse> resp = client->Analyze(req);
  if (!resp.ok()) {
    return absl::Status(resp.status().code(),
                        absl::StrCat(a.server, ": ", resp.status().message()));
  }
  nlohmann::json all = nlohmann::json::array();
  const bool with_env = !a.env.files.empty();
  if (!a.json && !with_env)
    std::printf("BRDF %s\n  %-10s %6s %6s %12s\n", resp->brdf().c_str(), "epsilon", "F_rho",
                "P_rho", "eps_brdf");
  for (const shrm::v1::AnalyzeResult& r : resp->results()) {
    if (a.json) {
      if (with_env) {
        all.push_back(nlohmann::json::parse(r.analysis_json(), nullptr, false));
      } else {
        all.push_back(jobs::BrdfOrdersJson(r.epsilon(), r.f_brdf(), r.p_brdf(), r.eps_brdf()));
      }
      continue;
    }
    if (!with_env) {
      std::printf("  %-10g %6d %6d %12.6g\n", r.epsilon(), r.f_brdf(), r.p_brdf(), r.eps_brdf());
      continue;
    }
    std::printf("epsilon %g: F_L %s, (F_rho, P_rho) = (%d, %d), (F_B, P_B) = (%d, %d)\n",
                r.epsilon(), r.f_light() >= 0 ? std::to_string(r.f_light()).c_str() : "not reached",
                r.f_brdf(), r.p_brdf(), r.f_b(), r.p_b());
    std::printf("  eps_light %.4g  eps_brdf %.4g  estimate min %.4g  bound (eq. 5.19) %.4g\n",
                r.eps_light(), r.eps_brdf(), r.eps_estimate(), r.eps_bound());
    std::printf("  suggested S_B %d, T_B %d\n", r.suggested_face_size(), r.suggested_view_size());
  }
  if (a.json) {
    if (!with_env && all.size() != 1) {
      nlohmann::json j;
      j["brdf"] = resp->brdf();
      j["results"] = all;
      std::printf("%s\n", j.dump(2).c_str());
    } else {
      std::printf("%s\n", (all.size() == 1 ? all[0] : all).dump(2).c_str());
    }
  }
  return absl::OkStatus();
#endif  // SHRM_CLI_HAS_CLIENT
}

absl::Status RunAnalyze(const AnalyzeArgs& a) {
  if (absl::Status s = jobs::ValidateAnalyzeEpsilons(a.epsilons); !s.ok()) {
    return WithMessage(s, absl::StrCat("--", s.message()));
  }
  if (a.print_lmax < 0) return absl::InvalidArgumentError("--print-lmax must be >= 0");
  if (a.threads < 0) return absl::InvalidArgumentError("--threads must be >= 0");
  if (!a.server.empty()) return AnalyzeRemote(a);
  if (a.brdf.empty()) {
    if (a.env.files.empty()) return absl::InvalidArgumentError("give --env, --brdf or both");
    return AnalyzeLighting(a);
  }
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<Brdf> brdf, ParseBrdfSpec(a.brdf));
  if (a.env.files.empty()) return AnalyzeBrdf(a, *brdf);
  return AnalyzeBoth(a, *brdf);
}

}  // namespace

void DefineAnalyze(CLI::App* sub, absl::Status* status) {
  auto args = std::make_shared<AnalyzeArgs>();
  AddEnvOptions(sub, &args->env, /*required=*/false);
  sub->add_option("map", args->env.files, "environment map (same as --env)");
  sub->add_option("--brdf", args->brdf, "BRDF spec, e.g. phong:s=32 (docs/brdf.md)");
  sub->add_option("--epsilon", args->epsilons, "tolerance(s), each in (0, 1)")
      ->capture_default_str()
      ->check(jobs::kOpenUnitInterval);
  sub->add_option("--lmax", args->lmax,
                  "lighting-only: maximum degree (default: what the map resolves, at most 255)");
  sub->add_option("--print-lmax", args->print_lmax, "lighting-only: print L_lm up to this degree")
      ->capture_default_str()
      ->check(jobs::kNonNegative);
  sub->add_option("--threads", args->threads, "worker threads (0: all cores)")
      ->capture_default_str()
      ->check(jobs::kNonNegative);
  sub->add_flag("--json", args->json, "machine-readable output");
  sub->add_flag("--verbose", args->verbose, "stage timings on stderr");
  AddServerOption(sub, &args->server);
  sub->callback([args, status] { *status = RunAnalyze(*args); });
}

}  // namespace shrm::cli
