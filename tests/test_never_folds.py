"""Shells that never fold (thick surfaces, chapter 4's promise, made a guarantee).

Every shell here is checked with Blender's own tools, independently of the project's
checker: `BVHTree.overlap` for skin/skin and skin/base crossings on Blender's own
triangulation of the result as written and of meshes read by Blender's OBJ importer, and numpy orientation tests
of every cell's tetrahedra and of the map a texture is drawn through (its Jacobian). Meshes: generated hard shapes (tests/data/hard: thin
parts, narrow gaps, sharp creases), the scanned bunny and Suzanne (whose eyes cross
its head: a base with intersections of its own).
"""

import bpy
import numpy as np
import pytest
from blender_checks import bases_cross, blender_check, loop_triangles, overlapping, triangles_cross, written_skins
from conftest import DATA, add, positions
from mathutils.bvhtree import BVHTree

import thicket_native as tn
from thicket import api, mesh_io
from thicket.pure import live_shells
from thicket.pure.arrays import MeshArrays

CASES = [("exterior", 0.1), ("exterior", 0.2), ("interior", 0.05), ("interior", 0.1), ("envelope", 0.1)]
HARD = sorted(p.stem for p in (DATA / "hard").glob("*.obj") if p.stem != "cards")


def load(name):
    """A test mesh as a Blender object: Blender's OBJ importer, or Suzanne."""
    if name == "suzanne":
        head = add("monkey")
        head.modifiers.new("subdivide", "SUBSURF").levels = 1
        bpy.ops.object.modifier_apply(modifier="subdivide")
        return head
    path = DATA / ("bunny-3k.obj" if name == "bunny" else f"hard/{name}.obj")
    bpy.ops.wm.obj_import(filepath=str(path))
    return bpy.context.selected_objects[0]


def normal_gaps(obj):
    """Per vertex, the distance along Blender's vertex normal to the mesh, outward and
    inward (BVHTree.ray_cast; the bounding-box diagonal where nothing is hit)."""
    mesh = obj.data
    p, n = positions(obj), np.empty((len(mesh.vertices), 3), np.float32)
    mesh.vertices.foreach_get("normal", n.ravel())
    diag = float(np.linalg.norm(np.ptp(p, axis=0)))
    tree = BVHTree.FromPolygons(p.tolist(), loop_triangles(mesh).tolist(), all_triangles=True)
    gaps = np.full((len(p), 2), diag)
    for k, sign in enumerate((1.0, -1.0)):
        for v in range(len(p)):  # a test-side reference, not product code
            d = n[v] * sign
            hit = tree.ray_cast((p[v] + d * 1e-5 * diag).tolist(), d.tolist(), diag)
            if hit[0] is not None:
                gaps[v, k] = hit[3]
    return gaps


def room(gaps, side, target):
    """The mean share of its target each vertex could keep if the shells of facing
    parts met halfway along the normal line."""
    out, inn = gaps[:, 0] / target, gaps[:, 1] / target
    share = {"exterior": out / 2, "interior": inn / 2, "envelope": np.minimum(out, inn)}[side]
    return float(np.minimum(share, 1.0).mean())


