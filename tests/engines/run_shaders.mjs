// The shipped WGSL library (shaders/wgsl/shrm.wgsl, docs/shaders.md) in a real WebGPU
// implementation: Debian's Chromium, WebGPU on SwiftShader, driven by playwright-core. It runs on
// SHRMs written by `shrm prefilter --ktx2` from a bundled real map, read here with ktx-parse and
// uploaded as the KTX2 level stands, and is compared with shrm's own CPU evaluation of the same
// file (`shrm render --view V -o ref.ktx2`: eq. 5.35 for a global SHRM, eq. 5.10 at every texel
// centre for a local one).
//
// Usage: node run_shaders.mjs SHRM_WGSL GLOBAL.ktx2 GLOBAL_REF.ktx2 LOCAL.ktx2 LOCAL_REF.ktx2
//          [GLOBAL_N.ktx2 GLOBAL_N_REF.ktx2 LOCAL_N.ktx2 LOCAL_N_REF.ktx2]
// (the optional four: SHRMs with shrm:view_variable "normal" and a Fresnel table, GGX f0 0.04,
// docs/shaders.md, run with the override
// SHRM_VIEW_NORMAL: the global pass against the CPU's map, whose texels each take Y_pq of their
// own normal (R_texel + V)/|R_texel + V|, and shrm_local at every texel centre with the argument
// shrm_view_normal(R_texel, V); a pass without the override must differ: negative control.)
// Checks (PASS/FAIL lines, exit 1 on any FAIL):
//   ktx2:    ktx-parse reads both SHRMs: cube-map array, layerCount (P + 1)^2 of shrm:pmax, one
//            level, RGBA32F, the Data Format Descriptor, the conventions' keys;
//   global:  shrm_global_pass (the per-frame pass) = the CPU's reflection map for the same view,
//            every texel; and for a mirrored view it differs (negative control);
//   local:   shrm_local at every texel centre = the CPU's B(R_texel, V); at random directions
//            inside faces = the bilinear interpolation of those texel values (what eq. 5.10's
//            four-tap form is: each tap evaluated in its own frame, then interpolated);
//   lights:  (the optional last four, SHRMs with peak lights, shrm:lights and shrm:light_model)
//            shrm_global_pass_lights and shrm_local + shrm_lights_at_texel = the CPU's map with
//            the lights summed by core's BRDF; without the lights they differ (negative control).
import { readFileSync } from 'node:fs';
import { resolve } from 'node:path';
import { read } from 'ktx-parse';
import { checker, launchChromium, serve, openPage, requireChromium } from './harness.mjs';
import { faceCoordinates, normalize, texelDirection } from './ktx_cube.mjs';

const [wgslPath, globalPath, globalRefPath, localPath, localRefPath, globalNPath, globalNRefPath, localNPath,
  localNRefPath, globalVPath, globalVRefPath, localVPath, localVRefPath, globalLPath, globalLRefPath, localLPath,
  localLRefPath] =
  process.argv.slice(2).map((p) => resolve(p));
if (!localRefPath) {
  console.error('usage: node run_shaders.mjs SHRM_WGSL GLOBAL.ktx2 GLOBAL_REF.ktx2 LOCAL.ktx2 LOCAL_REF.ktx2');
  process.exit(2);
}
requireChromium();
const { pass, fail, check, failures } = checker();

// Float32 evaluation on the GPU against the CPU's (float coefficients, double SH): the error of a
// sum of (P + 1)^2 terms c_k Y_k is a few float roundings of sum_k |c_k| |Y_k| (|Y_k| < 1 for
// P <= 7), so it is compared with that scale. 1e-6 is ~16 float epsilons (measured here: 5e-8).
const GLOBAL_REL = 1e-6;
// Local form: the texel frame (a rotation built from the direction) and the SH recurrence in float
// add a few roundings per term (measured: 1e-7). Random directions: the bilinear weights come from
// st in float (2^-24 relative of S), within the same scale.
const LOCAL_REL = 2e-6;
const RANDOM_POINTS = 2000;
// Peak lights: the shaders' float copy of the BRDF against core's double one, relative to the
// texel's sum|c_k| plus its value: a few float roundings per light of GGX's D, G and F (measured
// here: 1e-7; on llvmpipe the model alone stays below 7e-5 at any (N, V, w),
// tests/viewer_render_test.cc LightTransferMatchesCoreModels).
const LIGHTS_REL = 1e-5;

