// `shrm prefilter`: the SHRM of a map and a BRDF, written as an SHRM file with an optional JSON
// report and PNG preview (SHRM paper sec. 5.6.2).
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "client/cli_common.h"
#include "client/cli_validators.h"
#include "client/commands.h"
#include "client/prefilter_job.h"
#include "client/report.h"
#include "core/base/status_macros.h"
#include "core/brdf/brdf.h"
#include "core/io/atomic_file.h"
#include "core/io/image.h"
#include "core/shrm/prefilter.h"
#include "core/shrm/shrm_file.h"
#include "core/shrm/shrm_synthesis.h"

namespace shrm::cli {
namespace {

namespace v1 = ::shrm::v1;

// Preview: three spheres seen from these directions (front, side, above).
constexpr int kPreviewSize = 256;

// Orthographic renders of a unit sphere carrying the SHRM, seen from three views, side by side;
// exposure chosen so that the mean is mid-grey.
Image RenderSpheres(const ShrmCube& cube) {
  const Vec3 views[3] = {{0, 0, 1}, {1, 0, 0}, Vec3{0, 0.7, 0.7}.Normalized()};
  Image img;
  img.width = 3 * kPreviewSize;
  img.height = kPreviewSize;
  img.channels = 3;
  img.pixels.assign(static_cast<size_t>(img.width) * img.height * 3, 0.0f);
  for (int s = 0; s < 3; ++s) {
    const Vec3 v = views[s];
    const Vec3 up0 = std::abs(v.y) > 0.99 ? Vec3{0, 0, -1} : Vec3{0, 1, 0};
    const Vec3 right = up0.Cross(v).Normalized();
    const Vec3 up = v.Cross(right);
    for (int y = 0; y < kPreviewSize; ++y)
      for (int x = 0; x < kPreviewSize; ++x) {
        const double px = 2 * (x + 0.5) / kPreviewSize - 1, py = 1 - 2 * (y + 0.5) / kPreviewSize;
        const double r2 = px * px + py * py;
        if (r2 >= 1) continue;
        const Vec3 n = right * px + up * py + v * std::sqrt(1 - r2);
        Vec3 index = n;
        if (cube.index == ReparamKind::kTangent) {  // hair-like tangents along latitudes
          const Vec3 t = Vec3{0, 1, 0}.Cross(n);
          index = t.Norm() > 1e-6 ? t.Normalized() : Vec3{1, 0, 0};
        }
        const std::array<double, 3> b = ShrmEval(cube, index, v);
        for (int c = 0; c < 3; ++c)
          img.pixels[(static_cast<size_t>(y) * img.width + s * kPreviewSize + x) * 3 + c] =
              static_cast<float>(b[c]);
      }
  }
  return img;
}

double AutoExposure(const Image& img) {
  double sum = 0;
  size_t n = 0;
  for (size_t i = 0; i < img.pixels.size(); i += 3) {
    const double lum =
        0.2126 * img.pixels[i] + 0.7152 * img.pixels[i + 1] + 0.0722 * img.pixels[i + 2];
    if (lum > 0) {
      sum += lum;
      ++n;
    }
  }
  return n > 0 && sum > 0 ? std::log2(0.18 * n / sum) : 0.0;
}

// Prints the summary lines of a run (both modes).
void PrintSummary(const PrefilterArgs& a, const std::string& brdf_spec, int face_size,
                  const ShrmAnalysis& an, const nlohmann::json& timings) {
  std::printf("wrote %s: %s SHRM, %d x %d x 6 texels, (F_B, P_B) = (%d, %d)\n", a.output.c_str(),
              a.kind.c_str(), face_size, face_size, an.f_b, an.p_b);
  std::printf("  BRDF %s: (F_rho, P_rho) = (%d, %d), eps_brdf %.4g\n", brdf_spec.c_str(), an.f_brdf,
              an.p_brdf, an.eps_brdf);
  std::printf("  lighting: F_L %s, eps_light %.4g; eq. 5.19 bound %.4g\n",
              an.f_light >= 0 ? std::to_string(an.f_light).c_str() : "not reached", an.eps_light,
              an.eps_bound);
  std::printf("  time:");
  for (const auto& [k, v] : timings.items()) std::printf(" %s %.1f", k.c_str(), v.get<double>());
  std::printf("\n");
}

// --server: the same job on shrmd; the SHRM file it returns is byte-identical to the embedded
// run's (tests/service_test.cc).
absl::Status RunPrefilterRemote(const PrefilterArgs& a, const PrefilterOptions& opt,
                                PrefilterJobOutcome* outcome) {
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<client::ShrmClient> client, ConnectServer(a.server));
  Progress progress(a.verbose, a.quiet);
  v1::PrefilterRequest req;
  if (opt.f >= 0) {
    req.mutable_orders()->set_f(opt.f);
    req.mutable_orders()->set_p(opt.p);
  } else {
    req.set_epsilon(a.epsilon);
  }
  req.set_kind(opt.kind == ShrmKind::kLocal ? v1::SHRM_KIND_LOCAL : v1::SHRM_KIND_GLOBAL);
  req.set_face_size(a.size);
  req.set_half(a.half);
  // The job is idempotent (same request, same bytes): RunRemoteJob retries it whole.
  client::PrefilterOutcome out;
  double upload_ms = 0;
  int retries = 0;
  const absl::Status job = RunRemoteJob(
      client.get(), a.env, a.server, a.quiet,
      [&]() -> absl::Status {
        progress.Begin("upload");
        absl::Status uploaded = RemoteEnvironment(a.env, client.get(), req.mutable_environment());
        // table:PATH / merl:PATH: the file travels as a blob; shrm:brdf records the local spec.
        absl::StatusOr<client::RemoteBrdf> brdf =
            uploaded.ok() ? client::ResolveRemoteBrdf(a.brdf, client.get()) : uploaded;
        upload_ms += progress.End();
        if (!brdf.ok()) return brdf.status();
        req.set_brdf(brdf->spec);
        req.set_brdf_blob_sha256(brdf->blob_sha256);
        req.set_brdf_display_spec(brdf->display_spec);
        bool first = true;
        auto on_progress = [&](const v1::PrefilterProgress& p) {
          if (!first) progress.End();
          first = false;
          progress.Begin("remote " + p.stage());
        };
        absl::StatusOr<client::PrefilterOutcome> r = client->Prefilter(req, on_progress);
        if (!first) progress.End();
        if (!r.ok()) return r.status();
        out = std::move(*r);
        return absl::OkStatus();
      },
      &retries);
  if (outcome != nullptr) outcome->retries = retries;
  SHRM_RETURN_IF_ERROR(job);
  OutputTransaction outputs;
  const std::string shrm_tmp = outputs.Temp(a.output);
  progress.Begin("write");
  SHRM_RETURN_IF_ERROR(WriteFileAtomically(shrm_tmp, out.shrm_file));
  const double write_ms = progress.End();
  const v1::PrefilterReport& rep = out.report;
  nlohmann::json report = nlohmann::json::parse(rep.report_json(), nullptr, false);
  if (report.is_discarded()) return absl::DataLossError("the server's report is not JSON");
  report["output"] = a.output;
  report["source"] = a.env.files;
  report["server"] = a.server;
  report["timings"]["upload_ms"] = upload_ms;
  report["retries"] = retries;
  report["timings"]["local_write_ms"] = write_ms;
  if (!a.preview.empty()) {
    progress.Begin("preview");
    SHRM_ASSIGN_OR_RETURN(ShrmFile file, ReadShrmFile(shrm_tmp));
    const Image spheres = RenderSpheres(file.cube);
    SHRM_RETURN_IF_ERROR(WritePreviewPng(outputs.Temp(a.preview), spheres, AutoExposure(spheres)));
    report["timings"]["preview_ms"] = progress.End();
  }
  if (!a.report.empty()) SHRM_RETURN_IF_ERROR(WriteJsonFile(outputs.Temp(a.report), report));
  SHRM_RETURN_IF_ERROR(outputs.Commit());
  if (outcome != nullptr) {
    outcome->f_b = rep.f_b();
    outcome->p_b = rep.p_b();
  }
  if (a.quiet) return absl::OkStatus();
  if (a.json) {
    std::printf("%s\n", report.dump(2).c_str());
    return absl::OkStatus();
  }
  ShrmAnalysis an;
  an.f_light = rep.f_light();
  an.f_brdf = rep.f_brdf();
  an.p_brdf = rep.p_brdf();
  an.f_b = rep.f_b();
  an.p_b = rep.p_b();
  an.eps_light = rep.eps_light();
  an.eps_brdf = rep.eps_brdf();
  an.eps_bound = rep.eps_bound();
  PrintSummary(a, rep.brdf(), rep.face_size(), an, report["timings"]);
  std::printf("  server %s: lighting cache %s, BRDF cache %s\n", a.server.c_str(),
              rep.cache().lighting_hit() ? "hit" : "miss", rep.cache().brdf_hit() ? "hit" : "miss");
  return absl::OkStatus();
}

}  // namespace