@pytest.mark.parametrize("name", HARD + ["bunny", "suzanne"])
def test_shells_never_fold_by_blenders_own_checks(scene, name):
    obj = load(name)
    a = mesh_io.read_mesh(obj.data)
    tris = loop_triangles(obj.data)
    gaps = normal_gaps(obj)
    weights = (0.5 + 0.5 * np.abs(np.sin(a.vertices @ np.array([3.0, 2.0, 1.0], np.float32)))).astype(np.float32)
    for side, fraction in CASES:
        for factors in (None, weights):
            # Solid: an envelope's inner skin is written too.
            out = tn.shell(a.vertices, a.face_sizes, a.corners, fraction, side=side, relative=True, factors=factors, output="solid")
            # Each skin as Blender draws the result (each quad split by its own shape),
            # against the base as Blender draws it.
            found = blender_check(a.vertices, out, side, tris, written_skins(out, side))
            what = f"{name} {side} {fraction} {'weighted' if factors is not None else 'uniform'}: {found} {out['check']}"
            assert (found["self"], found["base"], found["inverted"], found["folding"]) == (0, 0, 0, 0), what
            assert out["check"]["clean"], what
            ratio = out["achieved"] / out["target"]
            # Compressed only as far as the geometry requires: at least half of the room.
            assert ratio.max() <= 1.0 + 1e-4 and ratio.mean() > 0.5 * room(gaps, side, out["target"]), what
            if name != "suzanne":
                assert found["own"] == 0 and out["check"]["base_crossing_faces"] == 0, what


def test_thickness_is_kept_where_the_normal_line_has_room(scene):
    """Where normal displacement would itself be valid, 95% of the target (the
    report's criterion), on the hard meshes at 10% exterior / 5% interior."""
    for name in HARD:
        bpy.ops.wm.read_factory_settings(use_empty=True)
        a = mesh_io.read_mesh(load(name).data)
        for side, fraction in (("exterior", 0.1), ("interior", 0.05)):
            out = tn.shell(a.vertices, a.face_sizes, a.corners, fraction, side=side, relative=True)
            r = tn.shell_report(a.vertices, a.face_sizes, a.corners, out["directors"], out["target"], base_offset=out["base_offset"], side=side)
            # Not yet every one (issue 14 stays open): on the hand 2 of 2,012 such
            # vertices and on the torus knot 0.5% (exterior) stay short, where the shell
            # of the part beside leans into their room.
            assert r["normal_valid_at_95"] >= 0.99, (name, side, r)


def test_the_knot_at_exterior_20_percent_gives_room_vertices_their_target(scene):
    """Issue 14's 95% rule where it was furthest off: the torus knot at exterior 20%,
    where 31% of the vertices with room reached 95% before the restore tried just over
    95% and swept again after lifting flat neighbours; by Blender's own checks clean."""
    obj = load("torus_knot")
    a = mesh_io.read_mesh(obj.data)
    out = tn.shell(a.vertices, a.face_sizes, a.corners, 0.2, side="exterior", relative=True, output="solid")
    found = blender_check(a.vertices, out, "exterior", loop_triangles(obj.data), written_skins(out, "exterior"))
    assert (found["self"], found["base"], found["inverted"], found["folding"]) == (0, 0, 0, 0), found
    plain = tn.shell(a.vertices, a.face_sizes, a.corners, 0.2, side="exterior", relative=True)
    r = tn.shell_report(a.vertices, a.face_sizes, a.corners, plain["directors"], plain["target"], base_offset=plain["base_offset"], side="exterior")
    assert r["normal_valid_at_95"] >= 0.35, r


def test_a_self_intersecting_base_is_reported_and_its_faces_selected(scene):
    head = load("suzanne")
    expected = np.unique(overlapping(positions(head), positions(head), loop_triangles(head.data), same=True))
    faces = api.crossing_faces(head)
    # Blender's own overlap finds the same crossing faces (by its loop triangles' faces).
    head.data.calc_loop_triangles()
    polygon = np.empty(len(head.data.loop_triangles), np.int32)
    head.data.loop_triangles.foreach_get("polygon_index", polygon)
    assert len(faces) > 0 and set(faces.tolist()) == set(np.unique(polygon[expected]).tolist())
    api.add_thick_surface(head, kind="SHELL", thickness=0.1)
    assert head.thicket.source_crossings == len(faces)
    assert "final check: no folds or crossings" in head.thicket.last_report
    bpy.ops.object.select_all(action="DESELECT")
    bpy.context.view_layer.objects.active = head
    assert bpy.ops.thicket.select_crossings() == {"FINISHED"}
    assert head.mode == "EDIT"
    bpy.ops.object.mode_set(mode="OBJECT")
    selected = np.empty(len(head.data.polygons), bool)
    head.data.polygons.foreach_get("select", selected)
    assert set(np.flatnonzero(selected).tolist()) == set(faces.tolist())
    # A clean mesh: nothing to select, and the panel says nothing about crossings.
    sphere = add("ico_sphere", subdivisions=3)
    api.add_thick_surface(sphere, kind="SHELL", thickness=0.1)
    assert sphere.thicket.source_crossings == 0 and len(api.crossing_faces(sphere)) == 0


