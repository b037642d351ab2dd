// Reads every KTX2 file of a `shrm ibl` set with ktx-parse (npm, an independent reader) and checks
// it against the set's ibl.json and the KTX 2.0 / Data Format specifications; decodes the values
// and checks them against what the input map implies.
//
// Usage: node check_ktx2.mjs SET_DIR [--constant R,G,B] [--patches] [--map PIXELS.txt]
//   --constant: the input was a constant map: every texel of every level is that colour.
//   --patches:  the input was engines_test.sh's patches.exr (ktx_cube.mjs PATCHES: red patch at
//               +X, green band at +Y, blue patch at -Z on grey): level 0 holds them in those
//               directions, and every level's face means are largest on those faces.
//   --map:      the input map's pixels as `oiiotool --dumpdata` prints them (lat-long; may be a
//               downsized copy): radiance_sh9 and irradiance.ktx2 are checked against it.
// With any of the three, radiance_sh9 is checked against the SH projection of the map's pixels
// and irradiance.ktx2 against the cosine-weighted integral of the map's pixels.
// Prints PASS/FAIL lines; exits 1 on any FAIL.
import { existsSync, readFileSync } from 'node:fs';
import { join } from 'node:path';
import { read, write } from 'ktx-parse';
import * as THREE from 'three';
import {
  FORMATS, FACE_NAMES, decodeCubeLevel, texelDirection, texelSolidAngle, latLongUv,
  projectSh9, projectToThreeSh9, latLongDirection, PATCHES, patchesPixel, halfToFloat,
} from './ktx_cube.mjs';

const args = process.argv.slice(2);
const dir = args[0];
const constIdx = args.indexOf('--constant');
const constant = constIdx > 0 ? args[constIdx + 1].split(',').map(Number) : null;
const patches = args.includes('--patches');
const mapIdx = args.indexOf('--map');
const mapFile = mapIdx > 0 ? args[mapIdx + 1] : null;

let failures = 0;
const pass = (m) => console.log(`PASS: ${m}`);
const fail = (m) => { console.log(`FAIL: ${m}`); failures++; };
const check = (ok, m) => (ok ? pass(m) : fail(m));
const tag = dir.split('/').filter(Boolean).pop();

const json = JSON.parse(readFileSync(join(dir, 'ibl.json'), 'utf8'));
const fmt = FORMATS[json.format];
check(fmt !== undefined, `${tag}: ibl.json format "${json.format}" is one of ${Object.keys(FORMATS)}`);
if (!fmt) process.exit(1);

// Relative rounding of one stored value (half: 11 significant bits; B10G11R11: 7 or 6; E5B9G9R9:
// 9 bits below the shared exponent of the largest channel, so relative to the largest channel).
const ROUNDING = { rgba16f: 2 ** -11, rgba32f: 2 ** -24, r11g11b10f: 2 ** -6, rgb9e5: 2 ** -9 };

const f32bits = (x) => { const b = new DataView(new ArrayBuffer(4)); b.setFloat32(0, x); return b.getUint32(0); };

// The DFD the Khronos Data Format Specification 1.4 gives for the format (sec. 5 and the
// "Vulkan formats" tables; E5B9G9R9 as libktx writes it: mantissa and exponent samples per channel).
function expectedSamples(name) {
  const FLOAT = 0x80, SIGNED = 0x40, EXPONENT = 0x20;
  const one = f32bits(1), minusOne = f32bits(-1);
  if (name === 'rgba16f' || name === 'rgba32f') {
    const bits = name === 'rgba16f' ? 16 : 32;
    return [0, 1, 2, 15].map((ch, i) => ({
      bitOffset: i * bits, bitLength: bits - 1, channelType: ch | FLOAT | SIGNED, lower: minusOne, upper: one,
    }));
  }
  if (name === 'r11g11b10f') {
    return [[0, 0, 11], [1, 11, 11], [2, 22, 10]].map(([ch, off, len]) => ({
      bitOffset: off, bitLength: len - 1, channelType: ch | FLOAT, lower: 0, upper: one,
    }));
  }
  const s = [];
  for (const ch of [0, 1, 2]) {
    s.push({ bitOffset: 9 * ch, bitLength: 8, channelType: ch, lower: 0, upper: 8448 });
    s.push({ bitOffset: 27, bitLength: 4, channelType: ch | EXPONENT, lower: 15, upper: 31 });
  }
  return s;
}

