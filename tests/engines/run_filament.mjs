// Filament (npm `filament` 1.53, WASM) in headless Chromium (Debian's /usr/bin/chromium, WebGL2 on
// SwiftShader, driven by playwright-core) loads `shrm ibl --containers ktx1` sets the way its
// samples load cmgen's files (createIblFromKtx1 with the "sh" key's irradiance, createSkyFromKtx1)
// and renders spheres through gltfio's ubershader materials; files served from a loopback HTTP
// server started here. Post-processing is off (no tone mapping, dithering or anti-aliasing) and the
// exposure is 1, so a pixel is intensity x the shaded radiance, in 8 bits. See docs/engines.md.
//
// Usage: node run_filament.mjs OUT_DIR WHITE_SET PATCH_SET [REAL_SET ...] [--broken BROKEN_SET ...]
//   WHITE_SET:  a set of a constant map (radiance 1) with --containers ktx1: the white furnace.
//   PATCH_SET:  a set of engines_test.sh's patches.exr (red at world +X) with ktx1 and ktx2.
//   REAL_SET:   sets of real maps (courtyard) with ktx1 and ktx2.
//   BROKEN_SET: copies of PATCH_SET whose ibl.ktx and skybox.ktx faces are mirrored
//               (break_set.mjs): the orientation checks must reject them (negative controls).
// Checks (PASS/FAIL lines, exit 1 on any FAIL):
//   furnace:     a metallic white sphere at each level's roughness shows intensity x 1 (Filament's
//                multiscatter DFG with energy compensation: E x compensation = 1 for f0 = 1).
//   sky:         the skybox seen along Filament's -X (where cmgen puts a lat-long map's +X) and
//                +X against the patches map looked up in node at each pixel's world direction
//                (n = (-x, y, -z), docs/ibl.md): the red patch where the map has it.
//   spheres:     metallic white spheres at each level's roughness k >= 1 against a CPU render
//                of Filament's shading from specular.ktx2 (the KTX2 file, in the world frame):
//                intensity x the chain sampled trilinearly at Filament's lod and lookup
//                direction (light_indirect.fs: lod = (levels - 1) r (2 - r), the reflection
//                bent towards the normal by roughness^4; r after gltfio's geometric specular
//                anti-aliasing); red on the side facing the patch.
//   diffuse:     a white dielectric sphere at roughness 1: Filament's evaluateIBL with the "sh"
//                key through its own SH formula, the chain and dfg.ktx2.
import { readFileSync, writeFileSync, mkdirSync } from 'node:fs';
import { join, resolve, basename } from 'node:path';
import { read } from 'ktx-parse';
import { HERE, checker, launchChromium, serve, openPage, requireChromium } from './harness.mjs';
import { decodeKtx1 } from './ktx1.mjs';
import { decodeCubeLevel, faceCoordinates, halfToFloat, latLongUv, normalize, patchesPixel, PATCHES } from './ktx_cube.mjs';

const groups = { '': [], '--broken': [] };
let group = '';
for (const a of process.argv.slice(2)) {
  if (a in groups) group = a;
  else groups[group].push(resolve(a));
}
const [outDir, whiteSet, patchSet, ...realSets] = groups[''];
const brokenSets = groups['--broken'];
if (!outDir || !whiteSet || !patchSet) {
  console.error('usage: node run_filament.mjs OUT_DIR WHITE_SET PATCH_SET [REAL_SET ...] [--broken SET ...]');
  process.exit(2);
}
requireChromium();
mkdirSync(outDir, { recursive: true });

const { pass, fail, check, failures } = checker();

// Tolerances (8-bit output of linear values, 0..255).
const FURNACE_TOL = 1;      // rounding of intensity x 1 to 8 bits, +-1 for the rasterizer's
const SPHERE_ABS = 2;       // 8-bit rounding (0.5) + half-float storage and GPU filtering (SwiftShader
const SPHERE_REL = 0.02;    //  8-bit filtering weights, seamless cube edges): per pixel
const SPHERE_FRACTION = 0.99;  // of the compared pixels within it; the rest near texel/face seams
const CLIP = 250;           // expected values above this are clipped by the 8-bit target: skipped
const SUBTEXEL = 1 / 32;    // half a step of 4-bit bilinear weights (GL ES 3.0's minimum subtexel
                            // precision), times the spread of the four taps

const sets = [whiteSet, patchSet, ...realSets, ...brokenSets];
const server = await serve(sets);
const base = server.base;