// ktx-parse gives the keys it knows (KTXorientation, KTXwriter) as strings, others as bytes.
const text = (kv, key) => {
  const v = kv[key];
  if (v === undefined || typeof v === 'string') return v;
  return new TextDecoder().decode(v).replace(/\0$/, '');
};

function loadShrm(path, name) {
  const k = read(new Uint8Array(readFileSync(path)));
  const pmax = Number(text(k.keyValue, 'shrm:pmax'));
  const count = (pmax + 1) * (pmax + 1);
  const dfd = k.dataFormatDescriptor[0];
  check(k.vkFormat === 109 && k.typeSize === 4, `ktx2 ${name}: vkFormat ${k.vkFormat} (R32G32B32A32_SFLOAT 109), typeSize ${k.typeSize}`);
  check(k.faceCount === 6 && k.layerCount === count && k.levels.length === 1 && k.pixelDepth === 0 &&
    k.pixelWidth === k.pixelHeight,
  `ktx2 ${name}: cube-map array of ${k.layerCount} layers ((P + 1)^2 = ${count} for shrm:pmax ${pmax}), ` +
    `${k.levels.length} level, ${k.pixelWidth} x ${k.pixelHeight}`);
  check(dfd.colorModel === 1 && dfd.samples.length === 4 && dfd.bytesPlane[0] === 16,
    `ktx2 ${name}: DFD RGBSDA, ${dfd.samples.length} samples, ${dfd.bytesPlane[0]} bytes per texel`);
  check(text(k.keyValue, 'shrm:format') === 'shrm-cube/1' && /layer k = SH coefficient k/.test(text(k.keyValue, 'shrm:layout') ?? '') &&
    text(k.keyValue, 'KTXorientation') === 'rd',
  `ktx2 ${name}: shrm:format ${text(k.keyValue, 'shrm:format')}, shrm:kind ${text(k.keyValue, 'shrm:kind')}, shrm:layout, KTXorientation rd`);
  const level = k.levels[0].levelData;
  const layers = new Float32Array(level.buffer.slice(level.byteOffset, level.byteOffset + level.byteLength));
  // shrm:fresnel: "K C v_0 .. v_K" (C values per node), as [K + 1][3], or null.
  let fresnel = null;
  const ft = text(k.keyValue, 'shrm:fresnel');
  if (ft !== undefined) {
    const w = ft.trim().split(/\s+/).map(Number);
    const nodes = w[0] + 1, ch = w[1];
    check(w.length === 2 + nodes * ch && (ch === 1 || ch === 3) && w.slice(2).every((v) => v > 0),
      `ktx2 ${name}: shrm:fresnel ${nodes} nodes of ${ch} channel(s), all positive`);
    fresnel = [];
    for (let i = 0; i < nodes; ++i)
      fresnel.push([0, 1, 2].map((c) => w[2 + i * ch + Math.min(c, ch - 1)]));
  }
  // shrm:lights "K x y z r g b .." as [K][6], shrm:light_model "M v_0 .. v_19" as 21 numbers.
  let lights = null, lightModel = null;
  const lt = text(k.keyValue, 'shrm:lights');
  if (lt !== undefined) {
    const w = lt.trim().split(/\s+/).map(Number);
    check(w.length === 1 + 6 * w[0] && w[0] > 0, `ktx2 ${name}: shrm:lights lists ${w[0]} lights of 6 numbers`);
    lights = [];
    for (let i = 0; i < w[0]; ++i) lights.push(w.slice(1 + 6 * i, 7 + 6 * i));
    lightModel = (text(k.keyValue, 'shrm:light_model') ?? '').trim().split(/\s+/).map(Number);
    check(lightModel.length === 21 && lightModel.every(Number.isFinite),
      `ktx2 ${name}: shrm:light_model has a model and 20 values (model ${lightModel[0]})`);
  }
  return { pmax, count, size: k.pixelWidth, layers, kind: text(k.keyValue, 'shrm:kind'),
    view: text(k.keyValue, 'shrm:view_variable') ?? 'view', fresnel, lights, lightModel };
}

