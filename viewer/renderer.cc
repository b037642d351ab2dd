#include "viewer/renderer.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "core/base/status_macros.h"
#include "viewer/glsl_snippets.h"

namespace shrm::viewer {
namespace {

constexpr char kBackgroundFragment[] = R"(#version 330 core
in vec2 v_ndc;
uniform sampler2D u_env;
uniform vec3 u_forward, u_right, u_up;  // right, up scaled by tan(fov/2) (and the aspect)
uniform mat3 u_inverse_rotation;        // R^-1 of the lighting's rotation (identity: none)
out vec4 o_color;
void main() {
  vec3 d = u_inverse_rotation * normalize(u_forward + v_ndc.x * u_right + v_ndc.y * u_up);
  // docs/conventions.md: d = (sin t sin p, cos t, -sin t cos p), u = p / 2pi + 1/2, v = t / pi.
  float t = acos(clamp(d.y, -1.0, 1.0));
  float p = atan(d.x, -d.z);
  vec2 uv = vec2(p * 0.15915494309189535 + 0.5, t * 0.3183098861837907);
  o_color = vec4(texture(u_env, uv).rgb, 0.0);
}
)";

// Reinhard per channel after 2^exposure, then the sRGB OETF (core/io/image.h WritePreviewPng).
constexpr char kToneGlsl[] = R"(
vec3 ToneMap(vec3 x, float exposure) {
  x = max(x, vec3(0.0)) * exp2(exposure);
  x = x / (1.0 + x);
  vec3 lo = 12.92 * x, hi = 1.055 * pow(x, vec3(1.0 / 2.4)) - 0.055;
  return mix(lo, hi, step(vec3(0.0031308), x));
}
)";

constexpr char kTonemapMain[] = R"(
uniform sampler2D u_hdr;
uniform float u_exposure;
out vec4 o_color;
void main() {
  o_color = vec4(ToneMap(texelFetch(u_hdr, ivec2(gl_FragCoord.xy), 0).rgb, u_exposure), 1.0);
}
)";

// Turbo colour map, polynomial approximation (Google, Apache-2.0, A. Mikhailov 2019).
constexpr char kDiffMain[] = R"(
uniform sampler2D u_hdr;
uniform sampler2D u_reference;
uniform int u_reference_valid;  // 0: no truth of this view yet (missing, or the camera moves)
uniform float u_exposure;
out vec4 o_color;
vec3 Turbo(float x) {
  const vec4 kR4 = vec4(0.13572138, 4.61539260, -42.66032258, 132.13108234);
  const vec4 kG4 = vec4(0.09140261, 2.19418839, 4.84296658, -14.18503333);
  const vec4 kB4 = vec4(0.10667330, 12.64194608, -60.58204836, 110.36276771);
  const vec2 kR2 = vec2(-152.94239396, 59.28637943);
  const vec2 kG2 = vec2(4.27729857, 2.82956604);
  const vec2 kB2 = vec2(-89.90310912, 27.34824973);
  x = clamp(x, 0.0, 1.0);
  vec4 v4 = vec4(1.0, x, x * x, x * x * x);
  vec2 v2 = v4.zw * v4.z;
  return vec3(dot(v4, kR4) + dot(v2, kR2), dot(v4, kG4) + dot(v2, kG2),
              dot(v4, kB4) + dot(v2, kB2));
}
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec4 a = texelFetch(u_hdr, p, 0);
  vec4 r = u_reference_valid != 0 ? texelFetch(u_reference, p, 0) : vec4(0.0);
  if (a.a == 0.0) {
    o_color = vec4(0.25 * ToneMap(a.rgb, u_exposure), 1.0);  // background, dimmed
  } else if (r.a == 0.0) {
    o_color = vec4(vec3(0.3), 1.0);  // ground truth not computed yet
  } else {
    float rel = length(a.rgb - r.rgb) / max(length(r.rgb), 1e-6);
    vec3 c = Turbo((log(max(rel, 1e-6)) * 0.43429448190325176 + 3.0) / 3.0);
    o_color = vec4(r.a < 1.0 ? 0.6 * c : c, 1.0);  // block estimates darker
  }
}
)";

constexpr char kGbufferFragment[] = R"(#version 330 core
in vec3 v_position;
in vec3 v_normal;
in vec4 v_tangent;
layout(location = 0) out vec4 o_position;
layout(location = 1) out vec4 o_normal;
layout(location = 2) out vec4 o_tangent;
void main() {
  o_position = vec4(v_position, 1.0);
  o_normal = vec4(normalize(v_normal), 1.0);
  o_tangent = vec4(normalize(v_tangent.xyz), 1.0);
}
)";