// --- node-side references ---------------------------------------------------------------------
// Filament's frame from the world's (docs/ibl.md "KTX1 for Filament"): n = (-x, y, -z).
const worldOf = (n) => [-n[0], n[1], -n[2]];
const S = 128, VIEW = 1.1;
// Sphere pixel (i, j) (row j = 0 at the top) -> the unit normal in Filament's frame, or null
// (orthographic camera at +Z looking at -Z, +Y up; radius 1).
function sphereNormal(i, j, rmax = 0.95) {
  const x = -VIEW + ((i + 0.5) * 2 * VIEW) / S, y = VIEW - ((j + 0.5) * 2 * VIEW) / S;
  const r2 = x * x + y * y;
  return r2 < rmax * rmax ? [x, y, Math.sqrt(1 - r2)] : null;
}
const reflect = (n) => [2 * n[2] * n[0], 2 * n[2] * n[1], 2 * n[2] * n[2] - 1];  // V = +Z
// Filament's lookup direction (light_indirect.fs getSpecularDominantDirection): mix(r, n, a^2),
// a = roughness^2 (pixel.roughness); not normalized (the cube lookup does not need it).
const dominant = (n, roughness) => {
  const r = reflect(n), w = roughness ** 4;
  return [0, 1, 2].map((c) => (1 - w) * r[c] + w * n[c]);
};
// gltfio's materials use Filament's geometric specular anti-aliasing (shading_parameters.fs
// normalFiltering, the defaults variance 0.15 and threshold 0.2): the roughness seen by the IBL
// grows with the screen-space change of the normal. On this sphere dN/dx = (1, 0, -x/z) and
// dN/dy = (0, 1, -y/z) per unit of view, times the pixel size.
const SAA_VARIANCE = 0.15, SAA_THRESHOLD = 0.2;
function filamentRoughness(perceptual, n) {
  const h = (2 * VIEW) / S, z2 = n[2] * n[2];
  const variance = SAA_VARIANCE * h * h * (2 + (n[0] * n[0] + n[1] * n[1]) / z2);
  const kernel = Math.min(2 * variance, SAA_THRESHOLD);
  const a = perceptual * perceptual;
  return Math.sqrt(Math.sqrt(Math.min(1, a * a + kernel)));
}
// Sky pixel (i, j) -> the view direction in Filament's frame (camera at the origin looking along
// `look` (an axis), +Y up, 90 degree vertical field of view).
function skyDirection(i, j, look) {
  const x = -1 + ((i + 0.5) * 2) / S, y = 1 - ((j + 0.5) * 2) / S;
  const right = normalize([-look[2], 0, look[0]]);  // look x up
  return normalize([0, 1, 2].map((a) => look[a] + x * right[a] + y * [0, 1, 0][a]));
}
// Bilinear lookup of a decoded cube level (six RGBA faces) inside the direction's face, and how
// far (in texels) the lookup is from that face's edge.
function sampleBilinear(level, d) {
  const { face, s, t } = faceCoordinates(d);
  const n = level.size;
  const fx = Math.min(n - 1, Math.max(0, s * n - 0.5)), fy = Math.min(n - 1, Math.max(0, t * n - 0.5));
  const x0 = Math.floor(fx), y0 = Math.floor(fy), x1 = Math.min(n - 1, x0 + 1), y1 = Math.min(n - 1, y0 + 1);
  const ax = fx - x0, ay = fy - y0;
  const f = level.faces[face];
  const at = (x, y, c) => f[(y * n + x) * 4 + c];
  const rgb = [0, 1, 2].map((c) => (1 - ay) * ((1 - ax) * at(x0, y0, c) + ax * at(x1, y0, c)) + ay * ((1 - ax) * at(x0, y1, c) + ax * at(x1, y1, c)));
  const edge = Math.min(s * n, (1 - s) * n, t * n, (1 - t) * n);
  // The spread of the four taps per channel: a GPU quantizes the bilinear weights (GL ES 3.0 asks
  // for 4 bits of subtexel precision), so its result may differ from the exact weights by up to
  // half a step of that spread.
  const spread = [0, 1, 2].map((c) => {
    const v = [at(x0, y0, c), at(x1, y0, c), at(x0, y1, c), at(x1, y1, c)];
    return Math.max(...v) - Math.min(...v);
  });
  return { rgb, edge, spread };
}
// What Filament's shader reads for a metallic pixel of normal n (light_indirect.fs
// prefilteredRadiance): the cube at lod = (levels - 1) r (2 - r), trilinear, at the dominant
// direction, r the anti-aliased perceptual roughness.
function filamentSpecular(cube, perceptual, n) {
  const r = filamentRoughness(perceptual, n);
  const lod = Math.min(cube.length - 1, (cube.length - 1) * r * (2 - r));
  const k0 = Math.floor(lod), k1 = Math.min(cube.length - 1, k0 + 1), f = lod - k0;
  const d = worldOf(dominant(n, r));
  const a = sampleBilinear(cube[k0], d), b = sampleBilinear(cube[k1], d);
  return {
    rgb: [0, 1, 2].map((c) => (1 - f) * a.rgb[c] + f * b.rgb[c]),
    edge: Math.min(a.edge, b.edge),
    spread: [0, 1, 2].map((c) => Math.max(a.spread[c], b.spread[c])),
  };
}

