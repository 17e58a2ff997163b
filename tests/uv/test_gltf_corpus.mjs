// `supermat mesh` on a corpus of glTF inputs, every output checked by the Khronos glTF-Validator (zero
// errors) and by what each case is about:
//   embedded   data-URI buffer and images in, a self-contained .gltf out (no side file)
//   glb        .glb in (images in buffer views) -> .glb out holding everything; .gltf in -> .glb out
//   paths      images and buffer in sub-folders with %-encoded names, OUT in another folder: copied,
//              byte for byte, and a normal map's bytes unchanged
//   multi      two meshes in the scene (three triangle primitives, two materials), a points primitive and
//              a mesh outside the scene sharing those materials: every scene triangle baked (the second
//              material's red shows in its texture), the others keep the original materials
//   transform  KHR_texture_transform on the base colour: the same textures as the same asset with the
//              transform applied to its UVs, and the new textures carry the transform
//   alpha      alphaMode MASK with an RGBA texture: the baked base colour keeps the alpha texel for texel;
//              OPAQUE drops it
//   rerun      OUT baked again (same folder, and onto itself with --force): the same image names (up to their
//              alternate NAME-1, docs/security.md) and count, the replaced textures removed,
//              asset.generator names supermat
// usage: node test_gltf_corpus.mjs SUPERMAT_MESH OUTDIR VALIDATOR_DIR   (exit 77 = skipped: no validator)
import fs from 'node:fs';
import path from 'node:path';
import zlib from 'node:zlib';
import { execFileSync } from 'node:child_process';
import { createRequire } from 'node:module';

const [mesh, outRoot, validatorDir] = process.argv.slice(2);
if (!mesh || !outRoot || !validatorDir) { console.error('usage: node test_gltf_corpus.mjs SUPERMAT_MESH OUTDIR VALIDATOR_DIR'); process.exit(2); }
if (!fs.existsSync(path.join(validatorDir, 'package.json'))) {
  console.log(`SKIP: no gltf-validator at ${validatorDir} (scripts/test.sh installs it with npm)`);
  process.exit(77);
}
const validator = createRequire(import.meta.url)(validatorDir);
let failures = 0, checks = 0;
function check(ok, what) { checks++; if (!ok) { failures++; console.log(`FAIL: ${what}`); } }

// ---- PNG ----
const crcTable = Array.from({ length: 256 }, (_, n) => { let c = n; for (let k = 0; k < 8; k++) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1; return c >>> 0; });
function crc32(b) { let c = 0xffffffff; for (const x of b) c = crcTable[(c ^ x) & 255] ^ (c >>> 8); return (c ^ 0xffffffff) >>> 0; }
function chunk(type, data) {
  const len = Buffer.alloc(4); len.writeUInt32BE(data.length);
  const td = Buffer.concat([Buffer.from(type, 'ascii'), data]);
  const crc = Buffer.alloc(4); crc.writeUInt32BE(crc32(td));
  return Buffer.concat([len, td, crc]);
}
function pngEncode(w, h, ch, px) {
  const ihdr = Buffer.alloc(13);
  ihdr.writeUInt32BE(w, 0); ihdr.writeUInt32BE(h, 4); ihdr[8] = 8; ihdr[9] = { 1: 0, 2: 4, 3: 2, 4: 6 }[ch];
  const raw = Buffer.alloc(h * (w * ch + 1));
  for (let y = 0; y < h; y++) { raw[y * (w * ch + 1)] = 0; Buffer.from(px.buffer, px.byteOffset + y * w * ch, w * ch).copy(raw, y * (w * ch + 1) + 1); }
  return Buffer.concat([Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]), chunk('IHDR', ihdr), chunk('IDAT', zlib.deflateSync(raw)), chunk('IEND', Buffer.alloc(0))]);
}
function pngDecode(buf) {
  let p = 8, w, h, ch; const idat = [];
  while (p < buf.length) {
    const len = buf.readUInt32BE(p), type = buf.toString('ascii', p + 4, p + 8), d = buf.subarray(p + 8, p + 8 + len);
    if (type === 'IHDR') { w = d.readUInt32BE(0); h = d.readUInt32BE(4); if (d[8] !== 8 || d[12] !== 0) throw new Error('8-bit non-interlaced only'); ch = { 0: 1, 4: 2, 2: 3, 6: 4 }[d[9]]; }
    if (type === 'IDAT') idat.push(d);
    p += 12 + len;
  }
  const raw = zlib.inflateSync(Buffer.concat(idat)), stride = w * ch, out = new Uint8Array(h * stride);
  for (let y = 0; y < h; y++) {
    const f = raw[y * (stride + 1)], row = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
    for (let x = 0; x < stride; x++) {
      const a = x >= ch ? out[y * stride + x - ch] : 0, b = y ? out[(y - 1) * stride + x] : 0, c = x >= ch && y ? out[(y - 1) * stride + x - ch] : 0;
      let v = row[x];
      if (f === 1) v += a; else if (f === 2) v += b; else if (f === 3) v += (a + b) >> 1;
      else if (f === 4) { const pp = a + b - c, pa = Math.abs(pp - a), pb = Math.abs(pp - b), pc = Math.abs(pp - c); v += pa <= pb && pa <= pc ? a : pb <= pc ? b : c; }
      out[y * stride + x] = v & 255;
    }
  }
  return { w, h, ch, px: out };
}

