"""Volumetric textures through thicket_native and the stack (thick surfaces, ch. 3, 7)."""

import os

import bmesh
import bpy
import numpy as np
import pytest
from conftest import add, positions, select_only

import thicket_native as tn
from thicket import api, mesh_io
from thicket.pure.kinds.volumetric_texture import TEXCOORD_ATTRIBUTE


def edge_use_counts(obj):
    """How many faces use each edge of `obj`'s mesh (numpy, no per-edge loop)."""
    mesh = obj.data
    loops = len(mesh.loops)
    edge_of_loop = np.empty(loops, np.int32)
    mesh.loops.foreach_get("edge_index", edge_of_loop)
    return np.bincount(edge_of_loop, minlength=len(mesh.edges))


def test_procedural_textures_have_their_shape_and_errors_are_clear():
    for pattern in ("chain_mail", "weave", "rivets", "grass", "fur", "bubbles"):
        t = tn.texture(pattern, size=(24, 20, 10), seed=3)
        assert t.shape == (10, 20, 24) and t.dtype == np.float32
        inside = (t >= 0.5).mean()
        assert 0.003 < inside < 0.9, (pattern, inside)
    with pytest.raises(tn.ThicketError, match="unknown texture"):
        tn.texture("plaid")
    with pytest.raises(tn.ThicketError, match="zero size"):
        tn.texture("fur", size=(0, 4, 4))


def test_chain_mail_on_a_uv_sphere_bakes_a_closed_mesh_and_leaves_the_source(scene):
    sphere = add("uv_sphere", segments=24, ring_count=12, radius=1.0)
    before = positions(sphere).copy()
    result = api.add_volumetric_texture(sphere, "chain_mail", shell_thickness=0.04, tiling=6.0, resolution=4, depth_steps=8)
    counts = edge_use_counts(result)
    assert len(result.data.polygons) > 5000
    assert (counts == 2).all(), f"{(counts == 1).sum()} boundary and {(counts > 2).sum()} non-manifold edges"
    tex = np.empty(len(result.data.vertices) * 3, np.float32)
    result.data.attributes[TEXCOORD_ATTRIBUTE].data.foreach_get("vector", tex)
    r = tex.reshape(-1, 3)[:, 2]
    assert 0.0 < r.min() and r.max() < 1.0
    assert result.data.has_custom_normals, "normals from the texture gradient"
    # Every baked vertex lies in the shell: between radius 1 (minus facets) and 1 + shell.
    radii = np.linalg.norm(positions(result), axis=1)
    diag = np.linalg.norm(np.ptp(before, axis=0))
    assert radii.min() > 0.95 and radii.max() < 1.0 + 0.04 * diag + 1e-3
    np.testing.assert_array_equal(positions(sphere), before)
    assert sphere.thicket.last_note == ""  # the UV sphere has UVs


def test_without_uvs_each_face_is_a_tile_and_the_user_is_told(scene):
    cube = add("cube", size=2.0)
    cube.data.uv_layers.remove(cube.data.uv_layers[0])
    result = api.add_volumetric_texture(cube, "rivets", shell_thickness=0.05, resolution=8, depth_steps=8)
    assert len(result.data.polygons) > 0
    assert "no UV map" in cube.thicket.last_note


def test_an_empty_bake_tells_the_user_why(scene):
    # Eight tiles per face edge at exactly 8 lattice steps (Follow Texture off): chain
    # mail's rings fall between the samples. The user is told instead of getting
    # nothing silently.
    cube = add("cube", size=2.0)
    cube.data.uv_layers.remove(cube.data.uv_layers[0])
    result = api.add_volumetric_texture(cube, "chain_mail", shell_thickness=0.05, tiling=8, resolution=8, follow_texture=False)
    assert len(result.data.polygons) == 0
    assert "baked no geometry" in cube.thicket.last_note and "Resolution" in cube.thicket.last_note


def test_a_texture_following_bake_keeps_what_a_coarse_lattice_loses(scene):
    # The same bake at the default (Follow Texture on): the lattice refines toward the
    # texture's texels, so the rings survive; 512 texels per face edge are more than
    # its most steps, and the note says the texture is still finer than the lattice.
    cube = add("cube", size=2.0)
    cube.data.uv_layers.remove(cube.data.uv_layers[0])
    result = api.add_volumetric_texture(cube, "chain_mail", shell_thickness=0.05, tiling=8, resolution=8, triangle_budget=200_000)
    assert len(result.data.polygons) > 10_000
    note = cube.thicket.last_note
    assert "finer than the bake lattice" in note and "baked no geometry" not in note
    bm = bmesh.new()
    bm.from_mesh(result.data)
    try:
        assert all(e.is_manifold for e in bm.edges)
    finally:
        bm.free()


