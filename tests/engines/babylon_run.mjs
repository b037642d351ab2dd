// Babylon.js and gltf-validator consume the ibl.glb of `shrm ibl --containers ...,gltf` sets
// (docs/engines.md, docs/ibl.md "glTF"). Babylon runs in headless Chromium (Debian's
// /usr/bin/chromium, WebGL2 on SwiftShader, playwright-core), served from a loopback HTTP server
// started here.
//
// Usage: node babylon_run.mjs OUT_DIR WHITE_SET PATCH_SET [SET ...]
//   WHITE_SET: a set of engines_test.sh's constant white map with the same scene (size, levels).
//   PATCH_SET: a set made from patches.exr (red patch at world +X, green at +Y).
//   SET:       further sets of the same size and levels (courtyard): every check but orientation.
// Checks (PASS/FAIL lines, exit 1 on any FAIL):
//   validator:   gltf-validator's validateBytes reports 0 errors (warnings/infos counted).
//   images:      the RGBD PNG faces, decoded here (babylon_glb.mjs), hold specular.ktx2's texels
//                at the directions docs/ibl.md gives (x mirrored, rows bottom-up) within half an
//                8-bit step of the gamma-2.2 value plus the KTX2's half-float rounding.
//   default:     Babylon's glTF loader (default left-handed scene) sets scene.environmentTexture
//                from the extension; the shader variant; the scene rendered into a float target
//                (image processing "by post-process", none attached: linear, no tone mapping or
//                exposure): no NaN, no black sphere pixel, a black background; the screenshot.
//   specular:    the metallic spheres' specular term against a node render of it. Babylon 9.35
//                (pbrBlockReflection, pbrIBLFunctions) fetches textureLod(cube, R_B, lod),
//                lod = log2(S (r^2 + 0.0005)) x lodGenerationScale, S = specularImageSize, scale
//                (levels - 1) / log2(S) from the loader, R_B the reflection of its view vector
//                normalize(eye - position) (also for an orthographic camera) in its world, where
//                the loader's root node maps glTF (x, y, z) to (-x, y, z); the cube is the PNGs
//                uploaded with flipY (image row 0 = t 1), RGBD-decoded to half floats, levels past
//                the file's black. It then multiplies by an environment-BRDF factor that is not 1
//                for a white metal (measured: about 0.75 at roughness 0.5, 0.44 at 0.75, 0.015 at
//                0.99) and adds diffuse from the SH. So the page renders with the irradiance
//                polynomial zeroed and the cube as linear (gammaSpace false: by default Babylon
//                raises the decoded radiance to the power 2.2, GAMMAREFLECTION), once for this set
//                and once for WHITE_SET (a white furnace: the factor F itself), and spec / F is
//                compared with the node's trilinear textureLod (seamless: neighbouring faces'
//                texels across edges) at the mesh's own interpolated vertex normal, where F >= F_MIN.
//   diffuse:     the dielectric sphere's diffuse term against E(n) / pi of the set's own SH9. The
//                full render (the cube as linear, the light's SH) minus the specular-only render
//                is what the SH adds; divided by the same difference for WHITE_SET (E / pi = 1 at
//                every normal, so any per-pixel factor of Babylon's diffuse that does not depend
//                on the light cancels), it is the E / pi Babylon shows. The reference is computed
//                here from sh9.json's radiance_sh9 (shrm's real SH basis and frame,
//                docs/conventions.md) with the Lambert factors A_l / pi = 1, 2/3, 1/4, at the
//                mesh's interpolated vertex normal: docs/ibl_sh9.md says Babylon's default path
//                gives exactly that from the `gltf` coefficients the file carries.
//   orientation: (PATCH_SET) the red patch lights the +X side of the mirror sphere where the
//                reflection of the view hits it, and the +X side of the diffuse sphere; a copy
//                of the GLB mirrored in x (faces and SH, written here) must fail that check.
import { readFileSync, writeFileSync, mkdirSync } from 'node:fs';
import { join, resolve, basename } from 'node:path';
import { createRequire } from 'node:module';
import { checker, launchChromium, serve, openPage, requireChromium } from './harness.mjs';
import { read } from 'ktx-parse';
import { decodeCubeLevel, faceCoordinates, faceDirection, normalize, patchCentre } from './ktx_cube.mjs';
import { parseGlb, writeGlb, decodePng, encodePng, specularImages } from './babylon_glb.mjs';

const validator = createRequire(import.meta.url)('gltf-validator');
const [outDir, whiteSet, patchSet, ...otherSets] = process.argv.slice(2).map((a) => resolve(a));
if (!outDir || !patchSet) {
  console.error('usage: node babylon_run.mjs OUT_DIR WHITE_SET PATCH_SET [SET ...]');
  process.exit(2);
}
requireChromium();
mkdirSync(outDir, { recursive: true });

