"""The thick-surface stack in real Blender: operators, persistence, regeneration."""

import bpy
import numpy as np
import pytest
from conftest import add, positions, select_only

from thicket import api
from thicket.pure.arrays import weight_attribute


def test_operator_on_every_selected_mesh_skips_non_meshes(scene):
    monkey = add("monkey")
    cube = add("cube", location=(3, 0, 0))
    bpy.ops.object.light_add(type="POINT")
    light = bpy.context.active_object
    select_only(monkey, cube, light)
    before = {o.name: positions(o).copy() for o in (monkey, cube)}
    assert bpy.ops.thicket.add_thick_surface(thickness=0.02, output="SOLID") == {"FINISHED"}
    for obj in (monkey, cube):
        result = obj.thicket.result
        assert result is not None and result.name == f"{obj.name}_thicket"
        assert result.parent == obj
        assert len(result.data.vertices) == 2 * len(obj.data.vertices)
        np.testing.assert_array_equal(positions(obj), before[obj.name])  # source untouched
    assert len(light.thicket.items) == 0 and light.thicket.result is None
    assert {o.name for o in bpy.data.objects} == {"Suzanne", "Suzanne_thicket", "Cube", "Cube_thicket", light.name}


def test_offset_matches_blender_solidify(scene):
    """Independent reference: Solidify (Simple, offset +1, no rim) moves the base by
    thickness x Blender's vertex normal; the Offset Shell must land on the same points."""
    monkey = add("monkey")
    api.add_thick_surface(monkey, thickness=0.1, thickness_mode="ABSOLUTE", output="OUTER")
    ours = positions(monkey.thicket.result)
    solidify = monkey.modifiers.new("ref", "SOLIDIFY")
    solidify.thickness, solidify.offset, solidify.use_rim = 0.1, 1.0, False
    evaluated = monkey.evaluated_get(bpy.context.evaluated_depsgraph_get())
    reference = positions(evaluated.to_mesh())[: len(monkey.data.vertices)]
    evaluated.to_mesh_clear()
    np.testing.assert_allclose(ours, reference, atol=2e-5)


