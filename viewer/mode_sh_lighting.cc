#include "viewer/mode_sh_lighting.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/base/status_macros.h"
#include "core/sh/rotation.h"
#include "core/sh/sh.h"
#include "core/sh/wigner.h"
#include "viewer/gl_util.h"

namespace shrm::viewer {

std::string ShRotateZGlsl(int lmax) {
  // c'_m = cos(m a) c_m - sin(m a) c_-m, c'_-m = sin(m a) c_m + cos(m a) c_-m (m > 0), written
  // out (constant indices keep the coefficients in registers; llvmpipe spills indexed arrays).
  std::string s = absl::StrCat("const int SH_N = ", ShCount(lmax),
                               ";\nvoid ShRotateZ(float ca, float sa, inout vec3 c[SH_N]) {\n");
  if (lmax >= 1) s += "  float c1 = ca, s1 = sa;\n";
  for (int m = 2; m <= lmax; ++m)
    absl::StrAppendFormat(&s, "  float c%d = c%d * ca - s%d * sa, s%d = s%d * ca + c%d * sa;\n", m,
                          m - 1, m - 1, m, m - 1, m - 1);
  s += "  vec3 p, q;\n";
  for (int m = 1; m <= lmax; ++m)
    for (int l = m; l <= lmax; ++l)
      absl::StrAppendFormat(&s,
                            "  p = c[%d]; q = c[%d]; c[%d] = c%d * p - s%d * q; c[%d] = s%d * p + "
                            "c%d * q;\n",
                            ShIndex(l, m), ShIndex(l, -m), ShIndex(l, m), m, m, ShIndex(l, -m), m,
                            m);
  return s + "}\n";
}

std::string LocalLightingGlsl(int lmax) {
  // X = D(RotationX(pi/2)) and X^T, band by band, their nonzero entries (about a quarter) as
  // literals.
  std::vector<double> x(WignerTableSize(lmax));
  RealRotationBlocks(lmax, RotationX(kPi / 2), x);
  constexpr double kZero = 1e-12;  // X's entries are 0 or O(0.1): drop the rounding residue
  std::string s = "uniform vec3 u_light[SH_N];  // world lighting L_lm (SH frame), RGB\n";
  for (bool transposed : {false, true}) {
    absl::StrAppend(&s, "void ShApplyX", transposed ? "T" : "",
                    "(in vec3 c[SH_N], out vec3 o[SH_N]) {\n");
    for (int l = 0; l <= lmax; ++l) {
      const int n = 2 * l + 1, base = l * l;
      const double* block = x.data() + WignerBandOffset(l);
      for (int r = 0; r < n; ++r) {
        std::string terms;
        for (int k = 0; k < n; ++k) {
          const double v = transposed ? block[k * n + r] : block[r * n + k];
          if (std::abs(v) > kZero)
            absl::StrAppendFormat(&terms, "%s%.9e * c[%d]", terms.empty() ? "" : " + ", v,
                                  base + k);
        }
        absl::StrAppendFormat(&s, "  o[%d] = %s;\n", base + r, terms.empty() ? "vec3(0.0)" : terms);
      }
    }
    s += "}\n";
  }
  return s + R"(
// The lighting in the tangent frame (t, n x t, n): coefficients D(Rot) L, Rot = Q^T, Q = S (t b n)
// (docs/conventions.md); D(Rz(a) Ry(b) Rz(g)) = Zr(a) X^T Zr(b) X Zr(g); the zyz angles from the
// quaternion of Rot (Shepperd), as core's EulerFromQuaternion: robust at the gimbal points.
void LocalLighting(vec3 normal, vec4 tangent, out vec3 c[SH_N]) {
  vec3 n = normalize(normal);
  vec3 t = normalize(tangent.xyz - dot(tangent.xyz, n) * n);
  vec3 b = cross(n, t);
  vec3 r0 = vec3(t.x, -t.z, t.y), r1 = vec3(b.x, -b.z, b.y), r2 = vec3(n.x, -n.z, n.y);
  float tr = r0.x + r1.y + r2.z;
  float qw, qx, qy, qz;
  if (tr >= r0.x && tr >= r1.y && tr >= r2.z) {
    qw = 0.5 * sqrt(max(1.0 + tr, 0.0));
    float f = 0.25 / qw;
    qx = (r2.y - r1.z) * f; qy = (r0.z - r2.x) * f; qz = (r1.x - r0.y) * f;
  } else if (r0.x >= r1.y && r0.x >= r2.z) {
    qx = 0.5 * sqrt(max(1.0 + r0.x - r1.y - r2.z, 0.0));
    float f = 0.25 / qx;
    qw = (r2.y - r1.z) * f; qy = (r0.y + r1.x) * f; qz = (r0.z + r2.x) * f;
  } else if (r1.y >= r2.z) {
    qy = 0.5 * sqrt(max(1.0 - r0.x + r1.y - r2.z, 0.0));
    float f = 0.25 / qy;
    qw = (r0.z - r2.x) * f; qx = (r0.y + r1.x) * f; qz = (r1.z + r2.y) * f;
  } else {
    qz = 0.5 * sqrt(max(1.0 - r0.x - r1.y + r2.z, 0.0));
    float f = 0.25 / qz;
    qw = (r1.x - r0.y) * f; qx = (r0.z + r2.x) * f; qy = (r1.z + r2.y) * f;
  }
  // w = cos(b/2) cos((a+g)/2), z = cos(b/2) sin((a+g)/2), y = sin(b/2) cos((a-g)/2),
  // x = -sin(b/2) sin((a-g)/2).
  float hp = (qz == 0.0 && qw == 0.0) ? 0.0 : atan(qz, qw);
  float hm = (qx == 0.0 && qy == 0.0) ? 0.0 : atan(-qx, qy);
  float beta = 2.0 * atan(sqrt(qx * qx + qy * qy), sqrt(qw * qw + qz * qz));
  float alpha = hp + hm, gamma = hp - hm;
  for (int k = 0; k < SH_N; ++k) c[k] = u_light[k];
  vec3 tmp[SH_N];
  ShRotateZ(cos(gamma), sin(gamma), c);
  ShApplyX(c, tmp);
  ShRotateZ(cos(beta), sin(beta), tmp);
  ShApplyXT(tmp, c);
  ShRotateZ(cos(alpha), sin(alpha), c);
}
)";
}