const { fail, check, failures } = checker();

// Tolerances.
// RGBD PNG vs specular.ktx2 (rgba16f): half an 8-bit step of v^(1/2.2) is a relative step of
// 2.2 x 0.5 / 255 / v^(1/2.2) in v, plus the KTX2's half-float rounding 2^-11.
const RGBD_STEP = 0.5 / 255;
const HALF_REL = 2 ** -11;
// Babylon vs the node render, per pixel and channel, |b - c| <= REL x c + ABS x (the sphere's
// largest value): REL covers the half-float texture (2^-11), SwiftShader's filtering and LOD
// arithmetic in float, and the interpolated normal's float rounding near the patches' sharp
// edges; ABS the same near zero. At most FRACTION of the pixels may exceed it (edges of the
// patches at roughness 0, where a 1e-4 shift of the normal moves an 8-to-0.05 step across a
// pixel, and the quotient spec / F at roughness 0.9, F about 0.15: measured 0.6-1.2%) and none
// by more than HARD x the peak (measured 0.05).
const REL = 0.02, ABS = 0.002, FRACTION = 0.02, HARD = 0.1;
// Babylon's diffuse / the white set's vs E(n) / pi, per pixel and channel:
// |b - e| <= DIFFUSE_REL x e + DIFFUSE_ABS x (the sphere's largest e). Babylon evaluates the SH
// polynomial in float, so what is left is float rounding (of the polynomial, of the two
// differences of renders, of the interpolated normal) and whatever of the specular term the
// light's SH feeds (Babylon mixes irradiance into rough reflections): measured 8e-4-1e-3 of the
// peak on average, 4.3e-3 at worst (patches and courtyard). A wrong convention moves the values
// by far more: the legacy path's band weights are checked to fail.
const DIFFUSE_REL = 0.01, DIFFUSE_ABS = 0.01;
// The white furnace's factor below which a pixel is not compared (the quotient would amplify the
// half-float rounding of both renders beyond REL).
const F_MIN = 0.1;
// The red patch spans 22 x 23 degrees and the mirror sphere's pixels are denser near its rim
// (the reflection doubles angles): the red centroid of the visible part lies within this of the
// normal that reflects the view ray into the patch's centre (the mirrored copy: about 60).
const MIRROR_DEG = 20;
// The page's camera position (Babylon and glTF z agree under the loader's root node).
const EYE_Z = 10;

// --- loopback server (harness.mjs): /engines/, /node_modules/, /set/<k>/ibl.glb ---------------
// /set/<k>/ibl.glb: the sets, then the folder of the mirrored copy.
const glbs = [whiteSet, patchSet, ...otherSets, join(outDir, 'mirrored')];
const server = await serve(glbs);
const base = server.base;