def test_persistence_through_save_and_reload(scene, tmp_path):
    cube = add("cube")
    api.add_thick_surface(cube, thickness=0.25, thickness_mode="ABSOLUTE", output="LAYERS", surfaces=3)
    path = str(tmp_path / "stack.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.open_mainfile(filepath=path)
    cube = bpy.data.objects["Cube"]
    item = cube.thicket.items[0]
    assert (item.thickness, item.thickness_mode, item.output, item.surfaces) == (0.25, "ABSOLUTE", "LAYERS", 3)
    assert cube.thicket.result.name == "Cube_thicket"
    assert cube.thicket.result.thicket.source == cube
    item.surfaces = 2  # still live after reload
    assert len(cube.thicket.result.data.vertices) == 16


def test_regenerates_after_editing_source_and_settings(scene):
    cube = add("cube")
    api.add_thick_surface(cube, thickness=0.1, thickness_mode="ABSOLUTE")
    result = cube.thicket.result
    co = positions(cube)
    co[:, 0] *= 2.0
    cube.data.vertices.foreach_set("co", co.ravel())
    cube.data.update()
    bpy.context.view_layer.update()  # the depsgraph update that drives regeneration
    assert positions(result)[:, 0].max() == pytest.approx(2.0 + 0.1 / np.sqrt(3), abs=1e-5)  # was 1 + 0.1/sqrt(3)
    cube.thicket.items[0].thickness = 0.3  # a setting change regenerates too
    assert np.linalg.norm(positions(result) - co, axis=1).max() == pytest.approx(0.3, abs=1e-5)


def test_edit_mode_changes_regenerate(scene):
    cube = add("cube")
    api.add_thick_surface(cube, thickness=0.1, thickness_mode="ABSOLUTE")
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.transform.translate(value=(0, 0, 1))
    bpy.context.view_layer.update()
    bpy.ops.object.mode_set(mode="OBJECT")
    assert positions(cube.thicket.result)[:, 2].min() > -0.2


def test_vertex_group_scales_thickness(scene):
    grid = add("grid", x_subdivisions=4, y_subdivisions=4, size=2)
    group = grid.vertex_groups.new(name="w")
    co = positions(grid)
    right = np.flatnonzero(co[:, 0] > 0.1)
    group.add(right.tolist(), 0.5, "REPLACE")
    api.add_thick_surface(grid, thickness=0.2, thickness_mode="ABSOLUTE", vertex_group="w")
    moved = positions(grid.thicket.result)[:, 2]
    expected = np.zeros(len(co))
    expected[right] = 0.1
    np.testing.assert_allclose(moved, expected, atol=1e-6)
    assert not any(o.name.startswith(".thicket probe") for o in bpy.data.objects)
    assert weight_attribute("w") not in grid.data.attributes  # nothing left on the source


def test_chained_items_follow_vertex_group_through_provenance(scene):
    grid = add("grid", x_subdivisions=3, y_subdivisions=3, size=2)
    grid.vertex_groups.new(name="w").add(list(range(len(grid.data.vertices))), 1.0, "REPLACE")
    api.add_thick_surface(grid, thickness=0.1, thickness_mode="ABSOLUTE", output="LAYERS", surfaces=2)
    api.add_item(grid, "OFFSET_SHELL", thickness=0.05, thickness_mode="ABSOLUTE", vertex_group="w")
    result = api.regenerate(grid)
    z = np.unique(np.round(positions(result)[:, 2], 5))
    np.testing.assert_allclose(z, [0.1, 0.15], atol=1e-5)  # surfaces at 0.05 and 0.1, then +0.05
    director = np.empty(len(result.data.vertices) * 3, np.float32)
    result.data.attributes["thicket_director"].data.foreach_get("vector", director)
    np.testing.assert_allclose(director.reshape(-1, 3)[:, 2], 0.05, atol=1e-6)


def test_item_add_remove_move_and_hide(scene):
    cube = add("cube")
    select_only(cube)
    bpy.ops.thicket.add_thick_surface(thickness=0.1, thickness_mode="ABSOLUTE")
    assert bpy.ops.thicket.item_add(kind="OFFSET_SHELL") == {"FINISHED"}
    stack = cube.thicket
    stack.items[1].thickness = 0.5
    stack.items[1].name = "second"
    assert bpy.ops.thicket.item_move(direction="UP") == {"FINISHED"}
    assert [i.name for i in stack.items] == ["second", "Offset Shell"]
    stack.items[0].show_viewport = False
    assert np.abs(positions(stack.result)).max() == pytest.approx(1 + 0.1 / np.sqrt(3), abs=1e-5)
    stack.active_index = 1
    assert bpy.ops.thicket.item_remove() == {"FINISHED"}
    assert len(stack.items) == 1


def test_apply_makes_ordinary_mesh_and_removes_stack(scene):
    cube = add("cube", location=(1, 2, 3))
    select_only(cube)
    bpy.ops.thicket.add_thick_surface()
    result = cube.thicket.result
    world_before = np.array([result.matrix_world @ v.co for v in result.data.vertices[:4]])
    assert bpy.ops.thicket.apply() == {"FINISHED"}
    assert result.parent is None and result.thicket.source is None
    assert len(cube.thicket.items) == 0 and cube.thicket.result is None
    world_after = np.array([result.matrix_world @ v.co for v in result.data.vertices[:4]])
    np.testing.assert_allclose(world_after, world_before, atol=1e-6)
    cube.location.x += 5  # no longer follows or regenerates
    bpy.context.view_layer.update()
    assert result.parent is None


def test_remove_deletes_stack_and_result(scene):
    cube = add("cube")
    select_only(cube)
    bpy.ops.thicket.add_thick_surface()
    mesh_name = cube.thicket.result.data.name
    assert bpy.ops.thicket.remove() == {"FINISHED"}
    assert "Cube_thicket" not in bpy.data.objects and mesh_name not in bpy.data.meshes
    assert len(cube.thicket.items) == 0
    assert len(cube.data.vertices) == 8


def test_operators_declare_undo_and_poll():
    from thicket.operators import CLASSES

    for op in CLASSES:
        assert {"REGISTER", "UNDO"} <= set(op.bl_options), op.bl_idname
        assert hasattr(op, "poll"), op.bl_idname


def test_selecting_result_acts_on_source(scene):
    cube = add("cube")
    select_only(cube)
    bpy.ops.thicket.add_thick_surface()
    result = cube.thicket.result
    select_only(result)
    assert bpy.ops.thicket.regenerate() == {"FINISHED"}
    select_only(result)
    assert bpy.ops.thicket.add_thick_surface.poll()
    bpy.ops.thicket.add_thick_surface()
    assert len(result.thicket.items) == 0, "a result never gets a stack of its own"


def test_a_misspelt_setting_is_refused_and_adds_no_item(scene):
    """A keyword that is no stack item setting (a typo) used to land as a plain Python
    attribute on the item and change nothing; it is refused, with the near name."""
    obj = add("cube")
    with pytest.raises(TypeError, match="detail_modl.*did you mean 'detail_model'"):
        api.add_item(obj, "PROCEDURAL_DETAIL", detail_modl="BERRY")
    with pytest.raises(TypeError, match="not a stack item setting: 'model'"):
        api.add_detail_item(obj, model="BERRY")
    assert len(obj.thicket.items) == 0
    item = api.add_item(obj, "PROCEDURAL_DETAIL", detail_model="BERRY")
    assert item.detail_model == "BERRY"
