"""Implicit field trees through thicket_native (issue 17's script interface):
field_eval against closed forms, field_mesh checked with Blender's own tools
(bmesh's manifold test, BVHTree.overlap for crossing triangles), colours carried,
and bad trees, points, bounds and resolutions refused with ThicketErrors."""

import json
import math
import pathlib
import re
import subprocess
import time

import bmesh
import bpy
import numpy as np
import pytest
from mathutils.bvhtree import BVHTree

import thicket_native as tn

RED, BLUE = [1.0, 0.0, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0]


def sphere(center, radius, color=None):
    node = {"op": "sphere", "center": list(center), "radius": radius}
    if color is not None:
        node["color"] = color
    return node


def tree(node):
    return json.dumps(node)


def blender_mesh(out, name="field"):
    """A Blender mesh made from field_mesh's dict with foreach_set (not through the
    add-on, so these checks are Blender's alone)."""
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(out["vertices"]))
    mesh.vertices.foreach_set("co", out["vertices"].ravel())
    mesh.loops.add(len(out["corners"]))
    mesh.loops.foreach_set("vertex_index", out["corners"])
    mesh.polygons.add(len(out["face_sizes"]))
    starts = np.zeros(len(out["face_sizes"]), np.int32)
    np.cumsum(out["face_sizes"][:-1], out=starts[1:])
    mesh.polygons.foreach_set("loop_start", starts)
    mesh.update(calc_edges=True)
    assert not mesh.validate(), "Blender had to fix the mesh"
    return mesh


def blender_defects(out):
    """Edges that bmesh calls non-manifold (boundary edges included), and triangle
    pairs that cross by BVHTree.overlap (pairs sharing a vertex dropped)."""
    mesh = blender_mesh(out)
    try:
        bm = bmesh.new()
        bm.from_mesh(mesh)
        not_manifold = sum(not e.is_manifold for e in bm.edges)
        boundary = sum(e.is_boundary for e in bm.edges)
        bvh = BVHTree.FromBMesh(bm)
        bm.free()
    finally:
        bpy.data.meshes.remove(mesh)
    # BVHTree.FromBMesh answers with face indices (a quad's two triangles are one face).
    tris = faces(out)
    pairs = np.array(bvh.overlap(bvh), dtype=np.int64).reshape(-1, 2)
    if len(pairs):
        shared = (tris[pairs[:, 0]][:, :, None] == tris[pairs[:, 1]][:, None, :]).any(axis=(1, 2))
        pairs = pairs[~shared & (pairs[:, 0] != pairs[:, 1])]
    return {"not manifold": not_manifold, "boundary": boundary, "crossing pairs": len(pairs)}


def faces(out):
    """The faces as rows: all triangles (adaptive=False) or all quads (adaptive=True)."""
    sizes = np.unique(out["face_sizes"])
    assert len(sizes) <= 1, sizes
    return out["corners"].reshape(-1, int(sizes[0]) if len(sizes) else 3)


def triangles(out):
    """Quads split along corners 0-2, as field_mesh says their better split is."""
    f = faces(out)
    return f if f.shape[1] == 3 else np.concatenate([f[:, [0, 1, 2]], f[:, [0, 2, 3]]])


def volume(out):
    p = out["vertices"].astype(np.float64)
    tris = triangles(out)
    a, b, c = (p[tris[:, k]] for k in range(3))
    return np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0


def test_field_eval_of_a_sphere_is_its_closed_form():
    center, radius = np.array([0.3, -0.2, 0.1]), 0.7
    rng = np.random.default_rng(1)
    points = rng.uniform(-2, 2, (500, 3)).astype(np.float32)
    out = tn.field_eval(tree(sphere(center, radius, RED)), points)
    offset = points.astype(np.float64) - center
    distance = np.linalg.norm(offset, axis=1)
    assert out["values"].dtype == np.float32 and out["values"].shape == (500,)
    assert out["gradients"].shape == (500, 3) and out["colors"].shape == (500, 4)
    np.testing.assert_allclose(out["values"], distance - radius, atol=2e-6)
    np.testing.assert_allclose(out["gradients"], offset / distance[:, None], atol=2e-6)
    np.testing.assert_array_equal(out["colors"], np.tile(np.float32(RED), (500, 1)))
    assert (out["texture"] == 0).all() and (out["primitive_id"] == 0).all()
    # No points: empty arrays of the same kinds.
    empty = tn.field_eval(tree(sphere(center, radius)), np.zeros((0, 3), np.float32))
    assert empty["values"].shape == (0,) and empty["gradients"].shape == (0, 3) and empty["colors"].shape == (0, 4)


