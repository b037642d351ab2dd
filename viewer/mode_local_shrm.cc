#include "viewer/mode_local_shrm.h"

#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/status_macros.h"
#include "core/sh/sh.h"
#include "viewer/gl_util.h"
#include "viewer/glsl_snippets.h"

namespace shrm::viewer {
namespace {

constexpr char kFragmentMain[] = R"(
in vec3 v_position;
in vec3 v_normal;
in vec4 v_tangent;
uniform sampler2DArray u_coeffs;  // layer k * 6 + face: coefficient k
uniform int u_size;
uniform vec3 u_eye;
uniform int u_tangent_index;
out vec4 o_color;

// The texel of `face` at integer coordinates that may lie one step outside the face: the texel
// of the adjacent face containing the extrapolated centre direction (core's ResolveTexel).
void ResolveTexel(int face, ivec2 xy, out int of, out ivec2 oxy) {
  if (all(greaterThanEqual(xy, ivec2(0))) && all(lessThan(xy, ivec2(u_size)))) {
    of = face;
    oxy = xy;
    return;
  }
  vec2 st;
  CubeFaceCoordinates(CubeFaceDirection(face, (vec2(xy) + 0.5) / float(u_size)), of, st);
  oxy = clamp(ivec2(floor(st * float(u_size))), ivec2(0), ivec2(u_size - 1));
}

// B of texel (face, xy) for the view v_sh (SH frame), in the texel centre's local frame.
vec3 TexelValue(int face, ivec2 xy, vec3 v_sh) {
  vec3 r = ShFrame(normalize(CubeFaceDirection(face, (vec2(xy) + 0.5) / float(u_size))));
  float sa = length(r.xy), ca = r.z;
  float cb = 1.0, sb = 0.0;
  if (sa > 0.0) { cb = r.x / sa; sb = r.y / sa; }
  // w = Rot^T v = Ry(-alpha) Rz(-beta) v.
  vec3 u = vec3(cb * v_sh.x + sb * v_sh.y, -sb * v_sh.x + cb * v_sh.y, v_sh.z);
  vec3 w = vec3(ca * u.x - sa * u.z, u.y, sa * u.x + ca * u.z);
  float y[SH_COUNT];
  EvalSh(w, y);
  vec3 sum = vec3(0.0);
  for (int k = 0; k < SH_COUNT; ++k)
    sum += y[k] * texelFetch(u_coeffs, ivec3(xy, k * 6 + face), 0).rgb;
  return sum;
}

#if FAST_PATH
uniform samplerCubeArray u_filtered;  // layer k = coefficient k, seamless bilinear
uniform float u_pole_sin;             // the four-tap pass within this sin(alpha) of the poles
#endif

void main() {
  vec3 n = normalize(v_normal);
  vec3 v = normalize(u_eye - v_position);
  vec3 index = u_tangent_index != 0 ? normalize(v_tangent.xyz) : 2.0 * dot(n, v) * n - v;
  vec3 v_sh = ShFrame(v);
#if FAST_PATH
  // Pass 1, away from the poles the local coefficient field is smooth: filter it in hardware and
  // evaluate once in the frame of the pixel's own index direction.
  vec3 r = ShFrame(normalize(index));
  float sa = length(r.xy);
  if (sa <= u_pole_sin) discard;  // left to the four-tap pass
  {
    float ca = r.z, cb = r.x / sa, sb = r.y / sa;
    vec3 u = vec3(cb * v_sh.x + sb * v_sh.y, -sb * v_sh.x + cb * v_sh.y, v_sh.z);
    vec3 w = vec3(ca * u.x - sa * u.z, u.y, sa * u.x + ca * u.z);
    float y[SH_COUNT];
    EvalSh(w, y);
    vec3 sum = vec3(0.0);
    for (int k = 0; k < SH_COUNT; ++k) sum += y[k] * texture(u_filtered, vec4(index, float(k))).rgb;
    o_color = vec4(sum, 1.0);
  }
#else
  // The four nearest texels, each in its own frame (everywhere, or in pass 2 only the pixels
  // that pass 1 left: the others fail the depth test before shading).
  int face;
  vec2 st;
  CubeFaceCoordinates(index, face, st);
  vec2 p = st * float(u_size) - 0.5;
  ivec2 p0 = ivec2(floor(p));
  vec2 f = p - vec2(p0);
  // The four taps written out (llvmpipe compiles a loop around TexelValue much slower).
  int f00, f10, f01, f11;
  ivec2 t00, t10, t01, t11;
  ResolveTexel(face, p0, f00, t00);
  ResolveTexel(face, p0 + ivec2(1, 0), f10, t10);
  ResolveTexel(face, p0 + ivec2(0, 1), f01, t01);
  ResolveTexel(face, p0 + ivec2(1, 1), f11, t11);
  vec3 sum = (1.0 - f.x) * (1.0 - f.y) * TexelValue(f00, t00, v_sh) +
             f.x * (1.0 - f.y) * TexelValue(f10, t10, v_sh) +
             (1.0 - f.x) * f.y * TexelValue(f01, t01, v_sh) + f.x * f.y * TexelValue(f11, t11, v_sh);
  o_color = vec4(sum, 1.0);
#endif
}
)";

// Pixels whose index direction lies within this many texel pitches (2 / S_B at the face centre)
// of the +-Y poles take the exact four-tap path.
constexpr double kPoleTexels = 4;

class LocalShrmMode final : public RenderMode {
 public:
  [[nodiscard]] absl::Status Init() override { return absl::OkStatus(); }

