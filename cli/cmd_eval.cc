// `shrm eval` (an SHRM file at one (N, V)), `shrm reference` (brute force over the map's pixels)
// and `shrm info` (an SHRM file's header).
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "absl/strings/str_cat.h"
#include "cli/cli_common.h"
#include "cli/commands.h"
#if SHRM_CLI_HAS_CLIENT
#include "client/shrm_client.h"
#endif
#include "core/base/status_macros.h"
#include "core/brdf/brdf.h"
#include "core/envmap/lighting.h"
#include "core/export/shrm_ktx2.h"
#include "core/shrm/shrm_eval.h"
#include "core/shrm/shrm_file.h"
#include "core/shrm/shrm_reference.h"
#include "core/shrm/shrm_synthesis.h"
#include "jobs/cli_validators.h"

namespace shrm::cli {
namespace {

#if SHRM_CLI_HAS_CLIENT
namespace v1 = ::shrm::v1;
#endif

struct PointArgs {
  std::string shrm;
  EnvArgs env;
  std::string brdf;
  std::string normal, view, tangent;
  int threads = 0;
  bool json = false;
  std::string server;
};

void PrintRgb(const std::array<double, 3>& rgb, bool json) {
  if (json) {
    std::printf("{\"rgb\": [%.9g, %.9g, %.9g]}\n", rgb[0], rgb[1], rgb[2]);
  } else {
    std::printf("%.9g %.9g %.9g\n", rgb[0], rgb[1], rgb[2]);
  }
}

// The texel-addressing direction and the view: (N or T, V) from the options.
absl::Status ParseGeometry(const PointArgs& a, bool tangent_index, Vec3* index, Vec3* v) {
  SHRM_ASSIGN_OR_RETURN(*v, ParseDirection(a.view, "--view"));
  if (tangent_index) {
    if (a.tangent.empty()) {
      return absl::InvalidArgumentError(
          "this BRDF is indexed by the tangent: give --tangent x,y,z");
    }
    SHRM_ASSIGN_OR_RETURN(*index, ParseDirection(a.tangent, "--tangent"));
    return absl::OkStatus();
  }
  if (a.normal.empty()) return absl::InvalidArgumentError("give --normal x,y,z");
  SHRM_ASSIGN_OR_RETURN(*index, ParseDirection(a.normal, "--normal"));
  return absl::OkStatus();
}

absl::Status RunEval(const PointArgs& a) {
  SHRM_ASSIGN_OR_RETURN(ShrmFile file, ReadShrm(a.shrm));
  Vec3 index, v;
  SHRM_RETURN_IF_ERROR(ParseGeometry(a, file.cube.index == ReparamKind::kTangent, &index, &v));
  if (file.cube.index == ReparamKind::kReflection && !(index.Dot(v) > 0)) {
    // V below the surface: the expansion, indexed by R = 2 (N.V) N - V, would give the surface
    // of normal -N. A BRDF clipped at the normal's horizon reflects nothing there, which is what
    // `shrm reference` sums; Phong (no horizon) keeps its value.
    absl::StatusOr<std::unique_ptr<Brdf>> brdf = ShrmFileBrdf(file, a.shrm);
    if (brdf.ok() && (*brdf)->clipped_at_normal_horizon()) {
      std::fprintf(stderr,
                   "shrm: note: N.V = %.3g: the view is below the surface, where %s reflects "
                   "nothing\n",
                   index.Dot(v) / (index.Norm() * v.Norm()), (*brdf)->spec().c_str());
      PrintRgb({0, 0, 0}, a.json);
      return absl::OkStatus();
    }
  }
  if (file.cube.lights.empty()) {
    PrintRgb(ShrmEval(file.cube, index, v), a.json);
    return absl::OkStatus();
  }
  // The lights are summed with the BRDF the file was made with.
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<Brdf> brdf, ShrmFileBrdf(file, a.shrm));
  PrintRgb(ShrmEvalWithLights(file.cube, *brdf, index, v), a.json);
  return absl::OkStatus();
}

absl::Status RunReference(const PointArgs& a) {
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<Brdf> brdf, ParseBrdfSpec(a.brdf));
  Vec3 index, v;
  SHRM_RETURN_IF_ERROR(ParseGeometry(a, brdf->reparam() == ReparamKind::kTangent, &index, &v));
  SHRM_ASSIGN_OR_RETURN(const jobs::EnvironmentSpec spec, EnvSpecFromArgs(a.env));
  if (!a.server.empty()) {
#if !SHRM_CLI_HAS_CLIENT
    return RunWithClient();
#else
    // The same sum on shrmd (the map and a BRDF file uploaded when it lacks them).
    SHRM_ASSIGN_OR_RETURN(std::unique_ptr<client::ShrmClient> c, ConnectServer(a.server));
    v1::ReferenceRequest req;
    auto set = [](const Vec3& d, v1::Direction* out) {
      out->set_x(d.x);
      out->set_y(d.y);
      out->set_z(d.z);
    };
    set(index, req.mutable_index());
    set(v, req.mutable_view());
    v1::ReferenceResponse resp;
    SHRM_RETURN_IF_ERROR(client::RunRemoteJob(
        c.get(), spec, a.server,
        [&] {
          SHRM_RETURN_IF_ERROR(client::UploadEnvironment(spec, c.get(), req.mutable_environment()));
          SHRM_ASSIGN_OR_RETURN(client::RemoteBrdf b, client::ResolveRemoteBrdf(a.brdf, c.get()));
          req.set_brdf(b.spec);
          req.set_brdf_blob_sha256(b.blob_sha256);
          SHRM_ASSIGN_OR_RETURN(resp, c->Reference(req));
          return absl::OkStatus();
        },
        // A table or MERL file travels as a blob: the server's errors name it by the file.
        RetryReporter(a.server, /*quiet=*/false), nullptr, client::BrdfFiles(a.brdf)));
    if (resp.rgb_size() != 3) return absl::DataLossError("the server's answer lacks 3 values");
    PrintRgb({resp.rgb(0), resp.rgb(1), resp.rgb(2)}, a.json);
    return absl::OkStatus();
#endif  // SHRM_CLI_HAS_CLIENT
  }
  SHRM_ASSIGN_OR_RETURN(EnvMap env, LoadEnv(spec));
  PrintRgb(BrdfReferenceRadiance(env.samples(), *brdf, jobs::EnvironmentRotation(spec), index, v),
           a.json);
  return absl::OkStatus();
}

