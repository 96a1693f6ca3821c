"""`make bench`: the L_p-field shell vs Blender's Solidify on concave meshes.

For each mesh: self-intersecting outer-layer face pairs, outer-vs-base intersections,
inverted prisms, min/mean achieved-thickness ratio and time, for Thicket's Shell and
Solidify Simple (with Even Thickness, with and without Clamp). All measured by
`thicket_native.shell_report` in this run. Complex mode changes vertex counts, so it
has no per-vertex directors to report on and is timed only.
"""

import pathlib
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path[:0] = [str(ROOT / "addon"), str(ROOT / "build" / "site"), str(ROOT / "tests")]

import bpy  # noqa: E402
import numpy as np  # noqa: E402

import thicket  # noqa: E402
from blender_objects import mesh_object  # noqa: E402
from thicket import mesh_io, native  # noqa: E402

EXTERIOR = 0.10  # fraction of the bounding-box diagonal, as in the issue


def solidify(obj, thickness, **settings):
    modifier = obj.modifiers.new("bench", "SOLIDIFY")
    modifier.thickness, modifier.offset, modifier.use_rim = thickness, 1.0, False
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


def row(name, report, seconds):
    if report is None:
        print(f"  {name:28s} {'-':>8s} {'-':>8s} {'-':>8s} {'-':>7s} {'-':>7s} {seconds * 1e3:9.1f}")
        return
    print(f"  {name:28s} {report['outer_self_intersections']:8d} {report['outer_base_intersections']:8d} "
          f"{report['inverted_cells']:8d} {report['min_ratio']:7.3f} {report['mean_ratio']:7.3f} {seconds * 1e3:9.1f}")


def bench(obj):
    tn = native.get()
    a = mesh_io.read_mesh(obj.data)
    n = a.vertex_count
    diag = float(np.linalg.norm(np.ptp(a.vertices, axis=0)))
    target = np.full(n, EXTERIOR * diag, np.float32)
    print(f"\n{obj.name}: {n} vertices, exterior {EXTERIOR:.0%} of diagonal")
    print(f"  {'method':28s} {'selfX':>8s} {'baseX':>8s} {'inverted':>8s} {'min':>7s} {'mean':>7s} {'ms':>9s}")
    t = time.perf_counter()
    shell = tn.shell(a.vertices, a.face_sizes, a.corners, EXTERIOR, relative=True)
    ours = time.perf_counter() - t
    row("Thicket Shell (L_p field)", tn.shell_report(a.vertices, a.face_sizes, a.corners, shell["directors"], shell["target"]), ours)
    for name, settings in (
        ("Solidify Simple", {}),
        ("Solidify Simple+Even", {"use_even_offset": True}),
        ("Solidify Simple+Even+Clamp", {"use_even_offset": True, "thickness_clamp": 1.0}),
        ("Solidify Complex", {"solidify_mode": "NON_MANIFOLD"}),
    ):
        out, seconds = solidify(obj, EXTERIOR * diag, **settings)
        report = None
        if len(out) == 2 * n:
            directors = np.ascontiguousarray(out[:n] - a.vertices)
            report = tn.shell_report(a.vertices, a.face_sizes, a.corners, directors, target)
        row(name, report, seconds)
    return ours


def voxel_object(name, dims, sub, filled):
    """The closed quad surface of unit voxels, each face split into sub x sub quads:
    the notched box and comb of the Rust tests (`testmeshes::voxels`)."""
    def inside(c):
        return all(0 <= c[a] < dims[a] for a in range(3)) and filled(*c)

    index, verts, faces = {}, [], []

    def vid(q):
        if q not in index:
            index[q] = len(verts)
            verts.append(tuple(x / sub for x in q))
        return index[q]

    for c in np.ndindex(*dims):
        if not inside(c):
            continue
        for a in range(3):
            for sign in (1, -1):
                nb = list(c)
                nb[a] += sign
                if inside(nb):
                    continue
                u, v = (a + 1) % 3, (a + 2) % 3
                base = [x * sub for x in c]
                if sign > 0:
                    base[a] += sub
                for du in range(sub):
                    for dv in range(sub):
                        def at(x, y):
                            q = list(base)
                            q[u] += x
                            q[v] += y
                            return tuple(q)
                        quad = [at(du, dv), at(du + 1, dv), at(du + 1, dv + 1), at(du, dv + 1)]
                        if sign < 0:
                            quad.reverse()
                        faces.append([vid(q) for q in quad])
    return mesh_object(name, verts, faces)


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
    for obj in (
        voxel_object("Notched box", (10, 6, 6), 2, lambda i, j, k: not (i == 5 and j >= 2)),
        voxel_object("Comb (fins 2 apart)", (13, 6, 4), 2, lambda i, j, k: j == 0 or i % 3 == 0),
        saddle_object(),
    ):
        bench(obj)
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
    print(f"\n  full exterior shell on {len(bunny.data.vertices)} vertices: {seconds:.2f} s "
          f"(target 0.5 s: {seconds / 0.5:.1f}x the target)")
    interactive_edit(bunny)


def interactive_edit(obj):
    """A Shell item following an edit of its source in Blender (thick surfaces 7.1):
    the time from the edited mesh to the written result, updated from the kept shell
    against built from scratch (Regenerate), in the same run."""
    from thicket import api
    from thicket.stack import live_shells

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
        print(f"  edit {step + 1}: followed incrementally in {live * 1e3:.0f} ms ({stats}), "
              f"regenerated from scratch in {fresh * 1e3:.0f} ms: {fresh / live:.1f}x faster")


if __name__ == "__main__":
    main()