void SetLocalLightingUniforms(GLuint program, int lmax, const double* world_rgb) {
  const std::vector<float> lf(world_rgb, world_rgb + ShCount(lmax) * 3);
  glUniform3fv(glGetUniformLocation(program, "u_light"), ShCount(lmax), lf.data());
}

namespace {

constexpr char kVertexMain[] = R"(
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec4 a_tangent;
layout(location = 3) in vec2 a_uv;
uniform mat4 u_view_projection;
out vec3 v_position;
out vec3 v_normal;
out vec4 v_tangent;
out vec2 v_uv;
const int PACKED = (3 * SH_N + 3) / 4;
out vec4 v_light[PACKED];  // local lighting, float 3 k + c = coefficient k, channel c
invariant gl_Position;
void main() {
  v_position = a_position;
  v_normal = a_normal;
  v_tangent = a_tangent;
  v_uv = a_uv;
  vec3 c[SH_N];
  LocalLighting(a_normal, a_tangent, c);
  float f[4 * PACKED];
  for (int k = 0; k < SH_N; ++k) {
    f[3 * k] = c[k].r;
    f[3 * k + 1] = c[k].g;
    f[3 * k + 2] = c[k].b;
  }
  for (int i = 3 * SH_N; i < 4 * PACKED; ++i) f[i] = 0.0;
  for (int j = 0; j < PACKED; ++j) v_light[j] = vec4(f[4 * j], f[4 * j + 1], f[4 * j + 2], f[4 * j + 3]);
  gl_Position = u_view_projection * vec4(a_position, 1.0);
}
)";

constexpr char kFragmentHead[] = R"(
// Variants (#define 0/1): NORMAL_MAP, ROTATE (per-pixel Taylor; 0: simplified), HSH (h = C L,
// the function HshFromSh is generated from C's nonzero entries), GREY (one BRDF channel: four
// coefficients per RGBA texel).
const int NB = (BMAX + 1) * (BMAX + 1);
const int NBP = 4 * ((NB + 3) / 4);  // padded to whole RGBA texels (GREY)
const int PACKED = (3 * SH_N + 3) / 4;
in vec3 v_position;
in vec3 v_normal;
in vec4 v_tangent;
in vec2 v_uv;
in vec4 v_light[PACKED];
uniform vec3 u_eye;
uniform sampler2DArray u_brdf;      // coefficients at the parabolic map of v_p
uniform sampler2D u_normal_map;     // tangent-space normals (viewer/normal_map.h)
out vec4 o_color;

)";