// ---- assets ----
// a box (positions, normals, a second UV set) whose six faces sit in a 3x2 atlas of TEXCOORD_0
function boxGeometry(scale = 1, uvMap = (u, v) => [u, v]) {
  const pos = [], nrm = [], uv = [], uv1 = [], idx = [];
  const faces = [[[1, 0, 0], [0, 1, 0], [0, 0, 1]], [[-1, 0, 0], [0, 0, 1], [0, 1, 0]], [[0, 1, 0], [0, 0, 1], [1, 0, 0]],
    [[0, -1, 0], [1, 0, 0], [0, 0, 1]], [[0, 0, 1], [1, 0, 0], [0, 1, 0]], [[0, 0, -1], [0, 1, 0], [1, 0, 0]]];
  faces.forEach(([n, a, b], f) => {
    const cu = (f % 3) / 3, cv = Math.floor(f / 3) / 2, base = pos.length / 3;
    for (const [s, t] of [[-1, -1], [1, -1], [1, 1], [-1, 1]]) {
      for (let k = 0; k < 3; k++) pos.push(scale * (n[k] + s * a[k] + t * b[k]));
      nrm.push(...n);
      uv.push(...uvMap(cu + (0.02 + 0.96 * (s + 1) / 2) / 3, cv + (0.02 + 0.96 * (t + 1) / 2) / 2));
      uv1.push((s + 1) / 2, (t + 1) / 2);
    }
    idx.push(base, base + 1, base + 2, base, base + 2, base + 3);
  });
  return { pos, nrm, uv, uv1, idx };
}
// glTF JSON + one binary buffer from a list of meshes' geometry; images are given separately
function buildAsset(geoms) {
  const bin = [], bufferViews = [], accessors = [];
  const add = (arr, type, comp, target, minmax) => {
    const b = comp === 5126 ? Buffer.from(new Float32Array(arr).buffer) : Buffer.from(new Uint16Array(arr).buffer);
    while (bin.reduce((s, x) => s + x.length, 0) % 4) bin.push(Buffer.alloc(1));
    const off = bin.reduce((s, x) => s + x.length, 0);
    bin.push(b);
    bufferViews.push({ buffer: 0, byteOffset: off, byteLength: b.length, target });
    const n = { VEC3: 3, VEC2: 2, SCALAR: 1 }[type], acc = { bufferView: bufferViews.length - 1, componentType: comp, count: arr.length / n, type };
    if (minmax) { acc.min = [0, 1, 2].map(k => Math.min(...arr.filter((_, i) => i % 3 === k))); acc.max = [0, 1, 2].map(k => Math.max(...arr.filter((_, i) => i % 3 === k))); }
    accessors.push(acc);
    return accessors.length - 1;
  };
  const prims = geoms.map(g => ({
    attributes: { POSITION: add(g.pos, 'VEC3', 5126, 34962, true), NORMAL: add(g.nrm, 'VEC3', 5126, 34962), TEXCOORD_0: add(g.uv, 'VEC2', 5126, 34962), TEXCOORD_1: add(g.uv1, 'VEC2', 5126, 34962) },
    indices: add(g.idx, 'SCALAR', 5123, 34963),
  }));
  while (bin.reduce((s, x) => s + x.length, 0) % 4) bin.push(Buffer.alloc(1));
  return { prims, bufferViews, accessors, bin: Buffer.concat(bin) };
}
function noiseTexture(n, seed, ch = 3, alphaFn = null) {
  const px = new Uint8Array(n * n * ch); let s = seed;
  for (let i = 0; i < n * n; i++) {
    for (let k = 0; k < Math.min(ch, 3); k++) { s = (s * 1103515245 + 12345) >>> 0; px[i * ch + k] = 40 + ((s >>> 16) % 160); }
    if (ch === 4) px[i * ch + 3] = alphaFn ? alphaFn(i % n, Math.floor(i / n)) : 255;
  }
  return pngEncode(n, n, ch, px);
}
function solidTexture(n, rgb) { const px = new Uint8Array(n * n * 3); for (let i = 0; i < n * n; i++) px.set(rgb, i * 3); return pngEncode(n, n, 3, px); }
const dataUri = (mime, b) => `data:${mime};base64,${b.toString('base64')}`;
function writeGlb(file, json, bin) {
  let js = Buffer.from(JSON.stringify(json)); while (js.length % 4) js = Buffer.concat([js, Buffer.from(' ')]);
  const parts = [Buffer.alloc(12), Buffer.alloc(8), js];
  if (bin) { const b = Buffer.concat([bin, Buffer.alloc((4 - bin.length % 4) % 4)]); parts.push(Buffer.alloc(8), b); parts[3].writeUInt32LE(b.length, 0); parts[3].writeUInt32LE(0x004e4942, 4); }
  parts[1].writeUInt32LE(js.length, 0); parts[1].writeUInt32LE(0x4e4f534a, 4);
  const all = Buffer.concat(parts);
  all.writeUInt32LE(0x46546c67, 0); all.writeUInt32LE(2, 4); all.writeUInt32LE(all.length, 8);
  fs.writeFileSync(file, all);
}
function readGltf(file) { // {json, bin} of a .gltf or .glb
  const b = fs.readFileSync(file);
  if (b.readUInt32LE(0) !== 0x46546c67) return { json: JSON.parse(b.toString('utf8')), bin: null };
  const jl = b.readUInt32LE(12), json = JSON.parse(b.toString('utf8', 20, 20 + jl));
  const bin = b.length > 20 + jl ? b.subarray(28 + jl, 28 + jl + b.readUInt32LE(20 + jl)) : null;
  return { json, bin };
}
// the bytes of image i of an output asset, wherever they are stored
function imageBytes(file, i) {
  const { json, bin } = readGltf(file), img = json.images[i], dir = path.dirname(file);
  const bufferData = (bi) => { const u = json.buffers[bi].uri; if (u === undefined) return bin; if (u.startsWith('data:')) return Buffer.from(u.split(',')[1], 'base64'); return fs.readFileSync(path.join(dir, decodeURIComponent(u))); };
  if (img.uri !== undefined) return img.uri.startsWith('data:') ? Buffer.from(img.uri.split(',')[1], 'base64') : fs.readFileSync(path.join(dir, decodeURIComponent(img.uri)));
  const bv = json.bufferViews[img.bufferView];
  return bufferData(bv.buffer).subarray(bv.byteOffset || 0, (bv.byteOffset || 0) + bv.byteLength);
}
const textureImage = (json, texInfo) => json.textures[texInfo.index].source;

