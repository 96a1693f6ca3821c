"""`make bench`: issue 17's 20-node soft-CSG tree (implicit::samples::SOFT_CSG_20, read
from its Rust source) meshed at 256 cells along the longest side by
thicket_native.field_mesh (dual contouring on the interval-culled octree, its field
evaluation included) beside the peer the issue names: the dense grid of the same box
evaluated through thicket_native.field_eval and meshed by scikit-image's
marching_cubes. Runs in the bench venv (.venv-bench: numpy, scikit-image), not in
Blender. Prints each one's time, the ratio and the triangles, in two boxes: the
tree's own bound grown by two cells (field_mesh's default, the box of
implicit_mesh_bench, whose figures these match), and the surface's box grown by 5%
(about 1.7x finer cells on this tree, whose interval bound is loose: about 3x the
triangles and the time)."""

import argparse
import json
import pathlib
import re
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path[:0] = [str(ROOT / "build" / "site")]

import numpy as np  # noqa: E402
import skimage  # noqa: E402
from skimage.measure import marching_cubes  # noqa: E402

import thicket_native as tn  # noqa: E402


def soft_csg_20():
    """The tree as the Rust examples and tests have it (one source)."""
    source = (ROOT / "rust" / "core" / "src" / "implicit" / "samples.rs").read_text()
    text = re.search(r'SOFT_CSG_20: &str = r#"(.*?)"#;', source, re.S).group(1)
    json.loads(text)
    return text


def best(fn, runs):
    times, out = [], None
    for _ in range(runs):
        start = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - start)
    return min(times), out


def dense_values(tree, lo, step, shape):
    """The field at every lattice point (x fastest in memory as (nz, ny, nx)), one
    z-plane batch at a time through field_eval."""
    nx, ny, nz = shape
    ys, xs = np.meshgrid(np.arange(ny, dtype=np.float32), np.arange(nx, dtype=np.float32), indexing="ij")
    plane = np.stack([lo[0] + step[0] * xs.ravel(), lo[1] + step[1] * ys.ravel(), np.zeros(nx * ny, np.float32)], axis=1)
    out = np.empty((nz, ny, nx), np.float32)
    for k in range(nz):
        plane[:, 2] = lo[2] + step[2] * k
        out[k] = tn.field_eval(tree, plane)["values"].reshape(ny, nx)
    return out


def compare(tree, bounds, resolution, runs, label):
    """Ours and the peer on one box (None: field_mesh's default, the tree's own)."""
    ours_s, ours = best(lambda: tn.field_mesh(tree, bounds=bounds, resolution=resolution), runs)
    cells = np.array(ours["cells"])
    lo, hi = (np.array(corner, np.float32) for corner in ours["bounds"])
    step = ((hi - lo) / cells).astype(np.float32)
    start = time.perf_counter()
    grid = dense_values(tree, lo, step, cells + 1)
    eval_s = time.perf_counter() - start
    # Outside at the box's faces, as field_mesh cuts the solid by the box.
    for face in (grid[0], grid[-1], grid[:, 0], grid[:, -1], grid[:, :, 0], grid[:, :, -1]):
        np.maximum(face, 1e-3, out=face)
    start = time.perf_counter()
    verts, faces, _, _ = marching_cubes(grid, level=0.0, spacing=(float(step[2]), float(step[1]), float(step[0])))
    mc_s = time.perf_counter() - start
    peer_s = eval_s + mc_s
    ours_tris = int(np.sum(ours["face_sizes"] - 2))
    box = tuple(tuple(round(float(c), 3) for c in corner) for corner in (lo, hi))
    print(f"{label}: box {box}, cells {tuple(int(c) for c in cells)}")
    print(f"  thicket field_mesh (dual contouring, culled):  {ours_s * 1e3:8.1f} ms (best of {runs}), {ours_tris} triangles")
    print(
        f"  field_eval dense grid + skimage marching_cubes: {peer_s * 1e3:8.1f} ms (eval {eval_s * 1e3:.1f} ms of {grid.size} points, marching cubes {mc_s * 1e3:.1f} ms), {len(faces)} triangles"
    )
    print(
        f"  ratio: skimage's time {peer_s / ours_s:.2f}x ours; our triangles {ours_tris / len(faces):.2f}x marching cubes'; {len(verts)} vs {len(ours['vertices'])} vertices"
    )


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--resolution", type=int, default=256)
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    tree = soft_csg_20()
    print(f"field + mesh of the 20-node soft-CSG tree at {args.resolution} cells along the longest side (thicket_native, scikit-image {skimage.__version__}):")
    compare(tree, None, args.resolution, args.runs, "the tree's own bound (field_mesh's default; implicit_mesh_bench's box)")
    # The surface's box from a coarse mesh, grown by 5%.
    coarse = tn.field_mesh(tree, resolution=32)["vertices"]
    centre, half = (coarse.min(0) + coarse.max(0)) / 2, (coarse.max(0) - coarse.min(0)) / 2 * 1.05
    bounds = (tuple(map(float, centre - half)), tuple(map(float, centre + half)))
    compare(tree, bounds, args.resolution, args.runs, "the surface's box grown by 5%")


if __name__ == "__main__":
    main()