function loadRef(path) {
  const k = read(new Uint8Array(readFileSync(path)));
  const level = k.levels[0].levelData;
  return {
    size: k.pixelWidth,
    view: text(k.keyValue, 'shrm:view').split(',').map(Number),
    data: new Float32Array(level.buffer.slice(level.byteOffset, level.byteOffset + level.byteLength)),
  };
}

// sum_k |c_k| of texel (face, x, y), channel c: the scale of its rounding error.
function magnitude(shrm, face, x, y, c) {
  let m = 0;
  for (let k = 0; k < shrm.count; ++k) m += Math.abs(shrm.layers[((((k * 6 + face) * shrm.size + y) * shrm.size + x) * 4) + c]);
  return m;
}

// Compares per texel; returns [worst error / scale, texels beyond rel].
function compareTexels(shrm, got, want, rel, withValue = false) {
  const s = shrm.size;
  let worst = 0, over = 0;
  for (let f = 0; f < 6; ++f)
    for (let y = 0; y < s; ++y)
      for (let x = 0; x < s; ++x)
        for (let c = 0; c < 3; ++c) {
          const i = ((f * s + y) * s + x) * 4 + c;
          const scale = magnitude(shrm, f, x, y, c) + (withValue ? Math.abs(want[i]) : 0) + 1e-30;
          const e = Math.abs(got[i] - want[i]) / scale;
          worst = Math.max(worst, e);
          if (e > rel) ++over;
        }
  return [worst, over];
}

const shrmGlobal = loadShrm(globalPath, 'global');
const shrmLocal = loadShrm(localPath, 'local');
const refGlobal = loadRef(globalRefPath);
const refLocal = loadRef(localRefPath);
check(shrmGlobal.kind === 'global' && shrmLocal.kind === 'local' && shrmGlobal.pmax > 0 && shrmLocal.pmax > 0,
  `inputs: a global (P ${shrmGlobal.pmax}) and a local (P ${shrmLocal.pmax}) SHRM with view dependence`);
const code = readFileSync(wgslPath, 'utf8');