const cubes = {};
for (const file of json.files.filter((f) => f.type === 'cube')) {
  const key = file.name.replace('.ktx2', '');
  const desc = json[key];
  const t = `${tag}/${file.name}`;
  const fileBytes = new Uint8Array(readFileSync(join(dir, file.name)));
  const c = read(fileBytes);
  const n0 = desc.levels[0].face_size;
  // ktx-parse's writer lays a file out as the spec's recommendations say (alignment, padding,
  // key order); shrm's files come back byte for byte (docs/ktx2.md).
  const again = write(read(fileBytes), { keepWriter: true });
  check(again.length === fileBytes.length && again.every((b, i) => b === fileBytes[i]),
    `${t}: ktx-parse rewrites it byte for byte (${fileBytes.length} bytes${again.length === fileBytes.length ? '' : `, rewritten ${again.length}`})`);
  check(c.vkFormat === fmt.vk && c.typeSize === fmt.typeSize,
    `${t}: vkFormat ${c.vkFormat} typeSize ${c.typeSize} (${json.format}: ${fmt.vk}, ${fmt.typeSize})`);
  check(c.pixelWidth === n0 && c.pixelHeight === n0 && c.pixelDepth === 0,
    `${t}: ${c.pixelWidth}x${c.pixelHeight}x${c.pixelDepth} (ibl.json face_size ${n0})`);
  check(c.faceCount === 6 && c.layerCount === 0, `${t}: faceCount ${c.faceCount}, layerCount ${c.layerCount}`);
  check(c.levelCount === desc.levels.length && c.levels.length === desc.levels.length,
    `${t}: levelCount ${c.levelCount} = ibl.json's ${desc.levels.length} levels`);
  check(c.supercompressionScheme === 0 && c.globalData === null, `${t}: no supercompression, no global data`);
  let sizesOk = true;
  c.levels.forEach((l, k) => {
    const n = Math.max(1, n0 >> k);
    const bytes = 6 * n * n * fmt.bytes;
    if (desc.levels[k].face_size !== n || l.levelData.byteLength !== bytes || l.uncompressedByteLength !== bytes) {
      sizesOk = false;
      fail(`${t}: level ${k}: ${l.levelData.byteLength} bytes (uncompressed ${l.uncompressedByteLength}), want 6x${n}x${n}x${fmt.bytes} = ${bytes}`);
    }
  });
  if (sizesOk) pass(`${t}: every level's byte length is 6 x n x n x ${fmt.bytes}, n = ${n0} >> level`);

  const d = c.dataFormatDescriptor[0];
  check(c.dataFormatDescriptor.length === 1 && d.vendorId === 0 && d.descriptorType === 0 && d.versionNumber === 2,
    `${t}: DFD is one Khronos basic block, version 2`);
  check(d.colorModel === 1 && d.colorPrimaries === 1 && d.transferFunction === 1 && d.flags === 0,
    `${t}: DFD model ${d.colorModel} (RGBSDA 1), primaries ${d.colorPrimaries} (BT709 1), transfer ${d.transferFunction} (LINEAR 1), flags ${d.flags}`);
  check(d.texelBlockDimension.every((v) => v === 0) && d.bytesPlane[0] === fmt.bytes && d.bytesPlane.slice(1).every((v) => v === 0),
    `${t}: DFD texel block 1x1x1x1, bytesPlane0 ${d.bytesPlane[0]} (${fmt.bytes})`);
  const want = expectedSamples(json.format);
  const got = d.samples.map((s) => ({
    bitOffset: s.bitOffset, bitLength: s.bitLength, channelType: s.channelType,
    lower: s.sampleLower >>> 0, upper: s.sampleUpper >>> 0,
  }));
  check(got.length === want.length && got.every((s, i) => JSON.stringify(s) === JSON.stringify(want[i]))
    && d.samples.every((s) => s.samplePosition.every((p) => p === 0)),
    `${t}: DFD ${got.length} samples as the spec gives for ${json.format}${got.length === want.length ? '' : ` (want ${want.length})`}: ${JSON.stringify(got)}`);

  const kv = c.keyValue;
  const text = (k) => (kv[k] === undefined ? undefined
    : typeof kv[k] === 'string' ? kv[k] : new TextDecoder().decode(kv[k]).replace(/\0$/, ''));
  check(text('KTXorientation') === 'rd', `${t}: KTXorientation "${text('KTXorientation')}"`);
  check(/^shrm /.test(text('KTXwriter') ?? ''), `${t}: KTXwriter "${text('KTXwriter')}"`);
  // The roughness keys describe the radiance chains; the irradiance cube has none.
  const chainKeys = key === 'irradiance' ? [] : ['shrm:preset', 'shrm:roughness', 'shrm:alpha'];
  for (const k of ['shrm:version', 'shrm:content', 'shrm:units', 'shrm:cube', 'shrm:degree', 'shrm:source', 'shrm:source_sha256', ...chainKeys]) {
    check(text(k) !== undefined && text(k).length > 0, `${t}: key ${k} = "${(text(k) ?? '').slice(0, 60)}"`);
  }
  check((text('shrm:cube') ?? '').includes('+X,-X,+Y,-Y,+Z,-Z'), `${t}: shrm:cube names the GL face order`);
  if (key !== 'irradiance') {
    check(text('shrm:preset') === json.preset, `${t}: shrm:preset = ibl.json preset "${json.preset}"`);
    check(text('shrm:alpha') === 'roughness^2' && desc.levels.every((l) => Math.abs(l.alpha - l.roughness ** 2) <= 1e-12),
      `${t}: shrm:alpha "${text('shrm:alpha')}", ibl.json alpha = roughness^2 on every level`);
    const rough = (text('shrm:roughness') ?? '').split(',').map(Number);
    const jr = desc.levels.map((l) => l.roughness);
    // The key holds 17 significant digits: the same doubles as ibl.json.
    check(rough.length === jr.length && rough.every((r, i) => r === jr[i]),
      `${t}: shrm:roughness [${rough}] = ibl.json's [${jr}]`);
  } else {
    check(text('shrm:roughness') === undefined, `${t}: no roughness keys on the irradiance cube`);
  }

  // Values.
  const levels = c.levels.map((l, k) => decodeCubeLevel(l.levelData, c.vkFormat, Math.max(1, n0 >> k)));
  let bad = 0, badAlpha = 0;
  for (const l of levels) for (const f of l.faces) for (let i = 0; i < f.length; i += 4) {
    for (let ch = 0; ch < 3; ++ch) if (!Number.isFinite(f[i + ch]) || f[i + ch] < 0) bad++;
    if (f[i + 3] !== 1) badAlpha++;
  }
  check(bad === 0 && badAlpha === 0, `${t}: every value finite and >= 0, alpha 1 (${bad} bad values, ${badAlpha} bad alphas)`);
  cubes[key] = { container: c, levels };

  if (constant) {
    // A constant map is its own prefiltered radiance and irradiance / pi, at every roughness:
    // only the storage rounding (and a little quadrature error) is allowed.
    const tol = 2 * ROUNDING[json.format] + 1e-4;
    let worst = 0;
    for (const l of levels) for (const f of l.faces) for (let i = 0; i < f.length; i += 4) {
      for (let ch = 0; ch < 3; ++ch) worst = Math.max(worst, Math.abs(f[i + ch] - constant[ch]) / constant[ch]);
    }
    check(worst <= tol, `${t}: constant map: every texel of all ${levels.length} levels = (${constant}) within ${tol.toExponential(2)} relative (worst ${worst.toExponential(2)})`);
  }
}

