"""Probe (not kept): the sun per corner in two stages on the main job's façade."""
import pathlib, sys, time
import bpy
import numpy as np
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import bench_life
from porous_weathering.blender import scratch_scene
from porous_weathering.core import solar
from porous_weathering.maps import rain, sky_bake, sun

_, [obj], _ = bench_life.facade()
occluders = sky_bake.default_occluders(obj)
original = sky_bake._bake_probes
state = {"type": "DIFFUSE", "normals": None}

def probes(copy, points, normals, step):
    state["normals"] = normals.copy()
    if state["type"] == "DIFFUSE":
        return original(copy, points, normals, step)
    real = bpy.ops.object.bake
    def shadow_bake(**kw):
        kw.pop("pass_filter", None)
        kw["type"] = "SHADOW"
        return real(**kw)
    bpy.ops.object.bake = shadow_bake
    try:
        return original(copy, points, normals, step)
    finally:
        bpy.ops.object.bake = real
sky_bake._bake_probes = probes

def timed(f):
    t = time.perf_counter(); v = f(); return v, time.perf_counter() - t

def sun_at(samples, seed=0, kind="DIFFUSE"):
    state["type"] = kind
    return timed(lambda: sun.bake_sun_corners(obj, sun.SunSettings(samples=samples, seed=seed), occluders))

_, rain_t = timed(lambda: rain.bake_rain_corners(obj, rain.RainSettings(samples=64, seed=0), occluders))
ref, ref_t = sun_at(1024, seed=1)
print(f"rain 64: {rain_t:.2f} s; sun reference 1024: {ref_t:.1f} s", flush=True)
# the open plane's S at each corner's normal: normals per point, back to corners through a 1-sample bake's order
state["type"] = "DIFFUSE"
one, _ = sun_at(1)
normals = state["normals"]
directions, weights = solar.year(50.0)
keep = weights > 0
scene_dirs = solar.scene_directions(directions[keep], 0.0); w = weights[keep]
unique, inverse = np.unique(np.round(normals, 5), axis=0, return_inverse=True)
print("distinct normals", len(unique), "suns", len(w), flush=True)
s0_unique = np.array([w @ np.maximum(scene_dirs @ u, 0.0) for u in unique])
s0_points = s0_unique[inverse.ravel()]
# corner -> point map: bake_corners returns values[corner_point]; recover it by baking an index
ids = np.arange(len(normals), dtype=np.float64)
def index_probe(copy, points, nrm, step):
    return ids[: len(points)].astype(np.float32)
sky_bake._bake_probes = index_probe
corner_point = sun.bake_sun_corners(obj, sun.SunSettings(samples=1), occluders).astype(np.int64)
sky_bake._bake_probes = probes
s0 = s0_points[corner_point]
rmse = lambda v: float(np.sqrt(np.mean((v - ref) ** 2)))
truly_lit = np.abs(ref - s0) < 0.003
print(f"corners {len(ref)}, lit by the reference (|S-S0| < 0.003): {truly_lit.mean():.3f}", flush=True)
plain = {}
for n in (16, 32, 64, 128, 256):
    v, t = sun_at(n)
    plain[n] = (v, t)
    print(f"plain {n:4d}: {t:6.2f} s  RMSE {rmse(v):.4f}  (lit corners {float(np.sqrt(np.mean((v-ref)[truly_lit]**2))):.4f}, others {float(np.sqrt(np.mean((v-ref)[~truly_lit]**2))):.4f})", flush=True)
for n1 in (4, 8, 16):
    shadow, t1 = sun_at(n1, kind="SHADOW")
    lit = shadow >= 1.0 - 1e-6
    print(f"SHADOW {n1}: {t1:.2f} s, lit {lit.mean():.3f}, of them lit by the reference {truly_lit[lit].mean():.3f}; "
          f"shadow range {shadow.min():.3f}..{shadow.max():.3f}", flush=True)
    for n2, (v, t) in plain.items():
        est = np.where(lit, s0, v)
        cost = t1 + t * (1 - lit.mean())
        print(f"  two-stage {n1}+{n2}: ~{cost:6.2f} s  RMSE {rmse(est):.4f}", flush=True)
    ratio = np.where(lit, s0, s0 * shadow)
    print(f"  S0 x SHADOW ratio alone ({n1}): RMSE {rmse(ratio):.4f}", flush=True)