absl::Status RunInfo(const std::string& path, bool json) {
  SHRM_ASSIGN_OR_RETURN(ShrmFile file, ReadShrm(path));
  const ShrmCube& c = file.cube;
  double lo = INFINITY, hi = -INFINITY;
  for (size_t t = 0; t < c.size() / (c.coeff_count() * 3); ++t)
    for (int ch = 0; ch < 3; ++ch) {
      const double v = c.data[t * c.coeff_count() * 3 + ch];
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  if (json) {
    nlohmann::json j = file.attributes;
    j["face_size"] = c.face_size;
    j["coefficients"] = c.coeff_count();
    j["c00_min"] = lo;
    j["c00_max"] = hi;
    std::printf("%s\n", j.dump(2).c_str());
    return absl::OkStatus();
  }
  std::printf("%s: %s SHRM indexed by %s, 6 x %d x %d texels, P = %d (%d coefficients x RGB)\n",
              path.c_str(), c.kind == ShrmKind::kLocal ? "local" : "global",
              c.index == ReparamKind::kTangent ? "the tangent" : "the reflection vector",
              c.face_size, c.face_size, c.pmax, c.coeff_count());
  std::printf("  c_00 range [%.6g, %.6g]\n", lo, hi);
  for (const auto& [k, v] : file.attributes) {
    if (k == "shrm:fresnel" && !c.fresnel.empty()) {  // 129 numbers: their summary (--json: all)
      std::printf("  %-20s %zu values: w(N.R) = %.6g at N.R = 1 .. %.6g at N.R = 0\n", k.c_str(),
                  c.fresnel.size(), ShrmFresnel(c, 1.0, 0), ShrmFresnel(c, 0.0, 0));
      continue;
    }
    if (k == "shrm:lights" && !c.lights.empty()) {  // 6 numbers a light (--json: all)
      double total[3] = {0, 0, 0};
      for (const ShrmLight& l : c.lights)
        for (int ch = 0; ch < 3; ++ch) total[ch] += l.weight[ch];
      std::printf("  %-20s %zu directional lights, L dOmega summed (%.6g, %.6g, %.6g)\n", k.c_str(),
                  c.lights.size(), total[0], total[1], total[2]);
      continue;
    }
    std::printf("  %-20s %s\n", k.c_str(), v.c_str());
  }
  return absl::OkStatus();
}

}  // namespace

void DefineEval(CLI::App* sub, absl::Status* status) {
  auto args = std::make_shared<PointArgs>();
  sub->add_option("--shrm", args->shrm, "SHRM file")->required();
  sub->add_option("--normal", args->normal, "unit normal N as x,y,z (world, +Y up)")
      ->check(jobs::kDirection);
  sub->add_option("--tangent", args->tangent, "tangent T (Kajiya-Kay SHRMs) as x,y,z")
      ->check(jobs::kDirection);
  sub->add_option("--view", args->view, "view direction V (towards the viewer) as x,y,z")
      ->required()
      ->check(jobs::kDirection);
  sub->add_flag("--json", args->json, "print {\"rgb\": [r, g, b]}");
  sub->callback([args, status] { *status = RunEval(*args); });
}

void DefineReference(CLI::App* sub, absl::Status* status) {
  auto args = std::make_shared<PointArgs>();
  AddEnvOptions(sub, &args->env, /*required=*/true);
  sub->add_option("--brdf", args->brdf, "BRDF spec (docs/brdf.md)")->required();
  sub->add_option("--normal", args->normal, "unit normal N as x,y,z (world, +Y up)")
      ->check(jobs::kDirection);
  sub->add_option("--tangent", args->tangent, "tangent T (Kajiya-Kay) as x,y,z")
      ->check(jobs::kDirection);
  sub->add_option("--view", args->view, "view direction V (towards the viewer) as x,y,z")
      ->required()
      ->check(jobs::kDirection);
  sub->add_flag("--json", args->json, "print {\"rgb\": [r, g, b]}");
  AddServerOption(sub, &args->server);
  sub->callback([args, status] { *status = RunReference(*args); });
}

void DefineInfo(CLI::App* sub, absl::Status* status) {
  auto path = std::make_shared<std::string>();
  auto json = std::make_shared<bool>(false);
  sub->add_option("file", *path, "SHRM file")->required();
  sub->add_flag("--json", *json, "machine-readable output");
  sub->callback([path, json, status] { *status = RunInfo(*path, *json); });
}

}  // namespace shrm::cli