// The DFG table (a 2D KTX2 of half floats) when the set has one on disk: the header, the DFD,
// byte-for-byte rewrite, and values within the split-sum's bounds (every channel finite and
// >= 0; the Filament / Babylon form (B, A + B, C) has B <= A + B <= 1, the (A, B) forms
// A + B <= 1: a BRDF integral with F <= 1 reflects at most what arrives).
const dfgFile = json.files.find((f) => f.name === 'dfg.ktx2');
if (dfgFile && json.dfg && existsSync(join(dir, 'dfg.ktx2'))) {
  const t = `${tag}/dfg.ktx2`;
  const bytes = new Uint8Array(readFileSync(join(dir, 'dfg.ktx2')));
  const c = read(bytes);
  const again = write(read(bytes), { keepWriter: true });
  check(again.length === bytes.length && again.every((b, i) => b === bytes[i]), `${t}: ktx-parse rewrites it byte for byte`);
  const ch = json.dfg.channels, n = json.dfg.size;
  const vk = ch <= 2 ? 83 : ch === 3 ? 90 : 97, kch = ch <= 2 ? 2 : ch;
  check(c.vkFormat === vk && c.typeSize === 2 && c.pixelWidth === n && c.pixelHeight === n && c.faceCount === 1
    && c.layerCount === 0 && c.levelCount === 1 && c.levels[0].levelData.byteLength === n * n * kch * 2,
    `${t}: vkFormat ${c.vkFormat} (${vk}), ${c.pixelWidth}x${c.pixelHeight}, faces ${c.faceCount}, levels ${c.levelCount}, ${c.levels[0].levelData.byteLength} bytes`);
  const d = c.dataFormatDescriptor[0];
  check(d.colorModel === 1 && d.transferFunction === 1 && d.samples.length === kch && d.bytesPlane[0] === kch * 2,
    `${t}: DFD RGBSDA, linear, ${d.samples.length} half-float samples`);
  const v = new DataView(c.levels[0].levelData.buffer, c.levels[0].levelData.byteOffset);
  let bad = 0, over = 0;
  for (let i = 0; i < n * n; ++i) {
    const x = [...Array(kch).keys()].map((k) => halfToFloat(v.getUint16(2 * (i * kch + k), true)));
    if (x.some((y) => !Number.isFinite(y) || y < 0)) bad++;
    const energy = json.dfg.consumer.startsWith('filament') && !json.dfg.consumer.includes('single') || json.dfg.consumer === 'babylon'
      ? (x[0] <= x[1] + 1e-3 && x[1] <= 1 + 1e-3) : (x[0] + x[1] <= 1 + 1e-3);
    if (!energy) over++;
  }
  check(bad === 0 && over === 0, `${t}: ${json.dfg.consumer} table: every value finite and >= 0 (${bad} bad), within the energy bound (${over} over)`);
}

