#!/usr/bin/env python3
"""ctest gen_assembly: supermat_tools.gen_data --assembly (objects made of parts) changes only what it names.

usage: test_gen_assembly.py OUT_DIR

- The new part kinds' signed distances (surfaces of revolution, capped cylinders) and every assembly's are
  1-Lipschitz outside the object, which the sphere tracer's steps rely on (a larger slope overshoots the
  surface; the ellipsoid's bound is scaled for that): 300 assemblies, pairs of nearby points outside,
  |d(p) - d(q)| <= |p - q| (1 + 1e-3; float32 distances).
- Their zero sets are where the shapes are: points on a revolution's profile curve (radius r(y)) and on a
  cylinder's side and caps, recomputed here from the parameters, are at distance 0 (|d| < 1e-5); the
  cylinder's distance is exact on its axis (|y| - h beyond a cap) and in its mid-plane (rho - r).
- An assembly has 3-7 parts, attached near its body (each part's centre within 1.2 body extents), and its
  materials: one per part, about 70 % of them new (not a copy of an earlier part's).
- render_sample: --assembly 0 and no option give the same sample bit for bit; --assembly 1 gives another
  object but leaves the main stream where it was (the light, exposure and white balance drawn after it
  are the same; so is the next draw).
- Through the command line (8 samples at 48², one map): the set made with --assembly 0.5 equals the set made
  without it in every sample whose own stream declines the assembly, and differs in every other; meta.json
  records it; --assembly 1.5 and --assembly with --views 6 exit non-zero naming --assembly.
"""
import json
import os
import shutil
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
from supermat_tools import gen_data as G  # noqa: E402
from supermat_tools import smrender as R  # noqa: E402
from test_litbake import write_hdr  # noqa: E402

fails = 0


def check(ok, what):
    global fails
    print(("ok   " if ok else "FAIL ") + what)
    fails += 0 if ok else 1


def lipschitz(f, rng, n=4000, scale=1.5, h=0.05):
    p = rng.uniform(-scale, scale, (n, 3)).astype(np.float64)
    d = rng.normal(size=(n, 3))
    d *= (rng.uniform(5e-3, h, n) / np.linalg.norm(d, axis=-1))[:, None]
    q = p + d
    fp, fq = f(p.astype(np.float32)).astype(np.float64), f(q.astype(np.float32)).astype(np.float64)
    out = (fp > 0) & (fq > 0)      # the tracer steps from outside; inside, only the sign matters
    ratio = np.abs(fp - fq)[out] / \
        np.linalg.norm(q.astype(np.float32).astype(np.float64) - p.astype(np.float32).astype(np.float64), axis=-1)[out]
    return float(ratio.max())


