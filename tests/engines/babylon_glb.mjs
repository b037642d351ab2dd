// Binary glTF and PNG in node, written from the specifications (glTF 2.0 "Binary glTF Layout";
// PNG: chunks, IHDR, zlib IDAT, row filters 0..4) with node's zlib only; the extension's RGBD
// decoding (rgb / D, with Babylon's gamma 2.2, helperFunctions.fx fromRGBD). Used by
// babylon_run.mjs to read ibl.glb independently of shrm and of Babylon, and to write the
// mirrored negative control and the screenshots.
import { inflateSync, deflateSync, crc32 } from 'node:zlib';

export function parseGlb(buf) {
  const dv = new DataView(buf.buffer, buf.byteOffset, buf.byteLength);
  if (dv.getUint32(0, true) !== 0x46546c67 || dv.getUint32(4, true) !== 2) throw new Error('not a glTF 2 GLB');
  const jsonLen = dv.getUint32(12, true);
  const json = JSON.parse(new TextDecoder().decode(buf.subarray(20, 20 + jsonLen)));
  const binAt = 20 + jsonLen;
  const bin = buf.subarray(binAt + 8, binAt + 8 + dv.getUint32(binAt, true));
  const view = (v) => {
    const bv = json.bufferViews[v];
    return bin.subarray(bv.byteOffset ?? 0, (bv.byteOffset ?? 0) + bv.byteLength);
  };
  return { json, bin, view };
}

// A GLB from a JSON document and a BIN chunk (padded as the spec says).
export function writeGlb(json, bin) {
  let text = Buffer.from(JSON.stringify(json));
  text = Buffer.concat([text, Buffer.alloc((4 - (text.length % 4)) % 4, 0x20)]);
  const b = Buffer.concat([Buffer.from(bin), Buffer.alloc((4 - (bin.length % 4)) % 4)]);
  const head = Buffer.alloc(20);
  head.writeUInt32LE(0x46546c67, 0); head.writeUInt32LE(2, 4);
  head.writeUInt32LE(20 + text.length + 8 + b.length, 8);
  head.writeUInt32LE(text.length, 12); head.writeUInt32LE(0x4e4f534a, 16);
  const binHead = Buffer.alloc(8);
  binHead.writeUInt32LE(b.length, 0); binHead.writeUInt32LE(0x004e4942, 4);
  return Buffer.concat([head, text, binHead, b]);
}

export function decodePng(buf) {
  const b = Buffer.from(buf);
  if (b.readUInt32BE(0) !== 0x89504e47) throw new Error('not a PNG');
  let at = 8, w = 0, h = 0, ch = 0;
  const idat = [];
  while (at < b.length) {
    const len = b.readUInt32BE(at), type = b.toString('latin1', at + 4, at + 8);
    if (type === 'IHDR') {
      w = b.readUInt32BE(at + 8); h = b.readUInt32BE(at + 12);
      if (b[at + 16] !== 8 || b[at + 20] !== 0) throw new Error('PNG: only 8-bit, non-interlaced');
      ch = { 6: 4, 2: 3 }[b[at + 17]];
    } else if (type === 'IDAT') idat.push(b.subarray(at + 8, at + 8 + len));
    at += 12 + len;
  }
  const raw = inflateSync(Buffer.concat(idat));
  const stride = w * ch, px = new Uint8Array(stride * h);
  for (let y = 0; y < h; ++y) {
    const f = raw[y * (stride + 1)];
    for (let x = 0; x < stride; ++x) {
      const a = x >= ch ? px[y * stride + x - ch] : 0, up = y ? px[(y - 1) * stride + x] : 0;
      const c = x >= ch && y ? px[(y - 1) * stride + x - ch] : 0;
      const p = a + up - c, pa = Math.abs(p - a), pb = Math.abs(p - up), pc = Math.abs(p - c);
      const pred = [0, a, up, (a + up) >> 1, pa <= pb && pa <= pc ? a : pb <= pc ? up : c][f];
      px[y * stride + x] = (raw[y * (stride + 1) + 1 + x] + pred) & 255;
    }
  }
  return { width: w, height: h, channels: ch, px };
}

export function encodePng(width, height, channels, px) {
  const chunk = (type, data) => {
    const len = Buffer.alloc(4); len.writeUInt32BE(data.length);
    const td = Buffer.concat([Buffer.from(type, 'latin1'), data]);
    const crc = Buffer.alloc(4); crc.writeUInt32BE(crc32(td) >>> 0);
    return Buffer.concat([len, td, crc]);
  };
  const ihdr = Buffer.alloc(13);
  ihdr.writeUInt32BE(width, 0); ihdr.writeUInt32BE(height, 4);
  ihdr[8] = 8; ihdr[9] = channels === 4 ? 6 : 2;
  const raw = Buffer.alloc((width * channels + 1) * height);
  for (let y = 0; y < height; ++y) raw.set(px.subarray(y * width * channels, (y + 1) * width * channels), y * (width * channels + 1) + 1);
  return Buffer.concat([Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]), chunk('IHDR', ihdr), chunk('IDAT', deflateSync(raw)), chunk('IEND', Buffer.alloc(0))]);
}

// RGBD (4-channel PNG) to linear RGB: (rgb / 255)^2.2 / (D / 255).
export function rgbdToFloat(img) {
  const n = img.width * img.height, out = new Float32Array(n * 3);
  for (let t = 0; t < n; ++t) {
    const d = img.px[t * 4 + 3] / 255;
    for (let c = 0; c < 3; ++c) out[t * 3 + c] = Math.pow(img.px[t * 4 + c] / 255, 2.2) / d;
  }
  return out;
}

// The specular images of the light: levels[k][face] = { size, rgb (rows from the top), png }.
export function specularImages(glb) {
  const light = glb.json.extensions.EXT_lights_image_based.lights[0];
  return light.specularImages.map((faces) => faces.map((i) => {
    const png = glb.view(glb.json.images[i].bufferView);
    const img = decodePng(png);
    return { size: img.width, img, rgb: img.channels === 4 ? rgbdToFloat(img) : null };
  }));
}
