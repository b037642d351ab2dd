// shrm shader library, GLSL 3.30 core (also GLSL 4.x): the pieces shared by shrm_global.glsl
// (eq. 5.35) and shrm_local.glsl (eq. 5.10). docs/shaders.md documents the binding layout; the
// conventions are docs/conventions.md's. Include order: this file, then the evaluator(s).
//
// The including program defines PMAX (the SHRM's order P_B, the KTX2 key "shrm:pmax") before
// this file, e.g. "#version 330 core\n#define PMAX 3\n" + shrm_common.glsl + shrm_global.glsl.
//
// Binding: one texture holding the SHRM as written by `shrm prefilter --ktx2` (docs/formats.md),
//   uniform sampler2DArray shrm_coeffs;
// uploaded as a 2D array texture of S x S x 6 (P + 1)^2 layers, layer k * 6 + face = the SH
// coefficient k = p (p + 1) + q of that cube face (faces +X -X +Y -Y +Z -Z): exactly the KTX2
// file's level 0 (layers, then faces, then rows, row 0 first) given to glTexImage3D as it is.
// It is read with texelFetch only (no filtering, any float format: RGBA32F, RGBA16F).

const int SH_COUNT = (PMAX + 1) * (PMAX + 1);

uniform sampler2DArray shrm_coeffs;

// Coefficient k (RGB) of texel (x, y) of cube face `face`.
vec3 ShrmCoefficient(int face, ivec2 xy, int k) {
  return texelFetch(shrm_coeffs, ivec3(xy, k * 6 + face), 0).rgb;
}

// The Fresnel table of an SHRM with the KTX2 key "shrm:fresnel" (shrm:view_variable "normal",
// docs/shaders.md "Fresnel normalization"): the expansion is of rho-hat / w(N.V), so the value is
// the sum times w(N.V) (ShrmFresnelCos: N.R for the normal variable, |R + V| / 2 for the view
// variable). The key's text is "K C v_0 .. v_K" (K = 128
// intervals, C channels per node): upload node k as shrm_fresnel[k] (C = 1: the value in all three
// components) and set shrm_fresnel_count = K + 1; without the key shrm_fresnel_count = 0 (w = 1).
// Node k is at N.R = 1 - k / K; between nodes the Catmull-Rom cubic in N.R of the writer
// (core/brdf/brdf_coefficients.h FresnelAt), ghost nodes beyond both ends on the quadratic
// through the three nearest.
#define SHRM_FRESNEL_NODES 129
uniform int shrm_fresnel_count;
uniform vec3 shrm_fresnel[SHRM_FRESNEL_NODES];

vec3 ShrmFresnel(float cos_nr) {
  if (shrm_fresnel_count != SHRM_FRESNEL_NODES) return vec3(1.0);
  const int K = SHRM_FRESNEL_NODES - 1;
  float t = (1.0 - clamp(cos_nr, 0.0, 1.0)) * float(K);
  int k = clamp(int(t), 0, K - 1);
  float u = clamp(t - float(k), 0.0, 1.0);
  vec3 p1 = shrm_fresnel[k], p2 = shrm_fresnel[k + 1];
  vec3 p0 = k == 0 ? 3.0 * (p1 - p2) + shrm_fresnel[2] : shrm_fresnel[max(k - 1, 0)];
  vec3 p3 = k + 2 <= K ? shrm_fresnel[min(k + 2, K)] : 3.0 * (p2 - p1) + shrm_fresnel[K - 2];
  vec3 v = p1 + 0.5 * u * (p2 - p0 + u * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 +
                                          u * (3.0 * (p1 - p2) + p3 - p0)));
  return max(v, 0.5 * min(p1, p2));
}

// N.V, the Fresnel table's argument, at the index direction (R, any length) and the evaluation's
// argument (world, unit): N.R where the argument is N (shrm:view_variable "normal": define
// SHRM_VIEW_NORMAL), |R + V| / 2 where it is V (the view variable; conventions 4).
float ShrmFresnelCos(vec3 index, vec3 arg) {
  vec3 r = normalize(index);
#ifdef SHRM_VIEW_NORMAL
  return dot(r, arg);
#else
  return 0.5 * length(r + arg);
#endif
}

// The SH frame of a world direction (pole +Y): ShFrame(w) = (w.x, -w.z, w.y).
vec3 ShFrame(vec3 w) { return vec3(w.x, -w.z, w.y); }

// Real SH with the Condon-Shortley phase, index l (l + 1) + m, of a unit direction d given IN THE
// SH FRAME, up to degree PMAX. Fully normalized Legendre recurrence without the sin^m factor,
// times Re/Im (x + i y)^m = sin^m(theta) cos/sin(m phi).
void EvalSh(vec3 d, out float y[SH_COUNT]) {
  const float kInv4Pi = 0.07957747154594767;
  float cm = 1.0, sm = 0.0;   // Re, Im of (x + i y)^m
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
      if (l > m) {
        p2 = p1;
        p1 = p;
      }
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

// Cube-map addressing (the GL / KTX2 major-axis table; faces +X -X +Y -Y +Z -Z), for world
// directions: the face and (s, t) in [0, 1]^2 of d (not necessarily unit), and the direction
// (not normalized) of (s, t) on `face`. Texel (x, y) of an S x S face covers
// st in [x, x + 1] / S x [y, y + 1] / S.
void CubeFaceCoordinates(vec3 d, out int face, out vec2 st) {
  vec3 a = abs(d);
  float sc, tc, ma;
  if (a.x >= a.y && a.x >= a.z) {
    ma = a.x;
    if (d.x > 0.0) {
      face = 0; sc = -d.z; tc = -d.y;
    } else {
      face = 1; sc = d.z; tc = -d.y;
    }
  } else if (a.y >= a.z) {
    ma = a.y;
    if (d.y > 0.0) {
      face = 2; sc = d.x; tc = d.z;
    } else {
      face = 3; sc = d.x; tc = -d.z;
    }
  } else {
    ma = a.z;
    if (d.z > 0.0) {
      face = 4; sc = d.x; tc = -d.y;
    } else {
      face = 5; sc = -d.x; tc = -d.y;
    }
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

// The reflection vector R = 2 (N.V) N - V (N, V world, unit; V towards the viewer): what
// addresses the texels of an SHRM with shrm:index "reflection". Tangent-indexed SHRMs
// (shrm:index "tangent", Kajiya-Kay) are addressed by the unit tangent T instead.
vec3 ShrmReflect(vec3 n, vec3 v) { return 2.0 * dot(n, v) * n - v; }

// The argument of Y_pq of an SHRM with shrm:view_variable "normal": the normal N = (R + V) / |R + V| that
// reflects V into R (R, V world, unit). For V = -R, where every N on R's equator does, the one
// of azimuth 0 in R's frame (core/shrm/shrm_eval.h ShrmViewArgument). SHRMs with shrm:view_variable "view"
// (or none) take V itself.
vec3 ShrmViewNormal(vec3 r, vec3 v) {
  vec3 h = r + v;
  float len = length(h);
  if (len > 1e-6) return h / len;
  vec3 rs = ShFrame(r);
  float sa = length(rs.xy), cb = 1.0, sb = 0.0;
  if (sa > 0.0) {
    cb = rs.x / sa;
    sb = rs.y / sa;
  }
  vec3 es = vec3(rs.z * cb, rs.z * sb, -sa);  // Rz(beta) Ry(alpha) (1, 0, 0), SH frame
  return vec3(es.x, es.z, -es.y);              // back to the world
}
