// The page side of babylon_run.mjs: Babylon.js (WebGL2, SwiftShader in headless Chromium) loads an
// ibl.glb with its glTF loader (EXT_lights_image_based sets scene.environmentTexture) and renders
// the file's spheres with a fixed orthographic camera into a float render target, image
// processing applied "by post-process" (none attached: linear values, no tone mapping, no
// exposure, no gamma), and returns the floats.
import { Engine } from '@babylonjs/core/Engines/engine.js';
import { Scene } from '@babylonjs/core/scene.js';
import { Constants } from '@babylonjs/core/Engines/constants.js';
import { FreeCamera } from '@babylonjs/core/Cameras/freeCamera.js';
import { Camera } from '@babylonjs/core/Cameras/camera.js';
import { Vector3 } from '@babylonjs/core/Maths/math.vector.js';
import { Color4 } from '@babylonjs/core/Maths/math.color.js';
import { RenderTargetTexture } from '@babylonjs/core/Materials/Textures/renderTargetTexture.js';
import { SphericalPolynomial } from '@babylonjs/core/Maths/sphericalPolynomial.js';
import { AppendSceneAsync } from '@babylonjs/core/Loading/sceneLoader.js';
import '@babylonjs/core/Loading/loadingScreen.js';
import '@babylonjs/core/Materials/Textures/baseTexture.polynomial.js';
import '@babylonjs/core/Materials/PBR/pbrMaterial.js';
import '@babylonjs/core/Engines/Extensions/engine.readTexture.js';
import '@babylonjs/loaders/glTF/2.0/index.js';
import '@babylonjs/loaders/glTF/glTFFileLoader.js';

const canvas = document.getElementById('c');
const engine = new Engine(canvas, false, { preserveDrawingBuffer: true, premultipliedAlpha: false });

// Loads `url` (an ibl.glb) into a new scene and renders it: orthographic camera at (0, 0, 10) of
// Babylon's world looking at the origin, +Y up, the view `halfWidth` x `halfHeight` wide.
async function render(url, width, height, halfWidth, halfHeight, linearEnv, specularOnly) {
  const scene = new Scene(engine);
  scene.clearColor = new Color4(0, 0, 0, 1);
  scene.imageProcessingConfiguration.applyByPostProcess = true;  // linear output
  scene.imageProcessingConfiguration.toneMappingEnabled = false;
  scene.imageProcessingConfiguration.exposure = 1;
  await AppendSceneAsync(url, scene, { pluginExtension: '.glb' });
  const camera = new FreeCamera('fixed', new Vector3(0, 0, 10), scene);
  camera.setTarget(Vector3.Zero());
  camera.mode = Camera.ORTHOGRAPHIC_CAMERA;
  [camera.orthoLeft, camera.orthoRight] = [-halfWidth, halfWidth];
  [camera.orthoBottom, camera.orthoTop] = [-halfHeight, halfHeight];
  camera.minZ = 0.1;
  camera.maxZ = 20;
  scene.activeCamera = camera;
  const env = scene.environmentTexture;
  // Babylon 9.35 leaves the loader's RawCubeTexture at gammaSpace = true, so its PBR shader
  // applies toLinearSpace (x^2.2, GAMMAREFLECTION) to the radiance it already decoded from RGBD;
  // `linearEnv` sets gammaSpace = false (the radiance as decoded).
  if (env && linearEnv) env.gammaSpace = false;
  // `specularOnly`: the light's irradiance polynomial set to zero, so that a metallic pixel is
  // Babylon's specular term alone.
  if (env && specularOnly) env.sphericalPolynomial = new SphericalPolynomial();
  const rtt = new RenderTargetTexture('float', { width, height }, scene, {
    generateMipMaps: false, type: Constants.TEXTURETYPE_FLOAT, samplingMode: Constants.TEXTURE_NEAREST_SAMPLINGMODE,
  });
  rtt.renderList = scene.meshes.filter((m) => m.getTotalVertices() > 0);
  for (const m of rtt.renderList) m.alwaysSelectAsActiveMesh = true;
  rtt.activeCamera = camera;
  rtt.clearColor = new Color4(0, 0, 0, 1);
  scene.customRenderTargets.push(rtt);
  // Specular anti-aliasing (the glTF loader turns it on) adds a roughness from the screen-space
  // derivatives of the normal: off, so that the shading is a function of the pixel's normal.
  for (const m of scene.materials) if ('enableSpecularAntiAliasing' in m) m.enableSpecularAntiAliasing = false;
  await scene.whenReadyAsync();
  // Every mesh's effect compiled (shaders compile in parallel) before the frame that is read.
  for (let i = 0; i < 200 && !rtt.renderList.every((m) => m.isReady(true) && m.material.isReady(m)); ++i) {
    scene.render();
    await new Promise((ok) => setTimeout(ok, 20));
  }
  scene.render();
  const pixels = Array.from(await rtt.readPixels());
  // The canvas frame (linear, clamped to 8 bits) for the screenshot.
  const mat = rtt.renderList[0].material;
  const defines = mat.getEffect()?.defines ?? '';
  const info = {
    environment: env ? env.getClassName() : null,
    size: env ? env.getSize().width : 0,
    level: env?.level,
    lodGenerationScale: env?.lodGenerationScale,
    lodGenerationOffset: env?.lodGenerationOffset,
    textureType: env?._texture?.type,
    isRGBD: env?._texture?._isRGBD,
    material: mat.getClassName(),
    root: scene.getNodeByName('__root__') ? {
      rotation: scene.getNodeByName('__root__').rotationQuaternion?.asArray(),
      scaling: scene.getNodeByName('__root__').scaling.asArray(),
    } : null,
    meshes: rtt.renderList.map((m) => ({ name: m.name, ready: m.isReady(true) && m.material.isReady(m), enabled: m.isEnabled(), subMeshes: m.subMeshes?.length, indices: m.getTotalIndices(), centre: m.getBoundingInfo().boundingSphere.centerWorld.asArray(), roughness: m.material.roughness, metallic: m.material.metallic })),
    defines: defines.split('\n').filter((d) => /LODBASEDMICROSFURACE|LODINREFLECTIONALPHA|LINEARSPECULARREFLECTION|REALTIME_FILTERING|RGBDREFLECTION|MS_BRDF_ENERGY_CONSERVATION|BRDF_V_HEIGHT_CORRELATED|RADIANCEOCCLUSION|HORIZONOCCLUSION|SPECULARAA|REFLECTIONMAP_OPPOSITEZ|INVERTCUBICMAP|IMAGEPROCESSINGPOSTPROCESS|USESPHERICALFROMREFLECTIONMAP|USE_EXACT_SRGB|GAMMAREFLECTION|ENVIRONMENTBRDF\b|SPECULARTERM|USEIRRADIANCEMAP|USESPHERICALINVERTEX/.test(d)).map((d) => d.trim()),
  };
  scene.customRenderTargets.length = 0;
  scene.render();
  rtt.dispose();
  return { pixels, info, dispose: null };
}

window.shrmBabylon = {
  info: () => ({ version: Engine.Version, webgl2: engine.webGLVersion, renderer: engine.getGlInfo().renderer, floatRender: engine.getCaps().textureFloatRender }),
  render: async (url, w, h, hw, hh, linearEnv, specularOnly) => {
    for (const s of engine.scenes.slice()) s.dispose();
    const r = await render(url, w, h, hw, hh, linearEnv, specularOnly);
    return { pixels: r.pixels, info: r.info };
  },
};
window.shrmReady = true;
