// bench/race_ort.js - the ONNX Runtime leg of bench/race.py (npm onnxruntime-node, CPU).
//   node race_ort.js ONNX_DIR INPUT.f32 N,C,H,W THREADS RUNS OUT_DIR
// Loads ONNX_DIR/encode.onnx, unet/unet.onnx and decode.onnx (as bench/race.py exports them), runs
// encode -> unet (both branches, x0) -> decode per branch RUNS times on the float32 input and prints JSON
// {version, create_seconds, runs: [{encode, unet, decode_albedo, decode_rm, total}]} on stdout; writes the
// last run's decoder outputs to OUT_DIR/decode_albedo.f32 and decode_rm.f32 (little-endian float32).
'use strict';
const fs = require('fs');
const path = require('path');
const ort = require('onnxruntime-node');

async function main() {
    const [dir, input, xs, threads, runs, out] = process.argv.slice(2);
    if (!out) {
        console.error('usage: node race_ort.js ONNX_DIR INPUT.f32 N,C,H,W THREADS RUNS OUT_DIR');
        process.exit(2);
    }
    const xshape = xs.split(',').map(Number);
    const opts = {
        intraOpNumThreads: Number(threads), interOpNumThreads: 1, executionMode: 'sequential',
        graphOptimizationLevel: 'all', executionProviders: ['cpu'],
    };
    const t0 = process.hrtime.bigint();
    const enc = await ort.InferenceSession.create(path.join(dir, 'encode.onnx'), opts);
    const unet = await ort.InferenceSession.create(path.join(dir, 'unet', 'unet.onnx'), opts);
    const dec = await ort.InferenceSession.create(path.join(dir, 'decode.onnx'), opts);
    const createSeconds = Number(process.hrtime.bigint() - t0) / 1e9;
    const buf = fs.readFileSync(input);
    const xdata = new Float32Array(buf.buffer, buf.byteOffset, buf.length / 4);
    const x = new ort.Tensor('float32', Float32Array.from(xdata), xshape);
    const res = [];
    let last = null;
    const now = () => Number(process.hrtime.bigint()) / 1e9;
    for (let r = 0; r < Number(runs); r++) {
        const t = {};
        let s = now();
        const z = (await enc.run({ x })).z;
        t.encode = now() - s;
        s = now();
        const u = await unet.run({ z });
        t.unet = now() - s;
        s = now();
        const ya = (await dec.run({ z: u.x0_albedo })).y;
        t.decode_albedo = now() - s;
        s = now();
        const yr = (await dec.run({ z: u.x0_rm })).y;
        t.decode_rm = now() - s;
        t.total = t.encode + t.unet + t.decode_albedo + t.decode_rm;
        console.error(`  ort run ${r + 1}/${runs}: ${t.total.toFixed(2)} s`);
        res.push(t);
        last = [ya, yr];
    }
    fs.writeFileSync(path.join(out, 'decode_albedo.f32'), Buffer.from(last[0].data.buffer, last[0].data.byteOffset, last[0].data.byteLength));
    fs.writeFileSync(path.join(out, 'decode_rm.f32'), Buffer.from(last[1].data.buffer, last[1].data.byteOffset, last[1].data.byteLength));
    process.stdout.write(JSON.stringify({ version: ort.env.versions.common, create_seconds: createSeconds, runs: res }) + '\n');
}

main().catch((e) => { console.error(`race_ort.js: ${e && e.stack ? e.stack : e}`); process.exit(1); });