// --- geometry of the scene ----------------------------------------------------------------
const W = 768, H = 128;
function sceneOf(glb) {
  const { json } = glb;
  const spheres = json.nodes.filter((n) => n.mesh !== undefined).map((n) => {
    const mat = json.materials[json.meshes[n.mesh].primitives[0].material].pbrMetallicRoughness;
    return { x: n.translation[0], roughness: mat.roughnessFactor, metallic: mat.metallicFactor };
  });
  const halfWidth = Math.max(...spheres.map((s) => Math.abs(s.x))) + 1.25;
  const prim = json.meshes[0].primitives[0];
  const acc = (i) => json.accessors[i];
  const f32 = (a) => { const v = glb.view(a.bufferView); return new Float32Array(v.buffer.slice(v.byteOffset, v.byteOffset + a.count * 12)); };
  const pos = f32(acc(prim.attributes.POSITION)), nrm = f32(acc(prim.attributes.NORMAL));
  const iv = glb.view(acc(prim.indices).bufferView);
  const idx = new Uint16Array(iv.buffer.slice(iv.byteOffset, iv.byteOffset + acc(prim.indices).count * 2));
  // Front-facing triangles (seen from +Z), for the per-pixel normal.
  const tris = [];
  for (let t = 0; t < idx.length; t += 3) {
    const [a, b, c] = [idx[t], idx[t + 1], idx[t + 2]];
    const P = [a, b, c].map((v) => [pos[3 * v], pos[3 * v + 1], pos[3 * v + 2]]);
    const N = [a, b, c].map((v) => [nrm[3 * v], nrm[3 * v + 1], nrm[3 * v + 2]]);
    const area = (P[1][0] - P[0][0]) * (P[2][1] - P[0][1]) - (P[2][0] - P[0][0]) * (P[1][1] - P[0][1]);
    if (area > 1e-12) tris.push({ P, N, area, lo: [Math.min(P[0][0], P[1][0], P[2][0]), Math.min(P[0][1], P[1][1], P[2][1])], hi: [Math.max(P[0][0], P[1][0], P[2][0]), Math.max(P[0][1], P[1][1], P[2][1])] });
  }
  return { spheres, halfWidth, halfHeight: (halfWidth * H) / W, tris };
}
// Pixel (i, j) (j = 0 at the bottom, as readPixels returns rows) -> glTF screen point.
const screenOf = (sc, i, j) => [-sc.halfWidth + ((i + 0.5) * 2 * sc.halfWidth) / W, -sc.halfHeight + ((j + 0.5) * 2 * sc.halfHeight) / H];
// The sphere under a pixel and the interpolated vertex normal there (glTF frame), or null;
// `interior` keeps pixels within that fraction of the radius (away from the silhouette).
function pixelNormal(sc, i, j, interior) {
  const [x, y] = screenOf(sc, i, j);
  for (let k = 0; k < sc.spheres.length; ++k) {
    const u = x - sc.spheres[k].x, v = y;
    if (u * u + v * v >= interior * interior) continue;
    for (const t of sc.tris) {
      if (u < t.lo[0] || u > t.hi[0] || v < t.lo[1] || v > t.hi[1]) continue;
      const [p0, p1, p2] = t.P;
      const w1 = ((u - p0[0]) * (p2[1] - p0[1]) - (p2[0] - p0[0]) * (v - p0[1])) / t.area;
      const w2 = ((p1[0] - p0[0]) * (v - p0[1]) - (u - p0[0]) * (p1[1] - p0[1])) / t.area;
      const w0 = 1 - w1 - w2;
      if (w0 < -1e-9 || w1 < -1e-9 || w2 < -1e-9) continue;
      const n = [0, 1, 2].map((a) => w0 * t.N[0][a] + w1 * t.N[1][a] + w2 * t.N[2][a]);
      return { k, n: normalize(n) };
    }
  }
  return null;
}

// --- Babylon's cube as the node render models it -------------------------------------------
// cube[level][face] = Float32Array rgb, GL rows (t = 0 first) = the PNG's rows bottom-up.
function babylonCube(levels) {
  return levels.map((faces) => faces.map(({ size, rgb }) => {
    const out = new Float32Array(size * size * 3);
    for (let y = 0; y < size; ++y) out.set(rgb.subarray((size - 1 - y) * size * 3, (size - y) * size * 3), y * size * 3);
    return { size, rgb: out };
  }));
}
// Texel (face, x, y) of a level, x or y possibly one outside the face: then the neighbouring
// face's texel at that texel centre's direction (seamless filtering).
function texel(level, face, x, y) {
  const n = level[face].size;
  if (x >= 0 && x < n && y >= 0 && y < n) return level[face].rgb.subarray((y * n + x) * 3, (y * n + x) * 3 + 3);
  const c = faceCoordinates(faceDirection(face, (x + 0.5) / n, (y + 0.5) / n));
  const xx = Math.min(n - 1, Math.max(0, Math.floor(c.s * n))), yy = Math.min(n - 1, Math.max(0, Math.floor(c.t * n)));
  return level[c.face].rgb.subarray((yy * n + xx) * 3, (yy * n + xx) * 3 + 3);
}
function bilinear(level, d) {
  const { face, s, t } = faceCoordinates(d);
  const n = level[face].size;
  const u = s * n - 0.5, v = t * n - 0.5, x0 = Math.floor(u), y0 = Math.floor(v), fx = u - x0, fy = v - y0;
  const out = [0, 0, 0];
  for (const [dx, dy, w] of [[0, 0, (1 - fx) * (1 - fy)], [1, 0, fx * (1 - fy)], [0, 1, (1 - fx) * fy], [1, 1, fx * fy]]) {
    const tx = texel(level, face, x0 + dx, y0 + dy);
    for (let c = 0; c < 3; ++c) out[c] += w * tx[c];
  }
  return out;
}
function trilinear(cube, d, lod) {
  const lo = Math.max(0, Math.floor(lod)), f = Math.max(0, lod - lo);
  const at = (l) => (l < cube.length ? bilinear(cube[l], d) : [0, 0, 0]);
  const a = at(lo);
  if (f === 0) return a;
  const b = at(lo + 1);
  return a.map((v, c) => (1 - f) * v + f * b[c]);
}