def test_bakes_keep_the_sources_materials_and_uvs(scene):
    # A UV sphere with two materials (top half 1, bottom half 0) and a renamed UV map,
    # tiling 2: each baked triangle takes the material of the face it grew from, and a
    # UV map of the source's name carries the source's UVs (the texture's (s, t) / 2).
    sphere = add("uv_sphere", segments=16, ring_count=8)
    sphere.data.uv_layers.active.name = "Skin"
    for name in ("Bottom", "Top"):
        sphere.data.materials.append(bpy.data.materials.new(name))
    z = np.array([p.center.z for p in sphere.data.polygons])
    sphere.data.polygons.foreach_set("material_index", (z > 0).astype(np.int32))
    result = api.add_volumetric_texture(sphere, "weave", shell_thickness=0.05, tiling=2.0, triangle_budget=100_000)
    mesh = result.data
    assert [m.name for m in mesh.materials] == ["Bottom", "Top"]
    index = np.empty(len(mesh.polygons), np.int32)
    mesh.polygons.foreach_get("material_index", index)
    centre = np.empty(len(mesh.polygons) * 3, np.float32)
    mesh.polygons.foreach_get("center", centre)
    cz = centre.reshape(-1, 3)[:, 2]
    clear = np.abs(cz) > 0.1  # away from the equator, where the halves meet
    assert np.array_equal(index[clear], (cz[clear] > 0).astype(np.int32))
    assert "Skin" in mesh.uv_layers
    uv = np.empty(len(mesh.loops) * 2, np.float32)
    mesh.uv_layers["Skin"].data.foreach_get("uv", uv)
    uv = uv.reshape(-1, 2)
    source_uv = np.empty(len(sphere.data.loops) * 2, np.float32)
    sphere.data.uv_layers["Skin"].data.foreach_get("uv", source_uv)
    source_uv = source_uv.reshape(-1, 2)
    assert np.all(uv >= source_uv.min(axis=0) - 1e-4) and np.all(uv <= source_uv.max(axis=0) + 1e-4)
    # The UV follows the surface: corners of one triangle lie close together in UV
    # (no triangle spans a seam), and the baked (s, t) of each vertex is twice its UV.
    tris = uv.reshape(-1, 3, 2)
    assert np.ptp(tris, axis=1).max() < 0.2
    texcoord = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.attributes[TEXCOORD_ATTRIBUTE].data.foreach_get("vector", texcoord)
    corners = np.empty(len(mesh.loops), np.int32)
    mesh.loops.foreach_get("vertex_index", corners)
    same = np.isclose(texcoord.reshape(-1, 3)[corners, :2], uv * 2.0, atol=1e-4).all(axis=1)
    assert same.mean() > 0.95  # all but corners on UV seams, where a vertex has two UVs
    # Without a UV map each face is a tile: the UV map holds each corner's tile (s, t).
    bare = add("ico_sphere", subdivisions=1)
    bare.data.uv_layers.remove(bare.data.uv_layers[0])
    baked = api.add_volumetric_texture(bare, "rivets", shell_thickness=0.05, triangle_budget=50_000)
    tile = np.empty(len(baked.data.loops) * 2, np.float32)
    baked.data.uv_layers["UVMap"].data.foreach_get("uv", tile)
    assert tile.min() >= -1e-4 and tile.max() <= 1.0 + 1e-4


def test_a_bake_reports_progress_and_can_be_cancelled(scene):
    sphere = add("ico_sphere", subdivisions=3)
    sphere.data.uv_layers.remove(sphere.data.uv_layers[0])
    base = mesh_io.read_mesh(sphere.data)
    shell = tn.shell(base.vertices, base.face_sizes, base.corners, 0.05, relative=True)
    args = (base.vertices, base.face_sizes, base.corners, shell["base_offset"], shell["directors"], [tn.texture("weave")])
    seen = []
    out = tn.bake_texture(*args, triangle_budget=0, progress=seen.append)
    assert len(out["corners"]) > 0
    assert seen and seen == sorted(seen) and 0.0 <= seen[0] and seen[-1] <= 1.0
    # Returning False cancels; so does an exception, which comes back to the caller.
    with pytest.raises(tn.ThicketError, match="cancelled"):
        tn.bake_texture(*args, triangle_budget=0, progress=lambda fraction: False)

    class Stop(Exception):
        pass

    def stop(fraction):
        raise Stop(fraction)

    with pytest.raises(Stop):
        tn.bake_texture(*args, triangle_budget=0, progress=stop)
    # The same bake still runs after a cancelled one.
    again = tn.bake_texture(*args, triangle_budget=0)
    assert np.array_equal(again["corners"], out["corners"])


