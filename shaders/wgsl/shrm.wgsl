// shrm shader library, WGSL (WebGPU): the GLSL library of shaders/glsl/ in one module.
//   - eq. 5.35, a GLOBAL SHRM evaluated once per frame: the compute entry point shrm_global_pass
//     writes this frame's reflection cube map (B~(R) = sum_pq B^_pq(R) Y_pq(V); for an SHRM with
//     shrm:view_variable "normal", set the override SHRM_VIEW_NORMAL: Y_pq of each texel's normal);
//   - eq. 5.10, a LOCAL SHRM per pixel: fn shrm_local(index, view) for the host's own shaders;
//   - the peak lights of an SHRM that has them: shrm_global_pass_lights, fn shrm_lights_sum.
// docs/shaders.md documents the bindings and the SHRM file (`shrm prefilter --ktx2`).
//
// The host prepends the SHRM's order P_B (KTX2 key "shrm:pmax") to this text:
//   const SHRM_PMAX: i32 = 3;
//
// Bindings (group 0):
//   0 shrm_coeffs: texture_2d_array<f32>, S x S, 6 (P + 1)^2 layers: layer k * 6 + face holds SH
//     coefficient k = p (p + 1) + q of that cube face (faces +X -X +Y -Y +Z -Z). This is the KTX2
//     file's level 0 as it is (layers, then faces, then rows, row 0 first), e.g. written with
//     queue.writeTexture into an rgba32float or rgba16float texture. Read with textureLoad only.
//   1 shrm: ShrmParams (uniform buffer, 16 bytes): view = V (world, unit, towards the viewer; used
//     by shrm_global_pass), size = S.
//   2 shrm_out: texture_storage_2d_array<rgba32float, write>, S x S x 6 (used by shrm_global_pass
//     only): face f of this frame's reflection map in layer f, texel (x, y) = the cube texel (x, y).
//     A cube view of the same texture (dimension "cube") samples it by R in the shading pass.
//   3 shrm_fresnel: ShrmFresnelTable (uniform buffer, 2080 bytes): the SHRM's Fresnel table (KTX2
//     key "shrm:fresnel", text "K C v_0 .. v_K" with K = 128 and C channels per node): count =
//     K + 1 and node k in nodes[k].rgb (C = 1: the value in all three), or count = 0 without the
//     key (w = 1). SHRMs with the key are the sum times w(N.V) (docs/shaders.md).
//   4 shrm_lights, 5 shrm_light: the peak lights of an SHRM with the keys "shrm:lights" and
//     "shrm:light_model" (the section "peak lights" below; entry point shrm_global_pass_lights,
//     fn shrm_lights_sum).

const SHRM_SH_COUNT: i32 = (SHRM_PMAX + 1) * (SHRM_PMAX + 1);

struct ShrmParams {
  view: vec3f,
  size: i32,
}

@group(0) @binding(0) var shrm_coeffs: texture_2d_array<f32>;
@group(0) @binding(1) var<uniform> shrm: ShrmParams;
@group(0) @binding(2) var shrm_out: texture_storage_2d_array<rgba32float, write>;

const SHRM_FRESNEL_NODES: i32 = 129;
struct ShrmFresnelTable {
  count: i32,
  nodes: array<vec4f, SHRM_FRESNEL_NODES>,
}
@group(0) @binding(3) var<uniform> shrm_fresnel: ShrmFresnelTable;

