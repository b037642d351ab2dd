#include "proto/job_codec.h"

#include <cmath>
#include <optional>
#include <string_view>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/base/status_macros.h"
#include "core/io/sha256.h"

namespace shrm::wire {
namespace {

namespace v1 = ::shrm::v1;

constexpr std::pair<EnvLayout, v1::Layout> kLayouts[] = {
    {EnvLayout::kAuto, v1::LAYOUT_UNSPECIFIED},
    {EnvLayout::kLatLong, v1::LAYOUT_LATLONG},
    {EnvLayout::kCubeFaces, v1::LAYOUT_CUBE_FACES},
    {EnvLayout::kHorizontalCross, v1::LAYOUT_HCROSS},
    {EnvLayout::kVerticalCross, v1::LAYOUT_VCROSS},
    {EnvLayout::kHorizontalStrip, v1::LAYOUT_HSTRIP},
    {EnvLayout::kVerticalStrip, v1::LAYOUT_VSTRIP},
    {EnvLayout::kAngular, v1::LAYOUT_ANGULAR}};

// The IBL enums: explicit values first (what the encoder sends), then _UNSPECIFIED (the default).
constexpr std::pair<ibl::RoughnessPreset, v1::IblPreset> kIblPresets[] = {
    {ibl::RoughnessPreset::kFilament, v1::IBL_PRESET_FILAMENT},
    {ibl::RoughnessPreset::kGltf, v1::IBL_PRESET_GLTF},
    {ibl::RoughnessPreset::kExplicit, v1::IBL_PRESET_EXPLICIT},
    {ibl::RoughnessPreset::kBabylon, v1::IBL_PRESET_BABYLON},
    {ibl::RoughnessPreset::kFilament, v1::IBL_PRESET_UNSPECIFIED}};
constexpr std::pair<jobs::IblFormat, v1::IblFormat> kIblFormats[] = {
    {jobs::IblFormat::kRgba16f, v1::IBL_FORMAT_RGBA16F},
    {jobs::IblFormat::kRgba32f, v1::IBL_FORMAT_RGBA32F},
    {jobs::IblFormat::kB10g11r11, v1::IBL_FORMAT_R11G11B10F},
    {jobs::IblFormat::kE5b9g9r9, v1::IBL_FORMAT_RGB9E5},
    {jobs::IblFormat::kRgba16f, v1::IBL_FORMAT_UNSPECIFIED}};
constexpr std::pair<jobs::IblShWindow, v1::IblShWindow> kIblShWindows[] = {
    {jobs::IblShWindow::kAuto, v1::IBL_SH_WINDOW_AUTO},
    {jobs::IblShWindow::kNone, v1::IBL_SH_WINDOW_NONE},
    {jobs::IblShWindow::kCmgen, v1::IBL_SH_WINDOW_CMGEN},
    {jobs::IblShWindow::kAuto, v1::IBL_SH_WINDOW_UNSPECIFIED}};
// The job's view variable: nullopt = auto.
constexpr std::pair<std::optional<ViewVariable>, v1::ViewVariable> kViewVariables[] = {
    {std::nullopt, v1::VIEW_VARIABLE_AUTO},
    {ViewVariable::kView, v1::VIEW_VARIABLE_VIEW},
    {ViewVariable::kNormal, v1::VIEW_VARIABLE_NORMAL}};

constexpr std::pair<PeakLights, v1::PeakLights> kPeakLights[] = {
    {PeakLights::kAuto, v1::PEAK_LIGHTS_AUTO},
    {PeakLights::kOn, v1::PEAK_LIGHTS_ON},
    {PeakLights::kOff, v1::PEAK_LIGHTS_OFF}};

// The core value of a proto enum value (InvalidArgument naming `field` for unknown values).
template <typename Core, typename Proto, size_t N>
absl::StatusOr<Core> FromProto(const std::pair<Core, Proto> (&table)[N], int value,
                               const char* field) {
  for (const auto& [core, proto] : table)
    if (proto == value) return core;
  return absl::InvalidArgumentError(absl::StrCat(field, ": unknown value ", value));
}

// The first proto value of a core value (`table` lists every core value).
template <typename Core, typename Proto, size_t N>
Proto ToProto(const std::pair<Core, Proto> (&table)[N], Core value) {
  for (const auto& [core, proto] : table)
    if (core == value) return proto;
  return table[0].second;
}

}  // namespace

absl::StatusOr<EnvLayout> LayoutFromProto(v1::Layout layout) {
  return FromProto(kLayouts, layout, "environment.layout");
}

v1::Layout LayoutToProto(EnvLayout layout) { return ToProto(kLayouts, layout); }

absl::Status CheckRemoteEnvironment(const jobs::EnvironmentSpec& env) {
  if (!env.ocio_config.empty()) {
    return absl::InvalidArgumentError(
        "ocio_config: a server cannot read the client's OpenColorIO config (it uses its own)");
  }
  return jobs::ValidateEnvironment(env);
}

absl::Status EncodeEnvironment(const jobs::EnvironmentSpec& env,
                               const std::vector<std::string>& sha256, v1::Environment* out) {
  SHRM_RETURN_IF_ERROR(CheckRemoteEnvironment(env));
  out->Clear();
  out->set_layout(LayoutToProto(env.layout));
  if (env.rotate_ypr_deg) {
    out->mutable_rotation()->set_yaw_deg((*env.rotate_ypr_deg)[0]);
    out->mutable_rotation()->set_pitch_deg((*env.rotate_ypr_deg)[1]);
    out->mutable_rotation()->set_roll_deg((*env.rotate_ypr_deg)[2]);
  }
  out->set_input_colour_space(env.input_colour_space);
  out->set_working_colour_space(env.working_colour_space);
  out->set_non_finite(env.replace_non_finite ? v1::NON_FINITE_POLICY_REPLACE_ZERO
                                             : v1::NON_FINITE_POLICY_REJECT);
  for (const std::string& h : sha256) out->add_sha256(h);
  for (const std::string& f : env.files) out->add_source_names(f);
  return absl::OkStatus();
}

absl::StatusOr<WireEnvironment> DecodeEnvironment(const v1::Environment& env) {
  WireEnvironment w;
  if (env.sha256_size() != 1 && env.sha256_size() != 6) {
    return absl::InvalidArgumentError(absl::StrCat(
        "environment.sha256: give one blob, or six cube faces; got ", env.sha256_size()));
  }
  for (const std::string& h : env.sha256()) {
    if (!IsSha256Hex(h)) {
      return absl::InvalidArgumentError(absl::StrCat("environment.sha256: '", h.substr(0, 80),
                                                     "' is not 64 lowercase hex digits"));
    }
    w.sha256.push_back(h);
  }
  SHRM_ASSIGN_OR_RETURN(w.spec.layout, LayoutFromProto(env.layout()));
  w.spec.input_colour_space = env.input_colour_space();
  if (!env.working_colour_space().empty()) {
    w.spec.working_colour_space = env.working_colour_space();
  }
  switch (env.non_finite()) {
    case v1::NON_FINITE_POLICY_UNSPECIFIED:
    case v1::NON_FINITE_POLICY_REJECT:
      w.spec.replace_non_finite = false;
      break;
    case v1::NON_FINITE_POLICY_REPLACE_ZERO:
      w.spec.replace_non_finite = true;
      break;
    default:
      return absl::InvalidArgumentError("environment.non_finite: unknown value");
  }
  if (env.has_rotation()) {
    const v1::Rotation& r = env.rotation();
    const std::array<double, 3> ypr = {r.yaw_deg(), r.pitch_deg(), r.roll_deg()};
    for (double a : ypr) {
      if (!std::isfinite(a)) {
        return absl::InvalidArgumentError("environment.rotation: angles must be finite");
      }
    }
    w.spec.rotate_ypr_deg = ypr;
  }
  if (env.source_names_size() > 0) {
    w.spec.files.assign(env.source_names().begin(), env.source_names().end());
  } else {
    w.spec.files = w.sha256;
  }
  return w;
}

v1::PrefilterRequest EncodePrefilterRequest(const jobs::PrefilterJob& job,
                                            const v1::Environment& env, const WireBrdf& brdf,
                                            bool visuals) {
  v1::PrefilterRequest req;
  *req.mutable_environment() = env;
  req.set_brdf(brdf.spec);
  req.set_brdf_blob_sha256(brdf.blob_sha256);
  req.set_brdf_display_spec(brdf.display_spec);
  if (job.orders) {
    req.mutable_orders()->set_f(job.orders->f);
    req.mutable_orders()->set_p(job.orders->p);
  } else if (job.tolerance > 0) {
    req.set_tolerance(job.tolerance);
  } else {
    req.set_epsilon(job.epsilon);
  }
  req.set_window(job.window == RingingWindow::kNone      ? v1::RINGING_WINDOW_NONE
                 : job.window == RingingWindow::kLanczos ? v1::RINGING_WINDOW_LANCZOS
                                                         : v1::RINGING_WINDOW_AUTO);
  req.set_view_variable(ToProto(kViewVariables, job.view));
  req.set_kind(job.kind == ShrmKind::kLocal ? v1::SHRM_KIND_LOCAL : v1::SHRM_KIND_GLOBAL);
  req.set_face_size(job.face_size);
  req.set_half(job.half);
  req.set_peak_lights(ToProto(kPeakLights, job.peak_lights));
  req.set_verify(job.verify);
  req.set_max_size_mb(job.max_size_mb);
  if (visuals) {
    req.add_outputs(v1::OUTPUT_SHRM_FILE);
    req.add_outputs(v1::OUTPUT_REPORT);
    req.add_outputs(v1::OUTPUT_REPORT_VISUALS);
  }
  return req;
}

absl::StatusOr<WirePrefilter> DecodePrefilterRequest(const v1::PrefilterRequest& request) {
  WirePrefilter w;
  w.brdf = {request.brdf(), request.brdf_blob_sha256(), request.brdf_display_spec()};
  w.job.brdf = request.brdf();
  // Neither of the oneof's fields: the job's default rule (the tolerance rule).
  if (request.has_orders()) {
    jobs::UseExplicitOrders(&w.job, jobs::Orders{request.orders().f(), request.orders().p()});
  } else if (request.order_choice_case() == v1::PrefilterRequest::kEpsilon) {
    jobs::UseEpsilonRule(&w.job, request.epsilon());
  } else if (request.order_choice_case() == v1::PrefilterRequest::kTolerance) {
    if (!(request.tolerance() > 0)) {  // 0 would silently mean the epsilon rule
      return absl::InvalidArgumentError(
          absl::StrCat("tolerance must be in (0, 1), got ", request.tolerance()));
    }
    jobs::UseToleranceRule(&w.job, request.tolerance());
  }
  switch (request.window()) {
    case v1::RINGING_WINDOW_AUTO:
      w.job.window = RingingWindow::kAuto;
      break;
    case v1::RINGING_WINDOW_NONE:
      w.job.window = RingingWindow::kNone;
      break;
    case v1::RINGING_WINDOW_LANCZOS:
      w.job.window = RingingWindow::kLanczos;
      break;
    default:
      return absl::InvalidArgumentError("window: unknown value");
  }
  SHRM_ASSIGN_OR_RETURN(w.job.view,
                        FromProto(kViewVariables, request.view_variable(), "view_variable"));
  switch (request.kind()) {
    case v1::SHRM_KIND_UNSPECIFIED:
    case v1::SHRM_KIND_GLOBAL:
      w.job.kind = ShrmKind::kGlobal;
      break;
    case v1::SHRM_KIND_LOCAL:
      w.job.kind = ShrmKind::kLocal;
      break;
    default:
      return absl::InvalidArgumentError("kind: unknown value");
  }
  w.job.face_size = request.face_size();
  w.job.half = request.half();
  SHRM_ASSIGN_OR_RETURN(w.job.peak_lights,
                        FromProto(kPeakLights, request.peak_lights(), "peak_lights"));
  if (request.has_verify()) w.job.verify = request.verify();  // absent: the job's default
  if (request.has_max_size_mb()) w.job.max_size_mb = request.max_size_mb();
  w.want_file = w.want_report = request.outputs_size() == 0;
  for (int o : request.outputs()) {
    if (o == v1::OUTPUT_SHRM_FILE) w.want_file = true;
    if (o == v1::OUTPUT_REPORT) w.want_report = true;
    if (o == v1::OUTPUT_REPORT_VISUALS) w.want_visuals = true;
  }
  if (request.brdf().empty()) return absl::InvalidArgumentError("brdf: a BRDF spec is required");
  SHRM_ASSIGN_OR_RETURN(WireEnvironment env, DecodeEnvironment(request.environment()));
  w.job.env = std::move(env.spec);
  w.sha256 = std::move(env.sha256);
  SHRM_RETURN_IF_ERROR(jobs::ValidatePrefilterJob(w.job));
  return w;
}

v1::IblRequest EncodeIblRequest(const jobs::IblJob& job, const v1::Environment& env) {
  v1::IblRequest req;
  *req.mutable_environment() = env;
  req.set_preset(ToProto(kIblPresets, job.preset));
  for (double r : job.roughness) req.add_roughness(r);
  req.set_face_size(job.face_size);
  req.set_levels(job.levels);
  req.set_sheen(job.sheen);
  req.set_format(ToProto(kIblFormats, job.format));
  req.set_irradiance_size(job.irradiance_size);
  req.set_dfg_size(job.dfg_size);
  req.set_tolerance(job.tolerance);
  req.set_verify(job.verify);
  req.set_sh_window(ToProto(kIblShWindows, job.sh_window));
  req.set_dfg(job.dfg);
  req.set_containers(jobs::IblContainersText(job.containers));
  req.set_preview(job.preview);
  return req;
}

absl::StatusOr<WireIbl> DecodeIblRequest(const v1::IblRequest& request) {
  WireIbl w;
  SHRM_ASSIGN_OR_RETURN(WireEnvironment env, DecodeEnvironment(request.environment()));
  w.job.env = std::move(env.spec);
  w.sha256 = std::move(env.sha256);
  SHRM_ASSIGN_OR_RETURN(w.job.preset, FromProto(kIblPresets, request.preset(), "preset"));
  SHRM_ASSIGN_OR_RETURN(w.job.format, FromProto(kIblFormats, request.format(), "format"));
  SHRM_ASSIGN_OR_RETURN(w.job.sh_window,
                        FromProto(kIblShWindows, request.sh_window(), "sh_window"));
  w.job.roughness.assign(request.roughness().begin(), request.roughness().end());
  if (request.face_size() != 0) w.job.face_size = request.face_size();
  w.job.levels = request.levels();
  w.job.sheen = request.sheen();
  if (request.irradiance_size() != 0) w.job.irradiance_size = request.irradiance_size();
  if (request.dfg_size() != 0) w.job.dfg_size = request.dfg_size();
  if (request.tolerance() != 0) w.job.tolerance = request.tolerance();
  if (request.has_verify()) w.job.verify = request.verify();
  if (!request.dfg().empty()) w.job.dfg = request.dfg();
  w.job.preview = request.preview();
  if (!request.containers().empty()) {
    absl::StatusOr<std::vector<jobs::IblContainer>> containers =
        jobs::ParseIblContainers(request.containers());
    if (!containers.ok()) {
      return WithMessage(containers.status(),
                         absl::StrCat("containers: ", containers.status().message()));
    }
    w.job.containers = *std::move(containers);
  }
  // Errors name the request's fields (jobs/job_options.h names the options).
  SHRM_RETURN_IF_ERROR(jobs::ValidateIblJobNamingOptions(w.job, [](std::string_view option) {
    return option == "env"    ? std::string("environment")
           : option == "size" ? std::string("face_size")
                              : std::string(option);
  }));
  return w;
}

}  // namespace shrm::wire
