"""Multiresolution analysis and synthesis (issue 18; Velho, Perlin, Ying and Biermann,
section 2): `thicket_native.analyze` / `synthesize_multires` and the `sculpt=` argument
of `procedural_detail`, then an artist's Multires sculpt read from Blender
(`thicket.api.analyze_multires`), rebuilt and compared with Blender's own evaluated
Multires mesh vertex for vertex through the matched numbering.

The sculpt is made headless as an artist's would be: a Multires modifier subdivided with
`object.multires_subdivide`, then its finest level set from a displaced copy of its own
evaluated mesh with `object.multires_reshape` (Blender's "Reshape" button).
"""

import bpy
import numpy as np
import pytest
from conftest import add

import thicket_native as tn
from thicket import api, mesh_io


def diagonal(p):
    return float(np.linalg.norm(p.max(axis=0) - p.min(axis=0)))


def evaluated_positions(obj):
    depsgraph = bpy.context.evaluated_depsgraph_get()
    return mesh_io.read_evaluated(obj, depsgraph).vertices


def evaluated(obj):
    return mesh_io.read_evaluated(obj, bpy.context.evaluated_depsgraph_get())


def reshape_to(obj, modifier, target, topology):
    """Sets the finest level of `obj`'s Multires `modifier` to the positions `target` on
    `topology` (the mesh arrays of its finest level) with `object.multires_reshape`
    (Blender's "Reshape" from a second object of the same topology)."""
    mesh = bpy.data.meshes.new("target")
    mesh.vertices.add(len(target))
    mesh.vertices.foreach_set("co", target.astype(np.float32).ravel())
    mesh.loops.add(len(topology.corners))
    mesh.loops.foreach_set("vertex_index", topology.corners)
    mesh.polygons.add(len(topology.face_sizes))
    mesh.polygons.foreach_set("loop_start", np.concatenate([[0], np.cumsum(topology.face_sizes)[:-1]]).astype(np.int32))
    mesh.polygons.foreach_set("loop_total", topology.face_sizes)
    mesh.update()
    other = bpy.data.objects.new("target", mesh)
    bpy.context.scene.collection.objects.link(other)
    chosen = [obj, other]
    with bpy.context.temp_override(object=obj, active_object=obj, selected_objects=chosen, selected_editable_objects=chosen):
        assert bpy.ops.object.multires_reshape(modifier=modifier.name) == {"FINISHED"}
    bpy.data.objects.remove(other)


def sculpted(obj, levels, offset):
    """`obj` with a Multires modifier of `levels` levels whose finest level is its own
    evaluated mesh moved by `offset(positions)` ((n, 3) per vertex)."""
    modifier = obj.modifiers.new("Multires", "MULTIRES")
    with bpy.context.temp_override(object=obj, active_object=obj):
        for _ in range(levels):
            assert bpy.ops.object.multires_subdivide(modifier=modifier.name, mode="CATMULL_CLARK") == {"FINISHED"}
    plain = evaluated(obj)
    target = plain.vertices + offset(plain.vertices)
    reshape_to(obj, modifier, target, plain)
    out = evaluated_positions(obj)
    assert np.abs(out - target).max() < 1e-5 * diagonal(target), "the reshape took"
    return out


def quads(corners):
    """The quads as sorted tuples starting at their least vertex (same winding)."""
    q = np.asarray(corners).reshape(-1, 4)
    k = np.argmin(q, axis=1)
    rolled = np.stack([q[np.arange(len(q)), (k + i) % 4] for i in range(4)], axis=1)
    return rolled[np.lexsort(rolled.T[::-1])]


def plain_fine(base, levels):
    """Fine positions in Thicket's numbering: a flat procedural detail is plain subdivision."""
    return tn.procedural_detail(*base, "rock", levels, params={"amplitude": 0.0})


def cube_arrays():
    v = np.array([[x, y, z] for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)], np.float32)
    faces = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [1, 3, 7, 5], [3, 2, 6, 7], [2, 0, 4, 6]]
    return v, np.full(6, 4, np.int32), np.array(faces, np.int32).ravel()