absl::Status RunPrefilterJob(const PrefilterArgs& a, PrefilterJobOutcome* outcome) {
  PrefilterOptions opt;
  opt.epsilon = a.epsilon;
  if (a.kind == "global") {
    opt.kind = ShrmKind::kGlobal;
  } else if (a.kind == "local") {
    opt.kind = ShrmKind::kLocal;
  } else {
    return absl::InvalidArgumentError(
        absl::StrCat("--kind must be local or global, got '", a.kind, "'"));
  }
  if (!a.orders.empty()) {
    std::vector<std::string> parts = absl::StrSplit(a.orders, ',');
    if (parts.size() != 2 || !absl::SimpleAtoi(parts[0], &opt.f) ||
        !absl::SimpleAtoi(parts[1], &opt.p) || opt.f < 0 || opt.p < 0) {
      return absl::InvalidArgumentError(
          absl::StrCat("--orders must be F,P with F, P >= 0, got '", a.orders, "'"));
    }
  }
  if (a.size < 0) return absl::InvalidArgumentError("--size must be >= 0");
  if (a.threads < 0) return absl::InvalidArgumentError("--threads must be >= 0");
  opt.face_size = a.size;
  opt.threads = ResolveThreads(a.threads);
  SHRM_RETURN_IF_ERROR(CheckOutputPath(a.output, "--output"));
  SHRM_RETURN_IF_ERROR(CheckOutputPath(a.preview, "--preview"));
  SHRM_RETURN_IF_ERROR(CheckOutputPath(a.report, "--report"));
  if (!a.server.empty()) return RunPrefilterRemote(a, opt, outcome);

  Progress progress(a.verbose, a.quiet);
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<Brdf> brdf, ParseBrdfSpec(a.brdf));
  SHRM_ASSIGN_OR_RETURN(opt.rotation, EnvRotation(a.env));
  progress.Begin("decode");
  SHRM_ASSIGN_OR_RETURN(EnvMap env, LoadEnv(a.env));
  SHRM_ASSIGN_OR_RETURN(const std::string source_hash, EnvSourceHash(a.env));
  const double decode_ms = progress.End();

  bool first = true;
  auto on_stage = [&](std::string_view stage) {
    if (!first) progress.End();
    first = false;
    progress.Begin(std::string(stage));
    return absl::OkStatus();
  };
  SHRM_ASSIGN_OR_RETURN(PrefilterResult r, Prefilter(env, *brdf, opt, on_stage));
  if (!first) progress.End();
  const ShrmAnalysis& an = r.analysis;

  std::map<std::string, std::string> attrs = {
      {"shrm:brdf", brdf->spec()},
      {"shrm:epsilon", a.orders.empty() ? absl::StrCat(a.epsilon) : "explicit orders"},
      {"shrm:orders", absl::StrCat(an.f_b, ",", an.p_b)},
      {"shrm:brdf_orders", absl::StrCat(an.f_brdf, ",", an.p_brdf)},
      {"shrm:eps_light", absl::StrCat(an.eps_light)},
      {"shrm:eps_brdf", absl::StrCat(an.eps_brdf)},
      {"shrm:eps_bound", absl::StrCat(an.eps_bound)},
      {"shrm:source", absl::StrJoin(a.env.files, ",")},
      {"shrm:source_sha256", source_hash},
      {"shrm:working_space", a.env.working_space},
      {"shrm:layout", EnvLayoutName(env.layout())},
  };
  if (!a.env.rotate.empty()) attrs["shrm:rotate_ypr_deg"] = absl::StrJoin(a.env.rotate, ",");
  OutputTransaction outputs;
  progress.Begin("write");
  SHRM_RETURN_IF_ERROR(WriteShrmFile(outputs.Temp(a.output), r.cube, attrs, a.half));
  const double write_ms = progress.End();

  nlohmann::json report = AnalysisJson(an);
  report["output"] = a.output;
  report["brdf"] = brdf->spec();
  report["kind"] = a.kind;
  report["face_size"] = r.cube.face_size;
  report["source"] = a.env.files;
  report["source_sha256"] = source_hash;
  report["layout"] = EnvLayoutName(env.layout());
  nlohmann::json timings = TimingsJson(r.timings);
  timings["decode_ms"] = decode_ms;
  timings["write_ms"] = write_ms;
  if (!a.preview.empty()) {
    progress.Begin("preview");
    const Image spheres = RenderSpheres(r.cube);
    SHRM_RETURN_IF_ERROR(WritePreviewPng(outputs.Temp(a.preview), spheres, AutoExposure(spheres)));
    timings["preview_ms"] = progress.End();
  }
  report["timings"] = timings;
  if (!a.report.empty()) SHRM_RETURN_IF_ERROR(WriteJsonFile(outputs.Temp(a.report), report));
  SHRM_RETURN_IF_ERROR(outputs.Commit());
  if (outcome != nullptr) {
    outcome->f_b = an.f_b;
    outcome->p_b = an.p_b;
  }
  if (a.quiet) return absl::OkStatus();
  if (a.json) {
    std::printf("%s\n", report.dump(2).c_str());
  } else {
    PrintSummary(a, brdf->spec(), r.cube.face_size, an, timings);
  }
  return absl::OkStatus();
}