// w(N.V) of the Fresnel table (1 without one): node k at N.V = 1 - k / K, the Catmull-Rom cubic
// in N.V between them, ghost nodes beyond both ends on the quadratic through the three nearest
// (core/brdf/brdf_coefficients.h FresnelAt).
fn shrm_fresnel_at(cos_nr: f32) -> vec3f {
  if (shrm_fresnel.count != SHRM_FRESNEL_NODES) {
    return vec3f(1.0);
  }
  let kk = SHRM_FRESNEL_NODES - 1;
  let t = (1.0 - clamp(cos_nr, 0.0, 1.0)) * f32(kk);
  let k = clamp(i32(t), 0, kk - 1);
  let u = clamp(t - f32(k), 0.0, 1.0);
  let p1 = shrm_fresnel.nodes[k].rgb;
  let p2 = shrm_fresnel.nodes[k + 1].rgb;
  var p0 = 3.0 * (p1 - p2) + shrm_fresnel.nodes[2].rgb;  // the quadratic beyond both ends
  if (k > 0) {
    p0 = shrm_fresnel.nodes[k - 1].rgb;
  }
  var p3 = 3.0 * (p2 - p1) + shrm_fresnel.nodes[kk - 2].rgb;
  if (k + 2 <= kk) {
    p3 = shrm_fresnel.nodes[k + 2].rgb;
  }
  let v = p1 + 0.5 * u * (p2 - p0 + u * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 +
                                        u * (3.0 * (p1 - p2) + p3 - p0)));
  return max(v, 0.5 * min(p1, p2));
}

// Coefficient k (RGB) of texel xy of cube face `face`.
fn shrm_coefficient(face: i32, xy: vec2i, k: i32) -> vec3f {
  return textureLoad(shrm_coeffs, xy, k * 6 + face, 0).rgb;
}

// The SH frame of a world direction (pole +Y): (w.x, -w.z, w.y).
fn shrm_sh_frame(w: vec3f) -> vec3f {
  return vec3f(w.x, -w.z, w.y);
}

// Real SH with the Condon-Shortley phase, index l (l + 1) + m, of a unit direction d given IN THE
// SH FRAME, up to degree SHRM_PMAX (the recurrence of shrm_common.glsl's EvalSh).
fn shrm_eval_sh(d: vec3f) -> array<f32, SHRM_SH_COUNT> {
  var y: array<f32, SHRM_SH_COUNT>;
  var cm = 1.0;
  var sm = 0.0;
  var pmm = sqrt(0.07957747154594767);
  for (var m = 0; m <= SHRM_PMAX; m++) {
    if (m > 0) {
      pmm *= -sqrt(f32(2 * m + 1) / f32(2 * m));
      let c = cm * d.x - sm * d.y;
      sm = cm * d.y + sm * d.x;
      cm = c;
    }
    var p2 = 0.0;
    var p1 = pmm;
    for (var l = m; l <= SHRM_PMAX; l++) {
      var p: f32;
      if (l == m) {
        p = pmm;
      } else if (l == m + 1) {
        p = sqrt(f32(2 * m + 3)) * d.z * pmm;
      } else {
        let fl = f32(l);
        let fm = f32(m);
        let a = sqrt((4.0 * fl * fl - 1.0) / (fl * fl - fm * fm));
        let b = sqrt(((fl - 1.0) * (fl - 1.0) - fm * fm) / (4.0 * (fl - 1.0) * (fl - 1.0) - 1.0));
        p = a * (d.z * p1 - b * p2);
      }
      if (l > m) {
        p2 = p1;
        p1 = p;
      }
      let base = l * (l + 1);
      if (m == 0) {
        y[base] = p;
      } else {
        y[base + m] = 1.4142135623730951 * p * cm;
        y[base - m] = 1.4142135623730951 * p * sm;
      }
    }
  }
  return y;
}

// Cube-map addressing (the GL / KTX2 / WebGPU major-axis table), world directions.
struct ShrmCubeCoord {
  face: i32,
  st: vec2f,  // [0, 1]^2; texel (x, y) of an S x S face covers [x, x + 1] / S x [y, y + 1] / S
}

fn shrm_cube_face_coordinates(d: vec3f) -> ShrmCubeCoord {
  let a = abs(d);
  var face: i32;
  var sc: f32;
  var tc: f32;
  var ma: f32;
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
  return ShrmCubeCoord(face, 0.5 * (vec2f(sc, tc) / ma + 1.0));
}