def test_native_analysis_then_synthesis_reproduces_the_fine_mesh():
    base = cube_arrays()
    for levels in (1, 2, 3):
        rocky = tn.procedural_detail(*base, "rock", levels, seed=3, params={"amplitude": 0.05})
        fine = rocky["vertices"]
        m = tn.analyze(*base, fine, levels)
        assert [len(d) for d in m["details"]] == [len(plain_fine(base, k)["vertices"]) for k in range(1, levels + 1)]
        assert all(d.dtype == np.float64 and d.shape[1] == 3 for d in m["details"])
        back = tn.synthesize_multires(m["vertices"], m["face_sizes"], m["corners"], m["details"])
        np.testing.assert_array_equal(back["corners"], rocky["corners"])
        assert np.abs(back["vertices"] - fine).max() < 1e-5 * diagonal(fine)
        # The same through procedural_detail's sculpt under a flat model.
        flat = tn.procedural_detail(m["vertices"], m["face_sizes"], m["corners"], "rock", levels, params={"amplitude": 0.0}, sculpt=m)
        assert np.abs(flat["vertices"] - fine).max() < 1e-5 * diagonal(fine)
    # A plain subdivision has no details and gives its base back.
    m = tn.analyze(*base, plain_fine(base, 3)["vertices"], 3)
    assert max(np.abs(d).max() for d in m["details"]) < 1e-6 * diagonal(base[0])
    assert np.abs(m["vertices"] - base[0]).max() < 1e-6 * diagonal(base[0])


def test_native_refuses_bad_input():
    base = cube_arrays()
    fine = plain_fine(base, 2)["vertices"]
    bad = [
        lambda: tn.analyze(*base, fine[:-1], 2),  # a count that is no subdivision
        lambda: tn.analyze(*base, fine, 3),  # levels that do not fit
        lambda: tn.analyze(*base, fine, 0),
        lambda: tn.analyze(*base, np.where(np.arange(len(fine))[:, None] == 5, np.nan, fine).astype(np.float32), 2),
        lambda: tn.synthesize_multires(*base, [np.zeros((25, 3))]),  # 26 vertices at level 1
        lambda: tn.synthesize_multires(*base, [np.full((26, 3), np.nan)]),
        lambda: tn.synthesize_multires(*base, [np.zeros((26, 2))]),
        lambda: tn.synthesize_multires(*base, "details"),
        lambda: tn.procedural_detail(*base, "rock", 1, sculpt={"vertices": base[0]}),
        lambda: tn.procedural_detail(*base, "rock", 1, sculpt=tn.analyze(*base, fine, 2)),  # more levels than made
        lambda: tn.match_subdivision(*base, 2, fine[:-1]),
    ]
    for call in bad:
        with pytest.raises(tn.InvalidInput):
            call()


def test_native_checks_the_fine_faces_when_given():
    base = cube_arrays()
    rocky = tn.procedural_detail(*base, "rock", 2, seed=5, params={"amplitude": 0.05})
    fine, sizes, corners = rocky["vertices"], rocky["face_sizes"], rocky["corners"]
    # Thicket's own faces pass, with or without their sizes, and change nothing.
    want = tn.analyze(*base, fine, 2)
    for m in (tn.analyze(*base, fine, 2, fine_corners=corners), tn.analyze(*base, fine, 2, fine_face_sizes=sizes, fine_corners=corners)):
        np.testing.assert_array_equal(m["vertices"], want["vertices"])
        assert all(np.array_equal(a, b) for a, b in zip(m["details"], want["details"]))
    # The same quads in another order, each from another first corner (as Blender's
    # renumbered sculpt has them), pass and change nothing.
    shuffled = np.roll(corners.reshape(-1, 4), 1, axis=1)[::-1].ravel()
    m = tn.analyze(*base, fine, 2, fine_corners=shuffled)
    np.testing.assert_array_equal(m["vertices"], want["vertices"])
    # Another numbering of the vertices (two swapped in the faces) is refused and named;
    # so are faces that are not quads, and sizes without corners.
    a, b = corners[0], corners[1]
    renumbered = np.where(corners == a, b, np.where(corners == b, a, corners)).astype(np.int32)
    with pytest.raises(tn.InvalidInput, match="is none of theirs .*numbered otherwise"):
        tn.analyze(*base, fine, 2, fine_corners=renumbered)
    triangles = np.concatenate([corners[:-4], corners[-4:-1], corners[-4:][[0, 2, 3]]])
    with pytest.raises(tn.InvalidInput, match="has 3 corners"):
        tn.analyze(*base, fine, 2, fine_face_sizes=np.r_[sizes[:-1], 3, 3], fine_corners=triangles)
    with pytest.raises(tn.InvalidInput, match="without fine_corners"):
        tn.analyze(*base, fine, 2, fine_face_sizes=sizes)
    with pytest.raises(tn.InvalidInput):
        tn.analyze(*base, fine, 2, fine_corners=corners[:-1])