def test_the_float64_test_deciding_inherited_pairs():
    """`bases_cross` (which base pairs cross, for the inherited rule): a triangle
    through another crosses it, lifted just clear of it does not, nor do triangles
    sharing a vertex or lying in one plane."""
    flat = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0]], np.float64)
    through = np.array([[0.5, 0.5, -1], [0.5, 0.5, 1], [1.5, 0.5, 1]], np.float64)
    for lift, crosses in ((0.0, True), (1.0 + 1e-9, False), (1.0 - 1e-6, True)):
        assert triangles_cross(flat[None], (through + [0, 0, lift])[None])[0] == crosses, lift
    assert not triangles_cross(flat[None], (flat + [0.5, 0.5, 0])[None])[0]  # coplanar
    # On a tilted plane, where corners are not exactly representable, the float64
    # determinants of disjoint coplanar triangles are rounding noise; the signs are
    # exact, so none crosses (the naive float64 test said 18 of these 2,000 cross).
    rng = np.random.default_rng(5)
    axes, _ = np.linalg.qr(rng.normal(size=(2000, 3, 3)))
    near = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float64)
    beside = np.array([[1 + 1e-6, 0, 0], [0, 1 + 1e-6, 0], [1, 1, 0]], np.float64)
    place = rng.normal(size=(2000, 1, 3)) * 10
    lift = rng.normal(size=(2000, 1, 3))
    t, u = (near @ axes + place + 0.3 * lift, beside @ axes + place + 0.3 * lift)
    assert not triangles_cross(t, u).any()
    # A triangle through the plane at a slope of 2e-12 still crosses.
    shallow = np.array([[0.2, 0.2, -1e-12], [0.6, 0.2, 1e-12], [0.2, 0.6, 1e-12]])
    assert triangles_cross(near[None], shallow[None])[0]
    points = np.vstack([flat, through, [[2, 2, 1], [2, 2, -1]]]).astype(np.float32)
    tris = np.array([[0, 1, 2], [3, 4, 5], [1, 6, 7]])
    # Triangle 2 shares corner 1 with triangle 0 and passes through its plane there.
    assert bases_cross(points, np.array([[0, 1], [1, 0], [0, 2]]), tris).tolist() == [True, True, False]


