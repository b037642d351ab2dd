// The page side of run_browser.mjs: three.js (WebGL2, SwiftShader in headless Chromium) consumes
// a `shrm ibl` set. Every function renders into a float render target and returns the floats it
// read back (run_browser.mjs compares them with what it decoded from the files in node).
import * as THREE from 'three';
import { KTX2Loader } from 'three/addons/loaders/KTX2Loader.js';
import { read } from 'ktx-parse';

const canvas = document.getElementById('c');
const renderer = new THREE.WebGLRenderer({ canvas, antialias: false, alpha: false });
renderer.toneMapping = THREE.NoToneMapping;
renderer.outputColorSpace = THREE.LinearSRGBColorSpace;
const gl = renderer.getContext();

// The uploaded form of each vkFormat shrm writes (WebGL2 internal formats RGBA16F, RGBA32F,
// R11F_G11F_B10F, RGB9_E5, chosen by three from format + type).
const UPLOAD = {
  97: { format: THREE.RGBAFormat, type: THREE.HalfFloatType, view: (b) => new Uint16Array(b.buffer, b.byteOffset, b.byteLength / 2) },
  109: { format: THREE.RGBAFormat, type: THREE.FloatType, view: (b) => new Float32Array(b.buffer, b.byteOffset, b.byteLength / 4) },
  122: { format: THREE.RGBFormat, type: THREE.UnsignedInt101111Type, view: (b) => new Uint32Array(b.buffer, b.byteOffset, b.byteLength / 4) },
  123: { format: THREE.RGBFormat, type: THREE.UnsignedInt5999Type, view: (b) => new Uint32Array(b.buffer, b.byteOffset, b.byteLength / 4) },
};

async function fetchBytes(url) {
  const r = await fetch(url);
  if (!r.ok) throw new Error(`${url}: HTTP ${r.status}`);
  return new Uint8Array(await r.arrayBuffer());
}

// What three's own KTX2Loader (r187) makes of the file: it reads uncompressed formats itself
// (no transcoder), but builds a 2D DataTexture for them whatever faceCount says, so it cannot be
// used for these cube maps; reported, not relied on.
async function loaderReport(url) {
  const loader = new KTX2Loader().detectSupport(renderer);
  const tex = await loader.loadAsync(url);
  const r = {
    class: tex.constructor.name, isCubeTexture: !!tex.isCubeTexture, type: tex.type, format: tex.format,
    width: tex.image.width, height: tex.image.height, mipmaps: tex.mipmaps.length,
    level0Values: tex.mipmaps[0]?.data?.length ?? 0,
  };
  tex.dispose();
  loader.dispose();
  return r;
}

// A THREE.CubeTexture with every level of the file, faces in file order given to GL as
// TEXTURE_CUBE_MAP_POSITIVE_X + i (three's uploadCubeTexture), rows as stored (flipY false).
function cubeFromKtx2(bytes, filter) {
  const c = read(bytes);
  const u = UPLOAD[c.vkFormat];
  if (!u) throw new Error(`vkFormat ${c.vkFormat} not handled`);
  const levelFaces = c.levels.map((l, k) => {
    const n = Math.max(1, c.pixelWidth >> k);
    const all = u.view(l.levelData);
    const per = all.length / 6;
    return Array.from({ length: 6 }, (_, f) => {
      const t = new THREE.DataTexture(all.subarray(f * per, (f + 1) * per), n, n, u.format, u.type);
      return t;
    });
  });
  const cube = new THREE.CubeTexture(levelFaces[0]);
  cube.mipmaps = levelFaces.slice(1).map((faces) => ({ image: faces }));
  cube.format = u.format;
  cube.type = u.type;
  cube.colorSpace = THREE.LinearSRGBColorSpace;
  cube.generateMipmaps = false;
  cube.flipY = false;
  cube.magFilter = filter === 'linear' ? THREE.LinearFilter : THREE.NearestFilter;
  cube.minFilter = c.levels.length === 1
    ? cube.magFilter
    : filter === 'linear' ? THREE.LinearMipmapLinearFilter : THREE.NearestMipmapNearestFilter;
  cube.needsUpdate = true;
  return { cube, levels: c.levels.length, size: c.pixelWidth };
}

function floatTarget(w, h) {
  return new THREE.WebGLRenderTarget(w, h, {
    type: THREE.FloatType, format: THREE.RGBAFormat, depthBuffer: true,
    minFilter: THREE.NearestFilter, magFilter: THREE.NearestFilter, colorSpace: THREE.LinearSRGBColorSpace,
  });
}

function readTarget(target) {
  const out = new Float32Array(target.width * target.height * 4);
  renderer.readRenderTargetPixels(target, 0, 0, target.width, target.height, out);
  return out;
}

// Direct lookups: pixel i of a W x H target returns textureLod(cube, q.xyz, q.w) for query i
// (a direction and an integer level), i.e. exactly what GL's cube-map selection finds there.
async function lookup(url, queries, width) {
  const { cube } = cubeFromKtx2(await fetchBytes(url), 'nearest');
  const n = queries.length / 4;
  const height = Math.ceil(n / width);
  const q = new Float32Array(width * height * 4);
  q.set(queries);
  const qt = new THREE.DataTexture(q, width, height, THREE.RGBAFormat, THREE.FloatType);
  qt.needsUpdate = true;
  const mat = new THREE.ShaderMaterial({
    glslVersion: THREE.GLSL3,
    uniforms: { cube: { value: cube }, queries: { value: qt } },
    vertexShader: 'void main() { gl_Position = vec4(position.xy, 0.0, 1.0); }',
    fragmentShader: `
      uniform samplerCube cube;
      uniform highp sampler2D queries;
      out highp vec4 colour;
      void main() {
        vec4 q = texelFetch(queries, ivec2(gl_FragCoord.xy), 0);
        colour = vec4(textureLod(cube, q.xyz, q.w).rgb, 1.0);
      }`,
  });
  const scene = new THREE.Scene();
  scene.add(new THREE.Mesh(new THREE.PlaneGeometry(2, 2), mat));
  const target = floatTarget(width, height);
  renderer.setRenderTarget(target);
  renderer.render(scene, new THREE.Camera());
  renderer.setRenderTarget(null);
  const out = readTarget(target);
  target.dispose(); qt.dispose(); cube.dispose(); mat.dispose();
  return Array.from(out.subarray(0, n * 4));
}