constexpr char kFragmentMain[] = R"(
void main() {
  float f[4 * PACKED];
  for (int j = 0; j < PACKED; ++j) {
    f[4 * j] = v_light[j].x;
    f[4 * j + 1] = v_light[j].y;
    f[4 * j + 2] = v_light[j].z;
    f[4 * j + 3] = v_light[j].w;
  }
  vec3 L[SH_N];
  for (int k = 0; k < SH_N; ++k) L[k] = vec3(f[3 * k], f[3 * k + 1], f[3 * k + 2]);
  vec3 n = normalize(v_normal);
  vec3 t = normalize(v_tangent.xyz - dot(v_tangent.xyz, n) * n);
  vec3 b = cross(n, t);
  vec3 v = normalize(u_eye - v_position);
  vec3 vl = vec3(dot(t, v), dot(b, v), dot(n, v));
  // The normal-map normal m = (sin th cos ph, sin th sin ph, cos th) in the frame (t, n x t, n).
  float cp = 1.0, sp = 0.0, ct = 1.0, st = 0.0, theta = 0.0;
#if NORMAL_MAP
  vec3 m = texture(u_normal_map, v_uv).xyz;
  if (v_tangent.w < 0.0) m.y = -m.y;
  float r = length(m.xy);
  if (r > 0.0) {
    cp = m.x / r;
    sp = m.y / r;
    float len = length(m);
    st = r / len;
    ct = m.z / len;
    theta = atan(st, ct);
  }
#endif
  // The view in the perturbed frame: v_p = R_p^T v = Rz(ph) Ry(-th) Rz(-ph) v.
  vec3 u = vec3(cp * vl.x + sp * vl.y, -sp * vl.x + cp * vl.y, vl.z);
  u = vec3(ct * u.x - st * u.z, u.y, st * u.x + ct * u.z);
  vec3 vp = vec3(cp * u.x - sp * u.y, sp * u.x + cp * u.y, u.z);
#if NORMAL_MAP && ROTATE
  // The lighting in the perturbed frame: D(R_p^T) = Zr(ph) Yr(-th) Zr(-ph), Yr by Taylor.
  ShRotateZ(cp, -sp, L);
  TaylorY15(-theta, L);
  ShRotateZ(cp, sp, L);
#endif
  vec3 h[NBP];
  for (int i = NB; i < NBP; ++i) h[i] = vec3(0.0);
#if HSH
  HshFromSh(L, h);
#else
  for (int i = 0; i < NB; ++i) h[i] = L[i];
#endif
  // Parabolic map of v_p (core's OutgoingBrdfTable::Lookup: below the horizon at its azimuth).
  vec2 p;
  float rho = length(vp.xy);
  if (vp.z <= 0.0) {
    p = rho > 0.0 ? vp.xy / rho : vec2(1.0, 0.0);
  } else {
    vec3 d = normalize(vp);
    p = d.xy / (1.0 + d.z);
    float pr = length(p);
    if (pr > 1.0) p /= pr;
  }
  vec2 tc = 0.5 * (p + 1.0);
  vec3 sum = vec3(0.0);
#if GREY
  for (int j = 0; j < NBP / 4; ++j) {
    vec4 g = texture(u_brdf, vec3(tc, float(j)));
    sum += h[4 * j] * g.x + h[4 * j + 1] * g.y + h[4 * j + 2] * g.z + h[4 * j + 3] * g.w;
  }
#else
  for (int k = 0; k < NB; ++k) sum += h[k] * texture(u_brdf, vec3(tc, float(k))).rgb;
#endif
  o_color = vec4(sum, 1.0);
}
)";

using Clock = std::chrono::steady_clock;

int Threads() { return static_cast<int>(std::max(1u, std::thread::hardware_concurrency())); }

// void HshFromSh(in vec3 L[SH_N], inout vec3 h[NBP]): h = C L (HSH paper eq. 18), C's nonzero
// entries (m = m') written out as literals.
std::string HshFromShGlsl(const ShHshConversion& c) {
  std::string s = "void HshFromSh(in vec3 L[SH_N], inout vec3 h[NBP]) {\n";
  for (int i = 0; i < c.rows(); ++i) {
    std::string terms;
    for (int j = 0; j < c.cols(); ++j) {
      const double v = c(i, j);
      if (v != 0) absl::StrAppendFormat(&terms, "%s%.9e * L[%d]", terms.empty() ? "" : " + ", v, j);
    }
    absl::StrAppendFormat(&s, "  h[%d] = %s;\n", i, terms.empty() ? "vec3(0.0)" : terms);
  }
  return s + "}\n";
}