async function validate(file, what) {
  const data = new Uint8Array(fs.readFileSync(file)), dir = path.dirname(file);
  const report = await validator.validateBytes(data, {
    uri: path.basename(file), maxIssues: 100,
    externalResourceFunction: (uri) => new Promise((resolve, reject) => {
      fs.readFile(path.join(dir, decodeURIComponent(uri)), (e, d) => e ? reject(e.toString()) : resolve(new Uint8Array(d)));
    }),
  });
  const errs = report.issues.messages.filter(m => m.severity === 0);
  check(report.issues.numErrors === 0, `${what}: ${file} has ${report.issues.numErrors} validator error(s): ${errs.slice(0, 5).map(m => `${m.code} ${m.pointer || ''} ${m.message}`).join('; ')}`);
  return report;
}
function bake(inp, out, extra = []) {
  try {
    execFileSync(mesh, ['--passthrough', '--size', '64', '--views-size', '64', '--force', ...extra, inp, out], { stdio: ['ignore', 'pipe', 'pipe'] });
    return true;
  } catch (e) {
    check(false, `supermat mesh ${inp} ${out} failed: ${e.stderr}`);
    return false;
  }
}
const filesIn = (dir) => fs.readdirSync(dir, { recursive: true }).filter(f => fs.statSync(path.join(dir, f)).isFile()).sort();
function fresh(name) { const d = path.join(outRoot, name); fs.rmSync(d, { recursive: true, force: true }); fs.mkdirSync(d, { recursive: true }); return d; }
const baseMaterial = (tex) => ({ pbrMetallicRoughness: { baseColorTexture: { index: tex }, metallicFactor: 0 } });