// --- the mirrored negative control -----------------------------------------------------------
// Every face image mirrored in x (faces +X and -X swapped, columns reversed) and the SH's x-odd
// terms (Babylon's basis x, xy, xz: indices 3, 4, 7) negated: the same light seen in a mirror.
function mirroredGlb(glb) {
  const json = JSON.parse(JSON.stringify(glb.json));
  const light = json.extensions.EXT_lights_image_based.lights[0];
  const views = json.bufferViews.map((_, v) => Buffer.from(glb.view(v)));
  for (const faces of light.specularImages) {
    for (const i of faces) {
      const img = decodePng(views[json.images[i].bufferView]);
      const n = img.width, ch = img.channels, px = new Uint8Array(img.px.length);
      for (let y = 0; y < n; ++y) for (let x = 0; x < n; ++x) for (let c = 0; c < ch; ++c) px[(y * n + x) * ch + c] = img.px[(y * n + n - 1 - x) * ch + c];
      views[json.images[i].bufferView] = encodePng(n, n, ch, px);
    }
    [faces[0], faces[1]] = [faces[1], faces[0]];
  }
  for (const i of [3, 4, 7]) light.irradianceCoefficients[i] = light.irradianceCoefficients[i].map((v) => -v);
  let offset = 0;
  const parts = [];
  views.forEach((b, v) => {
    const pad = (4 - (offset % 4)) % 4;
    parts.push(Buffer.alloc(pad), b);
    offset += pad;
    json.bufferViews[v].byteOffset = offset;
    json.bufferViews[v].byteLength = b.length;
    offset += b.length;
  });
  const bin = Buffer.concat(parts);
  json.buffers[0].byteLength = bin.length + ((4 - (bin.length % 4)) % 4);
  return writeGlb(json, bin);
}

// --- screenshots --------------------------------------------------------------------------------
function screenshot(name, pixels) {
  const px = new Uint8Array(W * H * 3);
  for (let j = 0; j < H; ++j) for (let i = 0; i < W; ++i) for (let c = 0; c < 3; ++c) {
    const v = pixels[4 * ((H - 1 - j) * W + i) + c];
    px[3 * (j * W + i) + c] = Math.round(255 * Math.min(1, Math.max(0, v)) ** (1 / 2.2));
  }
  writeFileSync(join(outDir, name), encodePng(W, H, 3, px));
}


// One render of GLB `ci` by the page: the float pixels and what Babylon reports.
async function babylonRender(ci, sc, linearEnv, specularOnly) {
  const res = await page.evaluate(([u, w, h, hw, hh, lin, so]) => window.shrmBabylon.render(u, w, h, hw, hh, lin, so),
    [`/set/${ci}/ibl.glb`, W, H, sc.halfWidth, sc.halfHeight, linearEnv, specularOnly]);
  return { img: Float32Array.from(res.pixels), info: res.info };
}

// Babylon's default render of a set: the loader's environment, the shader variant, no NaN, no
// black sphere pixel, a black background; the screenshot.
function checkDefaultRender(name, res, sc, light, S, scale) {
  const { img, info } = res;
  console.log(`INFO: Babylon ${name}: environmentTexture ${info.environment} size ${info.size}, level (intensity) ${info.level}, lodGenerationScale ${info.lodGenerationScale?.toFixed(4)}, texture type ${info.textureType} (2 = half float), RGBD kept ${info.isRGBD}, material ${info.material}, glTF root node ${JSON.stringify(info.root)}, defines: ${info.defines.join(' ')}`);
  console.log(`INFO: Babylon ${name}: meshes ${info.meshes.map((m) => `${m.name} at (${m.centre.map((v) => v.toFixed(2))}) roughness ${m.roughness} metallic ${m.metallic}`).join('; ')}`);
  check(info.environment !== null && Math.abs(info.lodGenerationScale - scale) < 1e-9 && info.size === S && info.level === light.intensity,
    `Babylon ${name}: the glTF loader's EXT_lights_image_based sets scene.environmentTexture (${info.environment}, size ${info.size}, level ${info.level}, lodGenerationScale ${info.lodGenerationScale?.toFixed(4)} = (levels - 1) / log2(size))`);
  const has = (d) => info.defines.some((x) => x.startsWith(`#define ${d}`));
  check(has('LODBASEDMICROSFURACE') && !has('LODINREFLECTIONALPHA') && !has('LINEARSPECULARREFLECTION') && !has('REALTIME_FILTERING') && !has('RGBDREFLECTION') && has('IMAGEPROCESSINGPOSTPROCESS') && !has('REFLECTIONMAP_OPPOSITEZ') && !has('SPECULARAA') && has('USESPHERICALFROMREFLECTIONMAP'),
    `Babylon ${name}: the shader variant the node render models (LODBASEDMICROSFURACE without LODINREFLECTIONALPHA / LINEARSPECULARREFLECTION / REALTIME_FILTERING / OPPOSITEZ / SPECULARAA, the cube decoded from RGBD at load, diffuse from the light's SH, linear output); GAMMAREFLECTION ${has('GAMMAREFLECTION') ? 'set (Babylon applies x^2.2 to the decoded radiance)' : 'not set'}`);
  screenshot(`babylon_${name}.png`, img);
  let nonFinite = 0, black = 0, spherePx = 0, bgLit = 0;
  for (let j = 0; j < H; ++j) for (let i = 0; i < W; ++i) {
    const p = img.subarray(4 * (j * W + i), 4 * (j * W + i) + 3);
    nonFinite += [...p].filter((v) => !Number.isFinite(v)).length;
    const [x, y] = screenOf(sc, i, j);
    const inAny = sc.spheres.some((s) => (x - s.x) ** 2 + y * y < 0.97 ** 2);
    const nearAny = sc.spheres.some((s) => (x - s.x) ** 2 + y * y < 1.03 ** 2);
    if (inAny) { spherePx++; if (Math.max(...p) <= 0) black++; } else if (!nearAny && Math.max(...p) !== 0) bgLit++;
  }
  check(nonFinite === 0 && black === 0 && bgLit === 0, `Babylon ${name} (default scene, as a viewer shows it): ${W}x${H} float image: ${nonFinite} NaN/inf values, ${black} of ${spherePx} sphere pixels black, ${bgLit} lit background pixels`);
}