const server = await serve([]);
const browser = await launchChromium(['--enable-unsafe-webgpu']);
try {
  const { page, log } = await openPage(browser, `${server.base}/engines/shaders_page.html`, 64, 64);
  const run = (args) => page.evaluate((a) => window.runShrm(a), args);
  const common = (shrm) => ({ code, pmax: shrm.pmax, size: shrm.size, layers: Array.from(shrm.layers),
    fresnel: shrm.fresnel, lights: shrm.lights, lightModel: shrm.lightModel });

  // Eq. 5.35.
  let r = await run({ ...common(shrmGlobal), view: refGlobal.view });
  if (r.error) {
    fail(`global: ${r.error}`);
  } else {
    const [worst, over] = compareTexels(shrmGlobal, r.global, refGlobal.data, GLOBAL_REL);
    check(over === 0, `global: shrm_global_pass = CPU eq. 5.35 at V = (${refGlobal.view.map((v) => v.toFixed(3))}), ` +
      `6 x ${shrmGlobal.size}^2 texels: worst error ${worst.toExponential(2)} of sum|c_k| (limit ${GLOBAL_REL})`);
    const mirrored = [-refGlobal.view[0], refGlobal.view[1], refGlobal.view[2]];
    const m = await run({ ...common(shrmGlobal), view: mirrored });
    const [, overMirrored] = compareTexels(shrmGlobal, m.global, refGlobal.data, GLOBAL_REL);
    check(overMirrored > 0.1 * 6 * 3 * shrmGlobal.size ** 2,
      `global negative control: at the mirrored view ${overMirrored} channel values differ from the CPU map`);
    check(r.errors.length === 0, `global: no WebGPU errors ${r.errors.join('; ')}`);
  }

  // Eq. 5.10 at every texel centre.
  const s = shrmLocal.size;
  const centres = [];
  for (let f = 0; f < 6; ++f)
    for (let y = 0; y < s; ++y)
      for (let x = 0; x < s; ++x) centres.push(texelDirection(f, x, y, s));
  r = await run({ ...common(shrmLocal), view: refLocal.view, dirs: centres });
  if (r.error) {
    fail(`local: ${r.error}`);
  } else {
    const got = r.local;
    const [worst, over] = compareTexels(shrmLocal, got, refLocal.data, LOCAL_REL);
    check(over === 0, `local: shrm_local at the ${centres.length} texel centres = CPU eq. 5.10: worst error ` +
      `${worst.toExponential(2)} of sum|c_k| (limit ${LOCAL_REL})`);
  }

  // Random directions inside faces (the four taps on the same face) against the bilinear
  // interpolation of the CPU texel values.
  let seed = 12345;
  const rnd = () => ((seed = (seed * 1103515245 + 12345) % 2147483648) / 2147483648);
  const dirs = [], want = [], scale = [];
  while (dirs.length < RANDOM_POINTS) {
    const d = normalize([rnd() * 2 - 1, rnd() * 2 - 1, rnd() * 2 - 1]);
    const { face, s: u, t: v } = faceCoordinates(d);
    const px = u * s - 0.5, py = v * s - 0.5;
    const x0 = Math.floor(px), y0 = Math.floor(py);
    if (x0 < 0 || y0 < 0 || x0 + 1 >= s || y0 + 1 >= s) continue;
    const fx = px - x0, fy = py - y0;
    const w = [[x0, y0, (1 - fx) * (1 - fy)], [x0 + 1, y0, fx * (1 - fy)], [x0, y0 + 1, (1 - fx) * fy], [x0 + 1, y0 + 1, fx * fy]];
    const rgb = [0, 0, 0], mag = [0, 0, 0];
    for (const [x, y, wt] of w)
      for (let c = 0; c < 3; ++c) {
        rgb[c] += wt * refLocal.data[((face * s + y) * s + x) * 4 + c];
        mag[c] += wt * magnitude(shrmLocal, face, x, y, c);
      }
    dirs.push(d);
    want.push(rgb);
    scale.push(mag);
  }
  r = await run({ ...common(shrmLocal), view: refLocal.view, dirs });
  if (r.error) {
    fail(`local random: ${r.error}`);
  } else {
    let worst = 0, over = 0;
    dirs.forEach((_, i) => {
      for (let c = 0; c < 3; ++c) {
        const e = Math.abs(r.local[i * 4 + c] - want[i][c]) / (scale[i][c] + 1e-30);
        worst = Math.max(worst, e);
        if (e > LOCAL_REL) ++over;
      }
    });
    check(over === 0, `local: shrm_local at ${dirs.length} random directions = bilinear of the CPU's texel ` +
      `values: worst error ${worst.toExponential(2)} of sum|c_k| (limit ${LOCAL_REL})`);
    check(r.errors.length === 0, `local: no WebGPU errors ${r.errors.join('; ')}`);
  }
  // SHRMs in the normal variable (shrm:view_variable "normal").
  if (localNRefPath) {
    const gN = loadShrm(globalNPath, 'global normal');
    const lN = loadShrm(localNPath, 'local normal');
    const gRef = loadRef(globalNRefPath);
    const lRef = loadRef(localNRefPath);
    check(gN.view === 'normal' && lN.view === 'normal' && gN.kind === 'global' && lN.kind === 'local',
      `normal inputs: shrm:view_variable ${gN.view} (global), ${lN.view} (local)`);
    check(gN.fresnel?.length === 129 && lN.fresnel?.length === 129,
      `normal inputs: GGX f0 0.04 SHRMs carry the Fresnel table (shrm:fresnel, 129 nodes)`);
    r = await run({ ...common(gN), view: gRef.view, viewNormal: true });
    if (r.error) {
      fail(`global normal: ${r.error}`);
    } else {
      const [worst, over] = compareTexels(gN, r.global, gRef.data, LOCAL_REL);
      check(over === 0, `global normal: shrm_global_pass with SHRM_VIEW_NORMAL = CPU eq. 5.35 (Y_pq of each ` +
        `texel's normal), 6 x ${gN.size}^2 texels: worst error ${worst.toExponential(2)} of sum|c_k| (limit ${LOCAL_REL})`);
      const plain = await run({ ...common(gN), view: gRef.view });
      const [, overPlain] = compareTexels(gN, plain.global, gRef.data, LOCAL_REL);
      check(overPlain > 0.1 * 6 * 3 * gN.size ** 2,
        `global normal negative control: without SHRM_VIEW_NORMAL ${overPlain} channel values differ`);
      check(r.errors.length === 0, `global normal: no WebGPU errors ${r.errors.join('; ')}`);
    }
    const centresN = [];
    for (let f = 0; f < 6; ++f)
      for (let y = 0; y < lN.size; ++y)
        for (let x = 0; x < lN.size; ++x) centresN.push(texelDirection(f, x, y, lN.size));
    r = await run({ ...common(lN), view: lRef.view, dirs: centresN, viewNormal: true });
    if (r.error) {
      fail(`local normal: ${r.error}`);
    } else {
      const [worst, over] = compareTexels(lN, r.local, lRef.data, LOCAL_REL);
      check(over === 0, `local normal: shrm_local(R, shrm_view_normal(R, V)) at the ${centresN.length} texel ` +
        `centres = CPU eq. 5.10 in the normal: worst error ${worst.toExponential(2)} of sum|c_k| (limit ${LOCAL_REL})`);
      const bare = await run({ ...common(lN), fresnel: null, view: lRef.view, dirs: centresN, viewNormal: true });
      const [, overBare] = compareTexels(lN, bare.local, lRef.data, LOCAL_REL);
      check(overBare > 0.1 * 6 * 3 * lN.size ** 2,
        `local normal negative control: without the Fresnel table ${overBare} channel values differ`);
      check(r.errors.length === 0, `local normal: no WebGPU errors ${r.errors.join('; ')}`);
    }
  }
  // View-variable SHRMs with the Fresnel table (conventions 4: w(N.V), N.V = |R + V| / 2).
  if (localVRefPath) {
    const gV = loadShrm(globalVPath, 'global view');
    const lV = loadShrm(localVPath, 'local view');
    const gRef = loadRef(globalVRefPath);
    const lRef = loadRef(localVRefPath);
    check(gV.view === 'view' && lV.view === 'view' && gV.fresnel?.length === 129 && lV.fresnel?.length === 129,
      `view inputs: GGX f0 0.04 SHRMs in the view variable carry the Fresnel table (shrm:fresnel, 129 nodes)`);
    r = await run({ ...common(gV), view: gRef.view });
    if (r.error) {
      fail(`global view fresnel: ${r.error}`);
    } else {
      const [worst, over] = compareTexels(gV, r.global, gRef.data, LOCAL_REL);
      check(over === 0, `global view fresnel: shrm_global_pass = CPU eq. 5.35 times w(|R + V| / 2), ` +
        `6 x ${gV.size}^2 texels: worst error ${worst.toExponential(2)} of sum|c_k| (limit ${LOCAL_REL})`);
      const bare = await run({ ...common(gV), fresnel: null, view: gRef.view });
      const [, overBare] = compareTexels(gV, bare.global, gRef.data, LOCAL_REL);
      check(overBare > 0.1 * 6 * 3 * gV.size ** 2,
        `global view negative control: without the Fresnel table ${overBare} channel values differ`);
      check(r.errors.length === 0, `global view fresnel: no WebGPU errors ${r.errors.join('; ')}`);
    }
    const centresV = [];
    for (let f = 0; f < 6; ++f)
      for (let y = 0; y < lV.size; ++y)
        for (let x = 0; x < lV.size; ++x) centresV.push(texelDirection(f, x, y, lV.size));
    r = await run({ ...common(lV), view: lRef.view, dirs: centresV });
    if (r.error) {
      fail(`local view fresnel: ${r.error}`);
    } else {
      const [worst, over] = compareTexels(lV, r.local, lRef.data, LOCAL_REL);
      check(over === 0, `local view fresnel: shrm_local(R, V) at the ${centresV.length} texel centres = CPU ` +
        `eq. 5.10 times w(|R + V| / 2): worst error ${worst.toExponential(2)} of sum|c_k| (limit ${LOCAL_REL})`);
      const bare = await run({ ...common(lV), fresnel: null, view: lRef.view, dirs: centresV });
      const [, overBare] = compareTexels(lV, bare.local, lRef.data, LOCAL_REL);
      check(overBare > 0.1 * 6 * 3 * lV.size ** 2,
        `local view negative control: without the Fresnel table ${overBare} channel values differ`);
      check(r.errors.length === 0, `local view fresnel: no WebGPU errors ${r.errors.join('; ')}`);
    }
  }
  // SHRMs with peak lights: the expansion plus the lights, summed by the shaders' BRDF copy.
  if (localLRefPath) {
    const gL = loadShrm(globalLPath, 'global lights');
    const lL = loadShrm(localLPath, 'local lights');
    const gRef = loadRef(globalLRefPath);
    const lRef = loadRef(localLRefPath);
    check(gL.lights?.length > 0 && lL.lights?.length > 0,
      `lights inputs: ${gL.lights?.length} peak lights (global), ${lL.lights?.length} (local), model ${gL.lightModel?.[0]}`);
    r = await run({ ...common(gL), view: gRef.view, viewNormal: gL.view === 'normal' });
    if (r.error) {
      fail(`global lights: ${r.error}`);
    } else {
      const [worst, over] = compareTexels(gL, r.global, gRef.data, LIGHTS_REL, true);
      check(over === 0, `global lights: shrm_global_pass_lights = CPU eq. 5.35 plus the lights at each texel's ` +
        `normal, 6 x ${gL.size}^2 texels: worst error ${worst.toExponential(2)} of sum|c_k| + |B| (limit ${LIGHTS_REL})`);
      const dark = await run({ ...common(gL), lights: null, view: gRef.view, viewNormal: gL.view === 'normal' });
      const [, overDark] = compareTexels(gL, dark.global, gRef.data, LIGHTS_REL, true);
      check(overDark > 0.1 * 6 * 3 * gL.size ** 2,
        `global lights negative control: without the lights ${overDark} channel values differ`);
      check(r.errors.length === 0, `global lights: no WebGPU errors ${r.errors.join('; ')}`);
    }
    const centresL = [];
    for (let f = 0; f < 6; ++f)
      for (let y = 0; y < lL.size; ++y)
        for (let x = 0; x < lL.size; ++x) centresL.push(texelDirection(f, x, y, lL.size));
    r = await run({ ...common(lL), view: lRef.view, dirs: centresL, viewNormal: lL.view === 'normal' });
    if (r.error) {
      fail(`local lights: ${r.error}`);
    } else {
      const [worst, over] = compareTexels(lL, r.local, lRef.data, LIGHTS_REL, true);
      check(over === 0, `local lights: shrm_local + shrm_lights_at_texel at the ${centresL.length} texel centres = ` +
        `CPU eq. 5.10 plus the lights: worst error ${worst.toExponential(2)} of sum|c_k| + |B| (limit ${LIGHTS_REL})`);
      check(r.errors.length === 0, `local lights: no WebGPU errors ${r.errors.join('; ')}`);
    }
  }
  const pageErrors = log.filter((l) => l.startsWith('pageerror') || l.startsWith('error'));
  check(pageErrors.length === 0, `page: no errors ${pageErrors.join('; ')}`);
} finally {
  await browser.close();
  server.close();
}
console.log(`run_shaders: ${failures()} failure(s)`);
process.exit(failures() ? 1 : 0);
