"""The L_p-field shell through thicket_native and the stack (thick surfaces, ch. 4)."""

import bpy
import numpy as np
import pytest
from conftest import DATA, add, positions

import thicket_native as tn
from thicket import api, mesh_io


def triangles_of(obj):
    mesh = obj.data
    mesh.calc_loop_triangles()
    tris = np.empty(len(mesh.loop_triangles) * 3, np.int32)
    mesh.loop_triangles.foreach_get("vertices", tris)
    return tris.reshape(-1, 3)


def test_build_shell_on_sphere_follows_normals(scene):
    sphere = add("ico_sphere", subdivisions=4, radius=1.0)
    v = positions(sphere)
    directors = tn.build_shell(v, triangles_of(sphere), 0.1, "exterior")
    assert directors.shape == v.shape and directors.dtype == np.float32
    normals = v / np.linalg.norm(v, axis=1, keepdims=True)
    lengths = np.linalg.norm(directors, axis=1)
    np.testing.assert_allclose(lengths, 0.1, rtol=0.02)
    cosine = np.sum(directors / lengths[:, None] * normals, axis=1)
    assert cosine.min() > 0.999
    inward = tn.build_shell(v, triangles_of(sphere), np.full(len(v), 0.1, np.float32), "interior")
    assert np.sum(inward * normals, axis=1).max() < -0.09


def test_field_shell_folds_far_less_than_offset_on_a_concave_head(scene):
    """Suzanne (subdivided) at 5% exterior: normal displacement folds in thousands of
    face pairs; the field shell must do an order of magnitude better and invert no prism."""
    head = add("monkey")
    head.modifiers.new("subdivide", "SUBSURF").levels = 1
    bpy.ops.object.modifier_apply(modifier="subdivide")
    a = mesh_io.read_mesh(head.data)
    diag = float(np.linalg.norm(np.ptp(a.vertices, axis=0)))
    field = tn.shell(a.vertices, a.face_sizes, a.corners, 0.05, relative=True)
    offset = tn.offset_shell(a.vertices, a.face_sizes, a.corners, 0.05, relative=True)
    target = np.full(len(a.vertices), 0.05 * diag, np.float32)
    ours = tn.shell_report(a.vertices, a.face_sizes, a.corners, field["directors"], field["target"])
    baseline = tn.shell_report(a.vertices, a.face_sizes, a.corners, offset["directors"], target)
    assert baseline["outer_self_intersections"] > 1000
    assert ours["outer_self_intersections"] * 10 < baseline["outer_self_intersections"]
    assert ours["inverted_cells"] == 0 and baseline["inverted_cells"] > 0
    assert 0 < ours["mean_ratio"] <= 1.0001


@pytest.mark.parametrize("side, fraction", [("exterior", 0.1), ("interior", 0.05)])
def test_scanned_bunny_shell_is_clean_and_keeps_thickness_where_normals_have_room(scene, side, fraction):
    """The issue's quality bar on the scan imported by Blender's own OBJ importer: no
    folds, no inverted prism, and 95% of the target wherever normal displacement would
    itself be valid."""
    bpy.ops.wm.obj_import(filepath=str(DATA / "bunny-3k.obj"))
    bunny = bpy.context.selected_objects[0]
    a = mesh_io.read_mesh(bunny.data)
    field = tn.shell(a.vertices, a.face_sizes, a.corners, fraction, side=side, relative=True)
    report = tn.shell_report(a.vertices, a.face_sizes, a.corners, field["directors"], field["target"], side=side)
    assert (report["outer_self_intersections"], report["outer_base_intersections"], report["inverted_cells"]) == (0, 0, 0), report
    assert report["normal_valid_vertices"] > 0.2 * len(a.vertices), report
    assert report["min_ratio_normal_valid"] >= 0.95, report


