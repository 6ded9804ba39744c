// Reads KTX2 files with ktx-parse (an independent reader) and prints, per file, what it found:
// format, size, layers, levels, the data format descriptor and the key/value data, plus the first
// few texel values of level 0 (R32 as float32, RGBA16F as half). Exit 1 when a file cannot be read.
// Usage: node check_ktx2.mjs FILE.ktx2...
import { read } from 'ktx-parse';
import { readFileSync } from 'node:fs';

function half(h) {
  const s = h & 0x8000 ? -1 : 1, e = (h >> 10) & 0x1f, m = h & 0x3ff;
  if (e === 0) return s * m * 2 ** -24;
  if (e === 31) return m ? NaN : s * Infinity;
  return s * (1 + m / 1024) * 2 ** (e - 15);
}

const out = {};
let failed = false;
for (const path of process.argv.slice(2)) {
  try {
    const c = read(new Uint8Array(readFileSync(path)));
    const lvl = c.levels[0].levelData;
    const dv = new DataView(lvl.buffer, lvl.byteOffset, lvl.byteLength);
    const first = [];
    for (let i = 0; i < 4; i++)
      first.push(c.typeSize === 2 ? half(dv.getUint16(2 * i, true)) : dv.getFloat32(4 * i, true));
    let finite = true;
    const n = lvl.byteLength / c.typeSize;
    for (let i = 0; i < n; i++) {
      const v = c.typeSize === 2 ? half(dv.getUint16(2 * i, true)) : dv.getFloat32(4 * i, true);
      if (!Number.isFinite(v)) { finite = false; break; }
    }
    const d = c.dataFormatDescriptor[0];
    out[path] = {
      vkFormat: c.vkFormat, typeSize: c.typeSize, width: c.pixelWidth, height: c.pixelHeight,
      depth: c.pixelDepth, layers: c.layerCount, faces: c.faceCount, levels: c.levels.length,
      supercompression: c.supercompressionScheme, levelBytes: lvl.byteLength,
      dfd: { colorModel: d.colorModel, colorPrimaries: d.colorPrimaries,
             transferFunction: d.transferFunction, bytesPlane0: d.bytesPlane[0],
             samples: d.samples.map((s) => ({ bitOffset: s.bitOffset, bitLength: s.bitLength,
                                               channelType: s.channelType })) },
      keyValue: Object.fromEntries(Object.entries(c.keyValue).map(([k, v]) =>
        [k, typeof v === 'string' ? v.replace(/\0$/, '') : new TextDecoder().decode(v).replace(/\0$/, '')])),
      first, finite };
  } catch (e) {
    out[path] = { error: String(e) };
    failed = true;
  }
}
console.log(JSON.stringify(out, null, 2));
process.exit(failed ? 1 : 0);