// ---- embedded ----
{
  const d = fresh('embedded'), a = buildAsset([boxGeometry()]), tex = noiseTexture(32, 1);
  const json = {
    asset: { version: '2.0' }, scene: 0, scenes: [{ nodes: [0] }], nodes: [{ mesh: 0 }],
    meshes: [{ primitives: [{ ...a.prims[0], material: 0 }] }], materials: [baseMaterial(0)],
    textures: [{ source: 0 }], images: [{ uri: dataUri('image/png', tex) }],
    buffers: [{ uri: dataUri('application/octet-stream', a.bin), byteLength: a.bin.length }], bufferViews: a.bufferViews, accessors: a.accessors,
  };
  fs.writeFileSync(path.join(d, 'in.gltf'), JSON.stringify(json));
  await validate(path.join(d, 'in.gltf'), 'embedded input');
  fs.mkdirSync(path.join(d, 'out'));
  if (bake(path.join(d, 'in.gltf'), path.join(d, 'out/out.gltf'))) {
    await validate(path.join(d, 'out/out.gltf'), 'embedded');
    check(JSON.stringify(filesIn(path.join(d, 'out'))) === '["out.gltf"]', `embedded: a self-contained .gltf writes no side file (got ${filesIn(path.join(d, 'out'))})`);
    const { json: o } = readGltf(path.join(d, 'out/out.gltf'));
    check(o.images.every(im => im.uri && im.uri.startsWith('data:image/png;base64,')), 'embedded: every image a data URI');
    check(o.buffers.every(b => b.uri.startsWith('data:')), 'embedded: the buffer a data URI');
  }
}