fn shrm_cube_face_direction(face: i32, st: vec2f) -> vec3f {
  let sc = 2.0 * st.x - 1.0;
  let tc = 2.0 * st.y - 1.0;
  switch face {
    case 0: { return vec3f(1.0, -tc, -sc); }
    case 1: { return vec3f(-1.0, -tc, sc); }
    case 2: { return vec3f(sc, 1.0, tc); }
    case 3: { return vec3f(sc, -1.0, -tc); }
    case 4: { return vec3f(sc, -tc, 1.0); }
    default: { return vec3f(-sc, -tc, -1.0); }
  }
}

// R = 2 (N.V) N - V (world, unit): the index of shrm:index "reflection" SHRMs ("tangent" ones are
// indexed by the unit tangent T).
fn shrm_reflect(n: vec3f, v: vec3f) -> vec3f {
  return 2.0 * dot(n, v) * n - v;
}

// SHRMs with shrm:view_variable "normal" take Y_pq of the normal N = (R + V) / |R + V| that reflects V
// into R, not of V: set this pipeline-overridable constant to true for them (the global pass
// then uses each texel's own N; shrm_local takes N where it takes `view`).
override SHRM_VIEW_NORMAL: bool = false;

// That normal (R, V world, unit); for V = -R, where every N on R's equator does, the one of
// azimuth 0 in R's frame (core/shrm/shrm_eval.h ShrmViewArgument).
fn shrm_view_normal(r: vec3f, v: vec3f) -> vec3f {
  let h = r + v;
  let len = length(h);
  if (len > 1e-6) {
    return h / len;
  }
  let rs = shrm_sh_frame(r);
  let sa = length(rs.xy);
  var cb = 1.0;
  var sb = 0.0;
  if (sa > 0.0) {
    cb = rs.x / sa;
    sb = rs.y / sa;
  }
  let es = vec3f(rs.z * cb, rs.z * sb, -sa);  // Rz(beta) Ry(alpha) (1, 0, 0), SH frame
  return vec3f(es.x, es.z, -es.y);             // back to the world
}

// ---- eq. 5.35: a global SHRM, once per frame ----------------------------------------------------

fn shrm_global_texel(face: i32, xy: vec2i, y: array<f32, SHRM_SH_COUNT>) -> vec3f {
  var sum = vec3f(0.0);
  for (var k = 0; k < SHRM_SH_COUNT; k++) {
    sum += y[k] * shrm_coefficient(face, xy, k);
  }
  return sum;
}

// Eq. 5.35 at texel xy of `face` (direction r, world, unit) for the frame's view (world, unit).
fn shrm_global_value(face: i32, xy: vec2i, r: vec3f, view: vec3f) -> vec3f {
  // The Fresnel table's factor at the texel's N.V = |R + V| / 2 (either view variable; exact,
  // and without the cancellation of dot(N, R) near V = -R).
  let w = shrm_fresnel_at(0.5 * length(r + view));
  var d = view;
  if (SHRM_VIEW_NORMAL) {
    d = shrm_view_normal(r, view);
  }
  let y = shrm_eval_sh(shrm_sh_frame(d));
  return shrm_global_texel(face, xy, y) * w;
}

// Dispatch (ceil(S / 8), ceil(S / 8), 6) workgroups per frame.
@compute @workgroup_size(8, 8, 1)
fn shrm_global_pass(@builtin(global_invocation_id) id: vec3u) {
  let s = u32(shrm.size);
  if (id.x >= s || id.y >= s || id.z >= 6u) {
    return;
  }
  let face = i32(id.z);
  let r = normalize(shrm_cube_face_direction(face, (vec2f(id.xy) + 0.5) / f32(s)));
  let sum = shrm_global_value(face, vec2i(id.xy), r, normalize(shrm.view));
  textureStore(shrm_out, vec2i(id.xy), face, vec4f(sum, 1.0));
}