def test_a_blender_subdivision_with_its_own_numbering_is_refused_when_its_faces_are_given(scene):
    # Blender's Subdivision Surface (no limit) has Thicket's vertex count and positions up
    # to numbering: its positions alone pass as a fine mesh (and analyse to noise), its
    # faces show it is not in Thicket's numbering.
    obj = add("cube", size=2)
    base = mesh_io.read_mesh(obj.data)
    base = (base.vertices, base.face_sizes, base.corners)
    modifier = obj.modifiers.new("Subdivision", "SUBSURF")
    modifier.levels, modifier.use_limit_surface = 2, False
    blender = evaluated(obj)
    ours = plain_fine(base, 2)
    assert len(blender.vertices) == len(ours["vertices"]) and not np.array_equal(blender.corners, ours["corners"])
    by_position = [p[np.lexsort(np.round(p, 4).T)] for p in (blender.vertices, ours["vertices"])]
    assert np.abs(by_position[0] - by_position[1]).max() < 1e-5, "the same points"
    m = tn.analyze(*base, blender.vertices, 2)
    assert max(np.abs(d).max() for d in m["details"]) > 0.01 * diagonal(base[0]), "Blender's numbering analyses to noise"
    with pytest.raises(tn.InvalidInput, match="numbered otherwise"):
        tn.analyze(*base, blender.vertices, 2, fine_face_sizes=blender.face_sizes, fine_corners=blender.corners)
    # Thicket's numbering of the same surface passes and has no details.
    m = tn.analyze(*base, ours["vertices"], 2, fine_face_sizes=ours["face_sizes"], fine_corners=ours["corners"])
    assert max(np.abs(d).max() for d in m["details"]) < 1e-6 * diagonal(base[0])


def test_an_analysis_past_its_memory_budget_is_refused_before_it_starts():
    # A 60 x 50 grid at 6 levels: 12.3 M fine faces. Plain subdivision's budget (200 bytes
    # a face, 2.5 GB) fits the 4 GB default; the analysis' (about 900 a face, 11 GB) does
    # not, and is refused before the fine mesh is even checked.
    n, m = 60, 50
    x, y = np.meshgrid(np.arange(n + 1), np.arange(m + 1), indexing="ij")
    v = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=1).astype(np.float32)
    i, j = np.meshgrid(np.arange(n), np.arange(m), indexing="ij")
    a = (i * (m + 1) + j).ravel()
    corners = np.stack([a, a + m + 1, a + m + 2, a + 1], axis=1).ravel().astype(np.int32)
    sizes = np.full(n * m, 4, np.int32)
    with pytest.raises(tn.OverLimit, match="the analysis of 6 subdivision levels .* 12288000 faces"):
        tn.analyze(v, sizes, corners, v, 6)
    # Plain subdivision to those levels passes its own check (refused only after it,
    # for the count of levels in the fine mesh).
    with pytest.raises(tn.InvalidInput, match="level 1 has 1 details"):
        tn.synthesize_multires(v, sizes, corners, [np.zeros((1, 3))] * 6)


PRIMITIVES = {
    "cube": dict(size=2),
    "grid": dict(x_subdivisions=4, y_subdivisions=3, size=2),
    # Triangle fans at the poles; 10-gon caps.
    "uv_sphere": dict(segments=12, ring_count=6, radius=1),
    "cylinder": dict(vertices=10, radius=1, depth=2),
}


