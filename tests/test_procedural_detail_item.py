"""The Procedural Detail stack item (issue 18) in real Blender: `thicket.api.
add_procedural_detail`, the Add Procedural Detail operator and the panel. Results are
compared with `thicket_native.procedural_detail` run here, checked with bmesh and
BVHTree, chained before a shell whose vertex group still applies, and bad input
leaves the source and the previous result as they were."""

import bmesh
import bpy
import numpy as np
import pytest
from blender_checks import quad_crossings
from conftest import add, positions, select_only
from mathutils.bvhtree import BVHTree

import thicket_native as tn
from thicket import api, mesh_io
from thicket.operators.procedural_detail_add import THICKET_OT_procedural_detail_add
from thicket.pure.kinds.procedural_detail import DETAIL_ATTRIBUTE
from thicket.stack.guard import suspended


def native_detail(obj, model, levels, seed=0, **params):
    """`thicket_native.procedural_detail` on `obj`'s mesh; lengths as the item stores
    them (Blender keeps float properties in single precision)."""
    a = mesh_io.read_mesh(obj.data)
    params = {k: float(np.float32(v)) if isinstance(v, float) else v for k, v in params.items()}
    return tn.procedural_detail(a.vertices, a.face_sizes, a.corners, model, levels, seed, params)


def point_values(mesh, name):
    values = np.empty(len(mesh.vertices), np.float32)
    mesh.attributes[name].data.foreach_get("value", values)
    return values


def face_vertices(mesh):
    corners = np.empty(len(mesh.loops), np.int32)
    mesh.loops.foreach_get("vertex_index", corners)
    sizes = np.empty(len(mesh.polygons), np.int32)
    mesh.polygons.foreach_get("loop_total", sizes)
    return sizes, corners


def closed_and_manifold(mesh):
    bm = bmesh.new()
    bm.from_mesh(mesh)
    try:
        return all(e.is_manifold for e in bm.edges) and all(v.is_manifold for v in bm.verts)
    finally:
        bm.free()


def test_rock_item_is_the_native_detail_and_leaves_the_source(scene):
    cube = add("cube")
    cube.data.materials.append(bpy.data.materials.new("a"))
    cube.data.materials.append(bpy.data.materials.new("b"))
    materials = np.array([0, 1, 0, 1, 0, 1], np.int32)
    cube.data.polygons.foreach_set("material_index", materials)
    before = positions(cube).copy()
    result = api.add_procedural_detail(cube, model="ROCK", levels=3, amplitude=0.03, seed=7)
    expected = native_detail(cube, "rock", 3, 7, amplitude=0.03)
    np.testing.assert_array_equal(positions(result), expected["vertices"])
    sizes, corners = face_vertices(result.data)
    assert (sizes == 4).all() and len(sizes) == 6 * 4**3
    np.testing.assert_array_equal(corners, expected["corners"])
    np.testing.assert_array_equal(point_values(result.data, DETAIL_ATTRIBUTE), expected["scalar"])
    got = np.empty(len(sizes), np.int32)
    result.data.polygons.foreach_get("material_index", got)
    np.testing.assert_array_equal(got, materials[expected["source_face"]])
    assert closed_and_manifold(result.data)
    assert np.abs(expected["scalar"]).max() > 0.01, "the rock moved the surface"
    np.testing.assert_array_equal(positions(cube), before)
    assert len(cube.data.polygons) == 6


def test_the_detail_goes_before_a_shell_and_the_shell_wraps_it(scene):
    cube = add("cube")
    api.add_thick_surface(cube, thickness=0.05, kind="SHELL", output="OUTER")
    result = api.add_procedural_detail(cube, model="ROCK", levels=2, amplitude=0.02)
    assert [i.kind for i in cube.thicket.items] == ["PROCEDURAL_DETAIL", "SHELL"]
    assert cube.thicket.active_index == 0
    detail = native_detail(cube, "rock", 2, amplitude=0.02)
    assert len(result.data.polygons) == len(detail["face_sizes"])
    # Blender's own test: the shell's outer surface does not cross the detailed base.
    base = BVHTree.FromPolygons([tuple(v) for v in detail["vertices"]], np.split(detail["corners"], np.cumsum(detail["face_sizes"])[:-1]))
    outer = BVHTree.FromPolygons([tuple(v) for v in positions(result)], [tuple(p.vertices) for p in result.data.polygons])
    assert outer.overlap(base) == []
    assert cube.thicket.last_error == ""