// The specular term against the node render: `spec` and `white` are Babylon's renders (the
// cube as linear, irradiance zero) of this set and of the white set (constant radiance 1, same
// scene); white = Babylon's environment-BRDF factor F at each pixel (a white furnace), so
// spec / white is the radiance Babylon fetched, compared with the node's trilinear textureLod of
// the decoded cube at R_B and Babylon's lod, where F >= F_MIN.
function compareSpecular(name, spec, white, sc, cube, light, S, scale) {
  let compared = 0, over = 0, worstHard = 0, skipped = 0;
  const perSphere = sc.spheres.map(() => ({ peak: 0, sum: 0, n: 0, worst: 0, fmin: Infinity, fmax: 0 }));
  const pix = [];
  for (let j = 0; j < H; ++j) for (let i = 0; i < W; ++i) {
    const hit = pixelNormal(sc, i, j, 0.95);
    if (!hit || sc.spheres[hit.k].metallic !== 1) continue;
    const s = sc.spheres[hit.k], n = hit.n;
    // Babylon's view vector is normalize(eye - position) even for an orthographic camera.
    const V = normalize([-(s.x + n[0]), -n[1], EYE_Z - n[2]]);
    const nv = n[0] * V[0] + n[1] * V[1] + n[2] * V[2];
    const R = [0, 1, 2].map((a) => 2 * nv * n[a] - V[a]);
    const lod = Math.log2(S * (s.roughness * s.roughness + 0.0005)) * scale;
    const want = trilinear(cube, [-R[0], R[1], R[2]], lod).map((v) => v * light.intensity);
    const F = white.img[4 * (j * W + i)];
    const st = perSphere[hit.k];
    st.fmin = Math.min(st.fmin, F); st.fmax = Math.max(st.fmax, F);
    if (!(F >= F_MIN)) { skipped++; continue; }
    st.peak = Math.max(st.peak, ...want);
    pix.push([hit.k, want, [0, 1, 2].map((c) => spec.img[4 * (j * W + i) + c] / F)]);
  }
  for (const [k, want, got] of pix) {
    const st = perSphere[k];
    let o = false;
    for (let c = 0; c < 3; ++c) {
      const d = Math.abs(got[c] - want[c]);
      st.sum += d / st.peak; st.n++;
      st.worst = Math.max(st.worst, d / st.peak);
      worstHard = Math.max(worstHard, d / st.peak);
      if (d > REL * want[c] + ABS * st.peak) o = true;
    }
    compared++;
    if (o) over++;
  }
  const stats = perSphere.map((st, k) => (sc.spheres[k].metallic === 1 ? `roughness ${sc.spheres[k].roughness.toFixed(3)} (F ${st.fmin.toFixed(3)}..${st.fmax.toFixed(3)}): mean ${st.n ? (st.sum / st.n).toExponential(1) : '-'} worst ${st.n ? st.worst.toExponential(1) : '-'} of peak ${st.peak.toFixed(3)}` : null)).filter(Boolean);
  check(compared > 0 && over <= FRACTION * compared && worstHard <= HARD,
    `Babylon ${name} specular term / white-furnace factor vs the node render (trilinear textureLod of the decoded cube at R_B, lod = log2(S (r^2 + 0.0005)) x ${scale.toFixed(4)}): ${compared} metallic-sphere pixels (${skipped} with F < ${F_MIN} skipped), ${over} (${((100 * over) / compared).toFixed(2)}%) beyond ${REL} x value + ${ABS} x peak (allowed ${100 * FRACTION}%), worst ${worstHard.toExponential(2)} of the peak (limit ${HARD}); per sphere |diff| / peak: ${stats.join('; ')}`);
}