def test_texture_without_a_shell_is_a_clear_error_and_changes_nothing(scene):
    sphere = add("ico_sphere", subdivisions=2)
    api.add_item(sphere, "VOLUMETRIC_TEXTURE", pattern="weave")
    with pytest.raises(ValueError, match="needs a Shell"):
        api.regenerate(sphere)
    assert api.result_of(sphere) is None


def test_over_budget_bakes_say_how_big_they_would_be(scene):
    sphere = add("ico_sphere", subdivisions=3)
    with pytest.raises(tn.ThicketError, match=r"about \d+ triangles"):
        api.add_volumetric_texture(sphere, "fur", resolution=16, depth_steps=32, max_triangles=1000)
    assert api.result_of(sphere) is None


def test_a_bake_over_its_budget_says_by_how_much(scene):
    # A budget far below what the error allowed can reach: the bake stays over it and
    # the stack's note names the count, the budget and the factor.
    sphere = add("ico_sphere", subdivisions=2)
    result = api.add_volumetric_texture(sphere, "weave", resolution=4, depth_steps=8, triangle_budget=100)
    count = len(result.data.polygons)
    assert count > 105
    note = sphere.thicket.last_note
    assert f"{count:,} triangles, {count / 100:.1f} times the Triangle Budget of 100" in note, note


def test_region_vertex_group_limits_the_texture(scene):
    sphere = add("ico_sphere", subdivisions=3, radius=1.0)
    group = sphere.vertex_groups.new(name="top")
    top = [v.index for v in sphere.data.vertices if v.co.z > 0.2]
    group.add(top, 1.0, "REPLACE")
    result = api.add_volumetric_texture(sphere, "grass", shell_thickness=0.1, resolution=10, depth_steps=12, vertex_group="top", tiling=1.0)
    p = positions(result)
    tex = np.empty(len(p) * 3, np.float32)
    result.data.attributes[TEXCOORD_ATTRIBUTE].data.foreach_get("vector", tex)
    r = tex.reshape(-1, 3)[:, 2]
    assert r[p[:, 2] < -0.5].max() < 0.25, "only the base slab below"
    assert r[p[:, 2] > 0.5].max() > 0.5, "grass on top"
    counts = edge_use_counts(result)
    assert (counts == 2).all()


def test_animated_texture_follows_the_frame_and_bakes_a_range(scene, tmp_path):
    plane = add("grid", x_subdivisions=6, y_subdivisions=6, size=2.0)
    result = api.add_volumetric_texture(plane, "bubbles", shell_thickness=0.1, tiling=2.0, resolution=8, depth_steps=12, follow_frame=True, speed=0.5)
    first = positions(result).copy()
    bpy.context.scene.frame_set(12)  # frame_change handler regenerates
    second = positions(plane.thicket.result)
    assert first.shape != second.shape or not np.allclose(first, second)
    paths = api.bake_frames(plane, 1, 3, str(tmp_path))
    assert [p.endswith(f"_{f:04d}.glb") for p, f in zip(paths, (1, 2, 3))] == [True] * 3
    assert all((tmp_path / p).stat().st_size > 1000 for p in paths)
    assert bpy.context.scene.frame_current == 12


def test_combined_pattern_adds_to_the_first(scene):
    sphere = add("uv_sphere", segments=16, ring_count=8)
    one = len(api.add_volumetric_texture(sphere, "rivets", tiling=4.0, resolution=6, depth_steps=10).data.polygons)
    sphere.thicket.items[1].combine = "weave"
    api.regenerate(sphere)
    assert len(sphere.thicket.result.data.polygons) > one


def uv_grid():
    """A 2x2 grid with a UV map spanning it (u = (x + 1) / 2, v = (y + 1) / 2)."""
    return add("grid", x_subdivisions=16, y_subdivisions=16, size=2.0)


def near(obj, centre, radius):
    p = positions(obj)
    return np.linalg.norm(p[:, :2] - np.asarray(centre), axis=1) < radius


def shell_r(obj):
    tex = np.empty(len(obj.data.vertices) * 3, np.float32)
    obj.data.attributes[TEXCOORD_ATTRIBUTE].data.foreach_get("vector", tex)
    return tex.reshape(-1, 3)[:, 2]


