"""`make bench`: Offset Shell vs Blender's Solidify, and the Blender <-> Rust data path.

Prints figures measured in this run only, side by side, as ratios (median of N runs).
"""

import pathlib
import statistics
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path[:0] = [str(ROOT / "addon"), str(ROOT / "build" / "site")]

import bpy  # noqa: E402
import numpy as np  # noqa: E402

import thicket  # noqa: E402
from thicket import api, mesh_io  # noqa: E402
from thicket.pure import native  # noqa: E402

RUNS = 7
THICKNESS = 0.02  # fraction of the bounding-box diagonal


def median_time(fn, runs=RUNS):
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def solidify_time(obj, thickness):
    modifier = obj.modifiers.new("bench solidify", "SOLIDIFY")
    modifier.thickness, modifier.offset, modifier.use_rim = thickness, 1.0, True
    depsgraph = bpy.context.evaluated_depsgraph_get()
    toggle = [thickness, thickness * 1.0001]

    def run():
        toggle.reverse()
        modifier.thickness = toggle[0]  # forces re-evaluation
        depsgraph.update()
        evaluated = obj.evaluated_get(depsgraph)
        evaluated.to_mesh()
        evaluated.to_mesh_clear()

    t = median_time(run)
    obj.modifiers.remove(modifier)
    return t


def bench_fixtures():
    bpy.ops.wm.open_mainfile(filepath=str(ROOT / "blend_fixtures" / "demo.blend"))
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=6, location=(0, -4, 0))
    bpy.context.active_object.name = "Icosphere-6"
    print("\nOffset Shell (solid output, full regenerate incl. Blender read/write) vs Solidify (Simple, rim),")
    print(f"thickness {THICKNESS} x diagonal, median of {RUNS}; both produce base + offset + rims")
    print(f"{'mesh':14s} {'verts':>8s} {'thicket ms':>11s} {'solidify ms':>12s} {'ratio':>7s}")
    for obj in [o for o in bpy.context.scene.objects if o.type == "MESH"]:
        api.add_thick_surface(obj, thickness=THICKNESS, output="SOLID")
        diag = np.linalg.norm(np.ptp(mesh_io.read_mesh(obj.data).vertices, axis=0))
        ours = median_time(lambda obj=obj: api.regenerate(obj))
        theirs = solidify_time(obj, THICKNESS * diag)
        print(f"{obj.name:14s} {len(obj.data.vertices):8d} {ours * 1e3:11.2f} {theirs * 1e3:12.2f} {ours / theirs:6.2f}x")


def bench_exchange():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=499, y_subdivisions=499, size=2)  # 250k vertices
    obj = bpy.context.active_object
    mesh = obj.data
    n = len(mesh.vertices)
    arrays = mesh_io.read_mesh(mesh)
    target = bpy.data.meshes.new("bench target")
    tn = native.get()
    read = median_time(lambda: mesh_io.read_mesh(mesh))
    report = median_time(lambda: tn.mesh_report(arrays.vertices, arrays.face_sizes, arrays.corners))
    offset = median_time(lambda: tn.offset_shell(arrays.vertices, arrays.face_sizes, arrays.corners, 0.01))
    write = median_time(lambda: mesh_io.write_mesh(target, arrays))
    faces = np.split(arrays.corners, np.cumsum(arrays.face_sizes)[:-1])
    vertex_list, face_list = arrays.vertices.tolist(), [f.tolist() for f in faces]

    def from_pydata():
        peer = bpy.data.meshes.new("peer")
        peer.from_pydata(vertex_list, [], face_list)
        bpy.data.meshes.remove(peer)

    pydata = median_time(from_pydata, runs=3)
    total = read + offset + write
    print(f"\nData exchange, {n} vertices / {len(mesh.polygons)} faces, median of {RUNS}")
    print(f"  Blender -> numpy (foreach_get)      {read * 1e3:8.2f} ms")
    print(f"  numpy -> Rust mesh_report -> dict   {report * 1e3:8.2f} ms")
    print(f"  numpy -> Rust offset_shell -> numpy {offset * 1e3:8.2f} ms")
    print(f"  numpy -> Blender (foreach_set)      {write * 1e3:8.2f} ms")
    print(f"  round trip with Offset Shell        {total * 1e3:8.2f} ms")
    print(f"  peer: Mesh.from_pydata (lists)      {pydata * 1e3:8.2f} ms  (our write / from_pydata = {write / pydata:.2f}x)")


if __name__ == "__main__":
    thicket.register()
    bench_fixtures()
    bench_exchange()
