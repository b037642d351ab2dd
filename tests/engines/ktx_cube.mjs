// Independent decoding of shrm's KTX2 cube maps (written from the Vulkan / Khronos Data Format
// specifications, not from shrm's code) and the OpenGL cube-map geometry (GL 4.6 sec. 8.13,
// "Cube Map Texture Selection"). Used in node (check_ktx2.mjs, run_browser.mjs) and in the page
// (page.mjs); plain ES module, no imports.

// The formats `shrm ibl --format` writes: VkFormat, channels stored, bytes per texel.
export const FORMATS = {
  rgba16f: { vk: 97, channels: 4, bytes: 8, typeSize: 2 },
  rgba32f: { vk: 109, channels: 4, bytes: 16, typeSize: 4 },
  r11g11b10f: { vk: 122, channels: 3, bytes: 4, typeSize: 4 },
  rgb9e5: { vk: 123, channels: 3, bytes: 4, typeSize: 4 },
};

export function formatByVk(vk) {
  for (const [name, f] of Object.entries(FORMATS)) if (f.vk === vk) return { name, ...f };
  return null;
}

// IEEE 754 binary16.
export function halfToFloat(h) {
  const s = h & 0x8000 ? -1 : 1;
  const e = (h >> 10) & 0x1f;
  const m = h & 0x3ff;
  if (e === 0) return s * m * 2 ** -24;
  if (e === 31) return m ? NaN : s * Infinity;
  return s * (1 + m / 1024) * 2 ** (e - 15);
}

// Unsigned small floats of B10G11R11_UFLOAT_PACK32: 5-bit exponent (bias 15), `mbits` mantissa.
function ufloat(bits, mbits) {
  const e = bits >> mbits;
  const m = bits & ((1 << mbits) - 1);
  if (e === 0) return (m / (1 << mbits)) * 2 ** -14;
  if (e === 31) return m ? NaN : Infinity;
  return (1 + m / (1 << mbits)) * 2 ** (e - 15);
}

// R in bits 0..10, G in 11..21, B in 22..31 (Vulkan: "B10G11R11": B is the most significant).
export function unpackB10G11R11(v) {
  return [ufloat(v & 0x7ff, 6), ufloat((v >>> 11) & 0x7ff, 6), ufloat((v >>> 22) & 0x3ff, 5)];
}

// R in bits 0..8, G in 9..17, B in 18..26, shared exponent in 27..31; value = m 2^(E - 15 - 9).
export function unpackE5B9G9R9(v) {
  const f = 2 ** ((v >>> 27) - 24);
  return [(v & 0x1ff) * f, ((v >>> 9) & 0x1ff) * f, ((v >>> 18) & 0x1ff) * f];
}

// One level of a cube (ktx-parse's KTX2Level) as six Float32Array RGBA faces, rows as stored
// (row 0 first). Alpha is 1 for the RGB formats.
export function decodeCubeLevel(levelData, vk, size) {
  const f = formatByVk(vk);
  if (!f) throw new Error(`unsupported vkFormat ${vk}`);
  const dv = new DataView(levelData.buffer, levelData.byteOffset, levelData.byteLength);
  const n = size * size;
  const faces = [];
  for (let face = 0; face < 6; ++face) {
    const out = new Float32Array(n * 4);
    for (let t = 0; t < n; ++t) {
      const off = (face * n + t) * f.bytes;
      let rgba;
      if (vk === 97) rgba = [0, 1, 2, 3].map((c) => halfToFloat(dv.getUint16(off + 2 * c, true)));
      else if (vk === 109) rgba = [0, 1, 2, 3].map((c) => dv.getFloat32(off + 4 * c, true));
      else if (vk === 122) rgba = [...unpackB10G11R11(dv.getUint32(off, true)), 1];
      else rgba = [...unpackE5B9G9R9(dv.getUint32(off, true)), 1];
      out.set(rgba, t * 4);
    }
    faces.push(out);
  }
  return { size, faces };
}