// The orientation scene: a unit sphere at the origin, orthographic camera at (1, 1, 1) looking at
// the origin with +Y up, so world +X is seen right of and below the centre, +Y above it, -Z
// hidden behind; camera axes right = (1, 0, -1)/sqrt2, up = (-1, 2, -1)/sqrt6. The view spans
// [-1.1, 1.1] in both screen axes. run_browser.mjs maps pixels back to normals with the same axes.
const VIEW = 1.1;
function sphereScene(material) {
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0, 0, 0);
  scene.add(new THREE.Mesh(new THREE.SphereGeometry(1, 192, 96), material));
  const camera = new THREE.OrthographicCamera(-VIEW, VIEW, VIEW, -VIEW, 0.1, 10);
  camera.position.set(1, 1, 1).multiplyScalar(5 / Math.sqrt(3));
  camera.up.set(0, 1, 0);
  camera.lookAt(0, 0, 0);
  return { scene, camera };
}

function renderSphere(material, size, display, extra) {
  const { scene, camera } = sphereScene(material);
  if (extra) scene.add(extra);
  const target = floatTarget(size, size);
  renderer.setRenderTarget(target);
  renderer.render(scene, camera);
  renderer.setRenderTarget(null);
  const out = readTarget(target);
  // Screenshot: the same scene on the canvas, exposure `display`, three's sRGB output.
  renderer.outputColorSpace = THREE.SRGBColorSpace;
  renderer.toneMapping = THREE.LinearToneMapping;
  renderer.toneMappingExposure = display;
  renderer.setSize(size, size, false);
  renderer.render(scene, camera);
  renderer.outputColorSpace = THREE.LinearSRGBColorSpace;
  renderer.toneMapping = THREE.NoToneMapping;
  target.dispose();
  return Array.from(out);
}

// The cube sampled by the sphere's (interpolated, world) normal at one level: the file as a globe.
async function normalSphere(url, level, size, display) {
  const { cube } = cubeFromKtx2(await fetchBytes(url), 'nearest');
  const mat = new THREE.ShaderMaterial({
    glslVersion: THREE.GLSL3,
    uniforms: { cube: { value: cube }, lod: { value: level } },
    vertexShader: `
      out vec3 vNormal;
      void main() {
        vNormal = normalize(mat3(modelMatrix) * normal);
        gl_Position = projectionMatrix * modelViewMatrix * vec4(position, 1.0);
      }`,
    fragmentShader: `
      uniform samplerCube cube;
      uniform float lod;
      in vec3 vNormal;
      out highp vec4 colour;
      void main() { colour = vec4(textureLod(cube, normalize(vNormal), lod).rgb, 1.0); }`,
  });
  const r = renderSphere(mat, size, display);
  cube.dispose(); mat.dispose();
  return r;
}

// three's own image-based lighting: MeshStandardMaterial (white, metalness 0, roughness 1) with
// the cube as envMap; three re-filters it (PMREMGenerator). `asRenderTarget`: the cube is
// uploaded first and then flagged isRenderTargetTexture, which is how three marks cubes that are
// in the GL convention (CubeCamera's); otherwise three negates x for CubeTextures.
async function standardSphere(url, size, display, asRenderTarget) {
  const { cube } = cubeFromKtx2(await fetchBytes(url), 'linear');
  if (asRenderTarget) {
    renderer.initTexture(cube);
    cube.isRenderTargetTexture = true;
  }
  const mat = new THREE.MeshStandardMaterial({ color: 0xffffff, metalness: 0, roughness: 1, envMap: cube });
  const r = renderSphere(mat, size, display);
  cube.dispose(); mat.dispose();
  return r;
}

// A LightProbe with the given three.js SH coefficients (9 x [r, g, b]) on a white Lambert sphere:
// out = irradiance / pi (three's BRDF_Lambert).
function probeSphere(coefficients, size, display) {
  const sh = new THREE.SphericalHarmonics3();
  coefficients.forEach((c, k) => sh.coefficients[k].set(c[0], c[1], c[2]));
  const probe = new THREE.LightProbe(sh, 1);
  const mat = new THREE.MeshLambertMaterial({ color: 0xffffff });
  const r = renderSphere(mat, size, display, probe);
  mat.dispose();
  return r;
}

function info() {
  return {
    renderer: gl.getParameter(gl.getExtension('WEBGL_debug_renderer_info')?.UNMASKED_RENDERER_WEBGL ?? gl.RENDERER),
    version: gl.getParameter(gl.VERSION),
    colorBufferFloat: !!gl.getExtension('EXT_color_buffer_float'),
    three: THREE.REVISION,
  };
}

window.shrmEngines = { info, loaderReport, lookup, normalSphere, standardSphere, probeSphere };
window.shrmReady = true;