// The +X / +Y / -Z patches of engines_test.sh's patches.exr (ktx_cube.mjs PATCHES).
function patchOf(d) {
  const { u, v } = latLongUv(d);
  const m = 0.02; // margin against resampling
  let bg = true;
  for (const p of PATCHES.patches) {
    const [u0, u1, v0, v1] = [p.x0 / PATCHES.width, p.x1 / PATCHES.width, p.y0 / PATCHES.height, p.y1 / PATCHES.height];
    if (u > u0 + m && u < u1 - m && v > v0 + m && v < v1 - m) return p.name;
    if (!(u < u0 - m || u > u1 + m || v < v0 - m || v > v1 + m)) bg = false;
  }
  return bg ? 'bg' : null;
}

if (patches) {
  const spec = cubes.specular.levels;
  const l0 = spec[0];
  // Level 0 is the map resampled: texels well inside a patch hold it, texels well away the grey.
  const count = { R: 0, G: 0, B: 0, bg: 0 };
  let worst = 0;
  for (let face = 0; face < 6; ++face) for (let y = 0; y < l0.size; ++y) for (let x = 0; x < l0.size; ++x) {
    const p = patchOf(texelDirection(face, x, y, l0.size));
    if (!p) continue;
    count[p]++;
    const want = p === 'bg' ? PATCHES.background : PATCHES.patches.find((q) => q.name === p).rgb;
    const i = (y * l0.size + x) * 4;
    for (let ch = 0; ch < 3; ++ch) worst = Math.max(worst, Math.abs(l0.faces[face][i + ch] - want[ch]) / 8);
  }
  check(count.R > 0 && count.G > 0 && count.B > 0 && worst < 0.05,
    `patches: specular level 0 holds red at +X, green at +Y, blue at -Z, grey elsewhere (${count.R}/${count.G}/${count.B}/${count.bg} texels classified; worst difference ${worst.toFixed(4)} of the patch value 8)`);
  // Every level: the face with the largest mean of each channel is the patch's face. (Not for
  // sheen: the Charlie lobe peaks at grazing angles, so its low-roughness levels are brightest
  // on the faces 90 degrees away from a patch.)
  for (const key of Object.keys(cubes).filter((k) => k !== 'sheen')) {
    const ok = cubes[key].levels.map((l) => {
      const means = l.faces.map((f) => [0, 1, 2].map((ch) => {
        let s = 0;
        for (let i = ch; i < f.length; i += 4) s += f[i];
        return s / (f.length / 4);
      }));
      const argmax = (ch) => means.reduce((b, m, i) => (m[ch] > means[b][ch] ? i : b), 0);
      return [argmax(0), argmax(1), argmax(2)];
    });
    const good = ok.every(([r, g, b]) => r === 0 && g === 2 && b === 5);
    check(good, `patches: ${key}: on every level the face with most red is +X, green +Y, blue -Z (got ${ok.map((a) => a.map((f) => FACE_NAMES[f]).join('/')).join(' ')})`);
  }
}

