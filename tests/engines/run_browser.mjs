// three.js in headless Chromium (Debian's /usr/bin/chromium, WebGL2 on SwiftShader, driven by
// playwright-core) consumes `shrm ibl` sets served from a loopback HTTP server started here.
//
// Usage: node run_browser.mjs OUT_DIR PATCH_SET [LOOKUP_SET ...] [--broken BROKEN_SET ...]
//                             [--probe LOOKUP_SET ...]
//   PATCH_SET:  a set made from engines_test.sh's patches.exr (ktx_cube.mjs PATCHES: red at +X,
//               green at +Y, blue at -Z), with --sheen: every check below.
//   LOOKUP_SET: further sets (other formats, other maps): lookups only.
//   --probe:    LOOKUP_SETs (real maps) that also get the LightProbe check (without orientation).
//   BROKEN_SET: break_set.mjs copies of PATCH_SET (mirrored, upside down): the orientation check
//               must reject them (negative controls; their lookups still match, as they should).
//   OUT_DIR:    screenshots (PNG) and the browser's console log.
// Checks (PASS/FAIL lines, exit 1 on any FAIL):
//   lookup:      every texel of every level of every cube, fetched by GL's cube-map selection at
//                the texel's direction (textureLod, float render target, readPixels), equals the
//                value decoded from the file in node: face order, row order, level order and the
//                packed formats' bit layout as a real GL consumer reads them.
//   orientation: the cube on a sphere (sampled by the world normal; orthographic camera at
//                (1,1,1), +Y up) at level 0 and a rough level: red around +X, green around +Y
//                (centroids of the bright pixels' normals), every pixel = the file's texel at the
//                pixel's normal.
//   three IBL:   MeshStandardMaterial with the cube as envMap (three's own PMREM), as three
//                treats a CubeTexture (x negated) and as a GL-convention render-target cube.
//   LightProbe:  radiance_sh9 converted to three's SphericalHarmonics3 lights a Lambert sphere:
//                rendered = three's SH irradiance formula evaluated in node, red around +X,
//                and close to irradiance.ktx2.
import { readFileSync, writeFileSync, mkdirSync } from 'node:fs';
import { join, resolve, basename } from 'node:path';
import { checker, launchChromium, serve, openPage, requireChromium } from './harness.mjs';
import { read } from 'ktx-parse';
import {
  decodeCubeLevel, texelDirection, sampleNearest, normalize, projectToThreeSh9, patchCentre,
} from './ktx_cube.mjs';

const groups = { '': [], '--broken': [], '--probe': [] };
let group = '';
for (const a of process.argv.slice(2)) {
  if (a in groups) group = a;
  else groups[group].push(resolve(a));
}
const [outDir, patchSet, ...lookupSets] = groups[''];
const brokenSets = groups['--broken'];
const probeSets = groups['--probe'].filter((p) => lookupSets.includes(p));
if (!outDir || !patchSet) {
  console.error('usage: node run_browser.mjs OUT_DIR PATCH_SET [LOOKUP_SET ...]');
  process.exit(2);
}
requireChromium();
mkdirSync(outDir, { recursive: true });

const { pass, fail, check, failures } = checker();

// --- loopback server: /engines/ = this folder, /node_modules/, /set/<k>/ = the sets -----------
const sets = [patchSet, ...lookupSets, ...brokenSets];
const server = await serve(sets);
const base = server.base;

// --- node-side decoding -------------------------------------------------------------------------
function loadCube(file) {
  const c = read(new Uint8Array(readFileSync(file)));
  return {
    vk: c.vkFormat,
    levels: c.levels.map((l, k) => decodeCubeLevel(l.levelData, c.vkFormat, Math.max(1, c.pixelWidth >> k))),
  };
}

const relDiff = (a, b) => Math.abs(a - b) / Math.max(Math.abs(b), 1e-3);

