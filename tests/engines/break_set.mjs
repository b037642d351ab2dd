// Negative controls: copies a `shrm ibl` set with every cube broken the way cube maps usually go
// wrong, rewritten with ktx-parse (everything else byte for byte as read). engines_test.sh
// checks that the orientation checks of check_ktx2.mjs and run_browser.mjs reject them.
//
// Usage: node break_set.mjs SET_DIR OUT_DIR mirror-x|flip-rows
//   mirror-x:  the texel for direction (x, y, z) holds the original's at (-x, y, z) (a cube in a
//              left-handed "skybox" convention, as three.js assumes for CubeTextures);
//   flip-rows: every face upside down (row 0 = t 1, the usual glTexImage2D / image-file mix-up).
import { readFileSync, writeFileSync, mkdirSync, copyFileSync } from 'node:fs';
import { join } from 'node:path';
import { read, write } from 'ktx-parse';
import { formatByVk, texelDirection, faceCoordinates } from './ktx_cube.mjs';

const [src, out, how] = process.argv.slice(2);
if (!['mirror-x', 'flip-rows'].includes(how)) {
  console.error('usage: node break_set.mjs SET_DIR OUT_DIR mirror-x|flip-rows');
  process.exit(2);
}
mkdirSync(out, { recursive: true });
const json = JSON.parse(readFileSync(join(src, 'ibl.json'), 'utf8'));
copyFileSync(join(src, 'ibl.json'), join(out, 'ibl.json'));
for (const f of json.files.filter((x) => x.type === 'cube')) {
  const c = read(new Uint8Array(readFileSync(join(src, f.name))));
  const bytes = formatByVk(c.vkFormat).bytes;
  c.levels.forEach((level, k) => {
    const n = Math.max(1, c.pixelWidth >> k);
    const old = level.levelData;
    const neu = new Uint8Array(old.length);
    for (let face = 0; face < 6; ++face) for (let y = 0; y < n; ++y) for (let x = 0; x < n; ++x) {
      let sf = face, sx = x, sy = n - 1 - y; // flip-rows
      if (how === 'mirror-x') {
        const d = texelDirection(face, x, y, n);
        const m = faceCoordinates([-d[0], d[1], d[2]]);
        [sf, sx, sy] = [m.face, Math.min(n - 1, Math.floor(m.s * n)), Math.min(n - 1, Math.floor(m.t * n))];
      }
      const to = ((face * n + y) * n + x) * bytes;
      const from = ((sf * n + sy) * n + sx) * bytes;
      neu.set(old.subarray(from, from + bytes), to);
    }
    level.levelData = neu;
  });
  writeFileSync(join(out, f.name), write(c, { keepWriter: true }));
}
console.log(`PASS: ${how} copy of ${src} in ${out}`);