def test_field_eval_blends_colours_by_the_soft_unions_weights():
    """union_wp's colour is the softmax of -p f over its children (Akleman-Chen 4.1)."""
    p = 4.0
    union = {"op": "union_wp", "p": p, "children": [sphere((-1, 0, 0), 0.5, RED), sphere((1, 0, 0), 0.5, BLUE)]}
    points = np.array([[-1.5, 0, 0], [0, 0, 0], [1.2, 0.3, 0]], np.float32)
    out = tn.field_eval(tree(union), points)
    for i, point in enumerate(points.astype(np.float64)):
        f = np.array([np.linalg.norm(point - [-1, 0, 0]) - 0.5, np.linalg.norm(point - [1, 0, 0]) - 0.5])
        w = np.exp(-p * (f - f.min()))
        w /= w.sum()
        np.testing.assert_allclose(out["colors"][i], w[0] * np.array(RED) + w[1] * np.array(BLUE), atol=1e-6)
        assert abs(out["values"][i] - -np.log(np.exp(-p * f).sum()) / p) < 1e-5
        assert out["primitive_id"][i] == int(np.argmin(f)) or abs(f[0] - f[1]) < 1e-9


@pytest.mark.parametrize("adaptive", [False, True])
def test_a_sphere_meshes_closed_and_manifold_by_blenders_checks_on_its_zero_set(scene, adaptive):
    center, radius, resolution = np.array([0.1, -0.05, 0.02]), 0.8, 40
    out = tn.field_mesh(tree(sphere(center, radius, RED)), resolution=resolution, adaptive=adaptive)
    assert out["vertices"].dtype == np.float32 and out["corners"].dtype == np.int32 and out["face_sizes"].dtype == np.int32
    # Triangles from the grid's marching prisms, quads from dual contouring.
    size = 4 if adaptive else 3
    assert (out["face_sizes"] == size).all() and len(out["corners"]) == size * len(out["face_sizes"]) > 1000
    assert max(out["cells"]) == resolution
    assert blender_defects(out) == {"not manifold": 0, "boundary": 0, "crossing pairs": 0}
    # Vertices on the zero set (grid: within a hundredth of a cell, refined on the
    # field; dual: within a tenth, where vertices far off are pulled onto it), facing
    # out, enclosing the ball's volume; normals are the radial directions.
    cell = (2 * radius) * (1 + 4 / resolution) / resolution
    offset = out["vertices"].astype(np.float64) - center
    distance = np.linalg.norm(offset, axis=1)
    assert np.abs(distance - radius).max() < (0.1 if adaptive else 0.01) * cell
    assert abs(volume(out) / (4 / 3 * math.pi * radius**3) - 1) < 0.01
    np.testing.assert_allclose(out["normals"], offset / distance[:, None], atol=1e-3)
    np.testing.assert_array_equal(out["colors"], np.tile(np.float32(RED), (len(out["vertices"]), 1)))
    assert out["texture"].shape == (len(out["vertices"]),)


@pytest.mark.parametrize("adaptive", [False, True])
def test_a_soft_union_carries_its_colours_and_ids_to_the_vertices(scene, adaptive):
    union = {"op": "union_wp", "p": 8, "children": [sphere((-0.5, 0, 0), 0.45, RED), sphere((0.5, 0, 0), 0.45, BLUE), sphere((0, 0.3, 0.4), 0.2)]}
    out = tn.field_mesh(tree(union), resolution=48, adaptive=adaptive)
    assert blender_defects(out) == {"not manifold": 0, "boundary": 0, "crossing pairs": 0}
    v, colors, ids = out["vertices"], out["colors"], out["primitive_id"]
    assert colors.shape == (len(v), 4) and ids.dtype == np.int32
    assert ((colors >= -1e-6) & (colors <= 1 + 1e-6)).all() and np.allclose(colors[:, 3], 1.0)
    # Far ends: each sphere's own colour and id; the blend between them at the waist.
    left, right = v[:, 0] < -0.8, v[:, 0] > 0.8
    assert left.any() and right.any()
    np.testing.assert_allclose(colors[left], np.tile(RED, (left.sum(), 1)), atol=0.01)
    np.testing.assert_allclose(colors[right], np.tile(BLUE, (right.sum(), 1)), atol=0.01)
    assert (ids[left] == 0).all() and (ids[right] == 1).all() and set(np.unique(ids)) <= {0, 1, 2}
    waist = (np.abs(v[:, 0]) < 0.03) & (v[:, 2] < 0)
    assert waist.any() and (colors[waist, 0] > 0.3).all() and (colors[waist, 2] > 0.3).all()
    # And what field_eval says there.
    np.testing.assert_allclose(tn.field_eval(tree(union), v)["colors"], colors, atol=1e-6)