Vec3 At4(const std::vector<float>& v, size_t pixel) {
  return {v[4 * pixel], v[4 * pixel + 1], v[4 * pixel + 2]};
}

// `s` with the mode it comes from in front: "mode 3 (sh-lighting): ...".
absl::Status NameMode(const ModeInfo& info, const absl::Status& s) {
  return absl::Status(s.code(),
                      absl::StrCat("mode ", info.key, " (", info.name, "): ", s.message()));
}

// Several errors as one status (the first one's code), OK if there are none.
absl::Status JoinErrors(const std::vector<absl::Status>& errors) {
  if (errors.empty()) return absl::OkStatus();
  std::vector<absl::string_view> messages;
  for (const absl::Status& e : errors) messages.push_back(e.message());
  return absl::Status(errors.front().code(), absl::StrJoin(messages, "; "));
}

// Rows top-first <-> GL order.
std::vector<float> FlipRows(const std::vector<float>& in, int width, int height) {
  std::vector<float> out(in.size());
  const size_t row = static_cast<size_t>(width) * 4;
  for (int y = 0; y < height; ++y)
    std::copy(in.begin() + (height - 1 - y) * row, in.begin() + (height - y) * row,
              out.begin() + y * row);
  return out;
}

}  // namespace

absl::StatusOr<std::unique_ptr<Renderer>> Renderer::Create(int width, int height,
                                                           int reference_threads) {
  std::unique_ptr<Renderer> r(new Renderer());
  r->reference_ = std::make_unique<ProgressiveReference>(reference_threads);
  glEnable(GL_TEXTURE_CUBE_MAP_SEAMLESS);
  r->empty_vao_ = GlVertexArray::Generate();
  SHRM_ASSIGN_OR_RETURN(r->background_program_,
                        BuildProgram(kFullscreenVertexShader, kBackgroundFragment, "background"));
  SHRM_ASSIGN_OR_RETURN(
      r->tonemap_program_,
      BuildProgram(kFullscreenVertexShader,
                   absl::StrCat("#version 330 core\n", kToneGlsl, kTonemapMain), "tone mapping"));
  SHRM_ASSIGN_OR_RETURN(
      r->diff_program_,
      BuildProgram(kFullscreenVertexShader,
                   absl::StrCat("#version 330 core\n", kToneGlsl, kDiffMain), "difference view"));
  SHRM_ASSIGN_OR_RETURN(r->gbuffer_program_,
                        BuildProgram(kMeshVertexShader, kGbufferFragment, "G-buffer"));
  SHRM_ASSIGN_OR_RETURN(r->overlay_, OverlayGl::Create());
  for (const ModeInfo& info : RegisteredModes()) {
    ModeSlot slot{&info, info.create(), absl::OkStatus(), absl::OkStatus()};
    const absl::Status s = slot.mode->Init();
    if (!s.ok()) slot.init_status = NameMode(info, s);
    r->modes_.push_back(std::move(slot));
  }
  SHRM_RETURN_IF_ERROR(r->Resize(width, height));
  return r;
}

absl::Status Renderer::Resize(int width, int height) {
  if (width == width_ && height == height_ && hdr_ != nullptr) return absl::OkStatus();
  width_ = width;
  height_ = height;
  SHRM_ASSIGN_OR_RETURN(hdr_, Framebuffer::Create(width, height, {GL_RGBA32F}));
  SHRM_ASSIGN_OR_RETURN(ldr_, Framebuffer::Create(width, height, {GL_RGBA8}));
  SHRM_ASSIGN_OR_RETURN(gbuffer_,
                        Framebuffer::Create(width, height, {GL_RGBA32F, GL_RGBA32F, GL_RGBA32F}));
  if (!reference_texture_) reference_texture_ = GlTexture::Generate();
  glBindTexture(GL_TEXTURE_2D, reference_texture_.get());
  reference_rgba_.assign(static_cast<size_t>(width) * height * 4, 0.0f);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, width, height, 0, GL_RGBA, GL_FLOAT,
               reference_rgba_.data());
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  reference_->Cancel();
  reference_key_valid_ = false;
  reference_key_.clear();
  diff_stats_ = {};
  return absl::OkStatus();
}

void Renderer::SetMesh(const Mesh& mesh) {
  mesh_ = std::make_unique<GpuMesh>(mesh);
  ++mesh_version_;
}

