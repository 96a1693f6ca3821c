"""`make bench`: the L_p-field shell vs Blender's Solidify, in one run.

For each mesh (generated hard shapes with thin parts and narrow gaps, Suzanne whose
eyes cross its head, the bunny scan) and each case (exterior 10% and 20%, interior
5% of the bounding-box diagonal): crossing face pairs and inverted cells found with
Blender's own tools (`BVHTree.overlap`, tetrahedron orientation; `tests/blender_checks.py`,
crossings inherited from a self-intersecting base not counted), min/mean achieved
thickness ratio and time, for Thicket's Shell and for Solidify Simple with Even
Thickness, Clamp off and on. The last column is Solidify's time over Thicket's.
"""

import pathlib
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path[:0] = [str(ROOT / "addon"), str(ROOT / "build" / "site"), str(ROOT / "tests")]

import bpy  # noqa: E402
import numpy as np  # noqa: E402
from blender_checks import blender_check, loop_triangles, overlapping  # noqa: E402
from blender_objects import mesh_object  # noqa: E402

import thicket  # noqa: E402
from thicket import mesh_io  # noqa: E402
from thicket.pure import native  # noqa: E402

EXTERIOR = 0.10  # fraction of the bounding-box diagonal, as in the issue
CASES = (("exterior", 0.10), ("exterior", 0.20), ("interior", 0.05))
HARD = ("hand", "cup", "comb", "coil", "torus_knot", "two_spheres", "touching_cubes", "blade")


def solidify(obj, thickness, side, **settings):
    """Solidify's offset vertices (rim off; offset +1 outward, -1 inward) and its time."""
    modifier = obj.modifiers.new("bench", "SOLIDIFY")
    modifier.thickness, modifier.offset, modifier.use_rim = thickness, 1.0 if side == "exterior" else -1.0, False
    for key, value in settings.items():
        setattr(modifier, key, value)
    t = time.perf_counter()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    elapsed = time.perf_counter() - t
    out = mesh_io.read_mesh(mesh).vertices.copy()
    evaluated.to_mesh_clear()
    obj.modifiers.remove(modifier)
    return out, elapsed


def row(name, found, ratio, seconds, ours):
    if found is None:
        print(f"  {name:26s} {'-':>7s} {'-':>7s} {'-':>8s} {'-':>6s} {'-':>6s} {seconds * 1e3:9.1f} {seconds / ours:7.2f}")
        return
    print(
        f"  {name:26s} {found['self']:7d} {found['base']:7d} {found['inverted']:8d} "
        f"{ratio.min():6.3f} {ratio.mean():6.3f} {seconds * 1e3:9.1f} {seconds / ours:7.2f}"
    )


def bench(obj):
    """Prints the table for `obj`; returns Thicket's time at exterior 10%."""
    tn = native.get()
    a = mesh_io.read_mesh(obj.data)
    n = a.vertex_count
    tris = loop_triangles(obj.data)
    diag = float(np.linalg.norm(np.ptp(a.vertices, axis=0)))
    own = len(np.unique(overlapping(a.vertices, a.vertices, tris, same=True)))
    print(f"\n{obj.name}: {n} vertices" + (f" ({own} triangles crossing the mesh itself)" if own else ""))
    print(f"  {'method':26s} {'selfX':>7s} {'baseX':>7s} {'inverted':>8s} {'min':>6s} {'mean':>6s} {'ms':>9s} {'vs ours':>7s}")
    first = None
    for side, fraction in CASES:
        print(f"  -- {side} {fraction:.0%}")
        t = time.perf_counter()
        shell = tn.shell(a.vertices, a.face_sizes, a.corners, fraction, side=side, relative=True)
        ours = time.perf_counter() - t
        first = ours if first is None else first
        row("Thicket Shell (L_p field)", blender_check(a.vertices, shell, side, tris), shell["achieved"] / shell["target"], ours, ours)
        for name, settings in (
            ("Solidify Even", {"use_even_offset": True}),
            ("Solidify Even+Clamp", {"use_even_offset": True, "thickness_clamp": 1.0}),
        ):
            out, seconds = solidify(obj, fraction * diag, side, **settings)
            found = ratio = None
            if len(out) == 2 * n:
                directors = np.ascontiguousarray(out[:n] - a.vertices)
                flipped = side == "interior" and np.linalg.norm(directors, axis=1).sum() == 0
                if flipped:  # Blender puts the offset copy second
                    directors = np.ascontiguousarray(out[n:] - a.vertices)
                result = {"base_offset": np.zeros_like(directors), "directors": directors}
                found = blender_check(a.vertices, result, side, tris)
                ratio = np.linalg.norm(directors, axis=1) / (fraction * diag)
            row(name, found, ratio, seconds, ours)
    return first