// E(n) / pi of real SH9 radiance coefficients L[i][rgb] (i = l (l + 1) + m) in shrm's basis, at a
// unit world normal n (glTF's world is shrm's: sh9.json's gltf frame_from_world is the identity):
// SH frame (x, -z, y) (ShFrameFromWorld), real SH with the Condon-Shortley phase, A_l / pi.
function shIrradianceOverPi(L, n, bands = [1, 2 / 3, 0.25]) {
  const [x, y, z] = [n[0], -n[2], n[1]];
  const k0 = 0.5 / Math.sqrt(Math.PI), k1 = Math.sqrt(3 / (4 * Math.PI));
  const k2 = 0.5 * Math.sqrt(15 / Math.PI), k20 = 0.25 * Math.sqrt(5 / Math.PI), k22 = 0.25 * Math.sqrt(15 / Math.PI);
  const Y = [k0, -k1 * y, k1 * z, -k1 * x, k2 * x * y, -k2 * y * z, k20 * (3 * z * z - 1), -k2 * x * z, k22 * (x * x - y * y)];
  const A = [0, 1, 1, 1, 2, 2, 2, 2, 2].map((l) => bands[l]);
  return [0, 1, 2].map((c) => Y.reduce((sum, y_i, i) => sum + A[i] * L[i][c] * y_i, 0));
}

// The diffuse term: (full - spec) / (whiteFull - whiteSpec) on the dielectric sphere against
// E(n) / pi x the light's intensity. The same pixels against Babylon's legacy polynomial path
// (bands weighed (A_l / pi)^2: 1, 4/9, 1/16, docs/ibl_sh9.md) must fail: the check can tell the
// conventions apart.
function compareDiffuse(name, full, spec, whiteFull, whiteSpec, sc, sh9, light) {
  const L = sh9.radiance_sh9;
  const pix = [];
  for (let j = 0; j < H; ++j) for (let i = 0; i < W; ++i) {
    const hit = pixelNormal(sc, i, j, 0.95);
    if (!hit || sc.spheres[hit.k].metallic !== 0) continue;
    const q = 4 * (j * W + i);
    const got = [0, 1, 2].map((c) => (full.img[q + c] - spec.img[q + c]) / (whiteFull.img[q + c] - whiteSpec.img[q + c]));
    pix.push([hit.n, got]);
  }
  const against = (bands) => {
    const want = pix.map(([n]) => shIrradianceOverPi(L, n, bands).map((v) => v * light.intensity));
    const peak = Math.max(...want.flat());
    let over = 0, worst = 0, sum = 0;
    pix.forEach(([, got], k) => {
      let o = false;
      for (let c = 0; c < 3; ++c) {
        const d = Math.abs(got[c] - want[k][c]);
        worst = Math.max(worst, d / peak);
        sum += d / peak;
        if (!(d <= DIFFUSE_REL * want[k][c] + DIFFUSE_ABS * peak)) o = true;
      }
      if (o) over++;
    });
    return { over, worst, mean: sum / (3 * pix.length), peak };
  };
  const r = against([1, 2 / 3, 0.25]);
  const legacy = against([1, 4 / 9, 1 / 16]);
  check(pix.length > 0 && r.over === 0 && legacy.over > 0,
    `Babylon ${name} diffuse term (full render - specular-only render, over the same for the white set) vs E(n) / pi of the set's radiance_sh9 (A_l / pi = 1, 2/3, 1/4): ${pix.length} dielectric-sphere pixels, ${r.over} beyond ${DIFFUSE_REL} x value + ${DIFFUSE_ABS} x peak (peak ${r.peak.toFixed(4)}), |diff| / peak mean ${r.mean.toExponential(2)} worst ${r.worst.toExponential(2)}; against the legacy path's weights 1, 4/9, 1/16: ${legacy.over} pixels beyond, worst ${legacy.worst.toExponential(2)} of the peak`);
}

let whiteRender = null;
let whiteFullRender = null;


// --- the checks for one set ---------------------------------------------------------------------
const deg = (a, b) => (Math.acos(Math.max(-1, Math.min(1, a[0] * b[0] + a[1] * b[1] + a[2] * b[2]))) * 180) / Math.PI;

