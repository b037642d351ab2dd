#include "viewer/scene_source.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <optional>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/status_macros.h"
#include "core/envmap/lighting.h"
#include "core/export/shrm_ktx2.h"
#include "core/sh/sh.h"
#include "core/shrm/shrm_file.h"
#include "jobs/prefilter_job.h"
#include "viewer/cube_convert.h"

namespace shrm::viewer {

absl::StatusOr<Image> DownsampleLatLong(const Image& image, int width) {
  Image src = image;
  if (src.width % width != 0 || src.height % (width / 2) != 0) {
    // Resample (bilinear) to the next multiple of `width`, then box-filter.
    const int factor = std::max(1, (src.width + width - 1) / width);
    SHRM_ASSIGN_OR_RETURN(src, EnvMap::FromLatLong(image).ToLatLong(width * factor));
  }
  Image out;
  out.width = width;
  out.height = width / 2;
  out.channels = 3;
  out.pixels.assign(static_cast<size_t>(out.width) * out.height * 3, 0.0f);
  const int fx = std::max(1, src.width / out.width), fy = std::max(1, src.height / out.height);
  for (int y = 0; y < out.height * fy && y < src.height; ++y)
    for (int x = 0; x < out.width * fx && x < src.width; ++x)
      for (int c = 0; c < 3; ++c)
        out.pixels[(static_cast<size_t>(y / fy) * out.width + x / fx) * 3 + c] +=
            src.at(x, y, c) / static_cast<float>(fx * fy);
  return out;
}

absl::StatusOr<std::shared_ptr<EnvironmentData>> EnvironmentBackground(EnvMap map,
                                                                       const std::string& path,
                                                                       int threads) {
  auto env = std::make_shared<EnvironmentData>(std::move(map));
  env->path = path;
  env->sh_lmax = -1;
  int width = env->map.NativeLatLongWidth();
  width = std::min(kMaxBackgroundWidth, std::max(2, width + (width & 1)));
  if (const Image* ll = env->map.lat_long_image(); ll != nullptr && ll->width <= width) {
    env->latlong = *ll;
  } else {
    SHRM_ASSIGN_OR_RETURN(env->latlong, env->map.ToLatLong(width, threads));
  }
  double lum = 0;
  for (size_t i = 0; i + 2 < env->latlong.pixels.size(); i += 3)
    lum += 0.2126 * env->latlong.pixels[i] + 0.7152 * env->latlong.pixels[i + 1] +
           0.0722 * env->latlong.pixels[i + 2];
  env->mean_luminance = lum / std::max<size_t>(1, env->latlong.pixels.size() / 3);
  return env;
}

absl::StatusOr<std::shared_ptr<const EnvironmentData>> LoadEnvironment(const std::string& path,
                                                                       int reference_width,
                                                                       int threads) {
  EnvMapOptions options;
  options.paths = {path};
  SHRM_ASSIGN_OR_RETURN(EnvMap map, EnvMap::Load(options));
  SHRM_ASSIGN_OR_RETURN(std::shared_ptr<EnvironmentData> env,
                        EnvironmentBackground(std::move(map), path, threads));
  env->sh_lmax = kSceneLightLmax;
  if (env->map.layout() == EnvLayout::kLatLong) {  // what the map's own grid resolves
    env->sh_lmax =
        std::max(0, std::min({env->sh_lmax, env->map.height() - 1, (env->map.width() - 1) / 2}));
  }
  SHRM_ASSIGN_OR_RETURN(env->sh,
                        LightingCoefficients(env->map, env->sh_lmax, Mat3::Identity(), threads));
  env->reference_width = reference_width;
  SHRM_ASSIGN_OR_RETURN(Image reference_map, DownsampleLatLong(env->latlong, reference_width));
  const EnvMap small = EnvMap::FromLatLong(std::move(reference_map));
  SHRM_ASSIGN_OR_RETURN(ReferenceIntegrator integrator,
                        ReferenceIntegrator::Create(small.samples()));
  env->reference = std::make_shared<const ReferenceIntegrator>(std::move(integrator));
  SHRM_ASSIGN_OR_RETURN(FastReference fast, FastReference::Create(env->map));
  env->fast_reference = std::make_shared<const FastReference>(std::move(fast));
  return std::shared_ptr<const EnvironmentData>(std::move(env));
}

absl::StatusOr<ShrmData> ShrmDataFromCube(ShrmCube cube,
                                          std::map<std::string, std::string> attributes,
                                          std::string origin, int threads, bool convert) {
  BrdfShaderParams light_brdf;
  if (!cube.lights.empty()) {
    // The modes sum the lights with the shaders' copy of the BRDF (shrm_lights.glsl); a file
    // drawn without them would look right and be wrong, so a BRDF they cannot evaluate is refused.
    auto it = attributes.find("shrm:brdf");
    SHRM_ASSIGN_OR_RETURN(
        light_brdf,
        PeakLightShaderParams(origin, it == attributes.end() ? std::string() : it->second,
                              cube.lights.size(), "view the SHRM of a job without --peak-lights"));
  }
  ShrmData d;
  const ShrmKind other = cube.kind == ShrmKind::kGlobal ? ShrmKind::kLocal : ShrmKind::kGlobal;
  ShrmCube converted;
  if (convert) {
    SHRM_ASSIGN_OR_RETURN(converted, ConvertShrmKind(cube, other, threads));
  } else {
    converted.kind = other;
  }
  if (cube.kind == ShrmKind::kGlobal) {
    d.global = std::move(cube);
    d.local = std::move(converted);
  } else {
    d.local = std::move(cube);
    d.global = std::move(converted);
  }
  d.origin = std::move(origin);
  d.light_brdf = light_brdf;
  d.p_b = d.global.pmax;
  if (auto it = attributes.find("shrm:brdf"); it != attributes.end()) d.brdf_spec = it->second;
  if (auto it = attributes.find("shrm:orders"); it != attributes.end()) {
    d.f_b = std::atoi(it->second.c_str());
  }
  if (auto it = attributes.find("shrm:epsilon"); it != attributes.end()) d.epsilon = it->second;
  if (auto it = attributes.find("shrm:eps_bound"); it != attributes.end()) {
    d.eps_bound = std::strtod(it->second.c_str(), nullptr);
  }
  if (auto it = attributes.find("shrm:tolerance"); it != attributes.end()) d.tolerance = it->second;
  if (const auto r = jobs::FileRecordedError(attributes, "shrm:measured_error");
      r && r->pairs > 0) {
    d.measured = ShrmData::Measured{r->error.front.rms, r->error.front.max, r->error.grazing.rms,
                                    r->error.grazing.max, r->pairs};
  }
  d.attributes = std::move(attributes);
  return d;
}

absl::StatusOr<ShrmData> LoadShrmData(const std::string& path, int threads) {
  const auto t0 = std::chrono::steady_clock::now();
  SHRM_ASSIGN_OR_RETURN(ShrmFile file, ReadShrm(path));
  SHRM_ASSIGN_OR_RETURN(ShrmData d, ShrmDataFromCube(std::move(file.cube), file.attributes,
                                                     absl::StrCat("file ", path), threads));
  d.compute_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return d;
}

std::string ShrmSummaryLine(const ShrmData& d) {
  std::string s = absl::StrFormat("F_B %d P_B %d (%d coeffs) S_B %d", d.f_b, d.p_b, ShCount(d.p_b),
                                  d.global.face_size);
  if (!d.tolerance.empty()) {
    absl::StrAppend(&s, " tolerance ", d.tolerance);
  } else if (!d.epsilon.empty()) {
    absl::StrAppend(&s, " eps ", d.epsilon);
  }
  if (d.measured.pairs > 0) {
    absl::StrAppendFormat(&s, " | measured RMS %.2g%% max %.2g%%, grazing RMS %.2g%% (%d pairs)",
                          100 * d.measured.front_rms, 100 * d.measured.front_max,
                          100 * d.measured.grazing_rms, d.measured.pairs);
  } else if (d.eps_bound >= 0) {
    absl::StrAppendFormat(&s, " | not measured (eq. 5.19 energy bound %.3g)", d.eps_bound);
  }
  return s;
}

jobs::PrefilterJob PrefilterJobFor(const ComputeRequest& req, const std::string& env_path) {
  jobs::PrefilterJob job;
  job.env.files = {env_path};
  job.brdf = req.brdf_spec;
  job.verify = req.verify;
  // The viewer's default is the paper's epsilon rule: a recomputation on a key press must take
  // a fraction of a second (docs/viewer.md); --tolerance asks for the per-direction rule.
  if (req.f >= 0 || req.p >= 0) {
    jobs::UseExplicitOrders(&job, jobs::Orders{req.f, req.p});
  } else if (req.tolerance > 0) {
    jobs::UseToleranceRule(&job, req.tolerance);
  } else {
    jobs::UseEpsilonRule(&job, req.epsilon);
  }
  job.kind = ShrmKind::kGlobal;
  job.face_size = req.face_size;
  return job;
}

ShrmComputeFn EmbeddedCompute(std::shared_ptr<const EnvironmentData> env) {
  return [env](const ComputeRequest& req,
               const PrefilterProgress& progress) -> absl::StatusOr<ShrmData> {
    const auto t0 = std::chrono::steady_clock::now();
    SHRM_ASSIGN_OR_RETURN(std::unique_ptr<Brdf> brdf, ParseBrdfSpec(req.brdf_spec));
    const jobs::PrefilterJob job = PrefilterJobFor(req, env->path);
    SHRM_RETURN_IF_ERROR(jobs::ValidatePrefilterJob(job));
    PrefilterOptions opt = jobs::CorePrefilterOptions(job, std::max(1, req.threads));
    opt.max_cube_values = jobs::EmbeddedCubeValueLimit();
    opt.verify = 0;  // measured below against the map's reference, built once
    SHRM_ASSIGN_OR_RETURN(PrefilterResult r, Prefilter(env->map, *brdf, opt, progress));
    if (job.verify > 0 && env->fast_reference != nullptr) {
      if (progress) SHRM_RETURN_IF_ERROR(progress("verify"));
      // A check longer than the kept reference is built for gets the job's own (the cube faces'
      // tree, FastReference::Create), so that it measures what `shrm prefilter` measures.
      std::optional<FastReference> own;
      if (job.verify > kLatLongTreeMaxQueries) {
        SHRM_ASSIGN_OR_RETURN(own, FastReference::Create(env->map, job.verify));
      }
      SHRM_ASSIGN_OR_RETURN(r.measured,
                            MeasureCubeError(own ? *own : *env->fast_reference, *brdf, opt.rotation,
                                             r.cube, job.verify, opt.threads));
      r.verified_pairs = job.verify;
    }
    if (progress) SHRM_RETURN_IF_ERROR(progress("convert"));
    // As `shrm prefilter` writes them, without hashing the file again (the map is loaded).
    const jobs::PrefilterProvenance provenance{brdf->spec(), {env->path, ""}, env->map.layout()};
    std::map<std::string, std::string> attrs = jobs::PrefilterFileAttributes(job, provenance, r);
    SHRM_ASSIGN_OR_RETURN(
        ShrmData d, ShrmDataFromCube(std::move(r.cube), std::move(attrs), "embedded", opt.threads));
    d.compute_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return d;
  };
}

AsyncShrmJob::~AsyncShrmJob() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    ++generation_;
  }
  for (Worker& w : threads_) w.thread.join();
}

