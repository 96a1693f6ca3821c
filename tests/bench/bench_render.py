"""`make bench`: Render Preview inside Blender at 1024x1024: the native render (GPU
slices on whatever adapter is present, and the CPU reference) beside the cost of
showing the frame in a Blender image (readback to numpy is inside the native call)."""

import math
import pathlib
import statistics
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path[:0] = [str(ROOT / "addon"), str(ROOT / "build" / "site")]

import bpy  # noqa: E402

import thicket  # noqa: E402
from thicket import api  # noqa: E402
from thicket.render import camera, preview  # noqa: E402

SIZE = 1024


def median_time(fn, runs=3):
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), out


def main():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    thicket.register()
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=4)  # 5120 faces
    obj = bpy.context.object
    api.add_volumetric_texture(obj, "chain_mail", shell_thickness=0.03, tiling=1.0, resolution=2, depth_steps=4)
    bpy.ops.object.camera_add(location=(0.0, -4.0, 0.0), rotation=(math.radians(90), 0.0, 0.0))
    scene = bpy.context.scene
    scene.camera = bpy.context.object
    depsgraph = bpy.context.evaluated_depsgraph_get()
    view, projection = camera.scene_camera(scene, depsgraph, obj, SIZE, SIZE)
    print(f"Render Preview in Blender, icosphere 5120 faces, chain mail, {SIZE}x{SIZE}")
    rows = []
    for method, slices in (("interpolating", 16), ("plain", 16), ("reference", 0)):
        seconds, out = median_time(lambda m=method, n=slices: preview.render_arrays(obj, view, projection, SIZE, SIZE, method=m, slices=max(n, 2)))
        show, _ = median_time(lambda rgba=out["rgba"]: preview.to_image(rgba))
        rows.append((method, slices, seconds, show, out["renderer"]))
    for method, slices, seconds, show, renderer in rows:
        label = f"{method} ({slices} slices)" if slices else method
        print(f"{label:26s} render {seconds * 1e3:8.1f} ms (stack read + shell + render + readback), show in image {show * 1e3:6.1f} ms  [{renderer}]")
    gpu, ref = rows[0][2], rows[2][2]
    print(f"ratio (GPU interpolating / CPU reference): {gpu / ref:.2f}x")


main()