def test_shell_stack_item_in_blender(scene):
    sphere = add("uv_sphere", radius=1.0)
    result = api.add_thick_surface(sphere, kind="SHELL", side="ENVELOPE", thickness=0.2, thickness_mode="ABSOLUTE", output="SOLID")
    radii = np.linalg.norm(positions(result), axis=1)
    n = len(sphere.data.vertices)
    np.testing.assert_allclose(radii[:n], 1.1, atol=0.01)  # outer layer
    np.testing.assert_allclose(radii[n:], 0.9, atol=0.01)  # inner layer of the envelope
    achieved = np.empty(len(result.data.vertices), np.float32)
    result.data.attributes["thicket_thickness"].data.foreach_get("value", achieved)
    np.testing.assert_allclose(achieved, 0.2, rtol=0.03)
    sphere.thicket.items[0].side = "INTERIOR"
    assert np.linalg.norm(positions(sphere.thicket.result), axis=1).max() < 1.0 + 1e-4


def uv_map(mesh, name):
    uv = np.empty(len(mesh.loops) * 2, np.float32)
    mesh.uv_layers[name].data.foreach_get("uv", uv)
    return uv.reshape(-1, 2)


def face_values(mesh, prop, dtype):
    out = np.empty(len(mesh.polygons), dtype)
    mesh.polygons.foreach_get(prop, out)
    return out


@pytest.mark.parametrize("kind", ["OFFSET_SHELL", "SHELL"])
@pytest.mark.parametrize("output", ["OUTER", "SOLID", "LAYERS"])
def test_shell_results_keep_the_uv_maps_and_material_indices_of_their_base(scene, kind, output):
    # A grid (open: a solid gets rims) with two UV maps and two materials.
    grid = add("grid", x_subdivisions=4, y_subdivisions=3, size=2.0)
    mesh = grid.data
    second = mesh.uv_layers.new(name="Second")
    shifted = uv_map(mesh, "UVMap") * 2.0 + 0.25
    second.data.foreach_set("uv", shifted.ravel())
    for name in ("Red", "Blue"):
        mesh.materials.append(bpy.data.materials.new(name))
    materials = (np.arange(len(mesh.polygons)) % 2).astype(np.int32)
    mesh.polygons.foreach_set("material_index", materials)
    base_uv = {name: uv_map(mesh, name) for name in ("UVMap", "Second")}
    result = api.add_thick_surface(grid, kind=kind, thickness=0.1, thickness_mode="ABSOLUTE", output=output, surfaces=2)
    out = result.data
    assert [layer.name for layer in out.uv_layers] == ["UVMap", "Second"]
    assert [m.name for m in out.materials] == ["Red", "Blue"]
    # Each result face is a copy of a base face (same corner count, UVs and material
    # in the same order, or reversed from the first corner on) or a rim quad, whose
    # UVs are its edge's.
    f = len(mesh.polygons)
    copies = len(out.polygons) // f if output != "SOLID" else 2
    sizes = face_values(out, "loop_total", np.int32)
    out_materials = face_values(out, "material_index", np.int32)
    np.testing.assert_array_equal(out_materials[: copies * f], np.tile(materials, copies))
    if output == "SOLID":
        assert len(out.polygons) > 2 * f and set(out_materials[2 * f :]) <= {0, 1}
    for name, uv in base_uv.items():
        got = uv_map(out, name)
        start = 0
        for face in range(copies * f):
            n = sizes[face]
            src = mesh.polygons[face % f]
            expected = uv[src.loop_start : src.loop_start + n]
            here = got[start : start + n]
            backwards = np.concatenate([expected[:1], expected[:0:-1]])
            assert np.allclose(here, expected) or np.allclose(here, backwards), f"{name} face {face}"
            start += n
        # Rim corners take UVs the base has.
        rims = got[start:]
        assert all(np.isclose(uv, r).all(axis=1).any() for r in rims)


@pytest.mark.parametrize("side", ["sideways", ""])
def test_bad_side_is_a_clear_error(side):
    v = np.eye(3, dtype=np.float32)
    with pytest.raises(tn.ThicketError, match="side"):
        tn.build_shell(v, np.array([[0, 1, 2]], np.int32), 0.1, side)


def _monkey_arrays():
    head = add("monkey")
    head.modifiers.new("subdivide", "SUBSURF").levels = 1
    bpy.ops.object.modifier_apply(modifier="subdivide")
    return head, mesh_io.read_mesh(head.data)


def _bump(vertices, centre, height, radius):
    """Vertices within `radius` of vertex `centre` pushed along +z, smoothly."""
    d = np.linalg.norm(vertices - vertices[centre], axis=1)
    w = np.clip(1.0 - d / radius, 0.0, None) ** 2
    moved = vertices.copy()
    moved[:, 2] += height * w
    return moved, int(np.count_nonzero(w))