async function checkSet(dir, withOrientation) {
  const name = basename(dir);
  const bytes = new Uint8Array(readFileSync(join(dir, 'ibl.glb')));
  // 1. gltf-validator.
  const report = await validator.validateBytes(bytes, { uri: 'ibl.glb', maxIssues: 100 });
  const is = report.issues;
  const msgs = is.messages.map((m) => `${m.code} ${m.pointer ?? ''}: ${m.message}`);
  check(is.numErrors === 0, `gltf-validator ${report.validatorVersion} ${name}/ibl.glb: ${is.numErrors} errors, ${is.numWarnings} warnings, ${is.numInfos} infos, ${is.numHints} hints${msgs.length ? ` (${[...new Set(msgs)].slice(0, 6).join('; ')})` : ''}`);

  // 2. the RGBD faces against specular.ktx2.
  const glb = parseGlb(bytes);
  const light = glb.json.extensions.EXT_lights_image_based.lights[0];
  const levels = specularImages(glb);
  const ktx = read(new Uint8Array(readFileSync(join(dir, 'specular.ktx2'))));
  let worst = 0, bad = 0, count = 0, clamped = 0;
  levels.forEach((faces, k) => {
    const ref = decodeCubeLevel(ktx.levels[k].levelData, ktx.vkFormat, Math.max(1, ktx.pixelWidth >> k));
    faces.forEach(({ size: n, img }, f) => {
      for (let row = 0; row < n; ++row) for (let col = 0; col < n; ++col) {
        // docs/ibl.md "glTF": image (f, col, row) = the GL texel (f', n-1-col, n-1-row) with +X
        // and -X swapped (the mirror x -> -x), written as an index map here.
        const sf = f === 0 ? 1 : f === 1 ? 0 : f;
        const r = ref.faces[sf].subarray(((n - 1 - row) * n + (n - 1 - col)) * 4, ((n - 1 - row) * n + (n - 1 - col)) * 4 + 3);
        const mx = Math.max(r[0], r[1], r[2], 1e-6);
        if (mx > 255) { clamped++; continue; }
        const d = Math.min(255, Math.max(1, Math.floor(255 / mx)));
        const p = img.px.subarray((row * n + col) * 4, (row * n + col) * 4 + 4);
        count++;
        let ok = p[3] === d;
        for (let c = 0; c < 3; ++c) {
          const exact = Math.min(1, (r[c] * d) / 255) ** (1 / 2.2);
          // The KTX2 value is the half-rounded one; the GLB's was made from the same stored value.
          const e = Math.abs(p[c] / 255 - exact) - HALF_REL * exact;
          worst = Math.max(worst, e);
          if (!(e <= RGBD_STEP + 1e-6)) ok = false;
        }
        if (!ok) bad++;
      }
    });
  });
  check(bad === 0 && levels.length === ktx.levels.length && light.specularImageSize === ktx.pixelWidth,
    `${name}/ibl.glb: ${levels.length} levels x 6 RGBD PNG faces (specularImageSize ${light.specularImageSize}) = specular.ktx2's ${count} texels at the documented directions within half an 8-bit step of v^(1/2.2) (worst ${worst.toExponential(2)}, bound ${RGBD_STEP.toExponential(2)}; ${bad} differ, ${clamped} above 255 skipped)`);

  // 3. Babylon.
  const sc = sceneOf(glb);
  const cube = babylonCube(levels);
  const S = light.specularImageSize, scale = (levels.length - 1) / Math.log2(S);
  const ci = glbs.indexOf(dir);
  const def = await babylonRender(ci, sc, false, false);
  checkDefaultRender(name, def, sc, light, S, scale);
  const spec = await babylonRender(ci, sc, true, true);
  if (!whiteRender) {
    const wb = readFileSync(join(whiteSet, 'ibl.glb'));
    const wsc = sceneOf(parseGlb(new Uint8Array(wb)));
    check(wsc.spheres.length === sc.spheres.length && wsc.spheres.every((s, k) => s.x === sc.spheres[k].x && s.roughness === sc.spheres[k].roughness),
      `white-furnace set ${basename(whiteSet)}: the same scene (sphere positions and roughness) as ${name}`);
    whiteRender = await babylonRender(0, wsc, true, true);
    whiteFullRender = await babylonRender(0, wsc, true, false);
    screenshot(`babylon_${basename(whiteSet)}_specular.png`, whiteRender.img);
  }
  compareSpecular(name, spec, whiteRender, sc, cube, light, S, scale);
  const full = await babylonRender(ci, sc, true, false);
  const sh9 = JSON.parse(readFileSync(join(dir, 'sh9.json'), 'utf8'));
  check(sh9.sh_window.width === 0, `${name}/sh9.json: no SH window applied (the coefficients in ibl.glb are A_l x radiance_sh9)`);
  compareDiffuse(name, full, spec, whiteFullRender, whiteRender, sc, sh9, light);
  return { img: def.img, sc, glb };
}