function loadKtx2Cube(file) {
  const c = read(new Uint8Array(readFileSync(file)));
  return c.levels.map((l, k) => decodeCubeLevel(l.levelData, c.vkFormat, Math.max(1, c.pixelWidth >> k)));
}
const mapPixel = (d) => {  // the patches map at world direction d (nearest pixel)
  const { u, v } = latLongUv(d);
  const i = Math.min(PATCHES.width - 1, Math.floor(u * PATCHES.width));
  const j = Math.min(PATCHES.height - 1, Math.floor(v * PATCHES.height));
  return patchesPixel(i, j);
};
// Centroid (pixel coordinates) and count of the pixels where `red(i, j)` holds.
function centroid(pred) {
  let n = 0, ci = 0, cj = 0;
  for (let j = 0; j < S; ++j) for (let i = 0; i < S; ++i) if (pred(i, j)) { n++; ci += i; cj += j; }
  return n ? { n, i: ci / n, j: cj / n } : { n: 0, i: NaN, j: NaN };
}
const isRed = (rgb) => rgb[0] > 2 * rgb[1] + 10 && rgb[0] > 2 * rgb[2] + 10;
const px = (img, i, j) => img.rgba.slice(4 * (j * S + i), 4 * (j * S + i) + 3);

async function render(options, shot) {
  const img = await page.evaluate((o) => window.shrmFilament.render(o), options);
  if (shot) writePng(join(outDir, shot), img);
  return img;
}

// A minimal PNG writer (stored deflate blocks, no compression) for the screenshots.
function writePng(file, img) {
  const crcTable = Array.from({ length: 256 }, (_, n) => {
    let c = n;
    for (let k = 0; k < 8; ++k) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
    return c >>> 0;
  });
  const crc = (buf) => { let c = 0xffffffff; for (const b of buf) c = crcTable[(c ^ b) & 0xff] ^ (c >>> 8); return (c ^ 0xffffffff) >>> 0; };
  const chunk = (type, data) => {
    const out = Buffer.alloc(12 + data.length);
    out.writeUInt32BE(data.length, 0); out.write(type, 4, 'ascii'); data.copy(out, 8);
    out.writeUInt32BE(crc(out.subarray(4, 8 + data.length)), 8 + data.length);
    return out;
  };
  const raw = Buffer.alloc(img.height * (1 + img.width * 4));
  for (let y = 0; y < img.height; ++y) {
    raw[y * (1 + img.width * 4)] = 0;
    for (let x = 0; x < img.width * 4; ++x) raw[y * (1 + img.width * 4) + 1 + x] = img.rgba[y * img.width * 4 + x];
  }
  const blocks = [];
  for (let o = 0; o < raw.length; o += 65535) {
    const part = raw.subarray(o, o + 65535);
    const h = Buffer.from([o + 65535 >= raw.length ? 1 : 0, part.length & 0xff, part.length >> 8, ~part.length & 0xff, (~part.length >> 8) & 0xff]);
    blocks.push(h, part);
  }
  let a = 1, b = 0;
  for (const v of raw) { a = (a + v) % 65521; b = (b + a) % 65521; }
  const adler = Buffer.alloc(4); adler.writeUInt32BE(((b << 16) | a) >>> 0);
  const ihdr = Buffer.alloc(13);
  ihdr.writeUInt32BE(img.width, 0); ihdr.writeUInt32BE(img.height, 4); ihdr[8] = 8; ihdr[9] = 6;
  writeFileSync(file, Buffer.concat([Buffer.from([137, 80, 78, 71, 13, 10, 26, 10]), chunk('IHDR', ihdr),
    chunk('IDAT', Buffer.concat([Buffer.from([0x78, 0x01]), ...blocks, adler])), chunk('IEND', Buffer.alloc(0))]));
}