// The input map as lat-long pixels (W, H, rgb(i, j)), when the input is known.
function knownMap() {
  if (constant) return { W: 64, H: 32, rgb: () => constant, what: 'the constant map' };
  if (patches) return { W: PATCHES.width, H: PATCHES.height, rgb: patchesPixel, what: 'patches.exr' };
  if (!mapFile) return null;
  const px = new Map();
  let W = 0, H = 0;
  for (const m of readFileSync(mapFile, 'utf8').matchAll(/Pixel \((\d+), (\d+)\):\s*(\S+)\s+(\S+)\s+(\S+)/g)) {
    const [i, j] = [+m[1], +m[2]];
    px.set(j * 100000 + i, [+m[3], +m[4], +m[5]]);
    W = Math.max(W, i + 1); H = Math.max(H, j + 1);
  }
  if (px.size !== W * H) throw new Error(`${mapFile}: ${px.size} pixels, not ${W} x ${H}`);
  return { W, H, rgb: (i, j) => px.get(j * 100000 + i), what: `${mapFile.split('/').pop()} (${W} x ${H})` };
}
// Its pixels as (direction, solid angle, rgb), docs/conventions.md lat-long, exact ring areas.
const map = knownMap();
const mapPixels = [];
if (map) {
  for (let j = 0; j < map.H; ++j) for (let i = 0; i < map.W; ++i) {
    const w = ((2 * Math.PI) / map.W) * (Math.cos((Math.PI * j) / map.H) - Math.cos((Math.PI * (j + 1)) / map.H));
    mapPixels.push({ d: latLongDirection((i + 0.5) / map.W, (j + 0.5) / map.H), w, rgb: map.rgb(i, j) });
  }
}

// radiance_sh9 against the SH projection, in the project's convention (ktx_cube.mjs projectSh9,
// from docs/conventions.md), of the input map's pixels; without a known map, of specular level 0
// (the map point-sampled onto the cube), loosely.
{
  const sh = Array.from({ length: 9 }, () => [0, 0, 0]);
  const add = (w, d, rgb) => {
    const b = projectSh9(d);
    for (let k = 0; k < 9; ++k) for (let ch = 0; ch < 3; ++ch) sh[k][ch] += w * b[k] * rgb[ch];
  };
  let what, tol;
  if (map) {
    for (const p of mapPixels) add(p.w, p.d, p.rgb);
    [what, tol] = [`of ${map.what}`, mapFile ? 0.01 : 5e-3];
  } else {
    const l0 = cubes.specular.levels[0];
    for (let face = 0; face < 6; ++face) for (let y = 0; y < l0.size; ++y) for (let x = 0; x < l0.size; ++x) {
      const i = (y * l0.size + x) * 4;
      add(texelSolidAngle(x, y, l0.size), texelDirection(face, x, y, l0.size), l0.faces[face].subarray(i, i + 3));
    }
    [what, tol] = ['of specular level 0', 0.15];
  }
  const ref = json.radiance_sh9;
  const scale = Math.max(...ref[0]);
  let worst = 0;
  for (let k = 0; k < 9; ++k) for (let ch = 0; ch < 3; ++ch) worst = Math.max(worst, Math.abs(sh[k][ch] - ref[k][ch]) / scale);
  check(ref.length === 9 && worst <= tol,
    `${tag}: radiance_sh9 = the SH projection ${what} in the docs/conventions.md basis within ${tol} of max L00 ${scale.toFixed(4)} (worst ${worst.toExponential(2)})`);

  // The conversion to three.js's SphericalHarmonics3 (used by run_browser's LightProbe check)
  // against three's own basis: same function value at 200 directions.
  const three = new THREE.SphericalHarmonics3();
  three.coefficients.forEach((v, k) => v.set(...[0, 1, 2].map((ch) => projectToThreeSh9(ref.map((c) => c[ch]))[k])));
  let worstConv = 0;
  for (let i = 0; i < 200; ++i) {
    const u = (i + 0.5) / 200, phi = i * 2.399963;
    const n = new THREE.Vector3(Math.sqrt(1 - (2 * u - 1) ** 2) * Math.cos(phi), 2 * u - 1, Math.sqrt(1 - (2 * u - 1) ** 2) * Math.sin(phi));
    const t = three.getAt(n, new THREE.Vector3());
    const b = projectSh9([n.x, n.y, n.z]);
    const p = [0, 1, 2].map((ch) => b.reduce((s, bk, k) => s + bk * ref[k][ch], 0));
    worstConv = Math.max(worstConv, Math.abs(t.x - p[0]) / scale, Math.abs(t.y - p[1]) / scale, Math.abs(t.z - p[2]) / scale);
  }
  check(worstConv < 1e-4, `${tag}: radiance_sh9 converted to three.SphericalHarmonics3 evaluates (three's getAt) as the project's basis does (worst ${worstConv.toExponential(2)} of max L00)`);
}

