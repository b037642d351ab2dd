// Filament (npm `filament`, WASM + WebGL2) loads `shrm ibl --containers ktx1` files the way its
// own samples load cmgen's: Engine.createIblFromKtx1 (ibl.ktx, with the irradiance SH of its "sh"
// key) and createSkyFromKtx1 (skybox.ktx), and renders a sphere per roughness through gltfio's
// ubershader materials (the sphere is a small glTF made here). Driven by run_filament.mjs.
'use strict';

// A UV sphere of radius 1 as a GLB: POSITION, NORMAL, indices; one material (metallic-roughness).
function sphereGlb(metallic, roughness) {
  const rings = 96, segs = 192;
  const pos = [], idx = [];
  for (let i = 0; i <= rings; ++i) {
    const th = (Math.PI * i) / rings;
    for (let j = 0; j <= segs; ++j) {
      const ph = (2 * Math.PI * j) / segs;
      pos.push(Math.sin(th) * Math.cos(ph), Math.cos(th), -Math.sin(th) * Math.sin(ph));
    }
  }
  for (let i = 0; i < rings; ++i) for (let j = 0; j < segs; ++j) {
    const a = i * (segs + 1) + j, b = a + segs + 1;
    idx.push(a, b, a + 1, a + 1, b, b + 1);
  }
  const p = new Float32Array(pos), ix = new Uint32Array(idx);
  const bin = new Uint8Array(p.byteLength * 2 + ix.byteLength);
  bin.set(new Uint8Array(p.buffer), 0);
  bin.set(new Uint8Array(p.buffer), p.byteLength);  // normals = positions on a unit sphere
  bin.set(new Uint8Array(ix.buffer), 2 * p.byteLength);
  const json = {
    asset: { version: '2.0', generator: 'shrm engines test' },
    scene: 0, scenes: [{ nodes: [0] }], nodes: [{ mesh: 0 }],
    meshes: [{ primitives: [{ attributes: { POSITION: 0, NORMAL: 1 }, indices: 2, material: 0 }] }],
    materials: [{ pbrMetallicRoughness: { baseColorFactor: [1, 1, 1, 1], metallicFactor: metallic, roughnessFactor: roughness } }],
    buffers: [{ byteLength: bin.byteLength }],
    bufferViews: [
      { buffer: 0, byteOffset: 0, byteLength: p.byteLength, target: 34962 },
      { buffer: 0, byteOffset: p.byteLength, byteLength: p.byteLength, target: 34962 },
      { buffer: 0, byteOffset: 2 * p.byteLength, byteLength: ix.byteLength, target: 34963 },
    ],
    accessors: [
      { bufferView: 0, componentType: 5126, count: p.length / 3, type: 'VEC3', min: [-1, -1, -1], max: [1, 1, 1] },
      { bufferView: 1, componentType: 5126, count: p.length / 3, type: 'VEC3' },
      { bufferView: 2, componentType: 5125, count: ix.length, type: 'SCALAR' },
    ],
  };
  let text = new TextEncoder().encode(JSON.stringify(json));
  const jsonLen = (text.length + 3) & ~3;
  const binLen = (bin.byteLength + 3) & ~3;
  const out = new Uint8Array(12 + 8 + jsonLen + 8 + binLen);
  const dv = new DataView(out.buffer);
  dv.setUint32(0, 0x46546c67, true); dv.setUint32(4, 2, true); dv.setUint32(8, out.length, true);
  dv.setUint32(12, jsonLen, true); dv.setUint32(16, 0x4e4f534a, true);
  out.fill(0x20, 20, 20 + jsonLen); out.set(text, 20);
  dv.setUint32(20 + jsonLen, binLen, true); dv.setUint32(24 + jsonLen, 0x004e4942, true);
  out.set(bin, 28 + jsonLen);
  return out;
}

const fetchBytes = async (url) => new Uint8Array(await (await fetch(url)).arrayBuffer());
const nextFrame = () => new Promise((ok) => requestAnimationFrame(ok));