// --- the checks -------------------------------------------------------------------------------
async function checkFiles(si, name) {
  const ibl = decodeKtx1(new Uint8Array(readFileSync(join(sets[si], 'ibl.ktx'))));
  const sky = decodeKtx1(new Uint8Array(readFileSync(join(sets[si], 'skybox.ktx'))));
  const json = JSON.parse(readFileSync(join(sets[si], 'ibl.json'), 'utf8'));
  const sh = ibl.kv.sh.trim().split(/\s+/).map(Number);
  check(ibl.header.numberOfFaces === 6 && ibl.header.numberOfMipmapLevels === json.specular.levels.length &&
    ibl.header.pixelWidth === json.specular.levels[0].face_size && sky.header.numberOfMipmapLevels === 1 &&
    sh.length === 27 && sh.every(Number.isFinite) && ibl.kv.KTXorientation === 'S=r,T=d',
  `${name}: ibl.ktx (0x${ibl.header.glInternalFormat.toString(16)}, ${ibl.levels.length} levels of ${ibl.header.pixelWidth}) and skybox.ktx read by the KTX 1.1 reader; "sh" holds 27 numbers`);
  return { ibl, json };
}

// The DFG table of the set (dfg.ktx2, the `filament` consumer: R16G16B16, column i at
// N.V = (i + 0.5) / n, row j at perceptual roughness (j + 0.5) / n), sampled as GL samples it
// (bilinear, clamped to the edge).
function loadDfg(file) {
  const c = read(new Uint8Array(readFileSync(file)));
  const n = c.pixelWidth, ch = c.vkFormat === 90 ? 3 : c.vkFormat === 83 ? 2 : 4;
  const d = c.levels[0].levelData;
  const dv = new DataView(d.buffer, d.byteOffset, d.byteLength);
  const at = (i, j, k) => halfToFloat(dv.getUint16(((j * n + i) * ch + k) * 2, true));
  return (nov, r) => {
    const fx = Math.min(n - 1, Math.max(0, nov * n - 0.5)), fy = Math.min(n - 1, Math.max(0, r * n - 0.5));
    const x0 = Math.floor(fx), y0 = Math.floor(fy), x1 = Math.min(n - 1, x0 + 1), y1 = Math.min(n - 1, y0 + 1);
    const ax = fx - x0, ay = fy - y0;
    return [0, 1].map((k) => (1 - ay) * ((1 - ax) * at(x0, y0, k) + ax * at(x1, y0, k)) + ay * ((1 - ax) * at(x0, y1, k) + ax * at(x1, y1, k)));
  };
}

// Filament's Irradiance_SphericalHarmonics (light_indirect.fs) of the "sh" key at a normal of its
// frame: the engine's own formula, max(sum, 0).
function filamentSh(sh, n, c) {
  const [x, y, z] = n;
  const b = [1, y, z, x, y * x, y * z, 3 * z * z - 1, z * x, x * x - y * y];
  return Math.max(0, b.reduce((acc, v, i) => acc + sh[3 * i + c] * v, 0));
}