absl::Status Renderer::SetScene(const SceneData& scene, std::optional<int> only_mode) {
  const bool new_env = scene.env != scene_.env;
  scene_ = scene;
  ++scene_version_;
  if (new_env && scene.env != nullptr) {
    const Image& img = scene.env->latlong;
    if (!env_texture_) env_texture_ = GlTexture::Generate();
    glBindTexture(GL_TEXTURE_2D, env_texture_.get());
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB32F, img.width, img.height, 0, GL_RGB, GL_FLOAT,
                 img.pixels.data());
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  }
  // Every available mode gets the scene; a mode that cannot take it is not ready(), the others
  // go on. The errors of all of them, in one status.
  std::vector<absl::Status> errors;
  for (ModeSlot& slot : modes_) {
    if (!slot.init_status.ok() || (only_mode && slot.info->key != *only_mode)) continue;
    const absl::Status s = UploadTo(slot);
    if (!s.ok()) errors.push_back(s);
  }
  return JoinErrors(errors);
}

absl::Status Renderer::UploadTo(ModeSlot& slot) {
  const absl::Status s = slot.mode->Upload(scene_);
  slot.last_error = s.ok() ? s : NameMode(*slot.info, s);
  slot.scene_version = scene_version_;
  return slot.last_error;
}

absl::Status Renderer::SyncMode(int key) {
  ModeSlot* slot = Slot(key);
  if (slot == nullptr || !slot->init_status.ok() || slot->scene_version == scene_version_) {
    return absl::OkStatus();
  }
  return UploadTo(*slot);
}

Renderer::ModeSlot* Renderer::Slot(int key) {
  for (ModeSlot& slot : modes_)
    if (slot.info->key == key) return &slot;
  return nullptr;
}

const Renderer::ModeSlot* Renderer::Slot(int key) const {
  for (const ModeSlot& slot : modes_)
    if (slot.info->key == key) return &slot;
  return nullptr;
}

RenderMode* Renderer::Mode(int key) const {
  const ModeSlot* slot = Slot(key);
  return slot != nullptr && slot->init_status.ok() ? slot->mode.get() : nullptr;
}

bool Renderer::ModeReady(int key) const {
  const RenderMode* m = Mode(key);
  return m != nullptr && m->ready();
}

absl::Status Renderer::ModeError(int key) const {
  const ModeSlot* slot = Slot(key);
  if (slot == nullptr) return absl::NotFoundError(absl::StrCat("mode ", key, " is not available"));
  return slot->init_status.ok() ? slot->last_error : slot->init_status;
}

absl::Status Renderer::InitErrors() const {
  std::vector<absl::Status> errors;
  for (const ModeSlot& slot : modes_)
    if (!slot.init_status.ok()) errors.push_back(slot.init_status);
  return JoinErrors(errors);
}

std::string Renderer::ModeStatus(int key) const {
  const RenderMode* m = Mode(key);
  return m == nullptr ? "" : m->Status();
}

bool Renderer::ModeKey(int mode, int key, std::string* message) {
  RenderMode* m = Mode(mode);
  return m != nullptr && m->OnKey(key, message);
}

void Renderer::DrawBackground(const OrbitCamera& camera, float aspect, const Mat3& rotation) {
  const double t = std::tan(camera.fov_y_deg() * kPi / 360);
  const Vec3 f = camera.Forward(), r = camera.Right() * (t * aspect), u = camera.Up() * t;
  const GLuint program = background_program_.get();
  glUseProgram(program);
  SetUniform(program, "u_forward", static_cast<float>(f.x), static_cast<float>(f.y),
             static_cast<float>(f.z));
  SetUniform(program, "u_right", static_cast<float>(r.x), static_cast<float>(r.y),
             static_cast<float>(r.z));
  SetUniform(program, "u_up", static_cast<float>(u.x), static_cast<float>(u.y),
             static_cast<float>(u.z));
  // R^-1 = R^T; GL takes columns: column j of R^T is row j of R, so R's rows in order.
  float inverse[9];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) inverse[3 * i + j] = static_cast<float>(rotation.m[i][j]);
  glUniformMatrix3fv(glGetUniformLocation(program, "u_inverse_rotation"), 1, GL_FALSE, inverse);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, env_texture_.get());
  SetUniform(program, "u_env", 0);
  glBindVertexArray(empty_vao_.get());
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glBindVertexArray(0);
  glUseProgram(0);
}

