// The page side of run_shaders.mjs: runs shaders/wgsl/shrm.wgsl in WebGPU (Chromium's, on
// SwiftShader) on an SHRM's coefficient layers as the KTX2 file stores them, and returns what it
// computed. window.runShrm(args) -> { global: Float32Array-like [6][S][S][4] } or
// { local: [n][4] } (plain arrays, for playwright).
async function device() {
  if (!navigator.gpu) throw new Error('no navigator.gpu (WebGPU disabled?)');
  const adapter = await navigator.gpu.requestAdapter();
  if (!adapter) throw new Error('no WebGPU adapter');
  return adapter.requestDevice();
}

// Reads a texture_2d_array (rgba32float, S x S x layers) back as [layer][y][x][4].
async function readTexture(dev, tex, size, layers) {
  const row = size * 16;
  const paddedRow = Math.ceil(row / 256) * 256;
  const buf = dev.createBuffer({ size: paddedRow * size * layers, usage: GPUBufferUsage.COPY_DST | GPUBufferUsage.MAP_READ });
  const enc = dev.createCommandEncoder();
  enc.copyTextureToBuffer({ texture: tex }, { buffer: buf, bytesPerRow: paddedRow, rowsPerImage: size }, [size, size, layers]);
  dev.queue.submit([enc.finish()]);
  await buf.mapAsync(GPUMapMode.READ);
  const src = new Float32Array(buf.getMappedRange());
  const out = new Float32Array(size * size * layers * 4);
  for (let l = 0; l < layers; ++l)
    for (let y = 0; y < size; ++y)
      out.set(src.subarray(((l * size + y) * paddedRow) / 4, ((l * size + y) * paddedRow) / 4 + size * 4),
        ((l * size + y) * size) * 4);
  buf.unmap();
  return out;
}