def test_incremental_shell_follows_an_edit_like_a_rebuild(scene):
    """A local edit retraces only part of the directors, and the shell equals a fresh
    one on the edited mesh (within the Barnes-Hut approximation and the repair)."""
    _, a = _monkey_arrays()
    diag = float(np.linalg.norm(np.ptp(a.vertices, axis=0)))
    live = tn.IncrementalShell(a.vertices, a.face_sizes, a.corners, 0.05, relative=True)
    assert live.vertex_count == len(a.vertices) and live.tolerance == pytest.approx(0.03)
    before = live.result()["directors"]
    moved, count = _bump(a.vertices, 0, 0.01 * diag, 0.1 * diag)
    stats = live.update(moved)
    # Local: neither the shell nor the field's patch tree was built anew.
    assert stats["changed"] == count and not stats["rebuilt"] and not stats["field_rebuilt"]
    assert count < stats["retraced"] < len(a.vertices) // 2
    after = live.result()
    fresh = tn.shell(moved, a.face_sizes, a.corners, 0.05, relative=True)
    h = 0.05 * diag
    differs = np.linalg.norm(after["directors"] - fresh["directors"], axis=1)
    # Trees refitted rather than rebuilt group the surface differently (Barnes-Hut
    # noise), and the repair's rounds shorten a tangle's directors differently; the
    # restore pass, greedy, may give one vertex its length back in one shell and not
    # in the other (both stay clean: the reports below).
    assert np.median(differs) < 5e-3 * h and np.percentile(differs, 90) < 0.03 * h
    # How many it gives back differently depends on where the edit falls: bumps at 13
    # vertices spread over the head left 0 to 11 of 2,012 vertices more than a quarter
    # of the thickness apart (0 to 12 once the restore checks cells before skin pairs).
    # One in a hundred bounds that; the mean length says neither shell is thinner.
    assert np.count_nonzero(differs > 0.25 * h) <= len(differs) // 100, np.sort(differs)[-5:] / h
    lengths = [np.linalg.norm(s["directors"], axis=1).mean() for s in (after, fresh)]
    assert lengths[0] == pytest.approx(lengths[1], rel=5e-3), lengths
    # What the tolerance kept is invisible beside that: retracing everything within
    # reach gives the same shell, but where the repair shortens a director to a
    # defect's crossing scale (found by steps of 0.9 and four bisections), a trace a
    # hair different can land one step apart: a vertex or two, by about 1% (one was,
    # by 1.2%, when the crossing scales came in).
    exact = tn.IncrementalShell(a.vertices, a.face_sizes, a.corners, 0.05, relative=True, tolerance=0.0)
    exact_stats = exact.update(moved)
    assert exact_stats["retraced"] > stats["retraced"]
    apart = np.linalg.norm(exact.result()["directors"] - after["directors"], axis=1)
    assert np.count_nonzero(apart > 1e-3 * h) <= 2 and apart.max() < 0.03 * h, np.sort(apart)[-3:] / h
    assert np.abs(after["directors"] - before).max() > 1e-3 * h  # it did move
    np.testing.assert_array_equal(after["corners"], fresh["corners"])
    # Suzanne's eyes cross her head, so even a fresh shell has crossings there: the
    # kept shell has no more of them.
    report = tn.shell_report(moved, a.face_sizes, a.corners, after["directors"], after["target"])
    reference = tn.shell_report(moved, a.face_sizes, a.corners, fresh["directors"], fresh["target"])
    for key in ("outer_self_intersections", "outer_base_intersections", "inverted_cells"):
        assert report[key] <= reference[key], key
    assert live.update(moved)["changed"] == 0


def test_incremental_shell_refuses_bad_updates_and_stays_usable(scene):
    _, a = _monkey_arrays()
    live = tn.IncrementalShell(a.vertices, a.face_sizes, a.corners, 0.05, relative=True, side="interior")
    with pytest.raises(tn.ThicketError, match="topology"):
        live.update(a.vertices[:-1])
    bad = a.vertices.copy()
    bad[3, 1] = np.nan
    with pytest.raises(tn.ThicketError):
        live.update(bad)
    with pytest.raises(tn.ThicketError, match="tolerance"):
        live.tolerance = -1.0
    with pytest.raises(tn.ThicketError, match="tolerance"):
        tn.IncrementalShell(a.vertices, a.face_sizes, a.corners, 0.05, tolerance=float("nan"))
    live.tolerance = 0.0
    rebuilt = live.update(a.vertices * 1.01)  # every vertex moved
    assert rebuilt["rebuilt"] and rebuilt["field_rebuilt"]
    assert live.result()["directors"].shape == a.vertices.shape