def saddle_object(n=24):
    """The open saddle sheet of the Rust tests: z = x^2 - y^2 over [-1, 1]^2."""
    x, y = np.meshgrid(np.linspace(-1, 1, n + 1), np.linspace(-1, 1, n + 1), indexing="ij")
    verts = np.column_stack([x.ravel(), y.ravel(), (x * x - y * y).ravel()])
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    a = (i * (n + 1) + j).ravel()
    faces = np.column_stack([a, a + n + 1, a + n + 2, a + 1])
    return mesh_object("Saddle (open)", verts.tolist(), faces.tolist())


def main():
    thicket.register()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    for name in HARD:
        bpy.ops.wm.obj_import(filepath=str(ROOT / "tests" / "data" / "hard" / f"{name}.obj"))
        bench(bpy.context.selected_objects[0])
    bench(saddle_object())
    bpy.ops.mesh.primitive_monkey_add()
    head = bpy.context.active_object
    head.name = "Suzanne (subdiv 1)"
    head.modifiers.new("s", "SUBSURF").levels = 1
    bpy.ops.object.modifier_apply(modifier="s")
    bpy.ops.wm.obj_import(filepath=str(ROOT / "tests" / "data" / "bunny-3k.obj"))
    bunny = bpy.context.selected_objects[0]
    bunny.name = "Bunny"
    for obj in (head, bunny):
        bench(obj)
    bpy.ops.object.select_all(action="DESELECT")
    bunny.select_set(True)
    bpy.context.view_layer.objects.active = bunny
    big = bunny.modifiers.new("s", "SUBSURF")
    big.levels = 2
    bpy.ops.object.modifier_apply(modifier="s")
    bunny.name = "Bunny (subdiv 2)"
    seconds = bench(bunny)
    print(f"\n  full exterior shell on {len(bunny.data.vertices)} vertices: {seconds:.2f} s (target 0.5 s: {seconds / 0.5:.1f}x the target)")
    # Thin parts at scan resolution (the issue's 26k-vertex thin-limbed scan): the comb
    # and the hand, subdivided twice (Catmull-Clark keeps teeth and fingers apart).
    thin = {}
    for name in ("comb", "hand"):
        bpy.ops.wm.obj_import(filepath=str(ROOT / "tests" / "data" / "hard" / f"{name}.obj"))
        obj = thin[name] = bpy.context.selected_objects[0]
        bpy.context.view_layer.objects.active = obj
        obj.modifiers.new("s", "SUBSURF").levels = 2
        bpy.ops.object.modifier_apply(modifier="s")
        obj.name = f"{name} (subdiv 2)"
        seconds = bench(obj)
        print(
            f"\n  full exterior shell on {len(obj.data.vertices)} vertices with thin parts: {seconds:.2f} s "
            f"({seconds / 0.5 * 26000 / len(obj.data.vertices):.1f}x the target of 0.5 s for 26k vertices)"
        )
    interactive_edit(bunny)
    # The issue's size for the 50 ms target: a 26k-vertex mesh with thin parts.
    interactive_edit(thin["comb"])


def interactive_edit(obj):
    """A Shell item following an edit of its source in Blender (thick surfaces 7.1):
    the time from the edited mesh to the written result, updated from the kept shell
    against built from scratch (Regenerate), in the same run."""
    from thicket import api
    from thicket.pure import live_shells

    api.add_thick_surface(obj, kind="SHELL", thickness=EXTERIOR)
    a = mesh_io.read_mesh(obj.data)
    n = a.vertex_count
    diag = float(np.linalg.norm(np.ptp(a.vertices, axis=0)))
    normals = np.empty(3 * n, np.float32)
    obj.data.vertices.foreach_get("normal", normals)
    normals = normals.reshape(-1, 3)
    centre = a.vertices[n // 3]
    distance = np.linalg.norm(a.vertices - centre, axis=1)
    rim = np.sort(distance)[n // 100]  # the 1% of vertices nearest the centre
    w = np.clip(1.0 - distance / rim, 0.0, None) ** 2
    print(f"\n{obj.name} with a Shell item (exterior {EXTERIOR:.0%}): a smooth bump of 1% of the diagonal over 1% of the vertices")
    for step in range(3):
        moved = a.vertices + normals * (0.01 * diag * w * (1 if step % 2 == 0 else -1))[:, None]
        obj.data.vertices.foreach_set("co", moved.ravel())
        obj.data.update()
        live_shells.recent.clear()
        t = time.perf_counter()
        bpy.context.view_layer.update()  # the depsgraph update that regenerates
        live = time.perf_counter() - t
        stats = next((s for s in live_shells.recent if s is not None and s["changed"]), None)
        t = time.perf_counter()
        api.regenerate(obj, fresh=True)
        fresh = time.perf_counter() - t
        print(
            f"  edit {step + 1}: followed incrementally in {live * 1e3:.0f} ms ({stats}), "
            f"regenerated from scratch in {fresh * 1e3:.0f} ms: {fresh / live:.1f}x faster"
        )


if __name__ == "__main__":
    main()
