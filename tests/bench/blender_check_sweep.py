"""Blender's own check of shells over any meshes: each mesh closed and cut open (the
faces beyond a tilted plane removed), exterior 20%, interior 10%, envelope 10% and
painted thickness (exterior 10%, interior 5%), the skins as the result writes them.

    .venv/bin/python tests/bench/blender_check_sweep.py -- mesh.obj ...

Prints per shell the time, `blender_checks.blender_check`'s counts (Blender's overlap
pairs, and those of them a float64 test finds crossing: Blender's float32 overlap
also reports pairs that only touch, as at a CAD part's seams) and the mean thickness
ratio. Any `self_crossing`, `base_crossing`, `inverted` or `folding` above zero is a
defect of the shell."""

import pathlib
import sys
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path[:0] = [str(ROOT / "tests"), str(ROOT / "addon"), str(ROOT / "build" / "site")]

import bpy  # noqa: E402
from blender_checks import blender_check, loop_triangles, written_skins  # noqa: E402

import thicket_native as tn  # noqa: E402
from thicket import mesh_io  # noqa: E402

CASES = [("exterior", 0.2, False), ("interior", 0.1, False), ("envelope", 0.1, False), ("exterior", 0.1, True), ("interior", 0.05, True)]


def cut_open(obj):
    """Removes the faces whose centres lie beyond a tilted plane 15% of the size past the centre."""
    import bmesh  # after bpy

    mesh = obj.data
    centres = np.empty(3 * len(mesh.polygons), np.float32)
    mesh.polygons.foreach_get("center", centres)
    centres = centres.reshape(-1, 3)
    co = np.empty(3 * len(mesh.vertices), np.float32)
    mesh.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    normal = np.array([0.3, 0.2, 0.93]) / np.linalg.norm([0.3, 0.2, 0.93])
    beyond = np.flatnonzero((centres - co.mean(axis=0)) @ normal > 0.15 * np.ptp(co, axis=0).max())
    bm = bmesh.new()
    bm.from_mesh(mesh)
    bm.faces.ensure_lookup_table()
    bmesh.ops.delete(bm, geom=[bm.faces[int(i)] for i in beyond], context="FACES")
    bm.to_mesh(mesh)
    bm.free()
    mesh.update()


def painted(vertices):
    """Per-vertex factors in [0, 1] that vary across the mesh, zero in places."""
    s = np.ptp(vertices, axis=0).max()
    return np.clip(0.5 + 0.8 * np.sin(7 * vertices[:, 0] / s) * np.cos(5 * vertices[:, 1] / s + 1.0), 0, 1).astype(np.float32)


def main(paths):
    for path in paths:
        for opened in (False, True):
            bpy.ops.wm.read_factory_settings(use_empty=True)
            bpy.ops.wm.obj_import(filepath=path)
            obj = bpy.context.selected_objects[0]
            if opened:
                cut_open(obj)
            a = mesh_io.read_mesh(obj.data)
            tris = loop_triangles(obj.data)
            for side, fraction, paint in CASES:
                factors = painted(a.vertices) if paint else None
                start = time.perf_counter()
                # Solid: an envelope's inner skin is written too, and checked as written.
                out = tn.shell(a.vertices, a.face_sizes, a.corners, fraction, side=side, relative=True, factors=factors, output="solid")
                seconds = time.perf_counter() - start
                found = blender_check(a.vertices, out, side, tris, written_skins(out, side))
                ok = out["target"] > 0
                ratio = float((out["achieved"][ok] / out["target"][ok]).mean()) if ok.any() else 1.0
                what = f"{pathlib.Path(path).name} {'open' if opened else 'closed'} {len(a.vertices)} {side} {fraction}{' painted' if paint else ''}"
                print(f"{what}: {seconds:.1f} s, {found}, mean ratio {ratio:.3f}", flush=True)


if __name__ == "__main__":
    main(sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else sys.argv[1:])