def test_shell_item_follows_source_edits_incrementally(scene):
    """Editing a source with a Shell item updates its result from the kept shell; the
    Regenerate operator builds from scratch; both agree."""
    from thicket.pure import live_shells

    head, a = _monkey_arrays()
    api.add_thick_surface(head, kind="SHELL", thickness=0.05)
    live_shells.recent.clear()
    result = head.thicket.result
    diag = float(np.linalg.norm(np.ptp(a.vertices, axis=0)))
    moved, count = _bump(a.vertices, 0, 0.01 * diag, 0.1 * diag)
    head.data.vertices.foreach_set("co", moved.ravel())
    head.data.update()
    bpy.context.view_layer.update()  # the depsgraph update that drives regeneration
    updates = [s for s in live_shells.recent if s is not None and s["changed"]]
    assert None not in live_shells.recent and len(updates) == 1, live_shells.recent
    assert updates[0]["changed"] == count and updates[0]["retraced"] < len(a.vertices) // 2
    live = positions(result)
    bpy.context.view_layer.objects.active = head
    assert bpy.ops.thicket.regenerate() == {"FINISHED"}
    assert live_shells.recent[-1] is None  # built from scratch
    fresh = positions(result)
    assert live.shape == fresh.shape
    differs = np.linalg.norm(live - fresh, axis=1)
    # As in test_incremental_shell_follows_an_edit_like_a_rebuild: a few vertices
    # (under one in a hundred) may have been given back their length in one and not
    # the other.
    far = np.count_nonzero(differs > 0.01 * diag)
    assert np.median(differs) < 1e-4 * diag and far <= len(differs) // 100, np.sort(differs)[-5:] / diag
    assert np.abs(live - mesh_io.read_mesh(head.data).vertices).max() > 0.04 * diag  # a shell, not the base


@pytest.mark.parametrize("kind", ["SHELL", "OFFSET_SHELL"])
def test_a_base_with_edges_of_three_faces_is_told_it_cannot_be_a_closed_manifold(scene, kind):
    cube = add("cube")
    api.add_thick_surface(cube, kind=kind, thickness=0.05, output="SOLID")
    assert "more than two faces" not in cube.thicket.last_note, cube.thicket.last_note
    # A fin on one of the cube's edges: that edge is used by three faces.
    mesh = cube.data
    fin = mesh.vertices[mesh.edges[0].vertices[0]].co, mesh.vertices[mesh.edges[0].vertices[1]].co
    finned = bpy.data.meshes.new("finned")
    points = [v.co.copy() for v in mesh.vertices] + [fin[1] * 2.0, fin[0] * 2.0]
    faces = [list(p.vertices) for p in mesh.polygons] + [[*mesh.edges[0].vertices, len(points) - 2, len(points) - 1]]
    finned.from_pydata(points, [], faces)
    cube.data = finned
    api.regenerate(cube)
    assert "1 edge of the mesh used by more than two faces" in cube.thicket.last_note, cube.thicket.last_note
    a = mesh_io.read_mesh(finned)
    assert tn.mesh_report(a.vertices, a.face_sizes, a.corners)["non_manifold_edges"] == 1
    # The fin's face taken off, its two vertices kept: as many vertices, other faces
    # (the count is remembered per topology, not per vertex count).
    unfinned = bpy.data.meshes.new("unfinned")
    unfinned.from_pydata(points, [], faces[:-1])
    cube.data = unfinned
    api.regenerate(cube)
    assert "more than two faces" not in cube.thicket.last_note, cube.thicket.last_note
    # And back to the fin: counted for the topology it is, not the last one seen.
    cube.data = finned
    api.regenerate(cube)
    assert "1 edge of the mesh used by more than two faces" in cube.thicket.last_note, cube.thicket.last_note
