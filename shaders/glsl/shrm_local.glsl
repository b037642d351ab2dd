// shrm shader library: a LOCAL SHRM evaluated per pixel (Ramamoorthi & Hanrahan, eq. 5.10):
//   B(R, V) = sum_{p,q} B_pq(R) Y_pq(w), w = Rot(R)^T V,  Rot(R) = Rz(beta) Ry(alpha),
// (shrm:view_variable "normal": w = Rot(R)^T N with the normal N = (R + V) / |R + V|: pass N, e.g. the
// shading normal or ShrmViewNormal(R, V), where the functions below take `view`; the value is then
// times the Fresnel table's w(N.R), shrm_common.glsl ShrmFresnel, 1 without a table),
// (alpha, beta) the SH angles of the texel's direction R (docs/conventions.md). Include after
// shrm_common.glsl. docs/shaders.md.
//
// Bindings (besides shrm_coeffs of shrm_common.glsl):
//   uniform int shrm_size;   // S, the face size (KTX2 pixelWidth)
// With SHRM_FILTERED defined (GLSL 4.00: cube-map arrays), also
//   uniform samplerCubeArray shrm_filtered;   // the same KTX2 level uploaded as a cube-map array
//                                             // (layer k = coefficient k), GL_LINEAR, seamless
//
// ShrmLocal(index, view): the exact form. The four texels nearest to the index direction, each
// evaluated in the frame of its own centre, then interpolated bilinearly (beyond a face's outer
// texel centres the neighbour is the adjacent face's texel containing the extrapolated centre):
// 4 (P + 1)^2 fetches. The frame Rot(R) turns by 2 pi around the +-Y poles of the SH frame, so
// interpolating coefficients of different frames is wrong there; this form never does.
// ShrmLocalFiltered(index, view): one evaluation of the hardware-filtered coefficients in the frame
// of the index direction ((P + 1)^2 filtered fetches); accurate away from the poles only: use it
// where sin(alpha) > a few texel pitches (2 / S each), ShrmLocal elsewhere (shrm-view's mode 2
// does this in two passes).

uniform int shrm_size;

// w = Rot^T v = Ry(-alpha) Rz(-beta) v for the frame of the SH-frame direction r (unit).
vec3 ShrmToLocalFrame(vec3 r, vec3 v) {
  float sa = length(r.xy), ca = r.z;
  float cb = 1.0, sb = 0.0;
  if (sa > 0.0) {
    cb = r.x / sa;
    sb = r.y / sa;
  }
  vec3 u = vec3(cb * v.x + sb * v.y, -sb * v.x + cb * v.y, v.z);
  return vec3(ca * u.x - sa * u.z, u.y, sa * u.x + ca * u.z);
}

// The texel of `face` at integer coordinates that may lie one step outside the face: the texel
// of the adjacent face containing the extrapolated centre direction.
void ShrmResolveTexel(int face, ivec2 xy, out int of, out ivec2 oxy) {
  if (all(greaterThanEqual(xy, ivec2(0))) && all(lessThan(xy, ivec2(shrm_size)))) {
    of = face;
    oxy = xy;
    return;
  }
  vec2 st;
  CubeFaceCoordinates(CubeFaceDirection(face, (vec2(xy) + 0.5) / float(shrm_size)), of, st);
  oxy = clamp(ivec2(floor(st * float(shrm_size))), ivec2(0), ivec2(shrm_size - 1));
}

// B of texel (face, xy) for the view v_sh (SH frame, unit), in the texel centre's frame.
vec3 ShrmLocalTexel(int face, ivec2 xy, vec3 v_sh) {
  vec3 r = ShFrame(normalize(CubeFaceDirection(face, (vec2(xy) + 0.5) / float(shrm_size))));
  float y[SH_COUNT];
  EvalSh(ShrmToLocalFrame(r, v_sh), y);
  vec3 sum = vec3(0.0);
  for (int k = 0; k < SH_COUNT; ++k) sum += y[k] * ShrmCoefficient(face, xy, k);
  return sum;
}

// Eq. 5.10 at the index direction (R, or T; world, any length) for the view (world, unit,
// towards the viewer).
vec3 ShrmLocal(vec3 index, vec3 view) {
  vec3 v_sh = ShFrame(view);
  int face;
  vec2 st;
  CubeFaceCoordinates(index, face, st);
  vec2 p = st * float(shrm_size) - 0.5;
  ivec2 p0 = ivec2(floor(p));
  vec2 f = p - vec2(p0);
  // The four taps written out (llvmpipe compiles a loop around ShrmLocalTexel much slower).
  int f00, f10, f01, f11;
  ivec2 t00, t10, t01, t11;
  ShrmResolveTexel(face, p0, f00, t00);
  ShrmResolveTexel(face, p0 + ivec2(1, 0), f10, t10);
  ShrmResolveTexel(face, p0 + ivec2(0, 1), f01, t01);
  ShrmResolveTexel(face, p0 + ivec2(1, 1), f11, t11);
  return ((1.0 - f.x) * (1.0 - f.y) * ShrmLocalTexel(f00, t00, v_sh) +
          f.x * (1.0 - f.y) * ShrmLocalTexel(f10, t10, v_sh) +
          (1.0 - f.x) * f.y * ShrmLocalTexel(f01, t01, v_sh) +
          f.x * f.y * ShrmLocalTexel(f11, t11, v_sh)) *
         ShrmFresnel(ShrmFresnelCos(index, view));
}

#ifdef SHRM_FILTERED
uniform samplerCubeArray shrm_filtered;

// sin(alpha) of the index direction: ShrmLocalFiltered is accurate where this exceeds a few
// texel pitches (2 / shrm_size each).
float ShrmPoleDistance(vec3 index) { return length(ShFrame(normalize(index)).xy); }

vec3 ShrmLocalFiltered(vec3 index, vec3 view) {
  float y[SH_COUNT];
  EvalSh(ShrmToLocalFrame(ShFrame(normalize(index)), ShFrame(view)), y);
  vec3 sum = vec3(0.0);
  for (int k = 0; k < SH_COUNT; ++k) sum += y[k] * texture(shrm_filtered, vec4(index, float(k))).rgb;
  return sum * ShrmFresnel(ShrmFresnelCos(index, view));
}
#endif