def main():
    out = sys.argv[1]
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(os.path.join(out, "hdri"))
    rng = np.random.default_rng(5)

    # 1. slopes and zero sets
    worst_part = worst_obj = 0.0
    zero_lathe = zero_cyl = exact_cyl = 0.0
    kinds, nparts, near = {}, [], True
    for i in range(300):
        a = G.Assembly(np.random.default_rng([3, i]))
        nparts.append(len(a.shapes))
        body = a.shapes[0]
        near &= all(np.linalg.norm(s["off"]) <= 1.2 * body["ext"] + 1e-6 for s in a.shapes[1:])
        for s in a.shapes:
            kinds[s["kind"]] = kinds.get(s["kind"], 0) + 1
            if s["kind"] in ("lathe", "cylinder"):
                worst_part = max(worst_part, lipschitz(lambda p, s=s: G.sdf_shape(s, p), rng, 800, 1.0))
            rot, off = s["rot"], s["off"]
            if s["kind"] == "lathe":
                t = rng.uniform(0.02, 0.98, 200)
                y = -s["h"] + 2 * s["h"] * t
                r = s["r0"] * (1 + sum(am * np.sin((j + 1) * np.pi * t + ph) for j, (am, ph) in enumerate(s["harm"])))
                keep = r > s["rmin"] + 1e-3
                phi = rng.uniform(0, 2 * np.pi, 200)
                loc = np.stack([r * np.cos(phi), y, r * np.sin(phi)], -1)[keep]
                zero_lathe = max(zero_lathe, float(np.abs(G.sdf_shape(s, (loc @ rot.T + off).astype(np.float32))).max()))
            if s["kind"] == "cylinder" and s["rr"] == 0:
                phi = rng.uniform(0, 2 * np.pi, 100)
                y = rng.uniform(-s["h"], s["h"], 100)
                side = np.stack([s["r"] * np.cos(phi), y, s["r"] * np.sin(phi)], -1)
                rad = s["r"] * np.sqrt(rng.uniform(0, 1, 100))
                cap = np.stack([rad * np.cos(phi), np.sign(y) * s["h"], rad * np.sin(phi)], -1)
                for loc in (side, cap):
                    zero_cyl = max(zero_cyl, float(np.abs(G.sdf_shape(s, (loc @ rot.T + off).astype(np.float32))).max()))
                ya = s["h"] + rng.uniform(0, 1, 50)
                axis = np.stack([np.zeros(50), ya, np.zeros(50)], -1)
                rr = s["r"] + rng.uniform(0, 1, 50)
                mid = np.stack([rr, np.zeros(50), np.zeros(50)], -1)
                exact_cyl = max(exact_cyl,
                                float(np.abs(G.sdf_shape(s, (axis @ rot.T + off).astype(np.float32)) - (ya - s["h"])).max()),
                                float(np.abs(G.sdf_shape(s, (mid @ rot.T + off).astype(np.float32)) - (rr - s["r"])).max()))
        if i < 60:
            worst_obj = max(worst_obj, lipschitz(a.sdf, rng, 1500, 1.2, 0.03))
    check(worst_part <= 1 + 1e-3, f"lathe and cylinder distances are 1-Lipschitz (largest slope {worst_part:.4f})")
    check(worst_obj <= 1 + 1e-3, f"whole assemblies' distances are 1-Lipschitz (largest slope {worst_obj:.4f}, 60 objects)")
    check(zero_lathe < 1e-5, f"points on a revolution's profile are on its surface (|d| <= {zero_lathe:.2e})")
    check(zero_cyl < 1e-5, f"points on a sharp cylinder's side and caps are on its surface (|d| <= {zero_cyl:.2e})")
    check(exact_cyl < 1e-5, f"a cylinder's distance is exact on its axis and in its mid-plane ({exact_cyl:.2e})")
    check(min(nparts) == 3 and max(nparts) == 7, f"3-7 parts per assembly (seen {min(nparts)}-{max(nparts)})")
    check(near, "every part's centre within 1.2 body extents of the body")
    check(all(kinds.get(k, 0) > 20 for k in ("lathe", "cylinder", "roundbox", "ellipsoid", "superquadric", "torus",
                                             "capsule")), f"every part kind drawn: {kinds}")

    # 2. render_sample and the main stream
    sky = np.full((32, 64, 3), 0.05, np.float32)
    sky[:16] = np.linspace(0.3, 2.0, 16)[:, None, None] * np.array([0.8, 0.9, 1.0], np.float32)
    sky[2:5, 20:25] = 30.0
    write_hdr(os.path.join(out, "hdri", "test_sky.hdr"), sky)
    envs = [R.EnvLight(p) for p in G.env_paths(os.path.join(out, "hdri"))]
    same0 = stream = differs = True
    for i in range(4):
        r0, r1, r2 = (np.random.default_rng([21, i]) for _ in range(3))
        s0 = G.render_sample(r0, envs, 32)
        s1 = G.render_sample(r1, envs, 32, assembly=0.0, arng=np.random.default_rng([21, i, 1]))
        s2 = G.render_sample(r2, envs, 32, assembly=1.0, arng=np.random.default_rng([21, i, 1]))
        same0 &= all(np.array_equal(s0[k], s1[k]) for k in s0)
        stream &= r0.random() == r2.random() and np.array_equal(s0["env_rot"], s2["env_rot"]) and \
            np.array_equal(s0["wb"], s2["wb"])
        differs &= not np.array_equal(s0["albedo"], s2["albedo"])
    check(same0, "--assembly 0 gives the sample of no option, bit for bit (4 samples)")
    check(stream, "--assembly 1 leaves the main stream where it was (light, white balance, next draw)")
    check(differs, "--assembly 1 draws another object (4 samples)")
    fresh = total = 0
    one_each = True
    for i in range(200):
        r = np.random.default_rng([31, i])
        a = G.Assembly(r)
        mats = G.assembly_materials(r, len(a.shapes))
        one_each &= len(mats) == len(a.shapes)
        fresh += len({id(m) for m in mats})
        total += len(mats)
    frac = fresh / total
    check(one_each, "one material per part (200 assemblies)")
    check(0.6 <= frac <= 0.85, f"{100 * frac:.1f} % of the parts' materials are their own (60-85 %)")

    # 3. the command line
    def gen(tag, *extra):
        d = os.path.join(out, tag)
        p = subprocess.run([sys.executable, "-m", "supermat_tools.gen_data", "--hdri-dir",
                            os.path.join(out, "hdri"), "--out", d, "--count", "8", "--size", "48", "--seed", "4",
                            "--jobs", "1", *extra], capture_output=True, text=True)
        return p, d
    p0, d0 = gen("set0")
    p1, d1 = gen("set_half", "--assembly", "0.5")
    check(p0.returncode == 0 and p1.returncode == 0, f"gen_data.py runs (exit {p0.returncode}, {p1.returncode})")
    if p0.returncode == 0 and p1.returncode == 0:
        z0, z1 = np.load(os.path.join(d0, "shard_0000.npz")), np.load(os.path.join(d1, "shard_0000.npz"))
        want = [np.random.default_rng([4, i, 0x6173]).random() < 0.5 for i in range(8)]
        got = [not np.array_equal(z0["rgba"][i], z1["rgba"][i]) for i in range(8)]
        check(got == want and 0 < sum(want) < 8,
              f"--assembly 0.5: samples {[i for i in range(8) if want[i]]} are assemblies, the rest as without it")
        check(json.load(open(os.path.join(d1, "meta.json"))).get("assembly") == 0.5, "meta.json records --assembly")
    for extra in (("--assembly", "1.5"), ("--assembly", "0.5", "--views", "6")):
        p, _ = gen("bad", *extra)
        check(p.returncode != 0 and "--assembly" in p.stderr + p.stdout,
              f"gen_data.py {' '.join(extra)}: exit {p.returncode}, message names --assembly")

    print("FAILED" if fails else "all passed")
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