def test_a_shells_vertex_group_follows_the_detailed_vertices(scene):
    """Each detailed vertex keeps the weight of the base vertex whose quarter of a face
    it lies in: an Offset Shell over the top face's group moves every vertex of the
    faces grown from the top face, and no vertex of those grown from the bottom one."""
    cube = add("cube")
    top = [v.index for v in cube.data.vertices if v.co.z > 0]
    cube.vertex_groups.new(name="top").add(top, 1.0, "REPLACE")
    api.add_thick_surface(cube, thickness=0.2, thickness_mode="ABSOLUTE", vertex_group="top")
    result = api.add_procedural_detail(cube, model="ROCK", levels=2, amplitude=0.01)
    detail = native_detail(cube, "rock", 2, amplitude=0.01)
    moved = np.linalg.norm(positions(result) - detail["vertices"], axis=1)
    quads = detail["corners"].reshape(-1, 4)
    normals = np.array([p.normal[:] for p in cube.data.polygons])
    top_face, bottom_face = int(np.argmax(normals[:, 2])), int(np.argmin(normals[:, 2]))
    assert (moved[quads[detail["source_face"] == top_face]] > 0.1).all()
    assert (moved[quads[detail["source_face"] == bottom_face]] < 1e-6).all()


def sphere_with_seed():
    sphere = add("ico_sphere", subdivisions=3, radius=1.0)
    seed = int(np.argmax(positions(sphere)[:, 2]))
    return sphere, seed


@pytest.mark.parametrize("source", ["GROUP", "SELECTED"])
def test_berry_seeds_from_a_vertex_group_or_the_selection(scene, source):
    sphere, seed = sphere_with_seed()
    if source == "GROUP":
        sphere.vertex_groups.new(name="seeds").add([seed], 1.0, "REPLACE")
    else:
        flags = np.zeros(len(sphere.data.vertices), bool)
        flags[seed] = True
        sphere.data.vertices.foreach_set("select", flags)
    result = api.add_procedural_detail(sphere, model="BERRY", levels=2, radius=0.15, seeds=source, vertex_group="seeds" if source == "GROUP" else "")
    expected = native_detail(sphere, "berry", 2, radius=0.15, seeds=[seed])
    np.testing.assert_array_equal(positions(result), expected["vertices"])
    height = point_values(result.data, DETAIL_ATTRIBUTE)
    radius = 0.15 * np.linalg.norm(np.ptp(positions(sphere), axis=0))
    assert height[seed] >= radius * 0.999, "the dome reaches its radius at the seed"
    # Level 1's dome has radius R, level 2's clusters lie within R of it with domes of R / 2.
    far = np.linalg.norm(expected["vertices"] - positions(sphere)[seed], axis=1) > 1.6 * radius
    assert far.any() and (height[far] == 0).all()


def test_seeds_that_name_nothing_are_refused_with_the_reason(scene):
    sphere, seed = sphere_with_seed()
    sphere.vertex_groups.new(name="light").add([seed], 0.2, "REPLACE")
    with pytest.raises(api.ThicketError, match="no vertex of weight 0.5"):
        api.add_procedural_detail(sphere, model="BERRY", levels=1, seeds="GROUP", vertex_group="light")
    sphere.data.vertices.foreach_set("select", np.zeros(len(sphere.data.vertices), bool))
    sphere.thicket.items[0].detail_seeds = "SELECTED"
    assert "no vertex is selected" in sphere.thicket.last_error