void RegisterPrefilter(CLI::App& app, absl::Status* status) {
  auto args = std::make_shared<PrefilterArgs>();
  CLI::App* sub = app.add_subcommand("prefilter", "compute the SHRM of a map and a BRDF");
  AddEnvOptions(sub, &args->env, /*required=*/true);
  sub->add_option("--brdf", args->brdf, "BRDF spec, e.g. microfacet:sigma=0.2 (docs/brdf.md)")
      ->required();
  sub->add_option("--epsilon", args->epsilon, "tolerance for the orders, in (0, 1)")
      ->capture_default_str()
      ->check(kOpenUnitInterval);
  sub->add_option("--orders", args->orders, "explicit orders F,P instead of --epsilon")
      ->check(kOrders);
  sub->add_option("--kind", args->kind, "global or local SHRM")
      ->capture_default_str()
      ->check(CLI::IsMember({"global", "local"}));
  sub->add_option("--size", args->size, "cube face size S_B (0: about 10 F_B)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  sub->add_option("-o,--output", args->output, "output SHRM file (.shrm.exr)")->required();
  sub->add_option("--report", args->report, "write a JSON report here");
  sub->add_option("--preview", args->preview, "write a PNG preview (three spheres) here");
  sub->add_flag("--half", args->half, "store half floats instead of float32");
  sub->add_option("--threads", args->threads, "worker threads (0: all cores)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  sub->add_flag("--json", args->json, "print the report as JSON on stdout");
  sub->add_flag("--verbose", args->verbose, "stage timings on stderr");
  AddServerOption(sub, &args->server);
  sub->callback([args, status] { *status = RunPrefilterJob(*args); });
}

}  // namespace shrm::cli
