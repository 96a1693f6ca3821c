"""Faces of five or more corners: Blender splits a non-planar n-gon its own way (its
polygon fill), and a shell checked over another split can fold or cross the base
under Blender's. The project splits n-gons as Blender does and writes its results'
n-gons as those triangles, so what Blender draws, renders and tests with
`BVHTree.overlap` is what the shell's final check passed. Blender's own
`loop_triangles` is the reference here."""

import bpy
import numpy as np
import pytest
from blender_checks import blender_check, loop_triangles, written_skins
from conftest import DATA

import thicket_native as tn
from thicket import mesh_io


def random_ngons(seed, count=300):
    """`count` separate n-gons (5 to 40 corners) in random planes, star-shaped and
    concave, their corners lifted off the plane by up to 15% of their radius."""
    rng = np.random.default_rng(seed)
    vertices, faces = [], []
    for _ in range(count):
        n = int(rng.integers(5, 41))
        angle = np.sort(rng.uniform(0, 2 * np.pi, n))
        radius = rng.uniform(0.3, 1.0, n)
        local = np.stack([radius * np.cos(angle), radius * np.sin(angle), rng.uniform(-0.15, 0.15, n)], axis=1)
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        start = len(vertices)
        vertices.extend(local @ q.T * rng.uniform(0.5, 2.0) + rng.uniform(-10, 10, 3))
        faces.append(list(range(start, start + n)))
    mesh = bpy.data.meshes.new("ngons")
    mesh.from_pydata(np.array(vertices, np.float32).tolist(), [], faces)
    mesh.update()
    return mesh


def triangle_sets(tris, faces_of):
    """Per face, the set of its triangles (each a sorted vertex triple)."""
    out = {}
    for t, f in zip(np.sort(tris, axis=1), faces_of):
        out.setdefault(int(f), set()).add(tuple(int(x) for x in t))
    return out


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_n_gons_are_split_as_blender_splits_them(scene, seed):
    mesh = random_ngons(seed)
    a = mesh_io.read_mesh(mesh)
    mesh.calc_loop_triangles()
    polygon = np.empty(len(mesh.loop_triangles), np.int32)
    mesh.loop_triangles.foreach_get("polygon_index", polygon)
    blender = triangle_sets(loop_triangles(mesh), polygon)
    # The offset shell writes each n-gon as the project's triangles (`source_face`
    # tells whose), over its own vertices (`source_vertex`).
    out = tn.offset_shell(a.vertices, a.face_sizes, a.corners, 0.01, output="outer")
    assert out["face_sizes"].max() == 3
    corners = out["source_vertex"][out["corners"]].reshape(-1, 3)
    ours = triangle_sets(corners, out["source_face"])
    assert len(ours) == len(blender) == len(a.face_sizes)
    differ = [f for f in blender if blender[f] != ours[f]]
    assert differ == [], f"{len(differ)} of {len(blender)} n-gons split otherwise than Blender's, e.g. face {differ[:1]}"


def test_shells_over_non_planar_n_gons_pass_blenders_checks(scene):
    """The twisted star prism (two concave non-planar 40-gon caps, thin arms) with
    every shell side: the skins as written, the base as Blender draws it."""
    bpy.ops.wm.obj_import(filepath=str(DATA / "hard" / "star_prism.obj"))
    obj = bpy.context.selected_objects[0]
    a = mesh_io.read_mesh(obj.data)
    assert a.face_sizes.max() == 40
    tris = loop_triangles(obj.data)
    for side, fraction in (("exterior", 0.1), ("interior", 0.05), ("envelope", 0.1)):
        out = tn.shell(a.vertices, a.face_sizes, a.corners, fraction, side=side, relative=True, output="solid")
        assert out["face_sizes"].max() <= 4
        skins = written_skins(out, side)
        written = skins[0]
        # Blender draws the skin's caps with the base caps' own triangles.
        on_cap = np.zeros(len(a.vertices), bool)
        on_cap[a.corners[np.repeat(a.face_sizes, a.face_sizes) > 4]] = True
        caps = {tuple(t) for t in np.sort(tris[on_cap[tris].all(axis=1)], axis=1)}
        assert len(caps) == 2 * 38
        assert {tuple(t) for t in np.sort(written[on_cap[written].all(axis=1)], axis=1)} == caps, side
        found = blender_check(a.vertices, out, side, tris, skins)
        assert (found["self"], found["base"], found["inverted"], found["folding"]) == (0, 0, 0, 0), (side, found)
        assert out["check"]["clean"], side