def test_a_large_result_asks_first_and_keeps_the_last_result(scene):
    cube = add("cube")
    result = api.add_procedural_detail(cube, model="ROCK", levels=1)
    kept = positions(result).copy()
    item = cube.thicket.items[0]
    with suspended():  # else the edit regenerates at once (headless: without asking)
        item.confirm_above, item.levels = 1000, 4  # 6 * 4 * 4^3 quads: 3072 triangles
    with pytest.raises(api.BakeNeedsConfirmation, match="3,072 triangles") as asked:
        api.regenerate(cube, ask=True)
    assert asked.value.estimate == 3072 and asked.value.making == "subdivision"
    np.testing.assert_array_equal(positions(result), kept)
    assert len(api.regenerate(cube).data.polygons) == 1536, "without asking it is made"


def test_over_the_memory_budget_is_refused_before_anything_is_made(scene):
    grid = add("grid", x_subdivisions=150, y_subdivisions=150)
    before = positions(grid).copy()
    with pytest.raises(api.ThicketError, match="GB"):
        api.add_procedural_detail(grid, model="ROCK", levels=6)
    assert grid.thicket.result is None
    np.testing.assert_array_equal(positions(grid), before)


def test_a_non_manifold_mesh_is_refused_and_the_source_kept(scene):
    mesh = bpy.data.meshes.new("fin")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1)], [], [(0, 1, 2), (1, 0, 3), (0, 1, 4)])
    obj = bpy.data.objects.new("fin", mesh)
    bpy.context.scene.collection.objects.link(obj)
    with pytest.raises(api.ThicketError, match="manifold"):
        api.add_procedural_detail(obj, model="ROCK", levels=1)
    assert len(obj.data.polygons) == 3 and obj.thicket.result is None
    obj.thicket.items[0].levels = 2  # a live edit: the error is the stack's, for the panel
    assert "manifold" in obj.thicket.last_error and obj.thicket.result is None


def test_the_operator_adds_a_preset_before_the_shells_and_undoes(scene):
    cube = add("cube")
    select_only(cube)
    api.add_thick_surface(cube, thickness=0.05)
    assert {"REGISTER", "UNDO"} <= THICKET_OT_procedural_detail_add.bl_options
    bpy.ops.ed.undo_push(message="before")
    assert bpy.ops.thicket.procedural_detail_add(preset="BERRY") == {"FINISHED"}
    bpy.ops.ed.undo_push(message="Add Procedural Detail")
    cube = bpy.data.objects["Cube"]
    assert [i.kind for i in cube.thicket.items] == ["PROCEDURAL_DETAIL", "OFFSET_SHELL"]
    item = cube.thicket.items[0]
    assert item.detail_model == "BERRY" and item.levels == 4 and item.name == "Procedural Detail (Berry)"
    assert len(cube.thicket.result.data.polygons) == 6 * 4**4, "regenerated live"
    bpy.ops.ed.undo()
    cube = bpy.data.objects["Cube"]
    assert [i.kind for i in cube.thicket.items] == ["OFFSET_SHELL"]


def test_the_panel_draws_the_detail_settings(scene):
    from test_field_blender import Layout

    from thicket.ui.item_settings import draw_item_settings

    cube = add("cube")
    api.add_item(cube, "PROCEDURAL_DETAIL")
    item = cube.thicket.items[0]
    drawn = []
    draw_item_settings(Layout(drawn), cube, item)
    tail = ["detail_at", "blend_model", "local_object", "detail_shader", "confirm_above"]
    assert drawn == ["detail_model", "levels", "seed", "detail_amplitude", "follow_frame", *tail]
    with suspended():
        item.detail_model, item.blend_model, item.detail_shader = "BERRY", "ROCK", "PLANET"
        item.local_object = bpy.data.objects.new("center", None)
    drawn.clear()
    draw_item_settings(Layout(drawn), cube, item)
    assert drawn == [
        *["detail_model", "levels", "seed", "detail_radius", "detail_children", "follow_frame", "detail_seeds", "detail_at"],
        *["blend_model", "blend_seed", "blend_gain", "blend_alpha", "blend_point", "blend_direction", "blend_width"],
        *["local_object", "local_radius", "local_gain", "local_at", "detail_shader", "shader_sea", "shader_snow", "confirm_above"],
    ]
    # Animated: each part's rate beside it (the berry does not grow).
    with suspended():
        item.detail_model, item.follow_frame = "TENTACLE", True
    drawn.clear()
    draw_item_settings(Layout(drawn), cube, item)
    for near, rate in (("speed", "detail_spin"), ("detail_spin", "detail_grow"), ("blend_width", "blend_sweep"), ("shader_snow", "shader_sea_rate")):
        assert drawn[drawn.index(near) + 1] == rate, drawn


