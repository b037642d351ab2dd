// Negative control for run_filament.mjs: copies a set's ibl.ktx and skybox.ktx with every cube
// level mirrored (the texel at direction (x, y, z) takes the one at (-x, y, z)), the mistake a
// writer that ignored Filament's frame, or mirrored it twice, would make. The orientation checks
// must reject the copy.
//
// Usage: node break_ktx1.mjs SET OUT_SET
import { readFileSync, writeFileSync, mkdirSync, copyFileSync, readdirSync } from 'node:fs';
import { join } from 'node:path';
import { decodeKtx1 } from './ktx1.mjs';
import { faceCoordinates, texelDirection } from './ktx_cube.mjs';

const [set, out] = process.argv.slice(2);
mkdirSync(out, { recursive: true });
for (const f of readdirSync(set)) copyFileSync(join(set, f), join(out, f));
for (const name of ['ibl.ktx', 'skybox.ktx']) {
  const bytes = new Uint8Array(readFileSync(join(set, name)));
  const { levels } = decodeKtx1(bytes);
  const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  const copy = bytes.slice();
  // Offsets of the level data: after the header and key/value data, each level is imageSize
  // (one face), then six faces (padded to 4 bytes).
  let at = 64 + dv.getUint32(60, true);
  for (const level of levels) {
    const faceBytes = dv.getUint32(at, true);
    at += 4;
    const stride = faceBytes + (3 - ((faceBytes + 3) % 4));
    const texel = faceBytes / (level.size * level.size);
    for (let face = 0; face < 6; ++face) for (let y = 0; y < level.size; ++y) for (let x = 0; x < level.size; ++x) {
      const d = texelDirection(face, x, y, level.size);
      const { face: sf, s, t } = faceCoordinates([-d[0], d[1], d[2]]);
      const sx = Math.min(level.size - 1, Math.floor(s * level.size)), sy = Math.min(level.size - 1, Math.floor(t * level.size));
      const from = at + sf * stride + (sy * level.size + sx) * texel, to = at + face * stride + (y * level.size + x) * texel;
      copy.set(bytes.subarray(from, from + texel), to);
    }
    at += 6 * stride;
  }
  writeFileSync(join(out, name), copy);
}
console.log(`PASS: break_ktx1: ${out}: ibl.ktx and skybox.ktx mirrored in x`);