// ---- peak lights (shrm:lights, shrm:light_model; docs/shaders.md "Peak lights") ------------------
// An SHRM made with `shrm prefilter --peak-lights` ships the map's brightest pixels as directional
// lights beside the expansion: the reflection is the SHRM's value plus
// sum_k weight_k rho-hat(N, V, d_k), rho-hat the BRDF's transfer (f_r max(N.d, 0) for the ordinary
// models), evaluated here by a copy of each analytic model (core/brdf/brdf_models.cc).
// Bindings (group 0; only the entry points below that use them need them bound):
//   4 shrm_lights: texture_2d<f32> (rgba32float, unfilterable), K x 2 texels: (k, 0).xyz = d_k
//     (world, unit), (k, 1).rgb = weight_k (radiance x solid angle).
//   5 shrm_light: ShrmLightParams (uniform buffer, 96 bytes): count K at byte 0, the model (the
//     first number of "shrm:light_model") at byte 4, its 20 values from byte 16.
// The global pass with lights is the entry point shrm_global_pass_lights; for local SHRMs add
// shrm_lights_sum(N, V) (N the tangent T for Kajiya-Kay) to shrm_local.
struct ShrmLightParams {
  count: i32,
  model: i32,
  brdf: array<vec4f, 5>,
}
@group(0) @binding(4) var shrm_lights: texture_2d<f32>;
@group(0) @binding(5) var<uniform> shrm_light: ShrmLightParams;

const SHRM_LIGHT_LAMBERT: i32 = 1;
const SHRM_LIGHT_PHONG: i32 = 2;
const SHRM_LIGHT_MICROFACET: i32 = 3;
const SHRM_LIGHT_LAFORTUNE: i32 = 4;
const SHRM_LIGHT_WARD: i32 = 5;
const SHRM_LIGHT_GGX: i32 = 6;
const SHRM_LIGHT_KAJIYA_KAY: i32 = 7;
const SHRM_PI: f32 = 3.14159265358979;

fn shrm_smith_lambda(a2: f32, c: f32) -> f32 {
  return 0.5 * (sqrt(1.0 + a2 * (1.0 - c * c) / (c * c)) - 1.0);
}