// void TaylorY15(float beta, inout vec3 c[SH_N]): c = (I + b A + b^2/2 diag(A^2)) c, the
// 1.5th-order Taylor y-rotation (core's TaylorYRotation::Apply15), with the derivative
// diagonals of A as literals.
std::string TaylorY15Glsl(const TaylorYRotation& taylor) {
  const int n = ShCount(taylor.lmax());
  const std::span<const double> sub = taylor.sub_diagonal(), d2 = taylor.second_diagonal();
  std::string s =
      "void TaylorY15(float beta, inout vec3 c[SH_N]) {\n  float bb = 0.5 * beta * beta;\n";
  for (int i = 1; i < n; ++i) {
    std::string first;
    if (sub[i] != 0) absl::StrAppendFormat(&first, "%.9e * c[%d]", sub[i], i - 1);
    if (i + 1 < n && sub[i + 1] != 0)
      absl::StrAppendFormat(&first, "%s%.9e * c[%d]", first.empty() ? "" : " + ", -sub[i + 1],
                            i + 1);
    absl::StrAppendFormat(&s, "  vec3 o%d = c[%d] * (1.0 + bb * %.9e)%s;\n", i, i, d2[i],
                          first.empty() ? "" : absl::StrCat(" + beta * (", first, ")"));
  }
  for (int i = 1; i < n; ++i) absl::StrAppendFormat(&s, "  c[%d] = o%d;\n", i, i);
  return s + "}\n";
}

// Program variant key.
int VariantKey(bool normal_map, bool rotate, bool hsh, bool grey) {
  return (normal_map ? 1 : 0) | (rotate ? 2 : 0) | (hsh ? 4 : 0) | (grey ? 8 : 0);
}

absl::StatusOr<GlProgram> BuildVariant(bool normal_map, bool rotate, bool hsh, bool grey) {
  const std::string defines = absl::StrCat("#version 330 core\n#define LMAX ", kShLightingLmax,
                                           "\n#define BMAX ", kShLightingLmax, "\n");
  std::string hsh_glsl, taylor_glsl;
  if (hsh) {
    SHRM_ASSIGN_OR_RETURN(const ShHshConversion c,
                          ShHshConversion::Create(kShLightingLmax, kShLightingLmax));
    hsh_glsl = HshFromShGlsl(c);
  }
  if (rotate) {
    SHRM_ASSIGN_OR_RETURN(const TaylorYRotation taylor, TaylorYRotation::Create(kShLightingLmax));
    taylor_glsl = TaylorY15Glsl(taylor);
  }
  return BuildProgram(
      absl::StrCat(defines, ShRotateZGlsl(kShLightingLmax), LocalLightingGlsl(kShLightingLmax),
                   kVertexMain),
      absl::StrCat(defines, "#define NORMAL_MAP ", normal_map ? 1 : 0, "\n#define ROTATE ",
                   rotate ? 1 : 0, "\n#define HSH ", hsh ? 1 : 0, "\n#define GREY ", grey ? 1 : 0,
                   "\n", ShRotateZGlsl(kShLightingLmax), kFragmentHead, hsh_glsl, taylor_glsl,
                   kFragmentMain),
      "mode 3 (SH lighting)");
}

}  // namespace

absl::Status ShLightingMode::Init() {
  // Programs are built per variant on first use (Program()); a GL without enough vertex outputs
  // (GL 3.3 guarantees 64 components) fails to link: the mode is then unavailable (the error says
  // why) and the viewer goes on without it. Build the default variant now to find out early.
  init_status_ = Program(false, false, false, true).status();
  return init_status_;
}

absl::StatusOr<GLuint> ShLightingMode::Program(bool normal_map, bool rotate, bool hsh, bool grey) {
  rotate = rotate && normal_map;
  const int key = VariantKey(normal_map, rotate, hsh, grey);
  auto it = programs_.find(key);
  if (it == programs_.end())
    it = programs_.emplace(key, BuildVariant(normal_map, rotate, hsh, grey)).first;
  if (!it->second.ok()) return it->second.status();
  return it->second->get();
}