// ---- glb ----
{
  const d = fresh('glb'), a = buildAsset([boxGeometry()]), tex = noiseTexture(32, 2), nrm = solidTexture(8, [128, 128, 255]);
  const bin = Buffer.concat([a.bin, tex, Buffer.alloc((4 - tex.length % 4) % 4), nrm]);
  const texOff = a.bin.length, nrmOff = a.bin.length + tex.length + (4 - tex.length % 4) % 4;
  const json = {
    asset: { version: '2.0' }, scene: 0, scenes: [{ nodes: [0] }], nodes: [{ mesh: 0 }],
    meshes: [{ primitives: [{ ...a.prims[0], material: 0 }] }], materials: [{ ...baseMaterial(0), normalTexture: { index: 1 } }],
    textures: [{ source: 0 }, { source: 1 }], images: [{ bufferView: a.bufferViews.length, mimeType: 'image/png' }, { bufferView: a.bufferViews.length + 1, mimeType: 'image/png' }],
    buffers: [{ byteLength: bin.length }], bufferViews: [...a.bufferViews, { buffer: 0, byteOffset: texOff, byteLength: tex.length }, { buffer: 0, byteOffset: nrmOff, byteLength: nrm.length }],
    accessors: a.accessors,
  };
  writeGlb(path.join(d, 'in.glb'), json, bin);
  await validate(path.join(d, 'in.glb'), 'glb input');
  fs.mkdirSync(path.join(d, 'out'));
  if (bake(path.join(d, 'in.glb'), path.join(d, 'out/out.glb'))) {
    await validate(path.join(d, 'out/out.glb'), 'glb -> glb');
    check(JSON.stringify(filesIn(path.join(d, 'out'))) === '["out.glb"]', `glb: a .glb is self-contained (files: ${filesIn(path.join(d, 'out'))})`);
    const { json: o } = readGltf(path.join(d, 'out/out.glb'));
    check(o.buffers.length === 1 && o.buffers[0].uri === undefined && o.images.every(im => im.uri === undefined && im.bufferView >= 0), 'glb: one buffer, every image in a buffer view');
    check(Buffer.compare(imageBytes(path.join(d, 'out/out.glb'), textureImage(o, o.materials[0].normalTexture)), nrm) === 0, 'glb: the normal map byte for byte');
  }
  // a .gltf with files in -> .glb out
  fs.writeFileSync(path.join(d, 'files.bin'), a.bin);
  fs.writeFileSync(path.join(d, 'files_base.png'), tex);
  fs.writeFileSync(path.join(d, 'files.gltf'), JSON.stringify({ ...json, images: [{ uri: 'files_base.png' }], textures: [{ source: 0 }], materials: [baseMaterial(0)],
    buffers: [{ uri: 'files.bin', byteLength: a.bin.length }], bufferViews: a.bufferViews }));
  fs.mkdirSync(path.join(d, 'out2'));
  if (bake(path.join(d, 'files.gltf'), path.join(d, 'out2/from_gltf.glb'))) {
    await validate(path.join(d, 'out2/from_gltf.glb'), '.gltf -> glb');
    check(JSON.stringify(filesIn(path.join(d, 'out2'))) === '["from_gltf.glb"]', '.gltf -> glb: no side file');
  }
}

// ---- paths: sub-folders and %-encoded names ----
{
  const d = fresh('paths'), a = buildAsset([boxGeometry()]), tex = noiseTexture(32, 3), nrm = solidTexture(8, [120, 130, 250]);
  fs.mkdirSync(path.join(d, 'in/tex maps'), { recursive: true }); fs.mkdirSync(path.join(d, 'in/geo'), { recursive: true });
  fs.writeFileSync(path.join(d, 'in/tex maps/base colour.png'), tex);
  fs.writeFileSync(path.join(d, 'in/tex maps/normal #1.png'), nrm);
  fs.writeFileSync(path.join(d, 'in/geo/mesh data.bin'), a.bin);
  const json = {
    asset: { version: '2.0' }, scene: 0, scenes: [{ nodes: [0] }], nodes: [{ mesh: 0 }],
    meshes: [{ primitives: [{ ...a.prims[0], material: 0 }] }], materials: [{ ...baseMaterial(0), normalTexture: { index: 1 } }],
    textures: [{ source: 0 }, { source: 1 }], images: [{ uri: 'tex%20maps/base%20colour.png' }, { uri: 'tex%20maps/normal%20%231.png' }],
    buffers: [{ uri: 'geo/mesh%20data.bin', byteLength: a.bin.length }], bufferViews: a.bufferViews, accessors: a.accessors,
  };
  fs.writeFileSync(path.join(d, 'in/asset.gltf'), JSON.stringify(json));
  await validate(path.join(d, 'in/asset.gltf'), 'paths input');
  fs.mkdirSync(path.join(d, 'out'));
  if (bake(path.join(d, 'in/asset.gltf'), path.join(d, 'out/baked.gltf'))) {
    await validate(path.join(d, 'out/baked.gltf'), 'paths');
    const { json: o } = readGltf(path.join(d, 'out/baked.gltf'));
    const n = textureImage(o, o.materials[0].normalTexture);
    check(o.images[n].uri === 'tex%20maps/normal%20%231.png', `paths: the normal map keeps its URI (${o.images[n].uri})`);
    check(fs.existsSync(path.join(d, 'out/tex maps/normal #1.png')) && Buffer.compare(fs.readFileSync(path.join(d, 'out/tex maps/normal #1.png')), nrm) === 0,
      'paths: the normal map copied into its sub-folder, byte for byte');
    check(fs.statSync(path.join(d, 'out/baked.bin')).size === a.bin.length, 'paths: the buffer beside OUT, complete');
  }
}

