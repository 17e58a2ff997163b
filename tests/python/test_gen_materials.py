#!/usr/bin/env python3
"""ctest gen_materials: supermat_tools.gen_data's material options that must leave everything else as it was.

usage: test_gen_materials.py

Materials of the two partly metal modes (masked metal, worn edges), 150 of each, drawn from numbered
streams and evaluated on random object-space points (decals removed, so that nothing is painted over):

- neither option set and both options at 0 give the same materials and maps, bit for bit, and leave the
  caller's stream where the default leaves it (the objects, views and lights drawn after stay the same);
- --metal-rough 1 leaves the albedo and the metal mask bit for bit as they were, and the roughness of every
  non-metal point; without it a metal point's roughness is half of what the same point would have as a
  dielectric (clipped at 0.05; recomputed here from the dielectric twin), so the metal is the smoother part
  in at least 85 % of the materials (95 % measured; a pattern's two roughness levels decide the rest); with
  it the metal's mean roughness per material covers [0.05, 1] (below 0.2 and above 0.85 both occur), is
  smoother than its surroundings in 30-70 % of the materials, and is nearly uncorrelated with its
  surroundings across materials (|r| < 0.3, against r > 0.6 without; 0.05 and 0.74 measured);
- --dark-metal 1 changes only the metal points' albedo, each material's by one factor per material in
  [1/8, 1] (linear light; checked before the albedo's clip to 1 can matter) with both ends near reached;
- cycles_procedural's assets (gen_refine_data.build, 24 of them at 64² texels): both options at 0 give the
  asset of neither option bit for bit; both at 1 leave the geometry, the UVs and the metal map bit for bit, and
  the texels with metal 0 (albedo and roughness; all but those where a decal's edge covers metal, which keep
  some of the metal's colour and roughness: at most 1 % of them), while the metal texels' albedo is darkened
  or kept (never brighter) and some of it changes;
- out-of-range values of either option: gen_data.py and cycles_procedural exit non-zero, naming the options.
"""
import copy
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
from supermat_tools import gen_data as G  # noqa: E402

fails = 0


def check(ok, what):
    global fails
    print(("ok   " if ok else "FAIL ") + what)
    fails += 0 if ok else 1


def draw(i, mode, **opt):
    """Material i of a mode, drawn from its own numbered stream; also the stream's next draw."""
    rng = np.random.default_rng([7, i])
    p = (0.0, 0.0, 1.0, 0.0) if mode == "mask" else (0.0, 0.0, 0.0, 1.0)
    m = G.make_material(rng, p, **opt)
    m["decals"] = []
    return m, rng.random()


def points(i, n=4000):
    r = np.random.default_rng([9, i])
    q = r.uniform(-1, 1, (n, 3)).astype(np.float32)
    curv = r.uniform(0.0, 1.2, n).astype(np.float32)   # worn edges appear where curvature (plus noise) > 0.55
    return q, curv


N = 150
same_default = same_stream = True
alb_same = metal_same = diel_same = True
half_ok = True
m_means, d_means, m_means0, d_means0 = [], [], [], []
dark_ok = True
dark_factors = []
n_metal_mats = 0
for mode in ("mask", "worn"):
    for i in range(N):
        q, curv = points(i)
        m_def, nxt_def = draw(i, mode)
        m_0, nxt_0 = draw(i, mode, dark=0.0, mrough=0.0)
        m_r, nxt_r = draw(i, mode, mrough=1.0)
        m_d, nxt_d = draw(i, mode, dark=1.0)
        a_def, r_def, t_def = G.eval_material(m_def, q, curv)
        a_0, r_0, t_0 = G.eval_material(m_0, q, curv)
        same_default &= np.array_equal(a_def, a_0) and np.array_equal(r_def, r_0) and np.array_equal(t_def, t_0)
        same_stream &= nxt_def == nxt_0 == nxt_r == nxt_d
        a_r, r_r, t_r = G.eval_material(m_r, q, curv)
        alb_same &= np.array_equal(a_r, a_def)
        metal_same &= np.array_equal(t_r, t_def)
        met = t_def > 0.5
        diel_same &= np.array_equal(r_r[~met], r_def[~met])
        # the dielectric twin: the same material with no metal, so each point's own roughness
        twin = copy.deepcopy(m_def)
        twin["mode"] = "dielectric"
        _, r_tw, _ = G.eval_material(twin, q, curv)
        inner = met & (r_tw > 0.051) & (r_tw < 0.999)     # away from the clips of the twin's roughness
        if inner.any():
            half_ok &= np.allclose(r_def[inner], np.maximum(0.5 * r_tw[inner], 0.05), rtol=0, atol=1e-6)
        if met.sum() >= 50 and (~met).sum() >= 50:
            m_means.append(r_r[met].mean()); d_means.append(r_r[~met].mean())
            m_means0.append(r_def[met].mean()); d_means0.append(r_def[~met].mean())
        a_d, r_d, t_d = G.eval_material(m_d, q, curv)
        ok = np.array_equal(t_d, t_def) and np.array_equal(r_d, r_def) and np.array_equal(a_d[~met], a_def[~met])
        if met.any():
            n_metal_mats += 1
            unclipped = met & (a_def.max(-1) < 0.999)
            if unclipped.sum() >= 10:
                f = a_d[unclipped] / np.maximum(a_def[unclipped], 1e-12)
                ok &= float(f.max() - f.min()) < 1e-5 and 1 / 8 - 1e-6 <= float(f.mean()) <= 1 + 1e-6
                dark_factors.append(float(f.mean()))
        dark_ok &= bool(ok)