// rho-hat(N, V, w) of the lights' BRDF (N is the unit tangent T for Kajiya-Kay); world, unit.
fn shrm_light_transfer(n: vec3f, v: vec3f, w: vec3f) -> f32 {
  let p = shrm_light.brdf[0];
  let model = shrm_light.model;
  let nw = dot(n, w);
  let nv = dot(n, v);
  if (model == SHRM_LIGHT_PHONG) {  // radially symmetric about R: no horizon test
    let rw = dot(2.0 * nv * n - v, w);
    if (rw <= 0.0) {
      return 0.0;
    }
    return (p.x + 1.0) / (2.0 * SHRM_PI) * pow(rw, p.x);
  }
  if (model == SHRM_LIGHT_KAJIYA_KAY) {
    let c = nw * nv + sqrt(max(0.0, 1.0 - nw * nw)) * sqrt(max(0.0, 1.0 - nv * nv));
    if (c <= 0.0) {
      return 0.0;
    }
    return p.y * pow(c, p.x);
  }
  if (nw <= 0.0 || nv <= 0.0) {
    return 0.0;
  }
  if (model == SHRM_LIGHT_LAMBERT) {
    return p.x / SHRM_PI * nw;
  }
  let h_sum = v + w;
  let len = length(h_sum);
  if (len <= 0.0) {
    return 0.0;
  }
  if (model == SHRM_LIGHT_MICROFACET) {
    let theta_h = 2.0 * asin(min(1.0, 0.5 * length(n - h_sum / len))) / p.x;
    return exp(-theta_h * theta_h) / (4.0 * SHRM_PI * p.x * p.x);
  }
  if (model == SHRM_LIGHT_LAFORTUNE) {
    var f = p.x / SHRM_PI;
    let tangential = dot(w, v) - nw * nv;
    let lobes = i32(p.y + 0.5);
    for (var k = 0; k < min(lobes, 4); k++) {
      let lobe = shrm_light.brdf[1 + k];  // C_xy, C_z, n, rho
      let d = lobe.x * tangential + lobe.y * nw * nv;
      if (d > 0.0) {
        f += lobe.w * pow(d, lobe.z);
      }
    }
    return f * nw;
  }
  if (model == SHRM_LIGHT_WARD) {  // p = (alpha_x, alpha_y, rho_s, rho_d)
    let nh = dot(n, h_sum);
    var e: f32;
    if (p.x == p.y) {
      let nh2 = nh * nh / dot(h_sum, h_sum);
      e = (1.0 - nh2) / nh2 / (p.x * p.x);
    } else {
      var axis = vec3f(0.0, 1.0, 0.0);
      if (abs(n.x) < 1.0 - 1e-6) {
        axis = vec3f(1.0, 0.0, 0.0);
      }
      let t = normalize(axis - n * dot(n, axis));
      let b = cross(n, t);
      let ht = dot(h_sum, t) / (nh * p.x);
      let hb = dot(h_sum, b) / (nh * p.y);
      e = ht * ht + hb * hb;
    }
    let f = p.w / SHRM_PI + p.z * exp(-e) / (4.0 * SHRM_PI * p.x * p.y * sqrt(nw * nv));
    return f * nw;
  }
  if (model == SHRM_LIGHT_GGX) {  // p = (alpha, f0)
    let h = h_sum / len;
    let nh = dot(n, h);
    let vh = max(0.0, dot(v, h));
    let a2 = p.x * p.x;
    let den = nh * nh * (a2 - 1.0) + 1.0;
    let d = a2 / (SHRM_PI * den * den);
    let g = 1.0 / (1.0 + shrm_smith_lambda(a2, nv) + shrm_smith_lambda(a2, nw));
    let x = 1.0 - vh;
    let x2 = x * x;
    let fresnel = p.y + (1.0 - p.y) * (x2 * x2 * x);
    return fresnel * d * g / (4.0 * nv);  // f_r (N.w) with f_r = F D G / (4 (N.w)(N.V))
  }
  return 0.0;
}

// The lights' reflection at (N, V) (world, unit; N is T for Kajiya-Kay).
fn shrm_lights_sum(n: vec3f, v: vec3f) -> vec3f {
  var sum = vec3f(0.0);
  for (var k = 0; k < shrm_light.count; k++) {
    let d = textureLoad(shrm_lights, vec2i(k, 0), 0).xyz;
    let weight = textureLoad(shrm_lights, vec2i(k, 1), 0).rgb;
    sum += weight * shrm_light_transfer(n, v, d);
  }
  return sum;
}

// The lights at a texel of the per-view map for the view V: the texel direction R (unit) is the
// reflection vector of N = (R + V) / |R + V|, or the tangent T itself for Kajiya-Kay.
fn shrm_lights_at_texel(r: vec3f, v: vec3f) -> vec3f {
  if (shrm_light.model == SHRM_LIGHT_KAJIYA_KAY) {
    return shrm_lights_sum(r, v);
  }
  return shrm_lights_sum(shrm_view_normal(r, v), v);
}

// shrm_global_pass plus the lights at each texel (bindings 4 and 5 as well).
@compute @workgroup_size(8, 8, 1)
fn shrm_global_pass_lights(@builtin(global_invocation_id) id: vec3u) {
  let s = u32(shrm.size);
  if (id.x >= s || id.y >= s || id.z >= 6u) {
    return;
  }
  let face = i32(id.z);
  let r = normalize(shrm_cube_face_direction(face, (vec2f(id.xy) + 0.5) / f32(s)));
  let v = normalize(shrm.view);
  let sum = shrm_global_value(face, vec2i(id.xy), r, v) + shrm_lights_at_texel(r, v);
  textureStore(shrm_out, vec2i(id.xy), face, vec4f(sum, 1.0));
}