// ---- multi: several meshes, primitives and materials ----
{
  const d = fresh('multi');
  const g0 = boxGeometry(1), g1 = boxGeometry(0.5, (u, v) => [u, v]), g2 = boxGeometry(0.7), gHidden = boxGeometry(1);
  const a = buildAsset([g0, g1, g2, gHidden]);
  fs.writeFileSync(path.join(d, 'multi.bin'), a.bin);
  fs.writeFileSync(path.join(d, 'a.png'), noiseTexture(32, 4));
  fs.writeFileSync(path.join(d, 'b.png'), solidTexture(16, [220, 30, 30]));
  fs.writeFileSync(path.join(d, 'n.png'), solidTexture(8, [128, 128, 255]));
  const points = { attributes: { POSITION: a.prims[0].attributes.POSITION, TEXCOORD_0: a.prims[0].attributes.TEXCOORD_0, TEXCOORD_1: a.prims[0].attributes.TEXCOORD_1 }, mode: 0, material: 0 };
  const json = {
    asset: { version: '2.0', generator: 'corpus' }, scene: 0, scenes: [{ nodes: [0, 1] }],
    nodes: [{ mesh: 0, translation: [-2, 0, 0] }, { mesh: 1, translation: [2, 0, 0], scale: [1.5, 1.5, 1.5] }],
    meshes: [{ primitives: [{ ...a.prims[0], material: 0 }, { ...a.prims[1], material: 1 }, points] },
      { primitives: [{ ...a.prims[2], material: 1 }] }, { primitives: [{ ...a.prims[3], material: 1 }] }],
    materials: [{ name: 'A', ...baseMaterial(0), normalTexture: { index: 2 }, occlusionTexture: { index: 2, texCoord: 1 }, emissiveFactor: [0.1, 0, 0] },
      { name: 'B', ...baseMaterial(1) }],
    textures: [{ source: 0 }, { source: 1 }, { source: 2 }], images: [{ uri: 'a.png' }, { uri: 'b.png' }, { uri: 'n.png' }],
    buffers: [{ uri: 'multi.bin', byteLength: a.bin.length }], bufferViews: a.bufferViews, accessors: a.accessors,
  };
  fs.writeFileSync(path.join(d, 'multi.gltf'), JSON.stringify(json));
  await validate(path.join(d, 'multi.gltf'), 'multi input');
  if (bake(path.join(d, 'multi.gltf'), path.join(d, 'baked.gltf'))) {
    const out = path.join(d, 'baked.gltf');
    await validate(out, 'multi');
    const { json: o } = readGltf(out);
    const baked = (mi) => { const m = o.materials[mi]; return m && m.pbrMetallicRoughness.baseColorTexture && /_baseColor/.test(o.images[textureImage(o, m.pbrMetallicRoughness.baseColorTexture)].uri || '') && m.pbrMetallicRoughness.metallicRoughnessTexture; };
    const tri = [o.meshes[0].primitives[0], o.meshes[0].primitives[1], o.meshes[1].primitives[0]];
    check(tri.every(p => baked(p.material)), 'multi: every triangle primitive of the scene has baked textures');
    check(o.meshes[0].primitives[2].material === 0 && !baked(0) && o.materials[0].pbrMetallicRoughness.baseColorTexture.index === 0,
      'multi: the points primitive keeps the original material A');
    check(o.meshes[2].primitives[0].material === 1 && !baked(1), 'multi: the mesh outside the scene keeps the original material B');
    check(tri[0].material !== tri[1].material && tri[1].material === tri[2].material, 'multi: one baked material per original material, shared across meshes');
    const mA = o.materials[tri[0].material];
    check(mA.normalTexture && mA.normalTexture.index === 2 && mA.occlusionTexture.texCoord === 1 && mA.emissiveFactor[0] === 0.1,
      'multi: normal, occlusion (TEXCOORD_1) and emissive stay as they were');
    // material B's base colour is plain red: its baked texture must be red where the bake wrote colour
    const t = pngDecode(imageBytes(out, textureImage(o, o.materials[tri[1].material].pbrMetallicRoughness.baseColorTexture)));
    let red = 0, lit = 0;
    for (let i = 0; i < t.w * t.h; i++) { const [r, g, b] = [t.px[i * t.ch], t.px[i * t.ch + 1], t.px[i * t.ch + 2]]; if (r + g + b > 30) { lit++; if (r > 150 && g < 90 && b < 90) red++; } }
    check(lit > 0.5 * t.w * t.h && red > 0.95 * lit, `multi: material B baked from both meshes is red (${red} of ${lit} coloured texels)`);
    check(o.asset.generator.startsWith('supermat'), `multi: asset.generator names supermat (${o.asset.generator})`);
  }
}

