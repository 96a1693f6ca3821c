"""`make demo`: a headless batch run of Thicket on a bundled fixture.

    .venv/bin/python blend_fixtures/demo.py blend_fixtures/demo.blend out
    blender -b blend_fixtures/demo.blend --python blend_fixtures/demo.py -- blend_fixtures/demo.blend out

Every mesh gets an L_p-field shell (3% of its size; the sheet's thickness follows its
"thickness" vertex group) filled with a volumetric texture, chain mail or grass in
turn, baked to geometry. Writes out/demo_thicket.blend, out/demo_thicket.glb, a
preview render of each object's thick surface (out/<object>_preview.png, the slice
renderer, or the CPU reference without a GPU) and all of them side by side
(out/demo_previews.png); prints what it wrote with triangle counts and times.
"""

import math
import os
import pathlib
import sys
import time

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path[:0] = [str(ROOT / "addon"), str(ROOT / "build" / "site")]

import bpy  # noqa: E402
import numpy as np  # noqa: E402
from mathutils import Vector  # noqa: E402

import thicket  # noqa: E402
from thicket import api  # noqa: E402

PATTERNS = ("chain_mail", "grass")
# Bakes sized for a demo: a 32-texel texture, simplified toward 150k triangles, and
# at most 4 M triangles sampled (the bunny has no UV map: one tile per face).
BAKE = dict(texture_size=32, triangle_budget=150_000, max_triangles=4_000_000)
PREVIEW_SIZE = 320


def frame_camera(scene, obj):
    """Points the scene camera at `obj` from the front right, framing its bounds."""
    corners = [obj.matrix_world @ Vector(c) for c in obj.bound_box]
    centre = sum(corners, Vector()) / 8.0
    radius = max((c - centre).length for c in corners) * 1.15
    camera = scene.camera
    fov = camera.data.angle
    direction = Vector((0.55, -1.0, 0.45)).normalized()
    camera.location = centre + direction * (radius / math.sin(fov / 2.0))
    camera.rotation_euler = (-direction).to_track_quat("-Z", "Y").to_euler()
    camera.data.clip_start, camera.data.clip_end = radius * 0.01, radius * 100.0


def image_rgb(image, background=0.92):
    """An image's pixels (rows top first) over a light grey background, as float RGB."""
    w, h = image.size
    px = np.empty(w * h * 4, np.float32)
    image.pixels.foreach_get(px)
    rgba = px.reshape(h, w, 4)[::-1]
    return rgba[..., :3] * rgba[..., 3:] + background * (1.0 - rgba[..., 3:])


def save_side_by_side(tiles, path):
    strip = np.concatenate(tiles, axis=1)
    h, w, _ = strip.shape
    image = bpy.data.images.new("Thicket demo", w, h, alpha=False)
    rgba = np.concatenate([strip[::-1], np.ones((h, w, 1), np.float32)], axis=2)
    image.pixels.foreach_set(np.ascontiguousarray(rgba, np.float32).ravel())
    image.filepath_raw = str(path)
    image.file_format = "PNG"
    image.save()


def main(argv):
    source, out_dir = pathlib.Path(argv[0]), pathlib.Path(argv[1])
    if not hasattr(bpy.types.Object, "thicket"):
        thicket.register()
    out_dir.mkdir(parents=True, exist_ok=True)
    out_blend, out_glb = out_dir / f"{source.stem}_thicket.blend", out_dir / f"{source.stem}_thicket.glb"
    bpy.ops.wm.open_mainfile(filepath=str(source))
    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = PREVIEW_SIZE
    scene.render.resolution_percentage = 100
    meshes = sorted((o for o in scene.objects if o.type == "MESH"), key=lambda o: o.name)
    results, tiles = [], []
    for k, obj in enumerate(meshes):
        pattern = PATTERNS[k % len(PATTERNS)]
        start = time.perf_counter()
        api.add_item(obj, "SHELL", thickness=0.03, side="EXTERIOR", vertex_group="thickness" if "thickness" in obj.vertex_groups else "")
        # Eight tiles across a UV map; without one each face is a tile already.
        tiling = 8.0 if obj.data.uv_layers else 1.0
        result = api.add_volumetric_texture(obj, pattern, tiling=tiling, **BAKE)
        baked = time.perf_counter() - start
        frame_camera(scene, obj)
        preview = out_dir / f"{obj.name}_preview.png"
        start = time.perf_counter()
        image = api.render_preview(obj, str(preview))
        rendered = time.perf_counter() - start
        tiles.append(image_rgb(image))
        results.append(result)
        note = f" ({obj.thicket.last_note})" if obj.thicket.last_note else ""
        print(
            f"  {obj.name:8s} {pattern:10s} -> {result.name}: {len(result.data.polygons):,} triangles, shell + bake {baked:.1f} s, preview {rendered:.1f} s{note}"
        )
        print(f"wrote {preview}")
    save_side_by_side(tiles, out_dir / "demo_previews.png")
    print(f"wrote {out_dir / 'demo_previews.png'}")
    bpy.ops.wm.save_as_mainfile(filepath=str(out_blend.resolve()), copy=True)
    print(f"wrote {out_blend}")
    start = time.perf_counter()
    api.export_glb(results, str(out_glb))
    print(f"wrote {out_glb} ({time.perf_counter() - start:.1f} s)")


if __name__ == "__main__":
    args = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else sys.argv[1:]
    main(args)
    if not bpy.app.binary_path:
        # Run as the bpy module (not Blender): its interpreter teardown is fragile (it
        # segfaults on 4.2 once any add-on class was registered, reproduced without
        # Thicket, and crashed once under load on 5.0.1). Everything is written: leave.
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(0)