// A white dielectric sphere (glTF's default f0 = 0.04) at the last level's roughness: Filament's
// evaluateIBL: E = mix(dfg.x, dfg.y, f0), Fr = E (1 + f0 (1/dfg.y - 1)) prefiltered(n),
// Fd = (1 - E) SH(n): the "sh" key's irradiance through the engine's formula, plus the specular
// term from specular.ktx2 and dfg.ktx2.
async function checkDiffuse(si, name, l, cube) {
  const dfg = loadDfg(join(sets[si], 'dfg.ktx2'));
  const sh = decodeKtx1(new Uint8Array(readFileSync(join(sets[si], 'ibl.ktx')))).kv.sh.trim().split(/\s+/).map(Number);
  const F0 = 0.04;
  const expected = (n) => {
    const [x, y] = dfg(Math.max(1e-4, n[2]), l.roughness);
    const E = (1 - F0) * x + F0 * y, comp = 1 + F0 * (1 / y - 1);
    const spec = filamentSpecular(cube, l.roughness, n);
    return { rgb: [0, 1, 2].map((c) => E * comp * spec.rgb[c] + (1 - E) * filamentSh(sh, n, c)), edge: spec.edge };
  };
  const vals = [];
  for (let j = 0; j < S; j += 4) for (let i = 0; i < S; i += 4) { const n = sphereNormal(i, j); if (n) vals.push(Math.max(...expected(n).rgb)); }
  vals.sort((a, b) => a - b);
  const I = 200 / 255 / Math.max(1e-6, vals[Math.floor(0.9 * (vals.length - 1))]);
  const img = await render({ set: `/set/${si}`, what: 'sphere', metallic: 0, roughness: l.roughness, intensity: I }, `filament_${name}_diffuse.png`);
  let compared = 0, within = 0, worst = 0;
  for (let j = 0; j < S; ++j) for (let i = 0; i < S; ++i) {
    const n = sphereNormal(i, j);
    if (!n) continue;
    const e = expected(n);
    if (e.edge < 1 || e.rgb.some((v) => 255 * I * v > CLIP)) continue;
    compared++;
    const got = px(img, i, j);
    let ok = true;
    for (let c = 0; c < 3; ++c) {
      const d = Math.abs(got[c] - 255 * I * e.rgb[c]);
      worst = Math.max(worst, d);
      if (d > SPHERE_ABS + SPHERE_REL * 255 * I * e.rgb[c]) ok = false;
    }
    if (ok) within++;
  }
  check(compared > 1000 && within >= SPHERE_FRACTION * compared,
    `diffuse ${name}: Filament's white dielectric sphere (roughness ${l.roughness.toFixed(3)}: SH irradiance from the "sh" key + specular) = CPU render from Filament's formulas with specular.ktx2 and dfg.ktx2 within ${SPHERE_ABS} + ${SPHERE_REL * 100}% at ${within} of ${compared} pixels (worst ${worst.toFixed(1)} of 255)`);
  if (si === 1) {
    const got = centroid((i, j) => sphereNormal(i, j) && isRed(px(img, i, j)));
    check(got.n > 0 && got.i < S / 2, `diffuse ${name}: the red patch's irradiance lights the Filament -X (world +X) side: red centroid (${got.i.toFixed(1)}, ${got.j.toFixed(1)}), ${got.n} pixels`);
  }
}