// ---- KHR_texture_transform ----
{
  const d = fresh('transform'), tex = noiseTexture(32, 5);
  const off = [0.25, -0.1], rot = 0.3, sc = [0.5, 0.75];
  const xf = (u, v) => { const c = Math.cos(rot), s = Math.sin(rot); return [c * sc[0] * u + s * sc[1] * v + off[0], -s * sc[0] * u + c * sc[1] * v + off[1]]; };
  fs.writeFileSync(path.join(d, 'tex.png'), tex);
  for (const [name, geo, ext] of [['with', boxGeometry(), { KHR_texture_transform: { offset: off, rotation: rot, scale: sc } }], ['applied', boxGeometry(1, xf), undefined]]) {
    const a = buildAsset([geo]);
    fs.writeFileSync(path.join(d, `${name}.bin`), a.bin);
    const json = {
      asset: { version: '2.0' }, scene: 0, scenes: [{ nodes: [0] }], nodes: [{ mesh: 0 }], meshes: [{ primitives: [{ ...a.prims[0], material: 0 }] }],
      materials: [{ pbrMetallicRoughness: { baseColorTexture: { index: 0, ...(ext ? { extensions: ext } : {}) }, metallicFactor: 0 } }],
      textures: [{ source: 0, sampler: 0 }], samplers: [{ wrapS: 10497, wrapT: 10497 }], images: [{ uri: 'tex.png' }],
      buffers: [{ uri: `${name}.bin`, byteLength: a.bin.length }], bufferViews: a.bufferViews, accessors: a.accessors,
      ...(ext ? { extensionsUsed: ['KHR_texture_transform'] } : {}),
    };
    fs.writeFileSync(path.join(d, `${name}.gltf`), JSON.stringify(json));
    bake(path.join(d, `${name}.gltf`), path.join(d, `${name}_out.gltf`));
  }
  const wOut = path.join(d, 'with_out.gltf'), aOut = path.join(d, 'applied_out.gltf');
  if (fs.existsSync(wOut) && fs.existsSync(aOut)) {
    await validate(wOut, 'transform');
    const { json: w } = readGltf(wOut), { json: ap } = readGltf(aOut);
    const pw = w.materials[0].pbrMetallicRoughness, pa = ap.materials[0].pbrMetallicRoughness;
    check(JSON.stringify(pw.baseColorTexture.extensions) === JSON.stringify({ KHR_texture_transform: { offset: off, rotation: rot, scale: sc } }) &&
      JSON.stringify(pw.metallicRoughnessTexture.extensions) === JSON.stringify(pw.baseColorTexture.extensions), 'transform: both new textures carry the transform');
    const tw = pngDecode(imageBytes(wOut, textureImage(w, pw.baseColorTexture))), ta = pngDecode(imageBytes(aOut, textureImage(ap, pa.baseColorTexture)));
    let same = 0, coloured = 0;
    for (let i = 0; i < tw.w * tw.h; i++) {
      let dmax = 0;
      for (let k = 0; k < 3; k++) dmax = Math.max(dmax, Math.abs(tw.px[i * 3 + k] - ta.px[i * 3 + k]));
      if (ta.px[i * 3] + ta.px[i * 3 + 1] + ta.px[i * 3 + 2] > 0) coloured++;
      if (dmax <= 2) same++;
    }
    // measured: every texel within 2/255 on this machine; 0.5 % allowed for rasterisation ties
    check(coloured > 0.3 * tw.w * tw.h && same >= 0.995 * tw.w * tw.h, `transform: the same texture as the transform applied to the UVs (${same} of ${tw.w * tw.h} texels within 2/255, ${coloured} coloured)`);
  }
}

