// `shrm render` (the reflection map for one view, eq. 5.35), `shrm explicit` (Cabral's 12 views,
// Kautz-McCool slices (eq. 5.25), a T_B x T_B view grid) and `shrm irradiance` (Lambertian).
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "cli/cli_common.h"
#include "cli/commands.h"
#if SHRM_CLI_HAS_CLIENT
#include "client/shrm_client.h"
#endif
#include "core/base/cubemap.h"
#include "core/base/status_macros.h"
#include "core/envmap/lighting.h"
#include "core/export/ktx2.h"
#include "core/export/shrm_ktx2.h"
#include "core/io/atomic_file.h"
#include "core/sh/sh.h"
#include "core/shrm/shrm_explicit.h"
#include "core/shrm/shrm_file.h"
#include "jobs/cli_validators.h"
#include "jobs/point_jobs.h"
#include "jobs/prefilter_job.h"
#include "jobs/report.h"
#include "shrm/version.h"

namespace shrm::cli {
namespace {

#if SHRM_CLI_HAS_CLIENT
namespace v1 = ::shrm::v1;
#endif

struct OutputArgs {
  std::string shrm;
  EnvArgs env;
  std::string view;
  std::string form = "cabral";
  int tb = 10;
  int size = 64;
  std::string output;
  int threads = 0;
  bool json = false;
  std::string server;
  int verify = jobs::kDefaultIrradianceVerify;  // irradiance: normals of the check
};

absl::Status RunRender(const OutputArgs& a) {
  const OptionPath shrm_input[] = {{"--shrm", a.shrm}};
  SHRM_RETURN_IF_ERROR(CheckOutputPath(a.output, "--output", shrm_input));
  SHRM_RETURN_IF_ERROR(CheckOutputExtension(
      a.output, "--output", {".exr", ".ktx2"},
      "the reflection map is written as OpenEXR (a horizontal cross), or as a KTX2 cube map"));
  SHRM_ASSIGN_OR_RETURN(Vec3 v, ParseDirection(a.view, "--view"));
  SHRM_ASSIGN_OR_RETURN(ShrmFile file, ReadShrm(a.shrm));
  SHRM_ASSIGN_OR_RETURN(RadianceCube map,
                        ReflectionMapForView(file.cube, v, ResolveThreads(a.threads)));
  if (!file.cube.lights.empty()) {
    // The file's peak lights, summed with the BRDF it was made with (docs/shrm.md).
    SHRM_ASSIGN_OR_RETURN(std::unique_ptr<Brdf> brdf, ShrmFileBrdf(file, a.shrm));
    AddLightsToViewMap(file.cube, *brdf, v, map, ResolveThreads(a.threads));
  }
  if (absl::EndsWithIgnoreCase(a.output, ".ktx2")) {
    // A cube map an engine (or the shader tests, docs/shaders.md) reads as it is: RGBA32F, A = 1.
    ktx2::Ktx2Image image;
    image.format = ktx2::Format::kR32G32B32A32Sfloat;
    image.width = image.height = map.face_size;
    image.faces = 6;
    ktx2::Level level{map.face_size, map.face_size, {}};
    const size_t texels = size_t{6} * map.face_size * map.face_size;
    level.pixels.resize(texels * 4);
    for (size_t t = 0; t < texels; ++t) {
      for (int c = 0; c < 3; ++c) level.pixels[t * 4 + c] = map.data[t * map.channels + c];
      level.pixels[t * 4 + 3] = 1.0f;
    }
    image.levels.push_back(std::move(level));
    image.key_values["shrm:view"] = absl::StrFormat("%.17g,%.17g,%.17g", v.x, v.y, v.z);
    image.key_values["shrm:eval"] = "eq. 5.35: B(R) = sum c_pq(R) Y_pq(V_s) for shrm:view";
    SHRM_ASSIGN_OR_RETURN(const std::string bytes,
                          ktx2::EncodeKtx2(image, {.writer = absl::StrCat("shrm ", kVersion)}));
    SHRM_RETURN_IF_ERROR(WriteFileAtomically(a.output, bytes));
    std::printf("wrote %s: reflection map for view (%.4g, %.4g, %.4g), KTX2 cube map %d x %d\n",
                a.output.c_str(), v.x, v.y, v.z, map.face_size, map.face_size);
    return absl::OkStatus();
  }
  SHRM_RETURN_IF_ERROR(WriteRadianceCross(a.output, map));
  std::printf("wrote %s: reflection map for view (%.4g, %.4g, %.4g), horizontal cross %d x %d\n",
              a.output.c_str(), v.x, v.y, v.z, 4 * map.face_size, 3 * map.face_size);
  return absl::OkStatus();
}

absl::Status RunExplicit(const OutputArgs& a) {
  if (a.tb < 1 || a.tb > kMaxExplicitTb) {
    return absl::InvalidArgumentError(
        absl::StrCat("--tb ", a.tb, " is outside [1, ", kMaxExplicitTb, "]"));
  }
  const OptionPath shrm_input[] = {{"--shrm", a.shrm}};
  SHRM_RETURN_IF_ERROR(CheckOutputPath(absl::StrCat(a.output, "_0.exr"), "--output", shrm_input));
  SHRM_ASSIGN_OR_RETURN(ShrmFile file, ReadShrm(a.shrm));
  std::unique_ptr<Brdf> lights_brdf;
  if (!file.cube.lights.empty()) {
    if (a.form == "kautz-mccool") {
      return absl::FailedPreconditionError(absl::StrCat(
          a.shrm, ": the SHRM carries ", file.cube.lights.size(),
          " peak lights, which the Kautz-McCool slices (averaged over the view's azimuth) do not "
          "hold: use --form cabral or grid, or make the SHRM with --peak-lights off"));
    }
    // The views' maps get the lights as `shrm render` adds them (docs/shrm.md "Peak lights").
    SHRM_ASSIGN_OR_RETURN(lights_brdf, ShrmFileBrdf(file, a.shrm));
  }
  // The maps are all held before they are written: refused, with their size, when they would
  // not fit (half this machine's memory, as a prefilter's cube).
  const double count = a.form == "grid"           ? static_cast<double>(a.tb) * a.tb
                       : a.form == "kautz-mccool" ? a.tb
                                                  : 12.0;
  const double values = count * kCubeFaceCount * file.cube.face_size * file.cube.face_size * 3;
  if (const double limit = jobs::EmbeddedCubeValueLimit(); limit > 0 && values > limit) {
    return absl::ResourceExhaustedError(absl::StrFormat(
        "--form %s --tb %d: %.0f maps of 6 x %d x %d texels need %.1f GB, above half this "
        "machine's memory (%.1f GB): give a smaller --tb",
        a.form, a.tb, count, file.cube.face_size, file.cube.face_size, values * 4 / 1e9,
        limit * 4 / 1e9));
  }
  const int threads = ResolveThreads(a.threads);
  std::vector<RadianceCube> maps;
  std::vector<Vec3> views;
  if (a.form == "cabral") {
    SHRM_ASSIGN_OR_RETURN(maps, CabralMaps(file.cube, threads));
    const std::array<Vec3, 12> ico = IcosahedronVertices();
    views.assign(ico.begin(), ico.end());
  } else if (a.form == "grid") {
    SHRM_ASSIGN_OR_RETURN(maps, ViewGridMaps(file.cube, a.tb, threads));
    views = ViewGrid(a.tb);
  } else if (a.form == "kautz-mccool") {
    if (file.cube.kind != ShrmKind::kLocal) {
      return absl::InvalidArgumentError(
          absl::StrCat(a.shrm, ": Kautz-McCool slices need a local SHRM (prefilter --kind local)"));
    }
    SHRM_ASSIGN_OR_RETURN(maps, KautzMcCoolSlices(file.cube, a.tb));
  } else {
    return absl::InvalidArgumentError(
        absl::StrCat("--form must be cabral, grid or kautz-mccool, got '", a.form, "'"));
  }
  if (lights_brdf != nullptr) {
    for (size_t i = 0; i < maps.size() && i < views.size(); ++i)
      AddLightsToViewMap(file.cube, *lights_brdf, views[i], maps[i], threads);
  }
  for (size_t i = 0; i < maps.size(); ++i) {
    SHRM_RETURN_IF_ERROR(WriteRadianceCross(absl::StrCat(a.output, "_", i, ".exr"), maps[i]));
  }
  std::printf("wrote %zu maps %s_0.exr .. %s_%zu.exr (%s)\n", maps.size(), a.output.c_str(),
              a.output.c_str(), maps.size() - 1, a.form.c_str());
  return absl::OkStatus();
}

absl::Status RunIrradiance(const OutputArgs& a) {
  if (a.size < 1) return absl::InvalidArgumentError("--size must be >= 1");
  SHRM_ASSIGN_OR_RETURN(const jobs::EnvironmentSpec spec, EnvSpecFromArgs(a.env));
  SHRM_RETURN_IF_ERROR(CheckOutputPath(a.output, "--output", JobInputFiles(spec, "")));
  SHRM_RETURN_IF_ERROR(
      CheckOutputExtension(a.output, "--output", {".exr"},
                           "the irradiance cube is written as OpenEXR (a horizontal cross)"));
  std::vector<double> e9;
  ibl::LevelError measured;
  if (!a.server.empty()) {
#if !SHRM_CLI_HAS_CLIENT
    return RunWithClient();
#else
    // The coefficients from shrmd (decode + transform there); the cube is built here from them,
    // so the files equal the embedded run's.
    SHRM_ASSIGN_OR_RETURN(std::unique_ptr<client::ShrmClient> c, ConnectServer(a.server));
    v1::IrradianceRequest req;
    req.set_verify(a.verify);
    v1::IrradianceResponse resp;
    SHRM_RETURN_IF_ERROR(client::RunRemoteJob(
        c.get(), spec, a.server,
        [&] {
          SHRM_RETURN_IF_ERROR(client::UploadEnvironment(spec, c.get(), req.mutable_environment()));
          SHRM_ASSIGN_OR_RETURN(resp, c->Irradiance(req));
          return absl::OkStatus();
        },
        RetryReporter(a.server, /*quiet=*/false)));
    if (resp.coefficients_size() != jobs::kIrradianceCoefficientCount) {
      return absl::DataLossError(absl::StrCat("the server sent ", resp.coefficients_size(),
                                              " irradiance values, expected 27"));
    }
    e9.assign(resp.coefficients().begin(), resp.coefficients().end());
    measured = {resp.measured_count(), resp.measured_rms(), resp.measured_max()};
#endif  // SHRM_CLI_HAS_CLIENT
  } else {
    SHRM_ASSIGN_OR_RETURN(EnvMap env, LoadEnv(spec));
    const Mat3 rotation = jobs::EnvironmentRotation(spec);
    SHRM_ASSIGN_OR_RETURN(e9, jobs::IrradianceSh9(env, rotation, ResolveThreads(a.threads)));
    measured = jobs::MeasureIrradianceSh9(env, rotation, e9, a.verify, ResolveThreads(a.threads));
  }
  if (!a.output.empty()) {
    SHRM_ASSIGN_OR_RETURN(RadianceCube cube, IrradianceCube(e9, 3, a.size));
    SHRM_RETURN_IF_ERROR(WriteRadianceCross(a.output, cube));
  }
  if (a.json) {
    nlohmann::json j;
    nlohmann::json co = nlohmann::json::array();
    for (int l = 0; l <= 2; ++l)
      for (int m = -l; m <= l; ++m) {
        const double* c = &e9[static_cast<size_t>(ShIndex(l, m)) * 3];
        co.push_back({{"l", l}, {"m", m}, {"rgb", {c[0], c[1], c[2]}}});
      }
    j["irradiance_coefficients"] = co;
    if (measured.count > 0)
      j["measured"] = {{"normals", measured.count}, {"rms", measured.rms}, {"max", measured.max}};
    if (!a.output.empty()) j["output"] = a.output;
    std::printf("%s\n", j.dump(2).c_str());
    return absl::OkStatus();
  }
  std::printf("Irradiance E_lm = A_l L_lm (l <= 2; E, not E/pi; real SH, SH frame)\n");
  std::printf("  %3s %4s %14s %14s %14s\n", "l", "m", "R", "G", "B");
  for (int l = 0; l <= 2; ++l)
    for (int m = -l; m <= l; ++m) {
      const double* c = &e9[static_cast<size_t>(ShIndex(l, m)) * 3];
      std::printf("  %3d %4d %14.6g %14.6g %14.6g\n", l, m, c[0], c[1], c[2]);
    }
  if (measured.count > 0) {
    std::printf(
        "measured at %d normals against the pixel sum: relative RMS %.3g, largest %.3g (the l <= 2 "
        "truncation)\n",
        measured.count, measured.rms, measured.max);
  }
  if (!a.output.empty())
    std::printf("wrote %s (irradiance by normal, horizontal cross)\n", a.output.c_str());
  return absl::OkStatus();
}

}  // namespace

void DefineRender(CLI::App* sub, absl::Status* status) {
  auto args = std::make_shared<OutputArgs>();
  sub->add_option("--shrm", args->shrm, "SHRM file")->required();
  sub->add_option("--view", args->view, "view direction V (towards the viewer) as x,y,z")
      ->required()
      ->check(jobs::kDirection);
  sub->add_option("-o,--output", args->output,
                  "output: EXR (horizontal cross), or a KTX2 cube map (.ktx2)")
      ->required();
  sub->add_option("--threads", args->threads, "worker threads (0: all cores)")
      ->check(jobs::kNonNegative);
  sub->callback([args, status] { *status = RunRender(*args); });
}

void DefineExplicit(CLI::App* sub, absl::Status* status) {
  auto args = std::make_shared<OutputArgs>();
  sub->add_option("--shrm", args->shrm, "SHRM file")->required();
  sub->add_option("--form", args->form,
                  "cabral (12 icosahedral views), kautz-mccool (T_B "
                  "slices, local SHRMs) or grid (T_B x T_B views)")
      ->capture_default_str();
  sub->add_option("--tb", args->tb, "T_B")
      ->capture_default_str()
      ->check(jobs::InRange(1, kMaxExplicitTb));
  sub->add_option("-o,--output", args->output, "output prefix: PREFIX_<k>.exr")->required();
  sub->add_option("--threads", args->threads, "worker threads (0: all cores)")
      ->check(jobs::kNonNegative);
  sub->callback([args, status] { *status = RunExplicit(*args); });
}

void DefineIrradiance(CLI::App* sub, absl::Status* status) {
  auto args = std::make_shared<OutputArgs>();
  AddEnvOptions(sub, &args->env, /*required=*/true);
  sub->add_option("--size", args->size, "cube face size of the irradiance map")
      ->capture_default_str()
      ->check(jobs::kPositive);
  sub->add_option("-o,--output", args->output, "output EXR (horizontal cross), optional");
  sub->add_option("--threads", args->threads, "worker threads (0: all cores)")
      ->check(jobs::kNonNegative);
  sub->add_option("--verify", args->verify,
                  "check the coefficients at N seeded normals against the pixel sum (0: no check)")
      ->capture_default_str()
      ->check(jobs::InRange(0, jobs::kMaxIrradianceVerify));
  sub->add_flag("--json", args->json, "machine-readable output");
  AddServerOption(sub, &args->server);
  sub->callback([args, status] { *status = RunIrradiance(*args); });
}

}  // namespace shrm::cli
