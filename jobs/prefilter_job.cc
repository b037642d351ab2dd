#include "jobs/prefilter_job.h"

#include <chrono>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/base/status_macros.h"
#include "jobs/report.h"
#include "shrm/version.h"

namespace shrm::jobs {

const char* ShrmKindName(ShrmKind kind) { return kind == ShrmKind::kLocal ? "local" : "global"; }

absl::StatusOr<ShrmKind> ParseShrmKind(absl::string_view name) {
  if (name == "global") return ShrmKind::kGlobal;
  if (name == "local") return ShrmKind::kLocal;
  return absl::InvalidArgumentError(absl::StrCat("kind must be local or global, got '", name, "'"));
}

absl::Status ValidatePrefilterJob(const PrefilterJob& job) {
  SHRM_RETURN_IF_ERROR(ValidateEnvironment(job.env));
  if (job.brdf.empty()) return absl::InvalidArgumentError("brdf: a BRDF spec is required");
  if (!(job.epsilon > 0 && job.epsilon < 1)) {
    return absl::InvalidArgumentError(absl::StrCat("epsilon must be in (0, 1), got ", job.epsilon));
  }
  if (job.orders) {
    const Orders& o = *job.orders;
    if (o.f < 0 || o.p < 0 || o.f > kMaxOrderF || o.p > kMaxOrderP) {
      return absl::InvalidArgumentError(absl::StrCat("orders: F must be in [0, ", kMaxOrderF,
                                                     "] and P in [0, ", kMaxOrderP, "], got ", o.f,
                                                     ",", o.p));
    }
  }
  if (job.face_size < 0 || job.face_size > kMaxFaceSize) {
    return absl::InvalidArgumentError(
        absl::StrCat("size (S_B) must be in [0, ", kMaxFaceSize, "], got ", job.face_size));
  }
  return absl::OkStatus();
}

PrefilterOptions CorePrefilterOptions(const PrefilterJob& job, int threads) {
  PrefilterOptions opt;
  opt.epsilon = job.epsilon;
  if (job.orders) {
    opt.f = job.orders->f;
    opt.p = job.orders->p;
  }
  opt.kind = job.kind;
  opt.face_size = job.face_size;
  opt.rotation = EnvironmentRotation(job.env);
  opt.threads = threads;
  return opt;
}

std::string EpsilonAttribute(const PrefilterJob& job) {
  return job.orders ? std::string(kExplicitOrdersAttribute) : absl::StrCat(job.epsilon);
}

std::map<std::string, std::string> PrefilterFileAttributes(const PrefilterJob& job,
                                                           const PrefilterProvenance& provenance,
                                                           const ShrmAnalysis& an) {
  std::map<std::string, std::string> attrs = {
      {"shrm:brdf", provenance.brdf_spec},
      {"shrm:epsilon", EpsilonAttribute(job)},
      {"shrm:orders", absl::StrCat(an.f_b, ",", an.p_b)},
      {"shrm:brdf_orders", absl::StrCat(an.f_brdf, ",", an.p_brdf)},
      {"shrm:eps_light", absl::StrCat(an.eps_light)},
      {"shrm:eps_brdf", absl::StrCat(an.eps_brdf)},
      {"shrm:eps_bound", absl::StrCat(an.eps_bound)},
      {"shrm:source", provenance.source.names},
      {"shrm:source_sha256", provenance.source.sha256},
      {"shrm:working_space", job.env.working_colour_space},
      {"shrm:layout", EnvLayoutName(provenance.layout)},
      {"shrm:version", kVersion},
  };
  if (job.env.rotate_ypr_deg) attrs["shrm:rotate_ypr_deg"] = RotationAttribute(job.env);
  return attrs;
}

nlohmann::json PrefilterReportJson(const PrefilterJob& job, const PrefilterProvenance& provenance,
                                   const ShrmAnalysis& analysis, int face_size) {
  nlohmann::json report = AnalysisJson(analysis);
  report["brdf"] = provenance.brdf_spec;
  report["kind"] = ShrmKindName(job.kind);
  report["face_size"] = face_size;
  report["source_sha256"] = provenance.source.sha256;
  report["layout"] = EnvLayoutName(provenance.layout);
  report["shrm_version"] = kVersion;
  return report;
}

std::string WhyFileDiffers(const PrefilterJob& job, const std::string& canonical_brdf,
                           const std::string& source_sha256, const ShrmFile& file) {
  const std::map<std::string, std::string>& a = file.attributes;
  auto differs = [&](const char* key, const std::string& want) -> std::string {
    auto it = a.find(key);
    const std::string have = it == a.end() ? std::string("(none)") : it->second;
    return have == want ? "" : absl::StrCat(key, " ", have, " != ", want);
  };
  std::string why;
  if (!(why = differs("shrm:brdf", canonical_brdf)).empty()) return why;
  if (!differs("shrm:source_sha256", source_sha256).empty()) return "source changed";
  if (!(why = differs("shrm:epsilon", EpsilonAttribute(job))).empty()) return why;
  if (job.orders &&
      !(why = differs("shrm:orders", absl::StrCat(job.orders->f, ",", job.orders->p))).empty())
    return why;
  if (!(why = differs("shrm:rotate_ypr_deg",
                      job.env.rotate_ypr_deg ? RotationAttribute(job.env) : "(none)"))
           .empty())
    return why;
  if (file.cube.kind != job.kind) return absl::StrCat("kind != ", ShrmKindName(job.kind));
  if (job.face_size > 0 && file.cube.face_size != job.face_size)
    return absl::StrCat("size ", file.cube.face_size, " != ", job.face_size);
  return "";
}

absl::StatusOr<PrefilterRun> RunPrefilterJob(const PrefilterJob& job, int threads,
                                             const PrefilterProgress& progress) {
  SHRM_RETURN_IF_ERROR(ValidatePrefilterJob(job));
  SHRM_ASSIGN_OR_RETURN(std::unique_ptr<Brdf> brdf, ParseBrdfSpec(job.brdf));
  if (progress) SHRM_RETURN_IF_ERROR(progress("decode"));
  const auto decode_start = std::chrono::steady_clock::now();
  SHRM_ASSIGN_OR_RETURN(EnvMap env, EnvMap::Load(EnvMapOptionsFor(job.env)));
  PrefilterRun run;
  SHRM_ASSIGN_OR_RETURN(run.provenance.source, LocalSourceIdentity(job.env));
  run.decode_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - decode_start)
          .count();
  run.replaced_non_finite = env.replaced_non_finite();
  run.provenance.brdf_spec = brdf->spec();
  run.provenance.layout = env.layout();
  SHRM_ASSIGN_OR_RETURN(run.result,
                        Prefilter(env, *brdf, CorePrefilterOptions(job, threads), progress));
  const ShrmAnalysis& an = run.result.analysis;
  run.attributes = PrefilterFileAttributes(job, run.provenance, an);
  run.report = PrefilterReportJson(job, run.provenance, an, run.result.cube.face_size);
  return run;
}

}  // namespace shrm::jobs