// ---- alpha ----
{
  const d = fresh('alpha'), n = 64;
  const tex = noiseTexture(n, 6, 4, (x, y) => (x < n / 2 ? 0 : 255) ^ ((y * 4) & 0xff));
  fs.writeFileSync(path.join(d, 'rgba.png'), tex);
  const a = buildAsset([boxGeometry()]);
  fs.writeFileSync(path.join(d, 'box.bin'), a.bin);
  for (const mode of ['MASK', 'OPAQUE']) {
    const json = {
      asset: { version: '2.0' }, scene: 0, scenes: [{ nodes: [0] }], nodes: [{ mesh: 0 }], meshes: [{ primitives: [{ ...a.prims[0], material: 0 }] }],
      materials: [{ ...baseMaterial(0), alphaMode: mode, ...(mode === 'MASK' ? { alphaCutoff: 0.4 } : {}) }], textures: [{ source: 0 }], images: [{ uri: 'rgba.png' }],
      buffers: [{ uri: 'box.bin', byteLength: a.bin.length }], bufferViews: a.bufferViews, accessors: a.accessors,
    };
    fs.writeFileSync(path.join(d, `${mode}.gltf`), JSON.stringify(json));
    if (!bake(path.join(d, `${mode}.gltf`), path.join(d, `${mode}_out.gltf`))) continue;
    const out = path.join(d, `${mode}_out.gltf`), { json: o } = readGltf(out);
    await validate(out, `alpha ${mode}`);
    const t = pngDecode(imageBytes(out, textureImage(o, o.materials[0].pbrMetallicRoughness.baseColorTexture)));
    if (mode === 'OPAQUE') { check(t.ch === 3, `alpha: OPAQUE bakes RGB (${t.ch} channels)`); continue; }
    const src = pngDecode(tex);
    let eq = 0;
    for (let i = 0; i < n * n; i++) if (t.px[i * 4 + 3] === src.px[i * 4 + 3]) eq++;
    check(t.ch === 4 && eq === n * n, `alpha: MASK keeps the texture's alpha texel for texel (${t.ch} channels, ${eq} of ${n * n} equal)`);
    check(o.materials[0].alphaMode === 'MASK' && o.materials[0].alphaCutoff === 0.4, 'alpha: alphaMode and alphaCutoff kept');
  }
}

// ---- re-running on its own output ----
{
  const d = path.join(outRoot, 'multi');
  const first = path.join(d, 'baked.gltf'), second = path.join(d, 'again.gltf');
  if (fs.existsSync(first) && bake(first, second)) {
    await validate(second, 'rerun');
    const o1 = readGltf(first).json, o2 = readGltf(second).json;
    check(o2.images.length === o1.images.length && o2.textures.length === o1.textures.length && o2.materials.length === o1.materials.length,
      `rerun: no pile-up (images ${o1.images.length} -> ${o2.images.length}, textures ${o1.textures.length} -> ${o2.textures.length}, materials ${o1.materials.length} -> ${o2.materials.length})`);
    check(bake(second, second, []), 'rerun: onto itself with --force');
    const o3 = readGltf(second).json;
    // a --force run whose texture bytes changed writes them under the other of their two names (NAME.png,
    // NAME-1.png: the old asset stays whole until the new .gltf replaces it), and removes the old ones
    const fam = (u) => u.replace(/-1(\.[^./]+)$/, '$1');
    check(JSON.stringify(o3.images.map(i => fam(i.uri))) === JSON.stringify(o2.images.map(i => fam(i.uri))), `rerun: the same image names, up to their alternate (${o3.images.map(i => i.uri)})`);
    const left = fs.readdirSync(d).filter(f => /^again_/.test(f) && !o3.images.some(i => decodeURIComponent(i.uri) === f) && !o3.buffers.some(b => decodeURIComponent(b.uri || '') === f));
    check(left.length === 0, `rerun: the old textures removed (left: ${left})`);
    await validate(second, 'rerun onto itself');
  }
}

console.log(`${checks - failures} of ${checks} checks passed`);
process.exit(failures ? 1 : 0);