void Renderer::UpdateReference(const OrbitCamera& camera, const RenderSettings& settings) {
  const RenderMode* mode = Mode(settings.mode);
  const bool needed = (settings.diff || (mode != nullptr && mode->needs_reference())) &&
                      scene_.env != nullptr && scene_.brdf != nullptr && mesh_ != nullptr;
  reference_current_ = false;
  if (!needed) {
    if (reference_key_valid_) {
      reference_->Cancel();
      reference_key_valid_ = false;
      reference_key_.clear();
    }
    return;
  }
  const OrbitView& v = camera.view();
  const std::string key =
      absl::StrCat(v.azimuth_deg, ",", v.elevation_deg, ",", v.distance, ",", camera.fov_y_deg(),
                   ",", width_, "x", height_, ",", scene_version_, ",", mesh_version_);
  if (key != reference_key_ && (settings.reference_may_restart || !reference_key_valid_)) {
    // G-buffer of this view.
    glBindFramebuffer(GL_FRAMEBUFFER, gbuffer_->id());
    glViewport(0, 0, width_, height_);
    glClearColor(0, 0, 0, 0);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glEnable(GL_DEPTH_TEST);
    glUseProgram(gbuffer_program_.get());
    const Mat4f vp = Multiply(camera.ProjectionMatrix(static_cast<double>(width_) / height_),
                              camera.ViewMatrix());
    SetUniformMat4(gbuffer_program_.get(), "u_view_projection", vp.data());
    mesh_->Draw();
    glUseProgram(0);
    glDisable(GL_DEPTH_TEST);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    const std::vector<float> pos = gbuffer_->ReadRgba(0), nrm = gbuffer_->ReadRgba(1),
                             tan = gbuffer_->ReadRgba(2);
    GeometryBuffer g;
    g.width = width_;
    g.height = height_;
    g.pixels.resize(static_cast<size_t>(width_) * height_);
    const Vec3 eye = camera.Eye();
    for (size_t i = 0; i < g.pixels.size(); ++i) {
      if (pos[4 * i + 3] == 0) continue;
      PixelGeometry& p = g.pixels[i];
      p.hit = true;
      p.position = At4(pos, i);
      p.normal = At4(nrm, i);
      p.tangent = At4(tan, i);
      p.view = (eye - p.position).Normalized();
    }
    reference_->Start(std::move(g), scene_.env->reference, scene_.brdf);
    reference_key_ = key;
    reference_key_valid_ = true;
    reference_uploaded_complete_ = false;
    diff_stats_ = {};
  }
  reference_current_ = key == reference_key_;
  if (!reference_uploaded_complete_) {
    // Read before polling: when the workers had finished, what Poll() hands over (or handed over
    // before) is the complete image.
    const bool finished = reference_->finished();
    std::vector<float> top_first;
    if (reference_->Poll(&top_first)) {
      reference_rgba_ = FlipRows(top_first, width_, height_);
      glBindTexture(GL_TEXTURE_2D, reference_texture_.get());
      glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, width_, height_, GL_RGBA, GL_FLOAT,
                      reference_rgba_.data());
    }
    reference_uploaded_complete_ = finished;
  }
}

void Renderer::ComputeDiffStats() {
  const std::vector<float> a = FlipRows(hdr_->ReadRgba(0), width_, height_);  // GL order
  std::vector<double> rel;
  double num = 0, den = 0;
  for (size_t i = 0; i < a.size() / 4; ++i) {
    if (a[4 * i + 3] == 0 || reference_rgba_[4 * i + 3] != 1.0f) continue;
    double d2 = 0, r2 = 0;
    for (int c = 0; c < 3; ++c) {
      const double d = a[4 * i + c] - reference_rgba_[4 * i + c];
      d2 += d * d;
      r2 += static_cast<double>(reference_rgba_[4 * i + c]) * reference_rgba_[4 * i + c];
    }
    num += d2;
    den += r2;
    rel.push_back(std::sqrt(d2 / std::max(r2, 1e-300)));
  }
  diff_stats_ = {};
  if (rel.empty()) return;
  std::sort(rel.begin(), rel.end());
  diff_stats_.valid = true;
  diff_stats_.pixels = static_cast<int64_t>(rel.size());
  diff_stats_.rel_rms = std::sqrt(num / std::max(den, 1e-300));
  diff_stats_.rel_median = rel[rel.size() / 2];
  diff_stats_.rel_p99 = rel[std::min(rel.size() - 1, rel.size() * 99 / 100)];
}