// Faces in GL order; the name is what a viewer of the files calls them.
export const FACE_NAMES = ['+X', '-X', '+Y', '-Y', '+Z', '-Z'];

// Direction (not normalized) of face coordinates s, t in [0, 1]: the inverse of the GL table
// (sc, tc, ma) = (-z, -y, x) for +X, (z, -y, x) for -X, (x, z, y) for +Y, (x, -z, y) for -Y,
// (x, -y, z) for +Z, (-x, -y, z) for -Z; s = (sc/|ma| + 1)/2, t = (tc/|ma| + 1)/2.
export function faceDirection(face, s, t) {
  const sc = 2 * s - 1;
  const tc = 2 * t - 1;
  switch (face) {
    case 0: return [1, -tc, -sc];
    case 1: return [-1, -tc, sc];
    case 2: return [sc, 1, tc];
    case 3: return [sc, -1, -tc];
    case 4: return [sc, -tc, 1];
    default: return [-sc, -tc, -1];
  }
}

export function normalize(d) {
  const l = Math.hypot(d[0], d[1], d[2]);
  return [d[0] / l, d[1] / l, d[2] / l];
}

// Unit direction of the centre of texel (x, y) (row y = 0 is t = 0) of an S x S face.
export function texelDirection(face, x, y, size) {
  return normalize(faceDirection(face, (x + 0.5) / size, (y + 0.5) / size));
}

// Face and (s, t) of a direction by the GL major-axis table.
export function faceCoordinates(d) {
  const [x, y, z] = d;
  const ax = Math.abs(x), ay = Math.abs(y), az = Math.abs(z);
  let face, sc, tc, ma;
  if (ax >= ay && ax >= az) {
    ma = ax;
    if (x > 0) [face, sc, tc] = [0, -z, -y];
    else [face, sc, tc] = [1, z, -y];
  } else if (ay >= az) {
    ma = ay;
    if (y > 0) [face, sc, tc] = [2, x, z];
    else [face, sc, tc] = [3, x, -z];
  } else {
    ma = az;
    if (z > 0) [face, sc, tc] = [4, x, -y];
    else [face, sc, tc] = [5, -x, -y];
  }
  return { face, s: 0.5 * (sc / ma + 1), t: 0.5 * (tc / ma + 1) };
}

// Nearest texel of a decoded level in direction d: [r, g, b, a].
export function sampleNearest(level, d) {
  const { face, s, t } = faceCoordinates(d);
  const n = level.size;
  const x = Math.min(n - 1, Math.floor(s * n));
  const y = Math.min(n - 1, Math.floor(t * n));
  const i = (y * n + x) * 4;
  return Array.from(level.faces[face].subarray(i, i + 4));
}

// Solid angle of texel (x, y) of an S x S face (the atan formula for a projected rectangle).
export function texelSolidAngle(x, y, size) {
  const a = (u, v) => Math.atan2(u * v, Math.sqrt(u * u + v * v + 1));
  const u0 = (2 * x) / size - 1, u1 = (2 * (x + 1)) / size - 1;
  const v0 = (2 * y) / size - 1, v1 = (2 * (y + 1)) / size - 1;
  return a(u0, v0) - a(u0, v1) - a(u1, v0) + a(u1, v1);
}

// Lat-long direction of docs/conventions.md: u, v in [0, 1] -> (sin t sin p, cos t, -sin t cos p)
// with theta = pi v, p = 2 pi (u - 0.5). Its inverse gives a direction's (u, v).
export function latLongDirection(u, v) {
  const th = Math.PI * v;
  const p = 2 * Math.PI * (u - 0.5);
  return [Math.sin(th) * Math.sin(p), Math.cos(th), -Math.sin(th) * Math.cos(p)];
}
export function latLongUv(d) {
  const p = Math.atan2(d[0], -d[2]);
  return { u: p / (2 * Math.PI) + 0.5, v: Math.acos(Math.max(-1, Math.min(1, d[1]))) / Math.PI };
}