def test_holes_from_a_vertex_group_and_a_cutter_object(scene):
    sheet = uv_grid()
    group = sheet.vertex_groups.new(name="hole")
    group.add([v.index for v in sheet.data.vertices if (v.co.x - 0.5) ** 2 + (v.co.y - 0.5) ** 2 < 0.3**2], 1.0, "REPLACE")
    result = api.add_volumetric_texture(sheet, "rivets", shell_thickness=0.05, tiling=4.0, resolution=6, depth_steps=10)
    assert near(result, (0.5, 0.5), 0.15).any() and near(result, (-0.5, -0.5), 0.15).any()
    item = sheet.thicket.items[1]
    item.hole_group = "hole"
    api.regenerate(sheet)
    assert not near(sheet.thicket.result, (0.5, 0.5), 0.15).any(), "nothing left in the hole"
    assert near(sheet.thicket.result, (-0.5, -0.5), 0.15).any()
    # A cutter object: a sphere over (-0.5, -0.5); the texture inside it is cut away.
    cutter = add("uv_sphere", radius=0.3, location=(-0.5, -0.5, 0.0))
    item.cutter = cutter
    api.regenerate(sheet)
    assert not near(sheet.thicket.result, (-0.5, -0.5), 0.2).any()
    assert (edge_use_counts(sheet.thicket.result) == 2).all(), "cut results stay closed"
    # Moving the cutter re-cuts through auto-update (background: at once).
    cutter.location = (0.5, -0.5, 0.0)
    bpy.context.view_layer.update()
    assert near(sheet.thicket.result, (-0.5, -0.5), 0.2).any()
    assert not near(sheet.thicket.result, (0.5, -0.5), 0.2).any()


def test_an_open_cutter_is_a_clear_error_and_the_result_stays(scene):
    sheet = uv_grid()
    result = api.add_volumetric_texture(sheet, "rivets", shell_thickness=0.05, tiling=4.0, resolution=4, depth_steps=8)
    before = positions(result).copy()
    sheet.thicket.items[1].cutter = add("grid", size=0.5)
    with pytest.raises(tn.ThicketError, match="not closed"):
        api.regenerate(sheet)
    np.testing.assert_array_equal(positions(sheet.thicket.result), before)


def test_moving_a_texture_region_leaves_the_base_in_its_trace(scene):
    sheet = uv_grid()
    group = sheet.vertex_groups.new(name="piece")
    group.add([v.index for v in sheet.data.vertices if (v.co.x + 0.5) ** 2 + v.co.y**2 < 0.35**2], 1.0, "REPLACE")
    api.add_volumetric_texture(sheet, "grass", shell_thickness=0.1, tiling=2.0, resolution=8, depth_steps=12, vertex_group="piece", seed=2)
    r, here = shell_r(sheet.thicket.result), near(sheet.thicket.result, (-0.5, 0.0), 0.2)
    there = near(sheet.thicket.result, (0.5, 0.0), 0.2)
    assert r[here].max() > 0.3 and r[there].max() < 0.22, "grass only in the piece"
    item = sheet.thicket.items[1]
    item.move_group = "piece"
    item.move_offset = (0.5, 0.0)  # UV units: the sheet's UVs span 2 units of x
    api.regenerate(sheet)
    result = sheet.thicket.result
    r, here, there = shell_r(result), near(result, (-0.5, 0.0), 0.2), near(result, (0.5, 0.0), 0.2)
    assert r[here].max() < 0.22, "the trace shows the base"
    assert r[there].max() > 0.3, "the piece landed"
    assert (edge_use_counts(result) == 2).all()


def test_large_bakes_wait_for_confirmation_in_the_interface(scene):
    from thicket.pure.kinds.volumetric_texture import BakeNeedsConfirmation

    sphere = add("ico_sphere", subdivisions=2)
    small = api.add_volumetric_texture(sphere, "weave", resolution=4, depth_steps=8)
    before = len(small.data.polygons)
    item = sphere.thicket.items[1]
    sphere.thicket.auto_update = False
    item.resolution = 12
    item.confirm_above = 1000
    item.triangle_budget = 500
    with pytest.raises(BakeNeedsConfirmation) as caught:
        api.regenerate(sphere, ask=True)
    assert caught.value.estimate > 1000 and f"{caught.value.estimate:,}" in str(caught.value)
    # Over its Triangle Budget too: the question says by how much.
    assert caught.value.budget == 500 and f"{caught.value.estimate / 500:.1f} times the Triangle Budget of 500" in str(caught.value)
    assert len(sphere.thicket.result.data.polygons) == before, "nothing baked before the OK"
    item.triangle_budget = 1_000_000  # the finer lattice kept whole
    api.regenerate(sphere)  # scripts (and the dialog's OK) bake without asking
    assert len(sphere.thicket.result.data.polygons) > before