absl::Status Renderer::Render(const OrbitCamera& camera, const RenderSettings& settings) {
  RenderMode* mode = Mode(settings.mode);
  if (mode == nullptr) {
    return absl::InvalidArgumentError(absl::StrCat("mode ", settings.mode, " is not available"));
  }
  if (mesh_ == nullptr) return absl::FailedPreconditionError("no mesh");
  UpdateReference(camera, settings);
  const double aspect = static_cast<double>(width_) / height_;
  FrameInputs frame;
  frame.mesh = mesh_.get();
  frame.camera = &camera;
  frame.view = camera.ViewMatrix();
  frame.projection = camera.ProjectionMatrix(aspect);
  frame.view_projection = Multiply(frame.projection, frame.view);
  frame.eye = camera.Eye();
  frame.central_view = camera.CentralView();
  frame.width = width_;
  frame.height = height_;
  frame.exposure = settings.exposure;
  frame.env_texture = env_texture_.get();
  // A truth of an older view (the camera is moving) is not shown.
  frame.reference_texture =
      reference_key_valid_ && reference_current_ ? reference_texture_.get() : 0;
  frame.reference_progress = reference_key_valid_ ? reference_->progress() : 0;

  glBindFramebuffer(GL_FRAMEBUFFER, hdr_->id());
  glViewport(0, 0, width_, height_);
  glClearColor(0, 0, 0, 0);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glDisable(GL_DEPTH_TEST);
  if (settings.background && env_texture_) {
    DrawBackground(camera, static_cast<float>(aspect), settings.background_rotation);
  }
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  if (mode->ready()) {
    ModeSlot& slot = *Slot(settings.mode);
    const absl::Status drawn = mode->Draw(frame);
    slot.last_error = drawn.ok() ? drawn : NameMode(*slot.info, drawn);
    if (!drawn.ok()) {
      glDisable(GL_DEPTH_TEST);
      glBindFramebuffer(GL_FRAMEBUFFER, 0);
      return slot.last_error;
    }
  }
  glDisable(GL_DEPTH_TEST);

  glBindFramebuffer(GL_FRAMEBUFFER, ldr_->id());
  glViewport(0, 0, width_, height_);
  const bool diff = settings.diff;
  const GLuint program = diff ? diff_program_.get() : tonemap_program_.get();
  glUseProgram(program);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, hdr_->color(0));
  SetUniform(program, "u_hdr", 0);
  SetUniform(program, "u_exposure", settings.exposure);
  if (diff) {
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_2D, reference_texture_.get());
    SetUniform(program, "u_reference", 1);
    SetUniform(program, "u_reference_valid", frame.reference_texture != 0 ? 1 : 0);
    glActiveTexture(GL_TEXTURE0);
  }
  glBindVertexArray(empty_vao_.get());
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glBindVertexArray(0);
  glUseProgram(0);
  // Progress bars along the top: SHRM computation (orange), ground truth (blue).
  glEnable(GL_SCISSOR_TEST);
  auto bar = [&](int row, double fraction, float r, float g, float b) {
    const int h = 5, y = height_ - (row + 1) * h;
    glScissor(0, y, width_, h);
    glClearColor(0.1f, 0.1f, 0.1f, 1);
    glClear(GL_COLOR_BUFFER_BIT);
    glScissor(0, y, static_cast<int>(width_ * std::clamp(fraction, 0.0, 1.0)), h);
    glClearColor(r, g, b, 1);
    glClear(GL_COLOR_BUFFER_BIT);
  };
  int row = 0;
  if (settings.compute_progress >= 0 && settings.compute_progress < 1)
    bar(row++, settings.compute_progress, 1.0f, 0.55f, 0.1f);
  if (reference_key_valid_ && !reference_->finished())
    bar(row++, reference_->progress(), 0.2f, 0.5f, 1.0f);
  glDisable(GL_SCISSOR_TEST);
  // Text overlay below the progress bars (2x font pixels).
  overlay_->Draw(settings.overlay, 2, 8 + 5 * row, width_, height_);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);

  if (diff && reference_current_ && reference_uploaded_complete_ &&
      (!diff_stats_.valid || diff_stats_mode_ != settings.mode)) {
    ComputeDiffStats();
    diff_stats_mode_ = settings.mode;
  }
  return absl::OkStatus();
}

void Renderer::BlitToWindow(int window_width, int window_height) const {
  glBindFramebuffer(GL_READ_FRAMEBUFFER, ldr_->id());
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, 0);
  glBlitFramebuffer(0, 0, width_, height_, 0, 0, window_width, window_height, GL_COLOR_BUFFER_BIT,
                    GL_NEAREST);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

std::vector<float> Renderer::ReadHdr() const { return hdr_->ReadRgba(0); }

Image Renderer::ReadLdr() const {
  const std::vector<float> rgba = ldr_->ReadRgba(0);
  Image img;
  img.width = width_;
  img.height = height_;
  img.channels = 3;
  img.pixels.resize(static_cast<size_t>(width_) * height_ * 3);
  for (size_t i = 0; i < rgba.size() / 4; ++i)
    for (int c = 0; c < 3; ++c) img.pixels[3 * i + c] = rgba[4 * i + c];
  return img;
}

}  // namespace shrm::viewer
