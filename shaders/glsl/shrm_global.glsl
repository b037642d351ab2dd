// shrm shader library: a GLOBAL SHRM evaluated once per frame (Ramamoorthi & Hanrahan, eq. 5.35):
//   B~(R) = sum_{p,q} B^_pq(R) Y_pq(V),   V = the frame's view direction (SH frame),
// or, for an SHRM with shrm:view_variable "normal" (define SHRM_VIEW_NORMAL), Y_pq(N) with each texel's
// own normal N = (R + V) / |R + V| (ShrmViewNormal), times the Fresnel table's w(N.R) where the SHRM
// has one (shrm_common.glsl ShrmFresnel),
// i.e. an ordinary reflection cube map for this frame's view, which the shading then samples by
// R (or T) with hardware filtering. Include after shrm_common.glsl (and shrm_lights.glsl with
// SHRM_LIGHTS defined for an SHRM with peak lights: the pass adds them at each texel's own
// normal, ShrmLightsAtTexel). docs/shaders.md.
//
// The per-frame pass (define SHRM_GLOBAL_PASS in the fragment shader, vertex shader
// shrm_fullscreen.vert): six draws of a full-screen triangle, draw f rendering into face f of an
// S x S cube map (RGBA16F or RGBA32F colour attachment, viewport S x S), with
//   uniform vec3 shrm_view;  // V: world, unit, from the surface towards the viewer
//   uniform int shrm_face;   // 0..5, the face bound as the colour attachment
// Texel (x, y) of the output face is pixel (x, y) of the attachment (gl_FragCoord), the cube-map
// texel of the same (x, y) in the input layers: the output is a cube map in the GL/KTX2 layout.
// Cost per frame: 6 S^2 (P + 1)^2 texel fetches and multiply-adds.

// sum_k coefficient_k(face, xy) y[k]: eq. 5.35 at one texel, y = Y_k(V) (EvalSh of ShFrame(V)).
vec3 ShrmGlobalTexel(int face, ivec2 xy, float y[SH_COUNT]) {
  vec3 sum = vec3(0.0);
  for (int k = 0; k < SH_COUNT; ++k) sum += y[k] * ShrmCoefficient(face, xy, k);
  return sum;
}

#ifdef SHRM_GLOBAL_PASS
uniform vec3 shrm_view;
uniform int shrm_face;
out vec4 shrm_color;
void main() {
  float y[SH_COUNT];
#ifdef SHRM_VIEW_NORMAL
  vec2 st = (floor(gl_FragCoord.xy) + 0.5) / float(textureSize(shrm_coeffs, 0).x);
  vec3 r = normalize(CubeFaceDirection(shrm_face, st));
  vec3 v = normalize(shrm_view);
  EvalSh(ShFrame(ShrmViewNormal(r, v)), y);
  // The Fresnel table's factor at the texel's N.R = |R + V| / 2 (1 without a table; exact, and
  // without the cancellation of dot(N, R) near V = -R).
  vec3 sum =
      ShrmGlobalTexel(shrm_face, ivec2(gl_FragCoord.xy), y) * ShrmFresnel(0.5 * length(r + v));
#ifdef SHRM_LIGHTS
  sum += ShrmLightsAtTexel(r, v);
#endif
  shrm_color = vec4(sum, 1.0);
#else
  vec3 v = normalize(shrm_view);
  EvalSh(ShFrame(v), y);
  vec3 sum = ShrmGlobalTexel(shrm_face, ivec2(gl_FragCoord.xy), y);
  vec2 st = (floor(gl_FragCoord.xy) + 0.5) / float(textureSize(shrm_coeffs, 0).x);
  vec3 r = normalize(CubeFaceDirection(shrm_face, st));
  // The table's factor at N.V = |R + V| / 2 (conventions 4).
  if (shrm_fresnel_count != 0) sum *= ShrmFresnel(0.5 * length(r + v));
#ifdef SHRM_LIGHTS
  sum += ShrmLightsAtTexel(r, v);
#endif
  shrm_color = vec4(sum, 1.0);
#endif
}
#endif