def test_blenders_check_excuses_only_crossings_of_the_faces_beneath(scene):
    """The independent check excuses a crossing only where the two base faces under
    it cross each other, as the project's checker does: Suzanne pressed flat has
    exactly its own crossings (none counted), but eyes grown inside the head cross
    faces they did not cross before, pairs that the old rule (any pair with a face
    that crosses something) let pass."""
    head = load("suzanne")
    a = mesh_io.read_mesh(head.data)
    tris = loop_triangles(head.data)
    flat = {"base_offset": np.zeros_like(a.vertices), "directors": np.zeros_like(a.vertices)}
    found = blender_check(a.vertices, flat, "exterior", tris)
    assert (found["self"], found["base"], found["inverted"]) == (0, 0, 0) and found["own"] > 0, found
    # Loose parts by label propagation over triangles; the head is the largest.
    labels = np.arange(len(a.vertices))
    while True:
        grown = labels.copy()
        np.minimum.at(grown, tris.ravel(), np.repeat(labels[tris].min(axis=1), 3))
        if (grown == labels).all():
            break
        labels = grown
    parts, sizes = np.unique(labels, return_counts=True)
    eyes = ~np.isin(labels, parts[sizes.argmax()])
    assert 0 < eyes.sum() < len(labels) // 4
    grown_eyes = np.zeros_like(a.vertices)
    for part in parts[parts != parts[sizes.argmax()]]:
        at = labels == part
        grown_eyes[at] = 0.3 * (a.vertices[at] - a.vertices[at].mean(axis=0))
    out = {"base_offset": np.zeros_like(a.vertices), "directors": grown_eyes}
    found = blender_check(a.vertices, out, "exterior", tris)
    skin = a.vertices + grown_eyes
    own = np.unique(overlapping(a.vertices, a.vertices, tris, same=True))
    pairs = overlapping(skin, skin, tris, same=True)
    old_rule = int((~np.isin(pairs, own).any(axis=1)).sum())
    assert found["self"] > old_rule, (found, old_rule)
    # Grown eyes pass through the head: most of those pairs cross, which the float64
    # test confirms (it counts only pairs of Blender's that it finds crossing).
    assert 0 < found["self_crossing"] <= found["self"], found