check(same_default, "both options at 0: the same materials and maps as neither option, bit for bit (300 materials)")
check(same_stream, "the options do not move the caller's stream (the next draw is the same with every option)")
check(alb_same and metal_same, "--metal-rough 1: albedo and metal mask bit for bit unchanged")
check(diel_same, "--metal-rough 1: every non-metal point's roughness unchanged")
check(half_ok, "without it: a metal point's roughness is half its dielectric twin's (clipped at 0.05), within 1e-6")
m_means, d_means = np.array(m_means), np.array(d_means)
m_means0, d_means0 = np.array(m_means0), np.array(d_means0)
print(f"     {len(m_means)} materials with both metal and other points")
check(len(m_means) >= 200, f"enough partly metal materials ({len(m_means)} >= 200)")
smoother0 = float((m_means0 < d_means0).mean())
check(smoother0 >= 0.85, f"without it the metal is the smoother part in {100 * smoother0:.1f} % of them (>= 85 %)")
smoother = float((m_means < d_means).mean())
check(0.3 <= smoother <= 0.7, f"with it the metal is the smoother part in {100 * smoother:.1f} % of them (30-70 %)")
r0 = float(np.corrcoef(m_means0, d_means0)[0, 1])
r1 = float(np.corrcoef(m_means, d_means)[0, 1])
check(r0 > 0.6, f"without it the metal's roughness follows its surroundings' across materials (r = {r0:.3f} > 0.6)")
check(abs(r1) < 0.3, f"with it the metal's roughness is nearly independent of them (r = {r1:.3f}, |r| < 0.3)")
check(m_means.min() < 0.2 and m_means.max() > 0.85,
      f"with it the metal's mean roughness spans [{m_means.min():.3f}, {m_means.max():.3f}] (below 0.2, above 0.85)")
dark_factors = np.array(dark_factors)
check(dark_ok, "--dark-metal 1: only the metal's albedo changes, by one factor per material in [1/8, 1]")
check(len(dark_factors) >= 150 and dark_factors.min() < 0.15 and dark_factors.max() > 0.85,
      f"--dark-metal 1: {len(dark_factors)} factors spanning [{dark_factors.min():.3f}, {dark_factors.max():.3f}]")

from supermat_tools import gen_refine_data as R  # noqa: E402

mp = [0.42, 0.2, 0.2, 0.18]
same0 = kept = darker = True
changed = moved = zeros = 0
for i in range(24):
    a = R.build(np.random.default_rng([62000, i]), 64, None, mp, 0.0)
    z = R.build(np.random.default_rng([62000, i]), 64, None, mp, 0.0, 0.0, 0.0)
    b = R.build(np.random.default_rng([62000, i]), 64, None, mp, 0.0, 1.0, 1.0)
    same0 &= all(np.array_equal(x, y) for x, y in zip(a, z))
    kept &= all(np.array_equal(a[k], b[k]) for k in (0, 1, 2, 3, 6))   # pos, normals, uv, indices, metal
    dielectric = a[6] == 0
    moved += int(np.sum(np.any(a[4][dielectric] != b[4][dielectric], -1) | (a[5][dielectric] != b[5][dielectric])))
    zeros += int(dielectric.sum())
    darker &= bool(np.all(b[4][~dielectric] <= a[4][~dielectric] + 1e-7))
    changed += int(np.any(b[4][~dielectric] != a[4][~dielectric]))
check(same0, "cycles_procedural assets: both options at 0 are the assets of neither option, bit for bit (24 assets)")
check(kept, "cycles_procedural assets, both options at 1: geometry, UVs and metal map bit for bit")
check(moved <= 0.01 * zeros,
      f"... and {zeros - moved} of {zeros} metal-0 texels unchanged ({moved} under decal edges, <= 1 %)")
check(darker and changed >= 6,
      f"... and the metal texels' albedo never brighter, darker in {changed} of 24 assets (>= 6)")

for mod, opt, val in (("gen_data", "--metal-rough", "1.5"), ("gen_data", "--metal-rough", "-0.1"),
                      ("gen_data", "--dark-metal", "2"), ("cycles_procedural", "--dark-metal", "2"),
                      ("cycles_procedural", "--metal-rough", "-0.5")):
    p = subprocess.run([sys.executable, "-m", "supermat_tools." + mod, "--hdri-dir", HERE, "--out",
                        os.devnull, "--count", "1", opt, val], capture_output=True, text=True)
    check(p.returncode != 0 and opt in p.stderr + p.stdout,
          f"{mod}.py {opt} {val}: exit {p.returncode}, message names {opt}")

print("FAILED" if fails else "all passed")
sys.exit(1 if fails else 0)
