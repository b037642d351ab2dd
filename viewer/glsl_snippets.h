// GLSL 3.30 pieces shared by the render modes (embedded strings: no shader files at run time).
#ifndef SHRM_VIEWER_GLSL_SNIPPETS_H_
#define SHRM_VIEWER_GLSL_SNIPPETS_H_

namespace shrm::viewer {

// Mesh vertex shader (attributes of viewer/gpu_mesh.h, identity model matrix): outputs the world
// position, normal, tangent (xyzw) and uv. Uniform: mat4 u_view_projection. gl_Position is
// invariant, so passes of different programs over the mesh produce the same depths.
inline constexpr char kMeshVertexShader[] = R"(#version 330 core
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec4 a_tangent;
layout(location = 3) in vec2 a_uv;
uniform mat4 u_view_projection;
out vec3 v_position;
out vec3 v_normal;
out vec4 v_tangent;
out vec2 v_uv;
invariant gl_Position;  // equal depths across programs (multi-pass modes)
void main() {
  v_position = a_position;
  v_normal = a_normal;
  v_tangent = a_tangent;
  v_uv = a_uv;
  gl_Position = u_view_projection * vec4(a_position, 1.0);
}
)";

// Real SH with the Condon-Shortley phase (docs/conventions.md), index l (l + 1) + m, of a unit
// direction d given IN THE SH FRAME, up to degree PMAX (a #define of the including shader):
//   void EvalSh(vec3 d, out float y[(PMAX + 1) * (PMAX + 1)]);
// Fully normalized Legendre recurrence without the sin^m factor (lambda~_l^m), times
// Re/Im (x + i y)^m = sin^m(theta) cos/sin(m phi).
inline constexpr char kShEvalGlsl[] = R"(
const int SH_COUNT = (PMAX + 1) * (PMAX + 1);
void EvalSh(vec3 d, out float y[SH_COUNT]) {
  const float kInv4Pi = 0.07957747154594767;
  float cm = 1.0, sm = 0.0;  // Re, Im of (x + i y)^m
  float pmm = sqrt(kInv4Pi);  // lambda~_m^m
  for (int m = 0; m <= PMAX; ++m) {
    if (m > 0) {
      pmm *= -sqrt(float(2 * m + 1) / float(2 * m));
      float c = cm * d.x - sm * d.y;
      sm = cm * d.y + sm * d.x;
      cm = c;
    }
    float p2 = 0.0, p1 = pmm;  // lambda~_{l-2}^m, lambda~_{l-1}^m
    for (int l = m; l <= PMAX; ++l) {
      float p;
      if (l == m) {
        p = pmm;
      } else if (l == m + 1) {
        p = sqrt(float(2 * m + 3)) * d.z * pmm;
      } else {
        float fl = float(l), fm = float(m);
        float a = sqrt((4.0 * fl * fl - 1.0) / (fl * fl - fm * fm));
        float b = sqrt(((fl - 1.0) * (fl - 1.0) - fm * fm) / (4.0 * (fl - 1.0) * (fl - 1.0) - 1.0));
        p = a * (d.z * p1 - b * p2);
      }
      if (l > m) { p2 = p1; p1 = p; }
      int base = l * (l + 1);
      if (m == 0) {
        y[base] = p;
      } else {
        y[base + m] = 1.4142135623730951 * p * cm;
        y[base - m] = 1.4142135623730951 * p * sm;
      }
    }
  }
}
)";

// Cube-map addressing of core/base/cubemap.h (the GL major-axis table; faces +X -X +Y -Y +Z -Z).
//   void CubeFaceCoordinates(vec3 d, out int face, out vec2 st);
//   vec3 CubeFaceDirection(int face, vec2 st);   // not normalized
// SH frame of a world direction: ShFrame(w) = (w.x, -w.z, w.y).
inline constexpr char kCubeGlsl[] = R"(
vec3 ShFrame(vec3 w) { return vec3(w.x, -w.z, w.y); }
void CubeFaceCoordinates(vec3 d, out int face, out vec2 st) {
  vec3 a = abs(d);
  float sc, tc, ma;
  if (a.x >= a.y && a.x >= a.z) {
    ma = a.x;
    if (d.x > 0.0) { face = 0; sc = -d.z; tc = -d.y; } else { face = 1; sc = d.z; tc = -d.y; }
  } else if (a.y >= a.z) {
    ma = a.y;
    if (d.y > 0.0) { face = 2; sc = d.x; tc = d.z; } else { face = 3; sc = d.x; tc = -d.z; }
  } else {
    ma = a.z;
    if (d.z > 0.0) { face = 4; sc = d.x; tc = -d.y; } else { face = 5; sc = -d.x; tc = -d.y; }
  }
  st = 0.5 * (vec2(sc, tc) / ma + 1.0);
}
vec3 CubeFaceDirection(int face, vec2 st) {
  float sc = 2.0 * st.x - 1.0, tc = 2.0 * st.y - 1.0;
  if (face == 0) return vec3(1.0, -tc, -sc);
  if (face == 1) return vec3(-1.0, -tc, sc);
  if (face == 2) return vec3(sc, 1.0, tc);
  if (face == 3) return vec3(sc, -1.0, -tc);
  if (face == 4) return vec3(sc, -tc, 1.0);
  return vec3(-sc, -tc, -1.0);
}
)";

}  // namespace shrm::viewer

#endif  // SHRM_VIEWER_GLSL_SNIPPETS_H_