def test_the_result_carries_the_achieved_ratio_and_the_panel_reports_it(scene):
    bpy.ops.wm.obj_import(filepath=str(DATA / "hard" / "comb.obj"))
    comb = bpy.context.selected_objects[0]
    result = api.add_thick_surface(comb, kind="SHELL", thickness=0.1, output="SOLID")
    n = len(result.data.vertices)
    ratio, achieved = np.empty(n, np.float32), np.empty(n, np.float32)
    result.data.attributes["thicket_ratio"].data.foreach_get("value", ratio)
    result.data.attributes["thicket_thickness"].data.foreach_get("value", achieved)
    diag = float(np.linalg.norm(np.ptp(positions(comb), axis=0)))
    np.testing.assert_allclose(ratio, achieved / (0.1 * diag), rtol=1e-4)
    assert ratio.min() < 0.95 < ratio.max() <= 1.0001  # the comb's gaps compress it
    report = comb.thicket.last_report
    compressed = int(((ratio[: n // 2]) < 0.95).sum())
    assert f"{compressed:,} of {n // 2:,} vertices compressed" in report, report
    assert f"min {ratio.min():.0%}" in report and "final check: no folds or crossings" in report


def test_incremental_edits_pushing_two_parts_together_stay_clean(scene):
    """Two spheres pushed into each other edit by edit: the live shell updates
    incrementally and is clean after every update, also once the spheres overlap
    (their crossing is then inherited)."""
    bpy.ops.wm.obj_import(filepath=str(DATA / "hard" / "two_spheres.obj"))
    obj = bpy.context.selected_objects[0]
    base = positions(obj).copy()
    left = base[:, 0] < base[:, 0].mean()
    tip = base[left, 0].max()
    radius = 0.5 * np.ptp(base[left, 0])
    # A sculpt-like grab: the cap of the left sphere facing the right one moves
    # towards it, most at the tip, smoothly less to the cap's rim.
    weight = np.where(left, np.clip(1.0 - (tip - base[:, 0]) / (0.4 * radius), 0.0, 1.0) ** 2, 0.0)
    assert 0 < (weight > 0).sum() < 0.15 * len(base)
    api.add_thick_surface(obj, kind="SHELL", thickness=0.1, output="OUTER")
    live_shells.recent.clear()
    tris = loop_triangles(obj.data)
    for step in np.linspace(0.0, 0.2 * radius, 7)[1:]:
        moved = base.copy()
        moved[:, 0] += step * weight
        obj.data.vertices.foreach_set("co", moved.ravel())
        obj.data.update()
        api.regenerate(obj)
        outer = positions(obj.thicket.result)
        out = {"base_offset": np.zeros_like(moved), "directors": outer - moved}
        found = blender_check(moved, out, "exterior", tris)
        assert (found["self"], found["base"], found["inverted"]) == (0, 0, 0), (step, found)
    assert found["own"] > 0, "the last edits push the spheres into each other"
    updates = [s for s in live_shells.recent if s is not None]
    assert len(updates) >= 6 and not any(s["rebuilt"] for s in updates), list(live_shells.recent)


@pytest.mark.parametrize("side", ["exterior", "interior", "envelope"])
def test_shells_of_open_cards_never_overlap_by_blenders_own_checks(scene, side):
    """2000 open cards, one in five a near-parallel copy 0.02-0.08 from another: the
    closed shell solids of different cards never cross (Blender's BVHTree.overlap on
    the solid output, pairs within one card dropped). Before the side walls were
    checked, a card across another card's edge crossed its shell's wall unseen."""
    bpy.ops.wm.obj_import(filepath=str(DATA / "hard" / "cards.obj"))
    a = mesh_io.read_mesh(bpy.context.selected_objects[0].data)
    out = tn.shell(a.vertices, a.face_sizes, a.corners, 0.1, side=side, output="solid")
    assert out["check"]["clean"], out["check"]
    solid = bpy.data.meshes.new("solid")
    mesh_io.write_mesh(solid, MeshArrays.from_native(out))
    solid_tris = loop_triangles(solid)
    card = out["source_vertex"] // 4  # cards.obj lists each card's four corners in turn
    pairs = overlapping(out["vertices"], None, solid_tris, same=True)
    across = pairs[card[solid_tris[pairs[:, 0], 0]] != card[solid_tris[pairs[:, 1], 0]]] if len(pairs) else pairs
    assert len(across) == 0, f"{side}: {len(across)} crossing pairs between cards' shells"
    ratio = out["achieved"] / out["target"]
    assert ratio.mean() > 0.5, ratio.mean()


def test_a_base_with_split_seams_is_shelled_as_one_surface(scene):
    """Exports split vertices along UV and patch seams (vertices at one position,
    unconnected). The shell treats a seam as the surface it is, not as two open
    boundaries pressed flat against each other: full thickness on a sphere split along
    its equator and a meridian, every copy of a seam vertex with the same director,
    and Blender's checks clean on the welded geometry."""
    import bmesh

    obj = add("uv_sphere")
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    seam = [e for e in bm.edges if all(abs(v.co.z) < 1e-5 or abs(v.co.y) < 1e-5 and v.co.x > 0 for v in e.verts)]
    bmesh.ops.split_edges(bm, edges=seam)
    bm.to_mesh(obj.data)
    bm.free()
    a = mesh_io.read_mesh(obj.data)
    points, canon = np.unique(a.vertices, axis=0, return_inverse=True)
    canon = canon.ravel()
    assert len(points) < len(a.vertices) - 40, "the seams split"
    tris = loop_triangles(obj.data)
    for side, fraction in CASES:
        out = tn.shell(a.vertices, a.face_sizes, a.corners, fraction, side=side, relative=True)
        ratio = out["achieved"] / out["target"]
        assert ratio.min() > 0.95, (side, fraction, ratio.min())
        welded = {key: np.zeros_like(points) for key in ("directors", "base_offset")}
        for key, value in welded.items():
            value[canon] = out[key]
            np.testing.assert_array_equal(value[canon], out[key], err_msg=f"{side}: copies of a seam vertex differ")
        found = blender_check(points, welded, side, canon[tris])
        assert (found["self"], found["base"], found["inverted"], found["folding"], found["own"]) == (0, 0, 0, 0, 0), (side, found)
    # Through the add-on, the panel's report (on the welded mesh) says it is clean.
    api.add_thick_surface(obj, kind="SHELL", thickness=0.1, output="SOLID")
    assert "final check: no folds or crossings" in obj.thicket.last_report, obj.thicket.last_report