def test_dual_contouring_keeps_the_corners_that_the_grid_cuts(scene):
    """A cut box (soft difference with a sphere) and an exact box: both meshers give
    closed manifolds without crossing triangles by Blender's checks, about the same
    volume; the dual mesh is quads and keeps the exact box's corners, which marching
    prisms on the grid cut off."""
    node = {
        "op": "difference_wp",
        "p": 12,
        "children": [
            {"op": "box", "center": [0, 0, 0], "half_size": [0.6, 0.4, 0.3], "radius": 0.05, "color": [0, 1, 0, 1]},
            sphere((0.4, 0.2, 0.3), 0.35, RED),
        ],
    }
    adaptive, grid = tn.field_mesh(tree(node), resolution=37), tn.field_mesh(tree(node), resolution=37, adaptive=False)
    assert (adaptive["face_sizes"] == 4).all() and (grid["face_sizes"] == 3).all()
    for out in (adaptive, grid):
        assert blender_defects(out) == {"not manifold": 0, "boundary": 0, "crossing pairs": 0}
    assert abs(volume(adaptive) / volume(grid) - 1) < 0.02
    center, half = np.array([0.013, -0.021, 0.017]), np.array([0.53, 0.41, 0.37])
    box = {"op": "box", "center": center.tolist(), "half_size": half.tolist()}
    corners = center + half * np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])

    def worst_corner(out):
        v = out["vertices"].astype(np.float64)
        return max(np.linalg.norm(v - c, axis=1).min() for c in corners)

    adaptive, grid = tn.field_mesh(tree(box), resolution=24), tn.field_mesh(tree(box), resolution=24, adaptive=False)
    assert blender_defects(adaptive) == {"not manifold": 0, "boundary": 0, "crossing pairs": 0}
    assert worst_corner(adaptive) < 0.1 * worst_corner(grid)
    assert abs(volume(adaptive) / np.prod(2 * half) - 1) < 1e-3


def test_unbounded_trees_need_bounds_and_the_box_closes_them(scene):
    plane = tree({"op": "plane", "point": [0, 0, 0.1], "normal": [0.2, 0.1, 1]})
    with pytest.raises(tn.InvalidInput, match="unbounded.*bounds"):
        tn.field_mesh(plane)
    out = tn.field_mesh(plane, bounds=((-1, -1, -1), (1, 1, 1)), resolution=20, adaptive=False)
    assert tuple(out["cells"]) == (20, 20, 20)
    assert blender_defects(out) == {"not manifold": 0, "boundary": 0, "crossing pairs": 0}
    # The part of the cube below the plane z = 0.1 - 0.2 x - 0.1 y: 4 * 1.1, less the
    # chamfers along its edges (marching prisms cut a sharp edge across its cells:
    # at most half a cell's square per unit of length, about 20 units of edges).
    cell = 2 / 20
    assert 0 < 4 * 1.1 - volume(out) < 0.5 * cell**2 * 20
    # Bounds as lists or an array work alike; a box that is not one is refused.
    again = tn.field_mesh(plane, bounds=np.array([[-1, -1, -1], [1, 1, 1]], np.float32), resolution=20, adaptive=False)
    np.testing.assert_array_equal(again["vertices"], out["vertices"])
    # Dual contouring keeps the box's edges where it cuts the solid: the volume exact
    # up to rounding.
    dual = tn.field_mesh(plane, bounds=((-1, -1, -1), (1, 1, 1)), resolution=20)
    assert blender_defects(dual) == {"not manifold": 0, "boundary": 0, "crossing pairs": 0}
    assert abs(volume(dual) - 4 * 1.1) < 1e-3
    for bad in [((0, 0, 0),), "box", ((0, 0), (1, 1)), ((1, 1, 1), (0, 0, 0)), ((0, 0, 0), (1, float("nan"), 1))]:
        with pytest.raises(tn.InvalidInput):
            tn.field_mesh(plane, bounds=bad, resolution=8)


BAD_TREES = [
    ("{", "not valid JSON"),
    ("[]", "must be a JSON object"),
    ('{"op": "blob"}', 'unknown op "blob"'),
    (json.dumps({"op": "sphere", "center": [float("nan"), 0, 0], "radius": 1}), "not valid JSON"),
    (json.dumps({"op": "sphere", "center": [0, 0, 0], "radius": float("inf")}), "not valid JSON"),
    ('{"op": "sphere", "center": [0, 0, 0], "radius": 1e999}', "not valid JSON"),
    (tree({"op": "union_wp", "p": 0, "children": [sphere((0, 0, 0), 1)]}), "p must be between"),
    (tree({"op": "intersection_wp", "p": -3, "children": [sphere((0, 0, 0), 1)]}), "p must be between"),
    (tree({"op": "min", "children": []}), "at least one child"),
    (tree({"op": "sphere", "center": [0, 0, 0], "radius": -1}), "radius must be a finite number >= 0"),
]


