// shrm shader library: the PEAK LIGHTS of an SHRM (`shrm prefilter --peak-lights`, KTX2 keys
// "shrm:lights" and "shrm:light_model"; docs/shaders.md "Peak lights"). The map's brightest
// pixels ship beside the expansion as directional lights; the reflection is the SHRM's value plus
//   sum_k weight_k rho-hat(N, V, d_k),
// rho-hat the BRDF's transfer (f_r max(N.d, 0) for the ordinary models; the arithmetic of
// core/brdf/brdf_models.cc). Include after shrm_common.glsl and define SHRM_LIGHTS before the
// files: the global pass (shrm_global.glsl) then adds the lights at each texel, and a host's
// local shading adds ShrmLights(N, V) to ShrmLocal.
//
// Bindings:
//   uniform sampler2D shrm_lights;      // K x 2 texels, RGBA32F, read with texelFetch:
//                                       // (k, 0).xyz = d_k (world, unit), (k, 1).rgb = weight_k
//                                       // (radiance x solid angle, the map's working space)
//   uniform int shrm_light_count;       // K (0: no lights)
//   uniform int shrm_light_model;       // the key's first number (SHRM_LIGHT_* below)
//   uniform vec4 shrm_light_brdf[5];    // the key's 20 values, 4 per vec4 in order
// The key's text is "M v_0 .. v_19" (core/brdf/brdf_shader_params.h lists what each model
// keeps where); "shrm:lights" is "K x_1 y_1 z_1 r_1 g_1 b_1 .. b_K".

#define SHRM_LIGHT_LAMBERT 1
#define SHRM_LIGHT_PHONG 2
#define SHRM_LIGHT_MICROFACET 3
#define SHRM_LIGHT_LAFORTUNE 4
#define SHRM_LIGHT_WARD 5
#define SHRM_LIGHT_GGX 6
#define SHRM_LIGHT_KAJIYA_KAY 7

uniform sampler2D shrm_lights;
uniform int shrm_light_count;
uniform int shrm_light_model;
uniform vec4 shrm_light_brdf[5];

const float kShrmLightPi = 3.14159265358979;

float ShrmSmithLambda(float a2, float c) {
  return 0.5 * (sqrt(1.0 + a2 * (1.0 - c * c) / (c * c)) - 1.0);
}

// rho-hat(N, V, w) of the lights' BRDF (N is the unit tangent T for Kajiya-Kay); world, unit.
float ShrmLightTransfer(vec3 n, vec3 v, vec3 w) {
  vec4 p = shrm_light_brdf[0];
  float nw = dot(n, w), nv = dot(n, v);
  if (shrm_light_model == SHRM_LIGHT_PHONG) {  // radially symmetric about R: no horizon test
    float rw = dot(2.0 * nv * n - v, w);
    return rw > 0.0 ? (p.x + 1.0) / (2.0 * kShrmLightPi) * pow(rw, p.x) : 0.0;
  }
  if (shrm_light_model == SHRM_LIGHT_KAJIYA_KAY) {
    float si = sqrt(max(0.0, 1.0 - nw * nw)), so = sqrt(max(0.0, 1.0 - nv * nv));
    float c = nw * nv + si * so;  // cos(theta_i' - theta_o')
    return c > 0.0 ? p.y * pow(c, p.x) : 0.0;
  }
  if (nw <= 0.0 || nv <= 0.0) return 0.0;
  if (shrm_light_model == SHRM_LIGHT_LAMBERT) return p.x / kShrmLightPi * nw;
  vec3 h_sum = v + w;
  float len = length(h_sum);
  if (len <= 0.0) return 0.0;
  if (shrm_light_model == SHRM_LIGHT_MICROFACET) {
    float theta_h = 2.0 * asin(min(1.0, 0.5 * length(n - h_sum / len))) / p.x;
    return exp(-theta_h * theta_h) / (4.0 * kShrmLightPi * p.x * p.x);
  }
  if (shrm_light_model == SHRM_LIGHT_LAFORTUNE) {
    float f = p.x / kShrmLightPi;
    float tangential = dot(w, v) - nw * nv;
    int lobes = int(p.y + 0.5);
    for (int k = 0; k < 4; ++k) {
      if (k >= lobes) break;
      vec4 lobe = shrm_light_brdf[1 + k];  // C_xy, C_z, n, rho
      float d = lobe.x * tangential + lobe.y * nw * nv;
      if (d > 0.0) f += lobe.w * pow(d, lobe.z);
    }
    return f * nw;
  }
  if (shrm_light_model == SHRM_LIGHT_WARD) {  // p = (alpha_x, alpha_y, rho_s, rho_d)
    float nh = dot(n, h_sum), e;
    if (p.x == p.y) {
      float nh2 = nh * nh / dot(h_sum, h_sum);
      e = (1.0 - nh2) / nh2 / (p.x * p.x);
    } else {
      vec3 axis = abs(n.x) < 1.0 - 1e-6 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0);
      vec3 t = normalize(axis - n * dot(n, axis));
      vec3 b = cross(n, t);
      float ht = dot(h_sum, t) / (nh * p.x), hb = dot(h_sum, b) / (nh * p.y);
      e = ht * ht + hb * hb;
    }
    float f = p.w / kShrmLightPi + p.z * exp(-e) / (4.0 * kShrmLightPi * p.x * p.y * sqrt(nw * nv));
    return f * nw;
  }
  if (shrm_light_model == SHRM_LIGHT_GGX) {  // p = (alpha, f0)
    vec3 h = h_sum / len;
    float nh = dot(n, h), vh = max(0.0, dot(v, h)), a2 = p.x * p.x;
    float den = nh * nh * (a2 - 1.0) + 1.0;
    float d = a2 / (kShrmLightPi * den * den);
    float g = 1.0 / (1.0 + ShrmSmithLambda(a2, nv) + ShrmSmithLambda(a2, nw));
    float x = 1.0 - vh, x2 = x * x;
    float fresnel = p.y + (1.0 - p.y) * (x2 * x2 * x);
    return fresnel * d * g / (4.0 * nv);  // f_r (N.w) with f_r = F D G / (4 (N.w)(N.V))
  }
  return 0.0;
}

// The lights' reflection at (N, V) (world, unit; N is T for Kajiya-Kay).
vec3 ShrmLights(vec3 n, vec3 v) {
  vec3 sum = vec3(0.0);
  for (int k = 0; k < shrm_light_count; ++k) {
    vec3 d = texelFetch(shrm_lights, ivec2(k, 0), 0).xyz;
    vec3 weight = texelFetch(shrm_lights, ivec2(k, 1), 0).rgb;
    sum += weight * ShrmLightTransfer(n, v, d);
  }
  return sum;
}

// The lights at a texel of the global pass's map for the view V: the texel direction R (unit) is
// the reflection vector of the normal N = (R + V) / |R + V| (ShrmViewNormal), or the tangent T
// itself for Kajiya-Kay (shrm:index "tangent").
vec3 ShrmLightsAtTexel(vec3 r, vec3 v) {
  if (shrm_light_count == 0) return vec3(0.0);
  return ShrmLights(shrm_light_model == SHRM_LIGHT_KAJIYA_KAY ? r : ShrmViewNormal(r, v), v);
}