// The project's real SH, l <= 2 (docs/conventions.md: Condon-Shortley phase kept, SH frame
// x_s = +X, y_s = -Z, z_s = +Y, index l(l+1)+m), written out in the world frame.
export function projectSh9(d) {
  const [X, Y, Z] = d;
  const xs = X, ys = -Z, zs = Y;
  const c0 = 0.5 / Math.sqrt(Math.PI);
  const c1 = Math.sqrt(3 / (4 * Math.PI));
  const c2 = Math.sqrt(15 / (4 * Math.PI)); // 1.092548
  const c20 = Math.sqrt(5 / (16 * Math.PI)); // 0.315392
  const c22 = Math.sqrt(15 / (16 * Math.PI)); // 0.546274
  return [
    c0,
    -c1 * ys, // Y_1,-1
    c1 * zs, // Y_1,0
    -c1 * xs, // Y_1,1
    c2 * xs * ys, // Y_2,-2
    -c2 * ys * zs, // Y_2,-1
    c20 * (3 * zs * zs - 1), // Y_2,0
    -c2 * xs * zs, // Y_2,1
    c22 * (xs * xs - ys * ys), // Y_2,2
  ];
}

// three.js's SphericalHarmonics3 coefficients from the project's (per colour channel): three's
// basis is (0.282095, 0.488603 y, 0.488603 z, 0.488603 x, 1.092548 xy, 1.092548 yz,
// 0.315392 (3z^2 - 1), 1.092548 xz, 0.546274 (x^2 - y^2)) in the world frame, no
// Condon-Shortley phase. Derived by substituting the SH frame into projectSh9 above; the two
// zonal/sectoral l = 2 terms mix (3Y^2-1 = -A/2 - 3B/2, X^2-Z^2 = -A/2 + B/2 with
// A = 3Z^2-1, B = X^2-Y^2 on the unit sphere).
export function projectToThreeSh9(p) {
  const h = Math.sqrt(3) / 2;
  return [
    p[0],
    p[2], // y  <- Y_1,0  ( c z_s = c Y)
    p[1], // z  <- Y_1,-1 (-c y_s = c Z)
    -p[3], // x  <- Y_1,1  (-c x_s = -c X)
    -p[7], // xy <- Y_2,1  (-c X Y)
    p[5], // yz <- Y_2,-1 ( c Y Z)
    -0.5 * p[6] - h * p[8], // 3z^2-1
    -p[4], // xz <- Y_2,-2 (-c X Z)
    -h * p[6] + 0.5 * p[8], // x^2-y^2
  ];
}

// The map engines_test.sh makes with oiiotool (keep the two in step): 256 x 128 lat-long, grey
// background, value 8 in one channel in each patch (pixel columns x0..x1-1, rows y0..y1-1):
// red around u = 0.75 (+X) 11..34 degrees above the horizon (so that an upside-down face shows),
// green in the top rows (+Y), blue around u = 0.5 (-Z) on the horizon.
export const PATCHES = {
  width: 256,
  height: 128,
  background: [0.05, 0.05, 0.05],
  patches: [
    { name: 'R', rgb: [8, 0, 0], x0: 184, x1: 200, y0: 40, y1: 56 },
    { name: 'G', rgb: [0, 8, 0], x0: 0, x1: 256, y0: 0, y1: 8 },
    { name: 'B', rgb: [0, 0, 8], x0: 120, x1: 136, y0: 56, y1: 72 },
  ],
};
export function patchesPixel(i, j) {
  const p = PATCHES.patches.find((q) => i >= q.x0 && i < q.x1 && j >= q.y0 && j < q.y1);
  return p ? p.rgb : PATCHES.background;
}

// The centre direction of a patch's pixel box.
export function patchCentre(name) {
  const p = PATCHES.patches.find((q) => q.name === name);
  return latLongDirection((p.x0 + p.x1) / 2 / PATCHES.width, (p.y0 + p.y1) / 2 / PATCHES.height);
}