@pytest.mark.parametrize("text, message", BAD_TREES)
def test_bad_trees_raise_thicket_errors_with_the_cores_message(text, message):
    points = np.zeros((4, 3), np.float32)
    for call in (lambda: tn.field_eval(text, points), lambda: tn.field_mesh(text, resolution=8)):
        with pytest.raises(tn.InvalidInput, match=message) as raised:
            call()
        assert isinstance(raised.value, tn.ThicketError) and isinstance(raised.value, ValueError)
    # And the module still works.
    assert tn.field_eval(tree(sphere((0, 0, 0), 1)), points)["values"][0] == -1.0


@pytest.mark.parametrize(
    "points, message",
    [
        (np.zeros((4, 2), np.float32), "shape"),
        (np.zeros((4, 3), np.float64), "float32"),
        (np.zeros((4, 6), np.float32)[:, ::2], "contiguous"),
        (np.array([[0, 0, 0], [1, np.nan, 0]], np.float32), "point 1 has a non-finite"),
        (np.array([[np.inf, 0, 0]], np.float32), "point 0 has a non-finite"),
    ],
)
def test_bad_points_are_refused(points, message):
    with pytest.raises(tn.InvalidInput, match=message):
        tn.field_eval(tree(sphere((0, 0, 0), 1)), points)


@pytest.mark.parametrize("resolution", [10**5, 2**40, 2049])
def test_resolutions_that_would_not_fit_in_memory_are_refused_at_once(resolution):
    start = time.perf_counter()
    with pytest.raises(tn.InvalidInput, match=r"too fine.*GB.*at most 2048"):
        tn.field_mesh(tree(sphere((0, 0, 0), 1)), resolution=resolution)
    assert time.perf_counter() - start < 1.0


@pytest.mark.parametrize("resolution", [1, 0, -5])
def test_resolutions_below_two_are_refused(resolution):
    with pytest.raises(tn.InvalidInput, match="at least 2"):
        tn.field_mesh(tree(sphere((0, 0, 0), 1)), resolution=resolution)


ROOT = pathlib.Path(__file__).resolve().parent.parent


def test_field_mesh_is_the_cores_mesh_bit_for_bit_and_meshes_the_box_it_returns():
    """field_mesh through the binding against thicket_core's mesh_dual on the same tree,
    box and resolution (implicit_mesh_bench --dual-only: issue 17's 20-node tree in
    its own bound grown by two cells): the same triangles and the same FNV-1a hash
    over positions, normals, attributes and quads, so the Python call meshes what the
    benchmark times and no more. Then the returned bounds, given back, mesh the same."""
    source = (ROOT / "rust" / "core" / "src" / "implicit" / "samples.rs").read_text()
    text = re.search(r'SOFT_CSG_20: &str = r#"(.*?)"#;', source, re.S).group(1)
    args = ["cargo", "run", "--release", "-q", "-p", "thicket-core", "--example", "implicit_mesh_bench", "--"]
    done = subprocess.run(args + ["--dual-only", "--runs", "1", "--resolutions", "48"], capture_output=True, text=True, timeout=1800, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    line = done.stdout.strip().splitlines()[-1]
    core_triangles = int(re.search(r"(\d+) triangles", line).group(1))
    core_hash = int(re.search(r"mesh hash ([0-9a-f]{16})", line).group(1), 16)

    out = tn.field_mesh(text, resolution=48)
    assert set(out["face_sizes"].tolist()) == {4}
    assert 2 * len(out["face_sizes"]) == core_triangles
    attributes = np.concatenate([out["colors"], out["texture"][:, None], out["primitive_id"][:, None].astype(np.float32)], axis=1)
    words = np.concatenate(
        [
            np.ascontiguousarray(out["vertices"], np.float32).view(np.uint32).ravel(),
            np.ascontiguousarray(out["normals"], np.float32).view(np.uint32).ravel(),
            np.ascontiguousarray(attributes, np.float32).view(np.uint32).ravel(),
            out["corners"].astype(np.uint32),
        ]
    )
    h = 0xCBF29CE484222325
    for w in words.tolist():
        h = ((h ^ w) * 0x100000001B3) & 0xFFFFFFFFFFFFFFFF
    assert h == core_hash

    lo, hi = out["bounds"]
    assert all(a < b for a, b in zip(lo, hi))
    again = tn.field_mesh(text, bounds=out["bounds"], resolution=48)
    assert again["bounds"] == out["bounds"]
    np.testing.assert_array_equal(again["vertices"], out["vertices"])
    np.testing.assert_array_equal(again["corners"], out["corners"])