def test_a_saved_stack_reloads_with_its_detail(scene, tmp_path):
    cube = add("cube")
    api.add_procedural_detail(cube, preset="ROCK", seed=3)
    path = str(tmp_path / "detail.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    cube = bpy.data.objects["Cube"]
    item = cube.thicket.items[0]
    assert (item.kind, item.detail_model, item.levels, item.seed) == ("PROCEDURAL_DETAIL", "ROCK", 4, 3)
    np.testing.assert_array_equal(positions(api.regenerate(cube)), native_detail(cube, "rock", 4, 3, amplitude=0.03)["vertices"])


def attribute_values(mesh, name, width):
    attr = mesh.attributes[name]
    values = np.empty(len(attr.data) * width, np.float32)
    attr.data.foreach_get("color" if width == 4 else "value", values)
    return attr, values.reshape(-1, width) if width > 1 else values


def test_the_planet_preset_blends_two_rocks_and_colours_them(scene):
    sphere = add("uv_sphere", segments=24, ring_count=12)
    result = api.add_procedural_detail(sphere, preset="PLANET", levels=3)
    item = sphere.thicket.items[0]
    a = mesh_io.read_mesh(sphere.data)
    f32 = lambda x: float(np.float32(x))  # noqa: E731 (Blender stores floats in single precision)
    expected = tn.procedural_detail(
        a.vertices, a.face_sizes, a.corners, "rock", 3, 0, {"amplitude": f32(0.03)},
        blend={"model": "rock", "params": {"amplitude": f32(0.03) * f32(1.6)}, "seed": 2, "plane": ((0, 0, 0), (1, 2, 0)), "width": f32(0.3)},
        shader={"name": "planet", "sea": 0.0, "snow": f32(0.03)},
    )  # fmt: skip
    np.testing.assert_array_equal(positions(result), expected["vertices"])
    attr, colors = attribute_values(result.data, "thicket_color", 4)
    assert (attr.domain, attr.data_type) == ("POINT", "FLOAT_COLOR")
    np.testing.assert_allclose(colors, expected["colors"], atol=1e-6)
    assert result.data.color_attributes.active_color_name == "thicket_color"
    _, blend = attribute_values(result.data, "thicket_blend", 1)
    assert blend.min() == 0.0 and blend.max() == 1.0, "both sub-planets show"
    assert item.blend_model == "ROCK" and item.detail_shader == "PLANET"


def test_a_local_center_empty_scales_the_detail_near_it_and_follows_it(scene):
    sphere = add("ico_sphere", subdivisions=3)
    verts = positions(sphere)
    top, bottom = int(np.argmax(verts[:, 2])), int(np.argmin(verts[:, 2]))
    empty = bpy.data.objects.new("center", None)
    scene.collection.objects.link(empty)
    empty.location = verts[top] * 1.05
    bpy.context.view_layer.update()
    plain = api.add_procedural_detail(sphere, model="ROCK", levels=2, amplitude=0.03)
    before = positions(plain).copy()
    sphere.thicket.items[0].local_object = empty  # regenerates live (at once, headless)
    a = mesh_io.read_mesh(sphere.data)
    amplitude = float(np.float32(0.03))
    expected = tn.procedural_detail(
        a.vertices, a.face_sizes, a.corners, "rock", 2, 0, {"amplitude": amplitude}, local=[{"center": top, "radius": 2.0, "gain": 0.0}]
    )
    result = sphere.thicket.result
    np.testing.assert_array_equal(positions(result), expected["vertices"])
    moved = np.linalg.norm(positions(result) - before, axis=1)
    assert moved[top] > 0 and moved[bottom] == 0
    empty.location = verts[bottom] * 1.05
    bpy.context.view_layer.update()  # the depsgraph update the handler sees (background: regenerated at once)
    moved = np.linalg.norm(positions(result) - before, axis=1)
    assert moved[top] == 0 and moved[bottom] > 0, "the modification followed the empty"


def test_placement_at_chosen_levels_and_a_blend_by_vertex_group(scene):
    sphere = add("ico_sphere", subdivisions=3)
    verts = positions(sphere)
    upper = np.flatnonzero(verts[:, 2] > 0).tolist()
    sphere.vertex_groups.new(name="berries").add(upper, 1.0, "REPLACE")
    result = api.add_procedural_detail(sphere, model="ROCK", levels=2, amplitude=0.02, at=[2, 3, 4, 5, 6])
    a = mesh_io.read_mesh(sphere.data)
    amplitude = float(np.float32(0.02))
    np.testing.assert_array_equal(
        positions(result), tn.procedural_detail(a.vertices, a.face_sizes, a.corners, "rock", 2, 0, {"amplitude": amplitude}, at=[2, 3, 4, 5, 6])["vertices"]
    )
    item = sphere.thicket.items[0]
    with suspended():
        item.detail_at = (True,) * 6
        item.blend_model, item.blend_alpha, item.blend_group, item.blend_width = "BERRY", "GROUP", "berries", 1.0
    result = api.regenerate(sphere)
    weights = np.zeros(len(verts), np.float32)
    weights[upper] = 1.0
    radius = float(np.float32(item.detail_radius))
    expected = tn.procedural_detail(
        a.vertices, a.face_sizes, a.corners, "rock", 2, 0, {"amplitude": amplitude},
        blend={"model": "berry", "params": {"radius": radius, "children": 3}, "seed": 1, "weights": weights, "width": 1.0},
    )  # fmt: skip
    np.testing.assert_array_equal(positions(result), expected["vertices"])
    _, blend = attribute_values(result.data, "thicket_blend", 1)
    np.testing.assert_array_equal(blend, expected["blend"])
    assert blend[upper].min() == 1.0 and blend[np.flatnonzero(verts[:, 2] < 0)].max() == 0.0


def f32(x):
    """A float as Blender stores it in a float property (single precision)."""
    return float(np.float32(x))


def test_a_tentacle_grows_from_the_selected_vertex_and_turns_with_the_frame(scene):
    sphere = add("ico_sphere", subdivisions=2)
    tip = int(np.argmax(positions(sphere)[:, 2]))
    flags = np.zeros(len(sphere.data.vertices), bool)
    flags[tip] = True
    sphere.data.vertices.foreach_set("select", flags)
    result = api.add_procedural_detail(sphere, preset="TENTACLE", levels=3, seeds="SELECTED")
    a = mesh_io.read_mesh(sphere.data)
    params = {"length": f32(0.012), "theta": 0.0, "spacing": f32(0.25), "seeds": [tip]}
    np.testing.assert_array_equal(positions(result), tn.procedural_detail(a.vertices, a.face_sizes, a.corners, "tentacle", 3, 0, params)["vertices"])
    before = positions(result).copy()
    assert np.linalg.norm(before[tip]) - 1.0 > 0.05, "the tip stands out of the sphere"
    item = sphere.thicket.items[0]
    item.follow_frame = True
    scene.render.fps, scene.render.fps_base = 24, 1.0
    scene.frame_set(36)  # 1.5 s: the tentacle turns by 1.5 radians (regenerated at once, headless)
    turned = tn.procedural_detail(a.vertices, a.face_sizes, a.corners, "tentacle", 3, 0, dict(params, theta=1.5))
    np.testing.assert_allclose(positions(sphere.thicket.result), turned["vertices"], atol=1e-6)
    assert np.abs(positions(result) - before).max() > 1e-3, "the turn moved the tentacle"


@pytest.mark.parametrize("model", ["SPUR", "MUSHROOM", "FUSE"])
def test_every_model_is_the_native_one_in_the_stack(scene, model):
    obj = add("cylinder", vertices=16, depth=2.0) if model == "FUSE" else add("ico_sphere", subdivisions=2)
    result = api.add_procedural_detail(obj, model=model, levels=2, seed=3)
    item = obj.thicket.items[0]
    params = {
        "SPUR": {"length": f32(item.detail_length), "spacing": f32(item.detail_spacing)},
        "MUSHROOM": {"radius": f32(item.detail_radius), "length": f32(item.detail_length)},
        "FUSE": {"amplitude": f32(item.detail_amplitude), "span": f32(item.fuse_span), "axis": (0.0, 0.0, 1.0)},
    }[model]
    a = mesh_io.read_mesh(obj.data)
    expected = tn.procedural_detail(a.vertices, a.face_sizes, a.corners, model.lower(), 2, 3, params)
    np.testing.assert_array_equal(positions(result), expected["vertices"])
    plain = tn.procedural_detail(a.vertices, a.face_sizes, a.corners, "rock", 2, 0, {"amplitude": 0.0})
    assert np.abs(positions(result) - plain["vertices"]).max() > 1e-3, "the model moved the surface"


def test_no_chosen_level_and_a_bad_setting_are_refused_without_leftovers(scene):
    cube = add("cube")
    api.add_procedural_detail(cube, model="ROCK", levels=1)
    cube.thicket.items[0].detail_at = (False,) * 6  # a live edit: the stack's error
    assert "tick at least one level" in cube.thicket.last_error
    with pytest.raises(TypeError):
        api.add_procedural_detail(cube, model="MARBLE")
    assert len(cube.thicket.items) == 1, "no half-set item left behind"
    with pytest.raises(api.ThicketError, match="tick at least one level"):
        api.add_procedural_detail(cube, model="ROCK", at=[])


def test_seeds_after_an_earlier_detail_item_are_the_source_vertices_only(scene):
    """After a first Procedural Detail, a selected source vertex seeds one tentacle
    (its own vertex), not one on every vertex that kept its weight."""
    sphere = add("ico_sphere", subdivisions=2)
    tip = int(np.argmax(positions(sphere)[:, 2]))
    flags = np.zeros(len(sphere.data.vertices), bool)
    flags[tip] = True
    sphere.data.vertices.foreach_set("select", flags)
    api.add_procedural_detail(sphere, model="ROCK", levels=1, amplitude=0.0)
    result = api.add_procedural_detail(sphere, model="SPUR", levels=1, seeds="SELECTED")
    order = [i.detail_model for i in sphere.thicket.items]
    assert order == ["ROCK", "SPUR"]
    a = mesh_io.read_mesh(sphere.data)
    rock = tn.procedural_detail(a.vertices, a.face_sizes, a.corners, "rock", 1, 0, {"amplitude": 0.0})
    item = sphere.thicket.items[1]
    spur = tn.procedural_detail(
        rock["vertices"],
        rock["face_sizes"],
        rock["corners"],
        "spur",
        1,
        0,
        {"length": f32(item.detail_length), "spacing": f32(item.detail_spacing), "seeds": [tip]},
    )
    np.testing.assert_allclose(positions(result), spur["vertices"], atol=1e-6)


def test_a_rock_too_rough_for_a_dense_mesh_is_guarded_and_the_user_told(scene):
    """The rock preset on a dense sphere would fold it; the item's result does not cross
    itself (Blender's BVH overlap) and the panel's note says the detail was reduced and
    how to keep it as set; a rock the mesh takes gets no such note."""
    sphere = add("ico_sphere", subdivisions=5)
    result = api.add_procedural_detail(sphere, preset="ROCK", levels=2)
    assert "so the surface does not fold" in sphere.thicket.last_note, sphere.thicket.last_note
    sizes, corners = face_vertices(result.data)
    assert (sizes == 4).all() and quad_crossings(positions(result), corners) == 0, "no two triangles that share no vertex cross"
    api.remove(sphere)
    api.add_procedural_detail(sphere, model="ROCK", levels=2, amplitude=0.0005)
    assert "does not fold" not in sphere.thicket.last_note, sphere.thicket.last_note


def test_every_uv_map_goes_through_the_levels_as_blenders_modifier_takes_it(scene):
    """Both UV maps of the source (the sphere's own, seams along a meridian and at the
    poles, and a Smart UV Project of other islands, the active one) come out under their
    names, the active one active, each equal corner by corner to Blender's Subdivision
    Surface modifier's (limit surface off, the same levels, UV Smooth "Keep Boundaries")
    on the source: UVs do not depend on the positions, so the rock's detail leaves them
    as they are."""
    from test_subdivision import blender_subdivided, corner_uv_difference

    sphere = add("uv_sphere", segments=16, ring_count=8)
    mesh = sphere.data
    mesh.uv_layers.active = mesh.uv_layers.new(name="Smart")
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.uv.smart_project()
    bpy.ops.object.mode_set(mode="OBJECT")
    assert [uv.name for uv in mesh.uv_layers] == ["UVMap", "Smart"] and mesh.uv_layers.active.name == "Smart"
    levels = 3
    result = api.add_procedural_detail(sphere, model="ROCK", levels=levels, amplitude=0.03, seed=2)
    ours = mesh_io.read_mesh(result.data)
    assert [uv.name for uv in result.data.uv_layers] == ["UVMap", "Smart"] and ours.uv_name == "Smart"
    assert "UV" not in sphere.thicket.last_note
    base = mesh_io.read_mesh(mesh)
    # The result's faces and corners are `subdivide`'s (checked in test_procedural_detail):
    # its level-3 control mesh places the faces for matching with the modifier's.
    plain = tn.subdivide(base.vertices, base.face_sizes, base.corners, levels, False)
    np.testing.assert_array_equal(ours.face_sizes, plain["face_sizes"])
    assert len(np.unique(np.stack([ours.corners, plain["corners"]], axis=1), axis=0)) == len(plain["vertices"])
    theirs = blender_subdivided(sphere, levels, False, uv_smooth="PRESERVE_BOUNDARIES")
    assert set(theirs.uv_maps) == {"UVMap", "Smart"}
    diagonal = float(np.linalg.norm(np.ptp(theirs.vertices, axis=0)))
    for name in ("UVMap", "Smart"):
        theirs.uvs = theirs.uv_maps[name]
        difference = corner_uv_difference(dict(plain, uvs=ours.uv_maps[name]), theirs, diagonal)
        assert difference <= 1e-5, f"{name}: {difference:.3g}"
    assert np.abs(ours.uv_maps["UVMap"] - ours.uv_maps["Smart"]).max() > 0.1


@pytest.mark.parametrize("primitive", ["uv_sphere", "ico_sphere", "cube"])
def test_the_berry_preset_on_a_primitive_is_not_noted_as_made_smaller(scene, primitive):
    """The berry preset as added, on Blender's convex primitives: its child domes fit
    on their parents', so the guard shrinks under SHRUNK_NOTE of the dome vertices by
    over a tenth and the item says nothing about it (it said 91% on the UV sphere)."""
    from thicket.pure.kinds.procedural_detail import SHRUNK_NOTE

    obj = add(primitive)
    api.add_procedural_detail(obj, preset="BERRY")
    assert obj.thicket.result is not None and "made visibly smaller" not in obj.thicket.last_note
    assert native_detail(obj, "berry", 4, radius=0.12, children=3)["shrunk"] <= SHRUNK_NOTE


def test_the_made_smaller_note_states_the_share_the_guard_visibly_reduced(scene):
    """The note reports `shrunk` (dome vertices the fold guard cut by over a tenth,
    once per vertex and level) and stays silent where the guard reduced nothing:
    level-1 domes on a convex sphere. On Suzanne, whose ears, eyes and creases bend
    tighter than the preset's domes, the domes are flattened at most vertices."""
    from thicket.pure.kinds.procedural_detail import SHRUNK_NOTE

    calm = add("uv_sphere")
    api.add_procedural_detail(calm, model="BERRY", levels=2, radius=0.1, children=0)
    assert native_detail(calm, "berry", 2, radius=0.1, children=0)["limited"] == 0.0
    assert "made visibly smaller" not in calm.thicket.last_note
    busy = add("monkey", location=(4.0, 0.0, 0.0))
    api.add_procedural_detail(busy, model="BERRY", levels=2, radius=0.12, children=0)
    share = native_detail(busy, "berry", 2, radius=0.12, children=0)["shrunk"]
    assert share > 10 * SHRUNK_NOTE and f"made visibly smaller (by over a tenth) at {share:.0%} of its vertices" in busy.thicket.last_note
