// An independent KTX 1.1 reader (Khronos "KTX File Format Specification" 1.1, written from it,
// not from shrm's code) for the cube maps `shrm ibl --containers ktx1` writes: header, key/value
// data, and each level's six faces decoded to Float32Array RGBA (alpha 1), rows as stored.
import { halfToFloat, unpackB10G11R11 } from './ktx_cube.mjs';

const GL = { HALF_FLOAT: 0x140b, FLOAT: 0x1406, RGB: 0x1907, RGB16F: 0x881b, RGB32F: 0x8815, R11F_G11F_B10F: 0x8c3a };
export { GL };

export function decodeKtx1(bytes) {
  const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  const id = [0xab, 0x4b, 0x54, 0x58, 0x20, 0x31, 0x31, 0xbb, 0x0d, 0x0a, 0x1a, 0x0a];
  id.forEach((b, i) => { if (bytes[i] !== b) throw new Error('not a KTX 1.1 file (identifier)'); });
  const u32 = (o) => dv.getUint32(o, true);
  if (u32(12) !== 0x04030201) throw new Error('endianness is not 0x04030201');
  const h = {
    glType: u32(16), glTypeSize: u32(20), glFormat: u32(24), glInternalFormat: u32(28),
    glBaseInternalFormat: u32(32), pixelWidth: u32(36), pixelHeight: u32(40), pixelDepth: u32(44),
    numberOfArrayElements: u32(48), numberOfFaces: u32(52), numberOfMipmapLevels: u32(56),
    bytesOfKeyValueData: u32(60),
  };
  const kv = {};
  let at = 64;
  const end = at + h.bytesOfKeyValueData;
  while (at < end) {
    const size = u32(at);
    const entry = bytes.subarray(at + 4, at + 4 + size);
    const nul = entry.indexOf(0);
    let value = entry.subarray(nul + 1);
    if (value.length && value[value.length - 1] === 0) value = value.subarray(0, value.length - 1);
    kv[new TextDecoder().decode(entry.subarray(0, nul))] = new TextDecoder().decode(value);
    at += 4 + size + (3 - ((size + 3) % 4));
  }
  const texelBytes = { [GL.R11F_G11F_B10F]: 4, [GL.RGB16F]: 6, [GL.RGB32F]: 12 }[h.glInternalFormat];
  if (!texelBytes) throw new Error(`glInternalFormat 0x${h.glInternalFormat.toString(16)} not decoded here`);
  const levels = [];
  for (let k = 0; k < Math.max(1, h.numberOfMipmapLevels); ++k) {
    const size = Math.max(1, h.pixelWidth >> k);
    const imageSize = u32(at);
    at += 4;
    if (imageSize !== size * size * texelBytes) throw new Error(`level ${k}: imageSize ${imageSize}, expected ${size * size * texelBytes} (one face)`);
    const faces = [];
    for (let f = 0; f < h.numberOfFaces; ++f) {
      const out = new Float32Array(size * size * 4);
      for (let t = 0; t < size * size; ++t) {
        const o = at + t * texelBytes;
        let rgb;
        if (texelBytes === 4) rgb = unpackB10G11R11(u32(o));
        else if (texelBytes === 6) rgb = [0, 1, 2].map((c) => halfToFloat(dv.getUint16(o + 2 * c, true)));
        else rgb = [0, 1, 2].map((c) => dv.getFloat32(o + 4 * c, true));
        out.set([...rgb, 1], 4 * t);
      }
      faces.push(out);
      at += imageSize + (3 - ((imageSize + 3) % 4));
    }
    levels.push({ size, faces });
  }
  if (at !== bytes.length) throw new Error(`${bytes.length - at} bytes after the last level`);
  return { header: h, kv, levels };
}