void AsyncShrmJob::Start(const ComputeRequest& request) {
  uint64_t gen;
  {
    std::lock_guard<std::mutex> lock(mu_);
    gen = ++generation_;
    busy_ = true;
    fraction_ = 0;
    stage_ = "start";
    result_.reset();
  }
  for (auto it = threads_.begin(); it != threads_.end();) {
    if (it->done->load()) {
      it->thread.join();
      it = threads_.erase(it);
    } else {
      ++it;
    }
  }
  auto done = std::make_shared<std::atomic<bool>>(false);
  std::thread worker([this, request, gen, done] {
    RunJob(request, gen);
    *done = true;
  });
  threads_.push_back({std::move(worker), std::move(done)});
}

void AsyncShrmJob::RunJob(const ComputeRequest& request, uint64_t gen) {
  static constexpr const char* kStages[] = {"brdf", "lighting", "analysis", "synthesis", "convert"};
  PrefilterProgress progress = [this, gen](std::string_view stage) -> absl::Status {
    if (generation_.load() != gen) return absl::CancelledError("superseded");
    for (int i = 0; i < 5; ++i)
      if (stage == kStages[i]) fraction_ = i / 5.0;
    std::lock_guard<std::mutex> lock(mu_);
    stage_ = std::string(stage);
    return absl::OkStatus();
  };
  absl::StatusOr<ShrmData> r = compute_(request, progress);
  std::lock_guard<std::mutex> lock(mu_);
  if (generation_.load() != gen) return;  // superseded: a newer job owns the result
  result_ = std::move(r);
  stage_ = "done";
  fraction_ = 1;
  busy_ = false;
}

std::string AsyncShrmJob::stage() const {
  std::lock_guard<std::mutex> lock(mu_);
  return stage_;
}

std::optional<absl::StatusOr<ShrmData>> AsyncShrmJob::Poll() {
  std::lock_guard<std::mutex> lock(mu_);
  std::optional<absl::StatusOr<ShrmData>> r = std::move(result_);
  result_.reset();
  return r;
}

std::optional<absl::StatusOr<ShrmData>> AsyncShrmJob::Wait() {
  while (busy_.load()) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  return Poll();
}

}  // namespace shrm::viewer