// irradiance.ktx2 against (1/pi) * integral of L(l) max(0, n.l) over the map's pixels, at texel
// centres spread over the six faces.
if (map) {
  const l0 = cubes.irradiance.levels[0];
  const step = Math.max(1, l0.size / (constant ? 4 : 8)); // 384 texels (96 for a constant map)
  let worst = 0, where = '', n = 0, peak = 0;
  const rows = [];
  for (let face = 0; face < 6; ++face) for (let y = step >> 1; y < l0.size; y += step) for (let x = step >> 1; x < l0.size; x += step) {
    const d = texelDirection(face, x, y, l0.size);
    const e = [0, 0, 0];
    for (const p of mapPixels) {
      const c = d[0] * p.d[0] + d[1] * p.d[1] + d[2] * p.d[2];
      if (c > 0) for (let ch = 0; ch < 3; ++ch) e[ch] += (p.w * c * p.rgb[ch]) / Math.PI;
    }
    const i = (y * l0.size + x) * 4;
    rows.push([e, Array.from(l0.faces[face].subarray(i, i + 3)), `${FACE_NAMES[face]} (${x},${y})`]);
    peak = Math.max(peak, ...e);
    n++;
  }
  // Allowed: the storage rounding (E5B9G9R9: relative to the texel's largest channel) twice, plus
  // `q` relative (floor 5% of the peak) for the map's quadrature and shrm's band limit.
  const q = mapFile ? 0.01 : 2e-3;
  let worstRel = 0;
  for (const [e, got, at] of rows) for (let ch = 0; ch < 3; ++ch) {
    const round = 2 * ROUNDING[json.format] * (json.format === 'rgb9e5' ? Math.max(...got) : got[ch]);
    const allowed = round + q * Math.max(e[ch], 0.05 * peak);
    const diff = Math.abs(got[ch] - e[ch]);
    if (diff / allowed > worst) {
      worst = diff / allowed;
      where = `${at} channel ${ch}: ${got[ch].toFixed(5)} vs ${e[ch].toFixed(5)}`;
    }
    worstRel = Math.max(worstRel, diff / Math.max(e[ch], 0.05 * peak));
  }
  check(worst <= 1, `${tag}: irradiance.ktx2 = irradiance / pi of ${map.what} by brute force at ${n} texels: worst difference ${worstRel.toExponential(2)} relative (floor 5% of the peak ${peak.toFixed(4)}), ${worst.toFixed(2)} of the allowed ${q} + 2 x ${json.format} rounding (at ${where})`);
}

console.log(`${tag}: ${failures === 0 ? 'all checks passed' : `${failures} check(s) failed`}`);
process.exit(failures === 0 ? 0 : 1);