// Where the red is on each sphere: the centroid of (red - the sphere's min red) over the pixel
// normals (glTF frame).
function redCentroids(img, sc) {
  const out = sc.spheres.map(() => ({ lo: Infinity, c: [0, 0, 0], w: 0, pix: [] }));
  for (let j = 0; j < H; ++j) for (let i = 0; i < W; ++i) {
    const [x, y] = screenOf(sc, i, j);
    for (let k = 0; k < sc.spheres.length; ++k) {
      const u = x - sc.spheres[k].x;
      if (u * u + y * y >= 0.95 ** 2) continue;
      const n = [u, y, Math.sqrt(1 - u * u - y * y)];
      const r = img[4 * (j * W + i)];
      out[k].lo = Math.min(out[k].lo, r);
      out[k].pix.push([n, r]);
    }
  }
  return out.map((o) => {
    for (const [n, r] of o.pix) { const w = r - o.lo; for (let a = 0; a < 3; ++a) o.c[a] += w * n[a]; o.w += w; }
    return normalize(o.c);
  });
}
function orientation(img, sc) {
  const RED = patchCentre('R');
  const cents = redCentroids(img, sc);
  // Mirror sphere (level 0): the normal reflecting the camera ray (0, 0, -1) into the patch.
  const nMirror = normalize([RED[0], RED[1], RED[2] + 1]);
  const k0 = 0, kd = sc.spheres.length - 1;
  return {
    mirror: deg(cents[k0], nMirror), mirrorX: cents[k0][0],
    diffuseX: cents[kd][0], diffuse: deg(cents[kd], normalize([RED[0], RED[1], Math.max(RED[2], 0) + 0.3])),
    ok: deg(cents[k0], nMirror) < MIRROR_DEG && cents[k0][0] > 0 && cents[kd][0] > 0.3,
  };
}

// --- main ---------------------------------------------------------------------------------------
const browser = await launchChromium();
let consoleLog = [];
let page;
try {
  ({ page, log: consoleLog } = await openPage(browser, `${base}/engines/babylon_page.html`, W, H));
  const info = await page.evaluate(() => window.shrmBabylon.info());
  check(info.webgl2 === 2 && info.floatRender, `browser: ${await browser.version()}, Babylon.js ${info.version}, WebGL${info.webgl2}, ${info.renderer}, float render targets ${info.floatRender}`);
  const t0 = Date.now();
  const first = await checkSet(patchSet, true);
  const o = orientation(first.img, first.sc);
  check(o.ok, `orientation ${basename(patchSet)} in Babylon: red on the mirror sphere centred ${o.mirror.toFixed(1)} deg from the normal that reflects the view ray into the red patch (want < ${MIRROR_DEG}; centroid x ${o.mirrorX.toFixed(2)} > 0), red on the diffuse sphere towards +X (centroid x ${o.diffuseX.toFixed(2)} > 0.3)`);
  // Negative control: the mirrored copy must fail the orientation check.
  const mirrored = mirroredGlb(first.glb);
  mkdirSync(join(outDir, 'mirrored'), { recursive: true });
  writeFileSync(join(outDir, 'mirrored', 'ibl.glb'), mirrored);
  const mi = glbs.length - 1;
  const res = await page.evaluate(([u, w, h, hw, hh]) => window.shrmBabylon.render(u, w, h, hw, hh, false, false), [`/set/${mi}/ibl.glb`, W, H, first.sc.halfWidth, first.sc.halfHeight]);
  const mimg = Float32Array.from(res.pixels);
  screenshot(`babylon_${basename(patchSet)}_mirrored.png`, mimg);
  const mo = orientation(mimg, first.sc);
  check(!mo.ok, `negative control: a copy of ${basename(patchSet)}/ibl.glb mirrored in x (faces and SH) fails the orientation check in Babylon (mirror sphere ${mo.mirror.toFixed(1)} deg, centroid x ${mo.mirrorX.toFixed(2)}; diffuse centroid x ${mo.diffuseX.toFixed(2)})`);
  for (const set of otherSets) await checkSet(set, false);
  console.log(`INFO: Babylon checks took ${((Date.now() - t0) / 1000).toFixed(1)} s; screenshots in ${outDir}: ${[patchSet, ...otherSets].map((s) => `babylon_${basename(s)}.png`).join(' ')} babylon_${basename(patchSet)}_mirrored.png`);
} catch (e) {
  fail(`babylon: ${e.stack ?? e}`);
} finally {
  writeFileSync(join(outDir, 'babylon_console.log'), consoleLog.join('\n') + '\n');
  await browser.close();
  server.close();
}
console.log(`babylon: ${failures() === 0 ? 'all checks passed' : `${failures()} check(s) failed`}`);
process.exit(failures() === 0 ? 0 : 1);