window.shrmFilament = {
  // Renders, reads the canvas back as RGBA bytes (top row first).
  //   what: 'sphere' (ortho camera at +Z looking at -Z, the sphere filling the view) or
  //         'sky' (perspective camera at the origin looking along `look`, 90 degree fov).
  async render({ set, what, metallic = 1, roughness = 0.5, intensity = 1, look = [-1, 0, 0] }) {
    const canvas = document.getElementById('c');
    const engine = window.shrmEngine;
    const scene = engine.createScene();
    const ibl = engine.createIblFromKtx1(await fetchBytes(`${set}/ibl.ktx`));
    // As Filament's samples do: the irradiance from the KTX's "sh" key (createIblFromKtx1 keeps it
    // in ibl.shfloats); rebuilt with it, intensity and all.
    const withSh = Filament.IndirectLight.Builder()
      .reflections(ibl.getReflectionsTexture())
      .irradianceSh(3, ibl.shfloats)
      .intensity(intensity)
      .build(engine);
    scene.setIndirectLight(withSh);
    const sky = engine.createSkyFromKtx1(await fetchBytes(`${set}/skybox.ktx`));
    scene.setSkybox(sky);
    let asset = null;
    const loader = engine.createAssetLoader();
    if (what === 'sphere') {
      asset = loader.createAsset(sphereGlb(metallic, roughness));
      await new Promise((ok) => asset.loadResources(ok, null, null, null));
      scene.addEntities(asset.getEntities());
    }
    const cameraEntity = Filament.EntityManager.get().create();
    const camera = engine.createCamera(cameraEntity);
    const view = engine.createView();
    view.setCamera(camera);
    view.setScene(scene);
    view.setViewport([0, 0, canvas.width, canvas.height]);
    view.setPostProcessingEnabled(false);  // no tone mapping, dithering or AA: linear output
    camera.setExposureDirect(1.0);
    if (what === 'sphere') {
      camera.setProjection(Filament.Camera$Projection.ORTHO, -1.1, 1.1, -1.1, 1.1, 0.1, 10);
      camera.lookAt([0, 0, 5], [0, 0, 0], [0, 1, 0]);
    } else {
      camera.setProjectionFov(90, 1, 0.1, 10, Filament.Camera$Fov.VERTICAL);
      camera.lookAt([0, 0, 0], look, [0, 1, 0]);
    }
    const renderer = engine.createRenderer();
    renderer.setClearOptions({ clearColor: [0, 0, 0, 1], clear: true });
    for (let i = 0; i < 3; ++i) {
      await nextFrame();
      if (renderer.beginFrame(window.shrmSwapChain)) {
        renderer.renderView(view);
        renderer.endFrame();
      }
      engine.execute();
    }
    await nextFrame();
    const c2 = document.createElement('canvas');
    c2.width = canvas.width; c2.height = canvas.height;
    const ctx = c2.getContext('2d');
    ctx.drawImage(canvas, 0, 0);
    const rgba = Array.from(ctx.getImageData(0, 0, c2.width, c2.height).data);
    engine.destroyRenderer(renderer);
    engine.destroyView(view);
    engine.destroyCameraComponent(cameraEntity);
    if (asset) loader.destroyAsset(asset);
    loader.delete();
    engine.destroyScene(scene);
    return { width: canvas.width, height: canvas.height, rgba };
  },
  info() {
    const gl = document.createElement('canvas').getContext('webgl2');
    const dbg = gl.getExtension('WEBGL_debug_renderer_info');
    return {
      version: gl.getParameter(gl.VERSION),
      renderer: dbg ? gl.getParameter(dbg.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER),
    };
  },
};

Filament.init([], () => {
  const canvas = document.getElementById('c');
  window.shrmEngine = Filament.Engine.create(canvas, { preserveDrawingBuffer: true });
  window.shrmSwapChain = window.shrmEngine.createSwapChain();
  window.shrmReady = true;
});