// --- the checks ---------------------------------------------------------------------------------
async function runChecks() {
  const t0 = Date.now();
  const phases = [];
  const phase = (name) => phases.push(`${name} ${((Date.now() - t0) / 1000).toFixed(1)} s`);
  // 1. lookups of every texel, every file of every set (not the broken copies).
  for (let si = 0; si < 1 + lookupSets.length; ++si) {
    const json = JSON.parse(readFileSync(join(sets[si], 'ibl.json'), 'utf8'));
    for (const f of json.files.filter((x) => x.type === 'cube')) {
      const cube = loadCube(join(sets[si], f.name));
      const queries = [];
      const want = [];
      cube.levels.forEach((l, k) => {
        for (let face = 0; face < 6; ++face) for (let y = 0; y < l.size; ++y) for (let x = 0; x < l.size; ++x) {
          queries.push(...texelDirection(face, x, y, l.size), k);
          const i = (y * l.size + x) * 4;
          want.push(l.faces[face][i], l.faces[face][i + 1], l.faces[face][i + 2]);
        }
      });
      const got = await page.evaluate(([u, q]) => window.shrmEngines.lookup(u, q, 256), [`/set/${si}/${f.name}`, queries]);
      let worst = 0, wrong = 0;
      for (let t = 0; t < want.length / 3; ++t) {
        let bad = false;
        for (let ch = 0; ch < 3; ++ch) {
          const d = relDiff(got[4 * t + ch], want[3 * t + ch]);
          worst = Math.max(worst, d);
          if (!(d <= 1e-6)) bad = true;
        }
        if (bad) wrong++;
      }
      check(wrong === 0, `lookup ${basename(sets[si])}/${f.name} (${json.format}): all ${want.length / 3} texels of ${cube.levels.length} levels read back by GL textureLod at their directions (worst relative difference ${worst.toExponential(2)}, ${wrong} differ)`);
    }
  }

  phase('lookups');
  // 2. three's KTX2Loader, for the record.
  const rep = await page.evaluate(() => window.shrmEngines.loaderReport('/set/0/specular.ktx2'));
  console.log(`INFO: three r${(await page.evaluate(() => window.shrmEngines.info())).three} KTX2Loader on specular.ktx2 -> ${rep.class} (isCubeTexture ${rep.isCubeTexture}), ${rep.width}x${rep.height}, ${rep.mipmaps} mipmaps, level 0 holds ${rep.level0Values} values (6 faces); it does not build cube textures from uncompressed KTX2 cubes, so the page builds a THREE.CubeTexture from ktx-parse's levels`);
  check(rep.mipmaps > 0, 'three KTX2Loader parses specular.ktx2 (vkFormat, levels) without a transcoder');

  const json = JSON.parse(readFileSync(join(patchSet, 'ibl.json'), 'utf8'));
  const spec = loadCube(join(patchSet, 'specular.ktx2'));
  const irr = loadCube(join(patchSet, 'irradiance.ktx2'));
  const S = 256, VIEW = 1.1;
  // Pixel (i, j) of the float image (j = 0 at the bottom) -> the world normal there, or null
  // (page.mjs sphereScene: orthographic camera at (1, 1, 1), +Y up).
  const RED = patchCentre('R'); // +X, 22.5 degrees up
  const CAM = { right: normalize([1, 0, -1]), up: normalize([-1, 2, -1]), back: normalize([1, 1, 1]) };
  const screenOf = (i, j) => [-VIEW + ((i + 0.5) * 2 * VIEW) / S, -VIEW + ((j + 0.5) * 2 * VIEW) / S];
  const normalAt = (i, j, rmax = 0.97) => {
    const [x, y] = screenOf(i, j);
    const r2 = x * x + y * y;
    if (r2 >= rmax * rmax) return null;
    const z = Math.sqrt(1 - r2);
    return [0, 1, 2].map((a) => x * CAM.right[a] + y * CAM.up[a] + z * CAM.back[a]);
  };
  const px = (img, i, j) => img.slice(4 * (j * S + i), 4 * (j * S + i) + 3);
  // Where a channel is bright: the peak, and the centroid of (value - the channel's minimum on
  // the sphere) as a world direction and as a screen position.
  const where = (img, ch) => {
    let lo = Infinity, peak = 0;
    for (let j = 0; j < S; ++j) for (let i = 0; i < S; ++i) if (normalAt(i, j)) {
      lo = Math.min(lo, img[4 * (j * S + i) + ch]);
      peak = Math.max(peak, img[4 * (j * S + i) + ch]);
    }
    const c = [0, 0, 0], sc = [0, 0];
    let sw = 0;
    for (let j = 0; j < S; ++j) for (let i = 0; i < S; ++i) {
      const n = normalAt(i, j);
      if (!n) continue;
      const w = img[4 * (j * S + i) + ch] - lo;
      const [x, y] = screenOf(i, j);
      for (let a = 0; a < 3; ++a) c[a] += w * n[a];
      sc[0] += w * x; sc[1] += w * y; sw += w;
    }
    const dir = normalize(c);
    const deg = (axis) => (Math.acos(Math.max(-1, Math.min(1, dir[0] * axis[0] + dir[1] * axis[1] + dir[2] * axis[2]))) * 180) / Math.PI;
    return { lo, peak, dir, screen: [sc[0] / sw, sc[1] / sw], toX: deg([1, 0, 0]), toRed: deg(RED), toY: deg([0, 1, 0]) };
  };
  const describe = (r, g) => `red peak ${r.peak.toFixed(3)} (min ${r.lo.toFixed(3)}), centroid at screen (${r.screen.map((v) => v.toFixed(2))}) = ${r.toRed.toFixed(1)} deg from the red patch's centre (${r.toX.toFixed(1)} from +X); green peak ${g.peak.toFixed(3)}, centroid at screen (${g.screen.map((v) => v.toFixed(2))}) = ${g.toY.toFixed(1)} deg from +Y`;
  const shot = async (name) => page.locator('#c').screenshot({ path: join(outDir, name) });
  // Not black, no NaN or infinity anywhere in the float image, background black.
  const sane = (img, name) => {
    let nonFinite = 0, lit = 0, sphere = 0, bgLit = 0;
    for (let j = 0; j < S; ++j) for (let i = 0; i < S; ++i) {
      const v = img.slice(4 * (j * S + i), 4 * (j * S + i) + 3);
      nonFinite += v.filter((x) => !Number.isFinite(x)).length;
      if (normalAt(i, j)) { sphere++; if (Math.max(...v) > 0) lit++; }
      else if (normalAt(i, j, 1.05) === null && Math.max(...v) !== 0) bgLit++;
    }
    check(nonFinite === 0 && lit === sphere && bgLit === 0,
      `${name}: ${S}x${S} float image read back: ${nonFinite} NaN/inf values, ${lit} of ${sphere} sphere pixels > 0, ${bgLit} lit background pixels`);
  };
  const fmt = (v) => v.toFixed(3);

  // The globe shows the patches where they are: red centroid near the red patch's centre, green
  // near +Y (the visible hemisphere pulls rough levels' centroids towards the camera).
  const globeOk = (r, g, level) => r.peak > 3 * r.lo && g.peak > 3 * g.lo && r.toRed < (level ? 30 : 15) && g.toY < (level ? 30 : 15);

  // 3. orientation: the cube as a globe, level 0 and the rough level nearest roughness 0.5.
  const rough = json.specular.levels.reduce((b, l, k, a) => (Math.abs(l.roughness - 0.5) < Math.abs(a[b].roughness - 0.5) ? k : b), 0);
  for (const level of [0, rough]) {
    const img = await page.evaluate(([l]) => window.shrmEngines.normalSphere('/set/0/specular.ktx2', l, 256, 0.5), [level]);
    await shot(`specular_level${level}.png`);
    sane(img, `globe level ${level}`);
    const r = where(img, 0), g = where(img, 1);
    check(globeOk(r, g, level), `orientation specular level ${level} (roughness ${+json.specular.levels[level].roughness.toFixed(4)}), camera at (1,1,1): ${describe(r, g)} (want < ${level ? 30 : 15} deg, peaks > 3 x min)`);
    // Every sphere pixel equals the file's texel at the pixel's normal (nearest filtering; the
    // interpolated normal may pick a neighbouring texel next to texel edges: accepted when a
    // direction within 0.3 texel of the normal selects that value).
    const L = spec.levels[level];
    const eps = (0.6 / L.size);
    let n = 0, wrong = 0, worst = 0;
    for (let j = 0; j < S; j += 2) for (let i = 0; i < S; i += 2) {
      const nn = normalAt(i, j, 0.95);
      if (!nn) continue;
      n++;
      const v = px(img, i, j);
      let best = Infinity;
      for (const [a, b, c] of [[0, 0, 0], [eps, 0, 0], [-eps, 0, 0], [0, eps, 0], [0, -eps, 0], [0, 0, eps], [0, 0, -eps]]) {
        const w = sampleNearest(L, normalize([nn[0] + a, nn[1] + b, nn[2] + c]));
        best = Math.min(best, Math.max(...[0, 1, 2].map((ch) => relDiff(v[ch], w[ch]))));
      }
      if (best > 1e-6) { wrong++; worst = Math.max(worst, best); }
    }
    check(wrong === 0, `values specular level ${level}: ${n} sphere pixels = the file's texel at the pixel normal (${wrong} differ${wrong ? `, worst ${worst.toExponential(2)}` : ''})`);
  }

  phase('globe');
  // 4. three's own IBL path (PMREM of the cube, MeshStandardMaterial): documents three's convention.
  for (const asRT of [false, true]) {
    const img = await page.evaluate(([rt]) => window.shrmEngines.standardSphere('/set/0/specular.ktx2', 256, 1.5, rt), [asRT]);
    await shot(`three_standard_${asRT ? 'rendertarget' : 'cubetexture'}.png`);
    sane(img, `three MeshStandardMaterial (${asRT ? 'render-target cube' : 'CubeTexture'})`);
    const r = where(img, 0), g = where(img, 1);
    const side = r.toX < 90 ? '+X side (correct)' : '-X side (mirrored)';
    console.log(`INFO: three MeshStandardMaterial envMap, cube ${asRT ? 'flagged isRenderTargetTexture' : 'as a plain CubeTexture'}: red on the ${side}: ${describe(r, g)}`);
    if (asRT) check(r.toX < 45 && g.toY < 45, `three IBL (MeshStandardMaterial, PMREM) with the cube marked as GL-convention (isRenderTargetTexture): red lights the +X side, green the +Y side`);
    else check(r.toX > 90 && g.toY < 45, `three IBL with the cube as a plain THREE.CubeTexture is mirrored in x, as three r187 does for every non-render-target CubeTexture (WebGLMaterials, PMREMGenerator flipEnvMap = -1): red lights the -X side, green the +Y side`);
  }

  phase('three IBL');
  // 5. LightProbe from radiance_sh9 (the patches set, and the --probe sets).
  const probe = async (si, irrTol) => {
    const set = sets[si];
    const name = basename(set);
    const pj = JSON.parse(readFileSync(join(set, 'ibl.json'), 'utf8'));
    const irrCube = loadCube(join(set, 'irradiance.ktx2'));
    const coef = Array.from({ length: 9 }, () => [0, 0, 0]);
    for (let ch = 0; ch < 3; ++ch) projectToThreeSh9(pj.radiance_sh9.map((c) => c[ch])).forEach((v, k) => { coef[k][ch] = v; });
    const img = await page.evaluate(([c]) => window.shrmEngines.probeSphere(c, 256, 1.5), [coef]);
    await shot(`three_lightprobe_${name}.png`);
    sane(img, `three LightProbe ${name}`);
    // three's shGetIrradianceAt (lights_pars_begin.glsl) / pi: what the Lambert sphere must show.
    const threeIrradiance = (n, ch) => {
      const [x, y, z] = n, c = coef.map((v) => v[ch]);
      return (c[0] * 0.886227 + 2 * 0.511664 * (c[1] * y + c[2] * z + c[3] * x) +
        2 * 0.429043 * (c[4] * x * y + c[5] * y * z + c[7] * x * z) + c[6] * (0.743125 * z * z - 0.247708) +
        c[8] * 0.429043 * (x * x - y * y)) / Math.PI;
    };
    let worst = 0, worstIrr = 0, n = 0, scale = 0;
    for (let j = 0; j < S; ++j) for (let i = 0; i < S; ++i) if (normalAt(i, j)) scale = Math.max(scale, ...px(img, i, j));
    const l0 = irrCube.levels[0];
    for (let j = 0; j < S; j += 2) for (let i = 0; i < S; i += 2) {
      const nn = normalAt(i, j, 0.95);
      if (!nn) continue;
      n++;
      const v = px(img, i, j);
      const w = sampleNearest(l0, nn);
      for (let ch = 0; ch < 3; ++ch) {
        worst = Math.max(worst, Math.abs(v[ch] - threeIrradiance(nn, ch)) / scale);
        worstIrr = Math.max(worstIrr, Math.abs(v[ch] - w[ch]) / scale);
      }
    }
    check(worst < 2e-3, `LightProbe ${name}: ${n} pixels = three's SH irradiance / pi at the pixel normal, evaluated in node (worst ${worst.toExponential(2)} of the peak ${fmt(scale)})`);
    check(worstIrr < irrTol, `LightProbe ${name} vs irradiance.ktx2 (an order-2 SH against the full irradiance): worst ${worstIrr.toFixed(3)} of the peak (tolerance ${irrTol})`);
    return img;
  };
  const img = await probe(0, 0.25);
  const r = where(img, 0), g = where(img, 1);
  check(r.toX < 45 && g.toY < 45, `LightProbe (radiance_sh9 -> three SphericalHarmonics3): ${describe(r, g)} (want < 45 deg)`);
  for (const set of probeSets) await probe(sets.indexOf(set), 0.1);
  phase('LightProbe');
  // 6. negative controls: the broken copies must fail the globe check at level 0.
  for (let b = 0; b < brokenSets.length; ++b) {
    const si = 1 + lookupSets.length + b;
    const img = await page.evaluate(([u]) => window.shrmEngines.normalSphere(u, 0, 256, 0.5), [`/set/${si}/specular.ktx2`]);
    await shot(`broken_${basename(brokenSets[b])}.png`);
    const r = where(img, 0), g = where(img, 1);
    check(!globeOk(r, g, 0), `negative control ${basename(brokenSets[b])}: the orientation check rejects it: ${describe(r, g)}`);
  }
  phase('negative controls');
  console.log(`INFO: elapsed (cumulative): ${phases.join(', ')}`);
  console.log(`INFO: screenshots in ${outDir}: ${['specular_level0', `specular_level${rough}`, 'three_standard_cubetexture', 'three_standard_rendertarget', ...[patchSet, ...probeSets].map((p) => `three_lightprobe_${basename(p)}`)].map((s) => `${s}.png`).join(' ')}`);
}

// --- main (last: the helpers above are initialized by now) ---------------------------------
const browser = await launchChromium();
let consoleLog = [];
let page;
try {
  ({ page, log: consoleLog } = await openPage(browser, `${base}/engines/page.html`, 256, 256));
  const info = await page.evaluate(() => window.shrmEngines.info());
  check(info.colorBufferFloat, `browser: ${await browser.version()}, ${info.version}, ${info.renderer}, three r${info.three}, EXT_color_buffer_float`);
  await runChecks();
} catch (e) {
  fail(`browser: ${e.stack ?? e}`);
} finally {
  writeFileSync(join(outDir, 'console.log'), consoleLog.join('\n') + '\n');
  await browser.close();
  server.close();
}
console.log(`browser: ${failures() === 0 ? 'all checks passed' : `${failures()} check(s) failed`}`);
process.exit(failures() === 0 ? 0 : 1);