@pytest.mark.parametrize("primitive, levels", [("cube", 2), ("cube", 3), ("grid", 2), ("uv_sphere", 2), ("cylinder", 2)])
def test_a_multires_sculpt_is_analysed_and_rebuilt(scene, primitive, levels):
    obj = add(primitive, **PRIMITIVES[primitive])

    def offset(p):
        bump = 0.05 * np.sin(9.0 * p[:, 0]) * np.cos(7.0 * p[:, 1]) + 0.03 * np.sin(11.0 * p[:, 2] + p[:, 0])
        # Up on the grid, along the position elsewhere.
        return np.outer(bump, [0.0, 0.0, 1.0]) if primitive == "grid" else p * bump[:, None]

    sculpt = sculpted(obj, levels, offset)
    blender = evaluated(obj)
    base_before = mesh_io.read_mesh(obj.data).vertices.copy()
    m = api.analyze_multires(obj)
    assert m["levels"] == levels
    order = m["order"]
    # The matching is a permutation that carries Blender's faces onto Thicket's.
    assert sorted(order.tolist()) == list(range(len(sculpt)))
    rebuilt = tn.synthesize_multires(m["vertices"], m["face_sizes"], m["corners"], m["details"])
    inverse = np.empty_like(order)
    inverse[order] = np.arange(len(order), dtype=order.dtype)
    np.testing.assert_array_equal(quads(inverse[blender.corners]), quads(rebuilt["corners"]))
    # Vertex for vertex, the rebuilt sculpt is Blender's Multires mesh.
    error = np.linalg.norm(rebuilt["vertices"] - sculpt[order], axis=1).max() / diagonal(sculpt)
    assert error < 1e-5, error
    # The sculpt is real detail: it is far from the plain subdivision of the analysed base.
    plain = tn.synthesize_multires(m["vertices"], m["face_sizes"], m["corners"], [np.zeros_like(d) for d in m["details"]])
    assert np.linalg.norm(plain["vertices"] - sculpt[order], axis=1).max() > 0.01 * diagonal(sculpt)
    # The object is as it was: same modifiers, same base, same sculpt.
    assert [md.type for md in obj.modifiers] == ["MULTIRES"] and obj.modifiers[0].total_levels == levels
    np.testing.assert_array_equal(mesh_io.read_mesh(obj.data).vertices, base_before)
    np.testing.assert_array_equal(evaluated_positions(obj), sculpt)
    assert not any(o.name.startswith(".thicket") for o in bpy.data.objects)


def test_procedural_detail_rides_on_a_sculpt(scene):
    obj = add("cube", size=2)
    sculpt = sculpted(obj, 3, lambda p: p * (0.1 * np.sin(6.0 * p[:, 0]) * np.sin(6.0 * p[:, 1]) * np.sin(6.0 * p[:, 2]))[:, None])
    m = api.analyze_multires(obj)
    base = (m["vertices"], m["face_sizes"], m["corners"])
    # A rock at level 1 under the sculpt: the surface moves, the sculpt's offset from the
    # surface it rides on keeps its size.
    rock = tn.procedural_detail(*base, "rock", 3, seed=2, params={"amplitude": 0.05}, at=[1])
    both = tn.procedural_detail(*base, "rock", 3, seed=2, params={"amplitude": 0.05}, at=[1], sculpt=m)
    plain = tn.synthesize_multires(*base, [np.zeros_like(d) for d in m["details"]])["vertices"]
    ours = sculpt[m["order"]]
    assert np.linalg.norm(rock["vertices"] - plain, axis=1).max() > 0.02 * diagonal(ours), "the rock moves the surface"
    feature = np.linalg.norm(ours - plain, axis=1)
    carried = np.linalg.norm(both["vertices"] - rock["vertices"], axis=1)
    assert feature.max() > 0.01 * diagonal(ours)
    assert np.sqrt(np.mean((carried - feature) ** 2)) < 0.2 * np.sqrt(np.mean(feature**2))


def test_an_object_without_a_sculpt_is_refused(scene):
    obj = add("cube", size=2)
    with pytest.raises(ValueError, match="no Multires"):
        api.analyze_multires(obj)
    obj.modifiers.new("Multires", "MULTIRES")
    with pytest.raises(ValueError, match="no levels"):
        api.analyze_multires(obj)