absl::Status ShLightingMode::Upload(const SceneData& scene) {
  const bool same = scene.env == env_ && scene.brdf != nullptr && brdf_ != nullptr &&
                    scene.brdf->spec() == brdf_spec_;
  env_ = scene.env;
  brdf_ = scene.brdf;
  brdf_spec_ = brdf_ != nullptr ? brdf_->spec() : "";
  draw_error_ = absl::OkStatus();
  if (!same) {
    for (Basis& b : bases_) {
      b.cpu.reset();
      b.status = absl::OkStatus();
    }
  }
  // The current basis's table now, so that ready() knows about BRDFs the tables refuse
  // (Kajiya-Kay); the other basis when it is first drawn.
  if (env_ != nullptr && brdf_ != nullptr && !env_->sh.empty())
    return PrepareBasis(settings_.basis);
  return absl::OkStatus();
}

absl::Status ShLightingMode::PrepareBasis(HemisphereBasis basis) {
  Basis& b = bases_[static_cast<int>(basis)];
  if (b.cpu.has_value()) return absl::OkStatus();
  if (!b.status.ok()) return b.status;
  const auto t0 = Clock::now();
  ShLightingOptions o;
  o.basis = basis;
  o.threads = Threads();
  absl::StatusOr<ShLightingCpu> cpu = ShLightingCpu::Create(env_->sh, *brdf_, o);
  if (!cpu.ok()) {
    b.status = absl::Status(cpu.status().code(),
                            absl::StrCat(basis == HemisphereBasis::kSh ? "SH" : "HSH",
                                         " BRDF coefficients: ", cpu.status().message()));
    return b.status;
  }
  table_ms_ = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  b.cpu = *std::move(cpu);
  // Texel (x, y) at (s, t) = ((x + 0.5) / R, (y + 0.5) / R): the parabolic (u, v) = 2 (s, t) - 1
  // of the table's texel centres. Grey tables: layer j holds coefficients 4j..4j+3 (RGBA);
  // RGB tables: layer k holds coefficient k (RGB).
  const OutgoingBrdfTable& table = b.cpu->table();
  const int r = table.options.resolution, nb = table.count, ch = table.channels;
  b.grey = ch == 1;
  const int layers = b.grey ? (nb + 3) / 4 : nb, comps = b.grey ? 4 : 3;
  std::vector<float> texels(static_cast<size_t>(layers) * r * r * comps, 0.0f);
  for (int k = 0; k < nb; ++k)
    for (int y = 0; y < r; ++y)
      for (int x = 0; x < r; ++x)
        for (int c = 0; c < (b.grey ? 1 : 3); ++c) {
          const int layer = b.grey ? k / 4 : k, comp = b.grey ? k % 4 : c;
          texels[((static_cast<size_t>(layer) * r + y) * r + x) * comps + comp] =
              table.Texel(x, y, std::min(c, ch - 1))[k];
        }
  if (!b.texture) b.texture = GlTexture::Generate();
  glBindTexture(GL_TEXTURE_2D_ARRAY, b.texture.get());
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexImage3D(GL_TEXTURE_2D_ARRAY, 0, b.grey ? GL_RGBA32F : GL_RGB32F, r, r, layers, 0,
               b.grey ? GL_RGBA : GL_RGB, GL_FLOAT, texels.data());
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D_ARRAY, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  return absl::OkStatus();
}

void ShLightingMode::PrepareNormalMap() {
  if (settings_.normal_map == NormalMapKind::kNone || settings_.normal_map == normal_uploaded_)
    return;
  const NormalMap map = MakeNormalMap(settings_.normal_map);
  if (!normal_texture_) normal_texture_ = GlTexture::Generate();
  glBindTexture(GL_TEXTURE_2D, normal_texture_.get());
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB32F, map.width, map.height, 0, GL_RGB, GL_FLOAT,
               map.texels.data());
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_REPEAT);
  normal_uploaded_ = settings_.normal_map;
}

bool ShLightingMode::ready() const {
  return init_status_.ok() && draw_error_.ok() && env_ != nullptr && brdf_ != nullptr &&
         !env_->sh.empty() && bases_[static_cast<int>(settings_.basis)].status.ok();
}

const ShLightingCpu* ShLightingMode::cpu(HemisphereBasis basis) const {
  const Basis& b = bases_[static_cast<int>(basis)];
  return b.cpu.has_value() ? &*b.cpu : nullptr;
}