async function runChecks() {
  // 1. White furnace.
  const white = await checkFiles(0, 'white');
  for (const l of white.json.specular.levels) {
    const I = 0.5;
    const img = await render({ set: '/set/0', what: 'sphere', roughness: l.roughness, intensity: I }, l.level === 1 ? 'filament_furnace_level1.png' : null);
    let worst = 0, count = 0;
    for (let j = 0; j < S; ++j) for (let i = 0; i < S; ++i) if (sphereNormal(i, j)) {
      count++;
      for (const v of px(img, i, j)) worst = Math.max(worst, Math.abs(v - 255 * I));
    }
    check(count > 0 && worst <= FURNACE_TOL, `furnace: Filament's metallic white sphere at roughness ${l.roughness.toFixed(3)} (level ${l.level}) lit by a constant map = ${255 * I} everywhere (worst |difference| ${worst.toFixed(1)} of 255, ${count} pixels)`);
  }

  // 2. The skybox along Filament's -X and +X against the patches map.
  for (let si = 1; si < sets.length; ++si) {
    const isPatch = si === 1, isBroken = si >= 2 + realSets.length;
    if (!isPatch && !isBroken) continue;
    const name = basename(sets[si]);
    for (const look of isBroken ? [[-1, 0, 0]] : [[-1, 0, 0], [1, 0, 0]]) {
      const img = await render({ set: `/set/${si}`, what: 'sky', look, intensity: 1 }, isPatch ? `filament_sky_${look[0] < 0 ? 'minus' : 'plus'}x.png` : null);
      const want = centroid((i, j) => isRed(mapPixel(worldOf(skyDirection(i, j, look))).map((v) => v * 255)));
      const got = centroid((i, j) => isRed(px(img, i, j)));
      const where = (c) => (c.n ? `${c.n} red pixels around (${c.i.toFixed(1)}, ${c.j.toFixed(1)})` : 'no red');
      const ok = want.n === 0 ? got.n === 0 : got.n > 0.5 * want.n && got.n < 2 * want.n && Math.hypot(got.i - want.i, got.j - want.j) < 3;
      const msg = `sky ${name} looking along Filament ${look[0] < 0 ? '-' : '+'}X: the patches map (world +X at Filament -X) has ${where(want)}; Filament shows ${where(got)}`;
      if (isBroken) check(!ok, `negative control: the sky check rejects ${msg}`);
      else check(ok, msg);
    }
  }

  // 3. Spheres per level against the CPU render from specular.ktx2 (world frame).
  for (let si = 1; si < 2 + realSets.length; ++si) {
    const name = basename(sets[si]);
    const { json } = await checkFiles(si, name);
    const cube = loadKtx2Cube(join(sets[si], 'specular.ktx2'));
    for (const l of json.specular.levels) {
      if (l.level === 0) continue;  // Filament clamps roughness 0 to its minimum: lod > 0
      // Intensity: the brightest unclipped reference at about 200 of 255.
      const vals = [];
      for (let j = 0; j < S; j += 4) for (let i = 0; i < S; i += 4) {
        const n = sphereNormal(i, j);
        if (n) vals.push(Math.max(...filamentSpecular(cube, l.roughness, n).rgb));
      }
      vals.sort((a, b) => a - b);
      const I = 200 / 255 / Math.max(1e-6, vals[Math.floor(0.9 * (vals.length - 1))]);
      const img = await render({ set: `/set/${si}`, what: 'sphere', roughness: l.roughness, intensity: I }, `filament_${name}_level${l.level}.png`);
      let compared = 0, within = 0, worst = 0, nan = 0;
      for (let j = 0; j < S; ++j) for (let i = 0; i < S; ++i) {
        const n = sphereNormal(i, j);
        if (!n) continue;
        const { rgb, edge, spread } = filamentSpecular(cube, l.roughness, n);
        const got = px(img, i, j);
        if (got.some((v) => !Number.isFinite(v))) nan++;
        if (edge < 1 || rgb.some((v) => 255 * I * v > CLIP)) continue;
        compared++;
        let ok = true;
        for (let c = 0; c < 3; ++c) {
          const want = 255 * I * rgb[c];
          const d = Math.abs(got[c] - want);
          worst = Math.max(worst, d);
          if (d > SPHERE_ABS + SPHERE_REL * want + SUBTEXEL * 255 * I * spread[c]) ok = false;
        }
        if (ok) within++;
      }
      check(nan === 0 && compared > 1000 && within >= SPHERE_FRACTION * compared,
        `sphere ${name} level ${l.level} (roughness ${l.roughness.toFixed(3)}, intensity ${I.toPrecision(3)}): Filament = CPU render from specular.ktx2 at Filament's lookup direction within ${SPHERE_ABS} + ${SPHERE_REL * 100}% + 1/32 of the taps' spread at ${within} of ${compared} pixels (${(100 * within / Math.max(1, compared)).toFixed(1)}%, worst ${worst.toFixed(1)} of 255)`);
      if (l.level === json.specular.levels.length - 1) await checkDiffuse(si, name, l, cube);
      if (si === 1) {
        // Red where the reflected ray sees the patch: the left (Filament -X) side of the sphere.
        const want = centroid((i, j) => { const n = sphereNormal(i, j); return n && isRed(filamentSpecular(cube, l.roughness, n).rgb.map((v) => 255 * I * v)); });
        const got = centroid((i, j) => sphereNormal(i, j) && isRed(px(img, i, j)));
        check(got.n > 0 && got.i < S / 2 && Math.hypot(got.i - want.i, got.j - want.j) < 4,
          `sphere ${name} level ${l.level}: the red patch lights the side facing Filament -X (world +X): red centroid (${got.i.toFixed(1)}, ${got.j.toFixed(1)}) vs CPU (${want.i.toFixed(1)}, ${want.j.toFixed(1)})`);
      }
    }
  }
}

const browser = await launchChromium();
let consoleLog = [];
let page;
try {
  ({ page, log: consoleLog } = await openPage(browser, `${base}/engines/filament_page.html`, S, S));
  const info = await page.evaluate(() => window.shrmFilament.info());
  pass(`Filament ${JSON.parse(readFileSync(join(HERE, 'node_modules/filament/package.json'), 'utf8')).version} started in ${await browser.version()}, ${info.version}, ${info.renderer}`);
  await runChecks();
  const errors = consoleLog.filter((l) => l.startsWith('pageerror') || l.startsWith('error'));
  check(errors.length === 0, `no page errors (${errors.length}${errors.length ? `: ${errors[0]}` : ''})`);
} catch (e) {
  fail(`browser: ${e.stack ?? e}`);
} finally {
  writeFileSync(join(outDir, 'filament_console.log'), consoleLog.join('\n') + '\n');
  await browser.close();
  server.close();
}
console.log(`filament: ${failures() === 0 ? 'all checks passed' : `${failures()} check(s) failed`}`);
process.exit(failures() === 0 ? 0 : 1);