  [[nodiscard]] absl::Status Upload(const SceneData& scene) override {
    ready_ = false;
    if (scene.shrm == nullptr) return absl::OkStatus();
    const ShrmCube& cube = scene.shrm->local;
    const int s = cube.face_size, n = cube.coeff_count(), ch = cube.channels;
    GLint max_layers = 0;
    glGetIntegerv(GL_MAX_ARRAY_TEXTURE_LAYERS, &max_layers);
    if (6 * n > max_layers) {
      return absl::ResourceExhaustedError(
          absl::StrCat("6 (P + 1)^2 = ", 6 * n,
                       " coefficient layers exceed GL_MAX_ARRAY_TEXTURE_LAYERS ", max_layers));
    }
    GLint major = 0;
    glGetIntegerv(GL_MAJOR_VERSION, &major);
    fast_path_ = major >= 4;  // cube map arrays (GL 4.0)
    if (!taps_program_ || pmax_ != cube.pmax) {
      taps_program_.reset();
      filtered_program_.reset();
      pmax_ = -1;
      for (int fast = 0; fast <= (fast_path_ ? 1 : 0); ++fast) {
        const std::string fragment = absl::StrCat(
            fast ? "#version 400 core\n" : "#version 330 core\n", "#define FAST_PATH ", fast,
            "\n#define PMAX ", cube.pmax, "\n", kShEvalGlsl, kCubeGlsl, kFragmentMain);
        SHRM_ASSIGN_OR_RETURN((fast ? filtered_program_ : taps_program_),
                              BuildProgram(kMeshVertexShader, fragment,
                                           fast ? "mode 2 (local SHRM, filtered pass)"
                                                : "mode 2 (local SHRM, four-tap pass)"));
      }
      pmax_ = cube.pmax;
    }
    // Layer k * 6 + face holds coefficient k of that face, texels in GL order: the layout of a
    // 2D array texture (exact texel fetches) and of a cube-map array (filtered pass) alike.
    std::vector<float> layered(static_cast<size_t>(6) * s * s * n * 3, 0.0f);
    for (int k = 0; k < n; ++k)
      for (int f = 0; f < 6; ++f)
        for (int y = 0; y < s; ++y)
          for (int x = 0; x < s; ++x)
            for (int c = 0; c < std::min(ch, 3); ++c)
              layered[(((static_cast<size_t>(k) * 6 + f) * s + y) * s + x) * 3 + c] =
                  cube.data[cube.Index(f, x, y, k, c)];
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    if (!texture_) texture_ = GlTexture::Generate();
    glBindTexture(GL_TEXTURE_2D_ARRAY, texture_.get());
    glTexImage3D(GL_TEXTURE_2D_ARRAY, 0, GL_RGB32F, s, s, 6 * n, 0, GL_RGB, GL_FLOAT,
                 layered.data());
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    if (fast_path_) {
      if (!filtered_) filtered_ = GlTexture::Generate();
      glBindTexture(GL_TEXTURE_CUBE_MAP_ARRAY, filtered_.get());
      glTexImage3D(GL_TEXTURE_CUBE_MAP_ARRAY, 0, GL_RGB32F, s, s, 6 * n, 0, GL_RGB, GL_FLOAT,
                   layered.data());
      glTexParameteri(GL_TEXTURE_CUBE_MAP_ARRAY, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
      glTexParameteri(GL_TEXTURE_CUBE_MAP_ARRAY, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
      glTexParameteri(GL_TEXTURE_CUBE_MAP_ARRAY, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
      glTexParameteri(GL_TEXTURE_CUBE_MAP_ARRAY, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    }
    size_ = s;
    tangent_index_ = cube.index == ReparamKind::kTangent;
    ready_ = true;
    return absl::OkStatus();
  }

  bool ready() const override { return ready_; }

  [[nodiscard]] absl::Status Draw(const FrameInputs& frame) override {
    if (!ready_) return absl::FailedPreconditionError("mode 2 has no SHRM to draw");
    // Pass 1 (GL >= 4): filtered coefficients, one frame per pixel, discarding the pixels near
    // the poles; pass 2: four taps in their own frames, shaded only where pass 1 left no depth
    // (the same vertex shader gives the same depths, so GL_LESS rejects the others early).
    if (fast_path_) Pass(filtered_program_.get(), frame);
    Pass(taps_program_.get(), frame);
    return absl::OkStatus();
  }

  std::string Status() const override {
    if (!ready_) return "";
    return absl::StrFormat("local coefficients %dx%dx6 x %d, per-pixel Y_pq(Rot^T V), %s", size_,
                           size_, ShCount(pmax_),
                           fast_path_ ? "filtered (4 taps near the poles)" : "4 taps");
  }

 private:
  void Pass(GLuint program, const FrameInputs& frame) {
    glUseProgram(program);
    SetUniformMat4(program, "u_view_projection", frame.view_projection.data());
    SetUniform(program, "u_eye", static_cast<float>(frame.eye.x), static_cast<float>(frame.eye.y),
               static_cast<float>(frame.eye.z));
    SetUniform(program, "u_size", size_);
    SetUniform(program, "u_tangent_index", tangent_index_ ? 1 : 0);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D_ARRAY, texture_.get());
    SetUniform(program, "u_coeffs", 0);
    if (program == filtered_program_.get()) {
      glActiveTexture(GL_TEXTURE1);
      glBindTexture(GL_TEXTURE_CUBE_MAP_ARRAY, filtered_.get());
      SetUniform(program, "u_filtered", 1);
      SetUniform(program, "u_pole_sin", static_cast<float>(kPoleTexels * 2.0 / size_));
      glActiveTexture(GL_TEXTURE0);
    }
    frame.mesh->Draw();
    glUseProgram(0);
  }

  // Destroyed in reverse order: the textures, then the programs.
  GlProgram filtered_program_, taps_program_;
  GlTexture filtered_, texture_;
  int pmax_ = -1, size_ = 0;
  bool tangent_index_ = false, ready_ = false, fast_path_ = false;
};

}  // namespace

std::unique_ptr<RenderMode> MakeLocalShrmMode() { return std::make_unique<LocalShrmMode>(); }

}  // namespace shrm::viewer