absl::Status ShLightingMode::Draw(const FrameInputs& frame) {
  if (!ready()) return absl::FailedPreconditionError("mode 3 needs --env and a BRDF");
  draw_error_ = DrawFrame(frame);
  return draw_error_;
}

absl::Status ShLightingMode::DrawFrame(const FrameInputs& frame) {
  SHRM_RETURN_IF_ERROR(PrepareBasis(settings_.basis));
  PrepareNormalMap();
  const Basis& basis = bases_[static_cast<int>(settings_.basis)];
  const ShLightingCpu& cpu = *basis.cpu;
  const bool use_map = settings_.normal_map != NormalMapKind::kNone;
  SHRM_ASSIGN_OR_RETURN(const GLuint program,
                        Program(use_map, settings_.mapping != NormalMapping::kSimplified,
                                cpu.conversion().has_value(), basis.grey));
  glUseProgram(program);
  SetUniformMat4(program, "u_view_projection", frame.view_projection.data());
  SetUniform(program, "u_eye", static_cast<float>(frame.eye.x), static_cast<float>(frame.eye.y),
             static_cast<float>(frame.eye.z));
  // A few hundred floats per frame: cheaper than tracking which program saw which data.
  SetLocalLightingUniforms(program, kShLightingLmax, cpu.world_lighting().data());
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D_ARRAY, basis.texture.get());
  SetUniform(program, "u_brdf", 0);
  glActiveTexture(GL_TEXTURE1);
  glBindTexture(GL_TEXTURE_2D, use_map ? normal_texture_.get() : 0);
  SetUniform(program, "u_normal_map", 1);
  glActiveTexture(GL_TEXTURE0);
  frame.mesh->Draw();
  glUseProgram(0);
  return absl::OkStatus();
}

std::string ShLightingMode::Status() const {
  const Basis& b = bases_[static_cast<int>(settings_.basis)];
  // Unavailable: the error (Init, Upload or Draw) was reported where it arose.
  if (!init_status_.ok() || !b.status.ok()) return "";
  std::string s = absl::StrFormat(
      "lighting l<=%d rotated per vertex (exact), %s BRDF %d coeffs, %dx%d table", kShLightingLmax,
      settings_.basis == HemisphereBasis::kSh ? "SH" : "HSH (h = C L)", ShCount(kShLightingLmax),
      kShLightingTableResolution, kShLightingTableResolution);
  absl::StrAppend(&s, ", normal map ", std::string(NormalMapKindName(settings_.normal_map)));
  if (settings_.normal_map != NormalMapKind::kNone)
    absl::StrAppend(&s, settings_.mapping == NormalMapping::kSimplified
                            ? " (simplified)"
                            : " (per-pixel Taylor 1.5th order)");
  if (b.cpu.has_value()) absl::StrAppendFormat(&s, ", table %.0f ms", table_ms_);
  absl::StrAppend(&s, " [S basis, N normal map, T Taylor/simplified]");
  return s;
}

bool ShLightingMode::OnKey(int key, std::string* message) {
  switch (key) {
    case 'S':
      draw_error_ = absl::OkStatus();  // what is drawn changes
      settings_.basis =
          settings_.basis == HemisphereBasis::kSh ? HemisphereBasis::kHsh : HemisphereBasis::kSh;
      *message = absl::StrCat("mode 3: BRDF coefficients in ",
                              settings_.basis == HemisphereBasis::kSh ? "SH" : "HSH (h = C L)");
      return true;
    case 'N':
      draw_error_ = absl::OkStatus();  // what is drawn changes
      settings_.normal_map = NextNormalMapKind(settings_.normal_map);
      *message =
          absl::StrCat("mode 3: normal map ", std::string(NormalMapKindName(settings_.normal_map)));
      return true;
    case 'T':
      draw_error_ = absl::OkStatus();  // what is drawn changes
      settings_.mapping = settings_.mapping == NormalMapping::kSimplified
                              ? NormalMapping::kTaylor
                              : NormalMapping::kSimplified;
      *message = absl::StrCat("mode 3: normal mapping ",
                              std::string(NormalMappingName(settings_.mapping)));
      return true;
    default:
      return false;
  }
}

std::unique_ptr<RenderMode> MakeShLightingMode() { return std::make_unique<ShLightingMode>(); }

}  // namespace shrm::viewer
