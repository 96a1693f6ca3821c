"""`make bench`: Catmull-Clark subdivision (`thicket_native.subdivide`, issue 18) vs
Blender's Subdivision Surface modifier (evaluated depsgraph, same bpy run), levels 3 and 4
on a 30k-quad torus and a 20k-triangle icosphere, Use Limit Surface on (the modifier's default; `subdivide` takes limit=True).

Then the procedural rock (`thicket_native.procedural_detail`) at level 4 on the torus
beside plain subdivision to level 4: time and peak memory.

Prints figures measured in this run only, side by side, as ratios (median of N runs).
Thicket's figure is the native call on numpy arrays; Blender's is the modifier's
evaluation plus `to_mesh` (its result as a Mesh).
"""

import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path[:0] = [str(ROOT / "addon"), str(ROOT / "build" / "site"), str(ROOT / "tests" / "bench")]

import bpy  # noqa: E402
import numpy as np  # noqa: E402
from bench_offset import median_time  # noqa: E402

import thicket_native as tn  # noqa: E402
from thicket import mesh_io  # noqa: E402


def modifier_time(obj, levels, runs):
    modifier = obj.modifiers.new("bench subsurf", "SUBSURF")
    modifier.levels = levels
    depsgraph = bpy.context.evaluated_depsgraph_get()

    def run():
        obj.data.update()  # tags the mesh: the modifier runs again
        depsgraph.update()
        evaluated = obj.evaluated_get(depsgraph)
        evaluated.to_mesh()
        evaluated.to_mesh_clear()

    t = median_time(run, runs)
    obj.modifiers.remove(modifier)
    return t


def main():
    print("\nCatmull-Clark subdivision (limit surface on) vs Blender's Subdivision Surface modifier")
    print(f"{'mesh':10s} {'faces':>7s} {'level':>5s} {'out faces':>10s} {'thicket ms':>11s} {'blender ms':>11s} {'ratio':>7s}")
    meshes = {
        "torus": lambda: bpy.ops.mesh.primitive_torus_add(major_segments=200, minor_segments=150),
        "icosphere": lambda: bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=6),
    }
    for name, make in meshes.items():
        bpy.ops.wm.read_factory_settings(use_empty=True)
        make()
        obj = bpy.context.active_object
        base = mesh_io.read_mesh(obj.data)
        arrays = (base.vertices, base.face_sizes, base.corners)
        for levels, runs in ((3, 5), (4, 3)):
            out = tn.subdivide(*arrays, levels, limit=True)
            ours = median_time(lambda levels=levels, arrays=arrays: tn.subdivide(*arrays, levels, limit=True), runs)
            theirs = modifier_time(obj, levels, runs)
            faces = len(base.face_sizes)
            print(f"{name:10s} {faces:7d} {levels:5d} {len(out['face_sizes']):10d} {ours * 1e3:11.1f} {theirs * 1e3:11.1f} {ours / theirs:6.2f}x")
            del out
        far_perf_beside(name, base, arrays)
    rock_synthesis()


def far_perf_times(path, levels):
    """OpenSubdiv's `far_perf` on an OBJ file: {level: (refine s, total s)} for levels 1
    to `levels`, or None where it is not installed (`make bench` installs Debian's
    opensubdiv-tools when it can)."""
    import re
    import shutil
    import subprocess

    tool = shutil.which("far_perf")
    if tool is None:
        return None
    try:
        text = subprocess.run([tool, "-l", str(levels), str(path)], capture_output=True, text=True, timeout=300).stdout
    except (OSError, subprocess.SubprocessError) as error:
        print(f"far_perf did not run: {error}")
        return None
    out, level = {}, None
    for line in text.splitlines():
        if m := re.match(r"\s*level (\d+):", line):
            level = int(m.group(1))
        elif level and (m := re.match(r"\s*(TopologyRefiner::Refine|Total)\s+([0-9.]+)", line)):
            refine, total = out.get(level, (None, None))
            out[level] = (float(m.group(2)), total) if m.group(1) != "Total" else (refine, float(m.group(2)))
    return out


def far_perf_beside(name, base, arrays):
    """`far_perf` (OpenSubdiv's own timing tool) on the same mesh beside `subdivide`: it
    refines feature-adaptively (only around extraordinary vertices, down to the level)
    and builds the patch and stencil tables a renderer evaluates, where `subdivide`
    refines uniformly and computes every vertex; so its Refine line is topology alone
    and its Total a different product. Printed as measured, in this run."""
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        path = pathlib.Path(folder) / f"{name}.obj"
        lines = [f"v {x:.7g} {y:.7g} {z:.7g}" for x, y, z in base.vertices]
        starts = np.concatenate([[0], np.cumsum(base.face_sizes)[:-1]])
        lines += ["f " + " ".join(str(i + 1) for i in base.corners[s : s + n]) for s, n in zip(starts, base.face_sizes)]
        path.write_text("\n".join(lines) + "\n")
        times = far_perf_times(path, 4)
    if times is None:
        print(f"{'':10s} far_perf (OpenSubdiv) not installed: no peer figure")
        return
    for levels in (3, 4):
        refine, total = (float("nan") if t is None else t for t in times.get(levels, (None, None)))
        ours = median_time(lambda levels=levels: tn.subdivide(*arrays, levels, limit=True), 3)
        print(
            f"{'':10s} far_perf level {levels}: refine {refine * 1e3:8.1f} ms, total (adaptive patches + stencils) {total * 1e3:8.1f} ms;"
            f" subdivide {ours * 1e3:8.1f} ms ({ours / total:5.2f}x its total)"
        )


def _status_kb(field):
    """A memory figure of this process from /proc/self/status, in kB (Linux)."""
    with open("/proc/self/status") as status:
        return next(int(line.split()[1]) for line in status if line.startswith(field + ":"))


def peak_growth(call):
    """`call()`'s result and how far the resident memory rose above where it started
    while it ran, in bytes (the peak is reset first: /proc/self/clear_refs, Linux)."""
    with open("/proc/self/clear_refs", "w") as refs:
        refs.write("5")
    start = _status_kb("VmRSS")
    out = call()
    return out, (_status_kb("VmHWM") - start) * 1024


def rock_synthesis():
    """Issue 18's rock at level 4 on the 30k-quad torus (7.7 M faces): time and peak
    memory of `procedural_detail` beside plain subdivision to the same level (limit
    off), in this run."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_torus_add(major_segments=200, minor_segments=150)
    base = mesh_io.read_mesh(bpy.context.active_object.data)
    arrays = (base.vertices, base.face_sizes, base.corners)
    print("\nProcedural detail (rock) at level 4 vs plain subdivision to level 4, the same torus (issue 18's target: rock under 2 s)")
    for label, call in (("subdivide", lambda: tn.subdivide(*arrays, 4)), ("rock", lambda: tn.procedural_detail(*arrays, "rock", 4))):
        seconds = median_time(call, 1)
        out, grown = peak_growth(call)
        faces = len(out["face_sizes"])
        print(f"  {label:10s} {faces:9d} faces {seconds:6.2f} s, peak memory {grown / 1e6:5.0f} MB above the start ({grown / faces:4.0f} bytes per face)")
        del out


if __name__ == "__main__":
    main()