// args: { code (WGSL), pmax, size, layers (the KTX2 level as float RGBA, [k][face][y][x][4]),
//         view [x, y, z], dirs (optional: index directions for shrm_local, [n][3]),
//         viewNormal (optional: the SHRM's shrm:view_variable is "normal": the override SHRM_VIEW_NORMAL),
//         fresnel (optional: the SHRM's Fresnel table, [K + 1][3]),
//         lights (optional: the peak lights, [K][6] direction and weight),
//         lightModel (optional, with lights: the 21 numbers of shrm:light_model) }
// With lights, the global pass is shrm_global_pass_lights and the local test adds
// shrm_lights_at_texel(R, V) (what `shrm render` adds: the lights at N = (R + V) / |R + V|).
window.runShrm = async (args) => {
  const dev = await device();
  const errors = [];
  dev.addEventListener('uncapturederror', (e) => errors.push(e.error.message));
  const { size, pmax } = args;
  const count = (pmax + 1) * (pmax + 1);
  const prelude = `const SHRM_PMAX: i32 = ${pmax};\n`;
  const test = `
@group(0) @binding(8) var<storage, read> test_dirs: array<vec4f>;
@group(0) @binding(9) var<storage, read_write> test_out: array<vec4f>;
@compute @workgroup_size(64)
fn test_local(@builtin(global_invocation_id) id: vec3u) {
  if (id.x >= arrayLength(&test_dirs)) {
    return;
  }
  let d = test_dirs[id.x].xyz;
  var arg = normalize(shrm.view);
  if (SHRM_VIEW_NORMAL) {
    arg = shrm_view_normal(normalize(d), arg);  // shrm:view_variable "normal": the argument is N
  }
  test_out[id.x] = vec4f(shrm_local(d, arg), 1.0);
}
@compute @workgroup_size(64)
fn test_local_lights(@builtin(global_invocation_id) id: vec3u) {
  if (id.x >= arrayLength(&test_dirs)) {
    return;
  }
  let d = test_dirs[id.x].xyz;
  let v = normalize(shrm.view);
  var arg = v;
  if (SHRM_VIEW_NORMAL) {
    arg = shrm_view_normal(normalize(d), arg);
  }
  test_out[id.x] = vec4f(shrm_local(d, arg) + shrm_lights_at_texel(normalize(d), v), 1.0);
}
`;
  const module = dev.createShaderModule({ code: prelude + args.code + test });
  const info = await module.getCompilationInfo();
  const messages = info.messages.filter((m) => m.type === 'error').map((m) => `${m.lineNum}:${m.linePos} ${m.message}`);
  if (messages.length) return { error: `WGSL does not compile: ${messages.join('; ')}` };

  const coeffs = dev.createTexture({ size: [size, size, 6 * count], format: 'rgba32float',
    usage: GPUTextureUsage.TEXTURE_BINDING | GPUTextureUsage.COPY_DST });
  dev.queue.writeTexture({ texture: coeffs }, new Float32Array(args.layers),
    { bytesPerRow: size * 16, rowsPerImage: size }, [size, size, 6 * count]);
  const params = new ArrayBuffer(16);
  new Float32Array(params, 0, 3).set(args.view);
  new Int32Array(params, 12, 1)[0] = size;
  const uniform = dev.createBuffer({ size: 16, usage: GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST });
  dev.queue.writeBuffer(uniform, 0, params);
  // The Fresnel table (binding 3): count and nodes, or count 0 (args.fresnel: [K + 1][3] or null).
  const table = new ArrayBuffer(16 + 129 * 16);
  if (args.fresnel) {
    new Int32Array(table, 0, 1)[0] = args.fresnel.length;
    const nodes = new Float32Array(table, 16, 129 * 4);
    args.fresnel.forEach((rgb, k) => nodes.set([rgb[0], rgb[1], rgb[2], 0], k * 4));
  }
  const fresnel = dev.createBuffer({ size: table.byteLength, usage: GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST });
  dev.queue.writeBuffer(fresnel, 0, table);
  const coeffView = coeffs.createView({ dimension: '2d-array' });
  // The peak lights (bindings 4 and 5): a K x 2 rgba32float texture and ShrmLightParams.
  const lit = Array.isArray(args.lights) && args.lights.length > 0;
  const lightEntries = [];
  if (lit) {
    const k = args.lights.length;
    const texels = new Float32Array(k * 2 * 4);
    args.lights.forEach((l, i) => {
      texels.set([l[0], l[1], l[2], 0], i * 4);
      texels.set([l[3], l[4], l[5], 0], (k + i) * 4);
    });
    const tex = dev.createTexture({ size: [k, 2, 1], format: 'rgba32float',
      usage: GPUTextureUsage.TEXTURE_BINDING | GPUTextureUsage.COPY_DST });
    dev.queue.writeTexture({ texture: tex }, texels, { bytesPerRow: k * 16, rowsPerImage: 2 }, [k, 2, 1]);
    const lp = new ArrayBuffer(96);
    new Int32Array(lp, 0, 2).set([k, args.lightModel[0]]);
    new Float32Array(lp, 16, 20).set(args.lightModel.slice(1, 21));
    const lpBuf = dev.createBuffer({ size: 96, usage: GPUBufferUsage.UNIFORM | GPUBufferUsage.COPY_DST });
    dev.queue.writeBuffer(lpBuf, 0, lp);
    lightEntries.push({ binding: 4, resource: tex.createView() }, { binding: 5, resource: { buffer: lpBuf } });
  }
  const constants = args.viewNormal ? { SHRM_VIEW_NORMAL: 1 } : {};

  if (!args.dirs) {
    // Eq. 5.35: the per-frame pass into an S x S x 6 storage texture.
    const out = dev.createTexture({ size: [size, size, 6], format: 'rgba32float',
      usage: GPUTextureUsage.STORAGE_BINDING | GPUTextureUsage.COPY_SRC });
    const pipeline = dev.createComputePipeline({ layout: 'auto',
      compute: { module, entryPoint: lit ? 'shrm_global_pass_lights' : 'shrm_global_pass', constants } });
    const group = dev.createBindGroup({ layout: pipeline.getBindGroupLayout(0), entries: [
      { binding: 0, resource: coeffView }, { binding: 1, resource: { buffer: uniform } },
      { binding: 2, resource: out.createView({ dimension: '2d-array' }) },
      { binding: 3, resource: { buffer: fresnel } }, ...lightEntries] });
    const enc = dev.createCommandEncoder();
    const pass = enc.beginComputePass();
    pass.setPipeline(pipeline);
    pass.setBindGroup(0, group);
    pass.dispatchWorkgroups(Math.ceil(size / 8), Math.ceil(size / 8), 6);
    pass.end();
    dev.queue.submit([enc.finish()]);
    const data = await readTexture(dev, out, size, 6);
    return { global: Array.from(data), errors };
  }
  // Eq. 5.10 at the given index directions (shrm_local).
  const n = args.dirs.length;
  const dirs = new Float32Array(n * 4);
  args.dirs.forEach((d, i) => dirs.set([d[0], d[1], d[2], 0], i * 4));
  const dirBuf = dev.createBuffer({ size: dirs.byteLength, usage: GPUBufferUsage.STORAGE | GPUBufferUsage.COPY_DST });
  dev.queue.writeBuffer(dirBuf, 0, dirs);
  const outBuf = dev.createBuffer({ size: dirs.byteLength, usage: GPUBufferUsage.STORAGE | GPUBufferUsage.COPY_SRC });
  const readBuf = dev.createBuffer({ size: dirs.byteLength, usage: GPUBufferUsage.COPY_DST | GPUBufferUsage.MAP_READ });
  const pipeline = dev.createComputePipeline({ layout: 'auto',
    compute: { module, entryPoint: lit ? 'test_local_lights' : 'test_local', constants } });
  const group = dev.createBindGroup({ layout: pipeline.getBindGroupLayout(0), entries: [
    { binding: 0, resource: coeffView }, { binding: 1, resource: { buffer: uniform } },
    { binding: 3, resource: { buffer: fresnel } }, ...lightEntries,
    { binding: 8, resource: { buffer: dirBuf } }, { binding: 9, resource: { buffer: outBuf } }] });
  const enc = dev.createCommandEncoder();
  const pass = enc.beginComputePass();
  pass.setPipeline(pipeline);
  pass.setBindGroup(0, group);
  pass.dispatchWorkgroups(Math.ceil(n / 64));
  pass.end();
  enc.copyBufferToBuffer(outBuf, 0, readBuf, 0, dirs.byteLength);
  dev.queue.submit([enc.finish()]);
  await readBuf.mapAsync(GPUMapMode.READ);
  const res = Array.from(new Float32Array(readBuf.getMappedRange()));
  readBuf.unmap();
  return { local: res, errors };
};
window.shrmReady = true;