def test_a_texture_file_feeds_the_bake_and_a_missing_one_is_named(scene, tmp_path):
    # A slab (alpha 1 up to r = 0.6, 0 from r = 0.7) saved as EXR and as PNG slices:
    # both bake to a closed slab whose top lies halfway, at r = 0.65.
    nz = 11
    slab = np.zeros((nz, 4, 4), np.float32)
    slab[: int(0.6 * (nz - 1)) + 1] = 1.0
    exr = str(tmp_path / "slab.exr")
    tn.save_texture(exr, slab)
    tn.save_texture(str(tmp_path / "slices"), slab)
    sheet = uv_grid()
    api.add_volumetric_texture(sheet, "weave", shell_thickness=0.05, resolution=2, depth_steps=20)
    item = sheet.thicket.items[1]
    for path in (exr, str(tmp_path / "slices" / "slice_000.png")):
        item.source = "FILE"
        item.filepath = path
        api.regenerate(sheet)
        r = shell_r(sheet.thicket.result)
        inner = np.abs(positions(sheet.thicket.result)[:, :2]).max(axis=1) < 0.9  # away from the side walls
        top = r[inner & (r > 0.3)]
        assert len(top) > 0 and np.all(np.abs(top - 0.65) < 0.02), (path, top.min(), top.max())
        assert (edge_use_counts(sheet.thicket.result) == 2).all()
    # Rewriting the file is seen (cached textures are keyed by modification time).
    thinner = np.zeros_like(slab)
    thinner[: nz // 4] = 1.0
    tn.save_texture(exr, thinner)
    os.utime(exr, (os.path.getatime(exr), os.path.getmtime(exr) + 10))
    item.filepath = exr
    api.regenerate(sheet)
    inner = np.abs(positions(sheet.thicket.result)[:, :2]).max(axis=1) < 0.9
    assert shell_r(sheet.thicket.result)[inner].max() < 0.4, "the rewritten, thinner slab"
    before = positions(sheet.thicket.result).copy()
    item.filepath = str(tmp_path / "nowhere.exr")
    with pytest.raises(tn.ThicketError, match="nowhere.exr"):
        api.regenerate(sheet)
    np.testing.assert_array_equal(positions(sheet.thicket.result), before)


def test_export_texture_writes_the_items_texture_for_blender_and_thicket(scene, tmp_path):
    sphere = add("ico_sphere", subdivisions=1)
    api.add_volumetric_texture(sphere, "rivets", texture_size=16, resolution=2, depth_steps=4)
    sphere.thicket.active_index = 1
    select_only(sphere)
    path = str(tmp_path / "rivets.exr")
    assert bpy.ops.thicket.export_texture(filepath=path) == {"FINISHED"}
    written = tn.load_texture(path)
    np.testing.assert_array_equal(written, tn.texture("rivets", size=(16, 16, 8)))
    image = bpy.data.images.load(path)
    assert tuple(image.size) == (16, 16 * 8)
    with pytest.raises(ValueError, match="not a Volumetric Texture"):
        api.export_texture(sphere, path, index=0)


def test_selected_faces_can_stand_in_for_a_vertex_group(scene):
    sheet = uv_grid()
    centres = np.empty(len(sheet.data.polygons) * 3, np.float32)
    sheet.data.polygons.foreach_get("center", centres)
    centres = centres.reshape(-1, 3)
    selected = np.linalg.norm(centres[:, :2] - (0.5, 0.5), axis=1) < 0.3
    sheet.data.polygons.foreach_set("select", selected)
    api.add_volumetric_texture(sheet, "rivets", shell_thickness=0.05, tiling=4.0, resolution=6, depth_steps=10, face_selection="HOLES")
    assert not near(sheet.thicket.result, (0.5, 0.5), 0.15).any(), "the selected faces are a hole"
    assert near(sheet.thicket.result, (-0.5, -0.5), 0.15).any()
    # As the region: the texture only on the selected faces, the base slab elsewhere.
    sheet.thicket.items[1].face_selection = "REGION"
    api.regenerate(sheet)
    r = shell_r(sheet.thicket.result)
    assert r[near(sheet.thicket.result, (0.5, 0.5), 0.15)].max() > 0.3
    assert r[near(sheet.thicket.result, (-0.5, -0.5), 0.3)].max() < 0.22
    # A modifier that changes the faces: a clear error, the result kept.
    sheet.modifiers.new("sub", "SUBSURF")
    before = positions(sheet.thicket.result).copy()
    with pytest.raises(ValueError, match="selected faces"):
        api.regenerate(sheet)
    np.testing.assert_array_equal(positions(sheet.thicket.result), before)