// ---- eq. 5.10: a local SHRM, per pixel ------------------------------------------------------------

// w = Rot^T v = Ry(-alpha) Rz(-beta) v for the frame of the SH-frame direction r (unit).
fn shrm_to_local_frame(r: vec3f, v: vec3f) -> vec3f {
  let sa = length(r.xy);
  let ca = r.z;
  var cb = 1.0;
  var sb = 0.0;
  if (sa > 0.0) {
    cb = r.x / sa;
    sb = r.y / sa;
  }
  let u = vec3f(cb * v.x + sb * v.y, -sb * v.x + cb * v.y, v.z);
  return vec3f(ca * u.x - sa * u.z, u.y, sa * u.x + ca * u.z);
}

struct ShrmTexel {
  face: i32,
  xy: vec2i,
}

// The texel of `face` at integer coordinates that may lie one step outside the face: the texel of
// the adjacent face containing the extrapolated centre direction.
fn shrm_resolve_texel(face: i32, xy: vec2i) -> ShrmTexel {
  let s = shrm.size;
  if (all(xy >= vec2i(0)) && all(xy < vec2i(s))) {
    return ShrmTexel(face, xy);
  }
  let c = shrm_cube_face_coordinates(
      shrm_cube_face_direction(face, (vec2f(xy) + 0.5) / f32(s)));
  return ShrmTexel(c.face, clamp(vec2i(floor(c.st * f32(s))), vec2i(0), vec2i(s - 1)));
}

// B of texel t for the view v_sh (SH frame, unit), in the texel centre's frame.
fn shrm_local_texel(t: ShrmTexel, v_sh: vec3f) -> vec3f {
  let r = shrm_sh_frame(normalize(
      shrm_cube_face_direction(t.face, (vec2f(t.xy) + 0.5) / f32(shrm.size))));
  let y = shrm_eval_sh(shrm_to_local_frame(r, v_sh));
  var sum = vec3f(0.0);
  for (var k = 0; k < SHRM_SH_COUNT; k++) {
    sum += y[k] * shrm_coefficient(t.face, t.xy, k);
  }
  return sum;
}

// Eq. 5.10 at the index direction (R, or T; world, any length) for the view (world, unit, towards
// the viewer): the four nearest texels, each evaluated in its own frame, interpolated bilinearly.
fn shrm_local(index: vec3f, view: vec3f) -> vec3f {
  let v_sh = shrm_sh_frame(view);
  let c = shrm_cube_face_coordinates(index);
  let p = c.st * f32(shrm.size) - 0.5;
  let p0 = vec2i(floor(p));
  let f = p - vec2f(p0);
  let sum =
      (1.0 - f.x) * (1.0 - f.y) * shrm_local_texel(shrm_resolve_texel(c.face, p0), v_sh) +
      f.x * (1.0 - f.y) * shrm_local_texel(shrm_resolve_texel(c.face, p0 + vec2i(1, 0)), v_sh) +
      (1.0 - f.x) * f.y * shrm_local_texel(shrm_resolve_texel(c.face, p0 + vec2i(0, 1)), v_sh) +
      f.x * f.y * shrm_local_texel(shrm_resolve_texel(c.face, p0 + vec2i(1, 1)), v_sh);
  // SHRMs with a Fresnel table: times w(N.V), N.V = N.R where `view` is N (SHRM_VIEW_NORMAL),
  // |R + V| / 2 where it is V (conventions 4).
  let r = normalize(index);
  var cos_nv = 0.5 * length(r + view);
  if (SHRM_VIEW_NORMAL) {
    cos_nv = dot(r, view);
  }
  return sum * shrm_fresnel_at(cos_nv);
}
