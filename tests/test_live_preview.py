"""The live preview follows every change of what it shows (issue 15: it refreshed
only when the view moved). The overlay's drawing needs a window, which background
Blender has not; what decides a redraw does not: the preview's content key changes
on real depsgraph updates of the source (mesh edits, modifiers, vertex groups, a
cutter object, stack settings) and not on updates of unrelated objects."""

import bpy
import numpy as np
import pytest

from thicket import api
from thicket.render import overlay


@pytest.fixture
def watched(scene):
    overlay.watch()
    yield
    overlay.unwatch()


def _source():
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=2)
    obj = bpy.context.active_object
    api.add_volumetric_texture(obj, pattern="chain_mail")
    obj.thicket.auto_update = False  # nothing to bake here: only what decides a redraw
    return obj


def _changes(what, obj):
    before = overlay.content_key(obj)
    what()
    bpy.context.view_layer.update()
    return overlay.content_key(obj) != before


def test_the_preview_key_follows_the_source_and_ignores_the_rest(watched):
    obj = _source()
    bpy.ops.mesh.primitive_cube_add(location=(5, 0, 0))
    other = bpy.context.active_object
    bpy.context.view_layer.update()

    def edit_mesh():
        co = np.empty(len(obj.data.vertices) * 3, np.float32)
        obj.data.vertices.foreach_get("co", co)
        co[2] += 0.1
        obj.data.vertices.foreach_set("co", co)
        obj.data.update()

    def add_modifier():
        obj.modifiers.new("twist", "SIMPLE_DEFORM")

    def paint_weights():
        group = obj.vertex_groups.new(name="w")
        group.add([0, 1, 2], 0.5, "REPLACE")

    def change_setting():
        obj.thicket.items[-1].tiling = 2.0

    def move_other():
        other.location.x += 1.0

    def edit_other():
        other.data.vertices[0].co.x += 0.1
        other.data.update()

    assert _changes(edit_mesh, obj)
    assert _changes(add_modifier, obj)
    assert _changes(paint_weights, obj)
    assert _changes(change_setting, obj)
    assert not _changes(move_other, obj)
    assert not _changes(edit_other, obj)
    # The other object becomes the texture's cutter: moving it now changes the preview.
    obj.thicket.items[-1].cutter = other
    bpy.context.view_layer.update()
    assert _changes(move_other, obj)


def test_watching_stops(watched):
    obj = _source()
    overlay.unwatch()
    start = overlay.generation(obj)
    obj.modifiers.new("twist", "SIMPLE_DEFORM")
    bpy.context.view_layer.update()
    assert overlay.generation(obj) == start


def test_an_object_made_again_under_the_same_name_is_a_new_preview(scene):
    """A stale handle must not outlive its object: the same name and settings in a
    new object (or a file loaded anew) are another preview, also when no update was
    counted in between (nothing watched here)."""
    obj = _source()
    name, before = obj.name, overlay.content_key(obj)
    bpy.data.objects.remove(obj)
    again = _source()
    again.name = name
    assert again.name == name
    assert overlay.content_key(again) != before
