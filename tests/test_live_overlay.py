"""The live preview's evaluation off the main thread (`render.overlay`): the
preparation (the stack before the drawn item, shells included, and the native handle)
runs as one build per source and each view's frame as one build per view, on the
stack's worker machinery (`stack.live_build`). Background Blender has no window and
runs no timers, so the tests drive what the overlay's timer calls (`overlay.refresh`,
with stand-in 3D views) and what the builds' timer calls (`overlay.wait`), as
test_stack_live does for the stack."""

import types

import bpy
import numpy as np
import pytest
from conftest import add
from test_stack_live import field_tree

from thicket import api
from thicket.render import lights, overlay

VIEW = ((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, -6), (0, 0, 0, 1))  # looking along +y from y = -6
PROJECTION = ((2, 0, 0, 0), (0, 2, 0, 0), (0, 0, -1.02, -0.2), (0, 0, -1, 0))
REFERENCE = dict(method="reference")


@pytest.fixture
def clean(scene):
    overlay.cancel()
    overlay._state.update(views={}, prepared=None, error="", note="", failed=None, started=-1e9, shown=None)
    yield scene
    overlay.cancel()
    overlay.wait()
    overlay._state.update(views={}, prepared=None, error="", note="", failed=None, started=-1e9, shown=None)


def _sphere(pattern="chain_mail"):
    sphere = add("uv_sphere", segments=24, ring_count=12)
    api.add_volumetric_texture(sphere, pattern, shell_thickness=0.08, resolution=4, depth_steps=8)
    sphere.thicket.auto_update = False  # only the preview evaluates here
    bpy.context.view_layer.objects.active = sphere
    return sphere


def _region(view=VIEW):
    """A stand-in for a 3D view's RegionView3D (what `camera.viewport_camera` reads)."""
    import mathutils

    return types.SimpleNamespace(view_matrix=mathutils.Matrix(view), window_matrix=mathutils.Matrix(PROJECTION))


def _frame(handle, width=40, height=30, **settings):
    """What the handle renders now on this thread (the reference renderer unless
    `settings` say otherwise)."""
    v, p = np.array(VIEW, np.float32), np.array(PROJECTION, np.float32)
    return handle.render(v, p, width, height, **(settings or REFERENCE))["rgba"]


def test_the_preparation_builds_on_a_worker_and_is_kept_only_when_polled(clean):
    sphere = _sphere()
    overlay.start_prepare(sphere)
    assert overlay._preparations.running(sphere) and overlay.progress() is not None
    assert overlay._state["prepared"] is None  # nothing kept before the timer
    overlay.wait()
    assert not overlay._preparations.running(sphere) and overlay.progress() is None
    key, handle = overlay._state["prepared"]
    assert key == overlay.content_key(sphere)
    # The same handle a preparation on this thread makes: the same frame.
    overlay._state["prepared"] = None
    _, here = overlay._prepared(sphere)
    np.testing.assert_array_equal(_frame(handle), _frame(here))
    assert overlay._state["error"] == ""


def test_a_newer_change_cancels_the_preparation_in_flight(clean):
    sphere = _sphere()
    overlay.start_prepare(sphere)
    first = overlay._preparations.builds[sphere.session_uid].job
    sphere.thicket.items[-1].tiling = 2.0
    overlay.start_prepare(sphere)
    assert first.cancelled
    if not first.done:  # the newer waits for the older's cancel: never two at once
        assert sphere.session_uid not in overlay._preparations.builds and overlay._preparations.running(sphere)
    overlay.wait()
    key, handle = overlay._state["prepared"]
    assert key == overlay.content_key(sphere)
    overlay._state["prepared"] = None
    np.testing.assert_array_equal(_frame(handle), _frame(overlay._prepared(sphere)[1]))  # the second state's


def test_a_stale_preparation_is_dropped(clean):
    """A setting changed behind the build, and an undo (its handler drops the builds):
    neither keeps the build's handle."""
    sphere = _sphere()
    overlay.start_prepare(sphere)
    sphere.thicket.items[-1].tiling = 3.0  # nothing started a preparation for this
    overlay.wait()
    assert overlay._state["prepared"] is None
    overlay.watch()
    try:
        assert overlay.on_undo_pre in bpy.app.handlers.undo_pre and overlay.on_undo_pre in bpy.app.handlers.redo_pre
        overlay.start_prepare(sphere)
        overlay.on_undo_pre()
        assert not overlay._preparations.running(sphere)
        overlay.wait()
        assert overlay._state["prepared"] is None
    finally:
        overlay.unwatch()
    assert overlay.on_undo_pre not in bpy.app.handlers.undo_pre


def test_an_error_is_shown_and_not_retried_until_the_content_changes(clean):
    sphere = add("ico_sphere", subdivisions=2)
    api.add_thick_surface(sphere, kind="OFFSET_SHELL")  # nothing the renderers draw
    sphere.thicket.auto_update = False
    views = [(1, 40, 30, _region())]
    overlay.refresh(sphere, views, now=0.0)
    overlay.wait()
    assert "no enabled Volumetric Texture" in overlay._state["error"] and overlay._state["prepared"] is None
    overlay.refresh(sphere, views, now=10.0)
    assert not overlay._preparations.running(sphere), "the same content is not prepared again"
    assert overlay.status_line().startswith("Thicket preview: ") and "Volumetric Texture" in overlay.status_line()
    api.add_item(sphere, "VOLUMETRIC_TEXTURE", pattern="rivets", resolution=4, depth_steps=8)
    sphere.thicket.auto_update = False
    overlay.refresh(sphere, views, now=20.0)
    assert overlay._preparations.running(sphere)
    overlay.wait()
    assert overlay._state["error"] == "" and overlay._state["prepared"] is not None


def test_refresh_prepares_then_renders_each_view_and_keeps_the_last_image(clean):
    """What the timer does: a view of a source not prepared waits for the
    preparation; once it landed the view's frame renders on a worker, and the image is
    kept only for what the view still wants. A change of content keeps the last image
    shown until the new one lands."""
    sphere = _sphere()
    overlay.refresh(sphere, [(1, 40, 30, _region())], now=0.0)
    assert overlay._preparations.running(sphere) and not overlay._renders.builds, "no frame before the handle"
    overlay.wait()
    (view,) = overlay.refresh(sphere, [(1, 40, 30, _region())], now=1.0)
    assert overlay._renders.running(view)
    overlay.wait()
    assert view.key == view.want and view.result.shape == (30, 40, 4)
    light = lights.scene_light(bpy.context.evaluated_depsgraph_get(), sphere)
    np.testing.assert_array_equal(view.result, _frame(overlay._state["prepared"][1], light=light))  # as the timer renders it
    first = view.result
    # Nothing changed: nothing renders again.
    overlay.refresh(sphere, [(1, 40, 30, _region())], now=2.0)
    assert not overlay._renders.running(view) and overlay._state["prepared"][0] == overlay.content_key(sphere)
    # The view moves while its frame renders: that render is cancelled and dropped,
    # a newer one starts once THROTTLE has passed.
    moved = ((1, 0, 0, 0.3), (0, 0, 1, 0), (0, -1, 0, -6), (0, 0, 0, 1))
    overlay.refresh(sphere, [(1, 40, 30, _region(moved))], now=3.0)
    job = overlay._renders.builds[view.session_uid].job
    overlay.refresh(sphere, [(1, 40, 30, _region())], now=3.0 + overlay.THROTTLE / 2)
    assert job.cancelled and view.session_uid not in overlay._renders.builds
    overlay.wait()
    assert view.result is first, "the cancelled render left the image as it was"
    # The content changes: the handle is prepared again, the view keeps its image meanwhile.
    view.result = None
    sphere.thicket.items[-1].tiling = 2.0
    overlay.refresh(sphere, [(1, 40, 30, _region())], now=4.0)
    assert overlay._preparations.running(sphere) and not overlay._renders.running(view) and view.result is None
    overlay.wait()
    overlay.refresh(sphere, [(1, 40, 30, _region())], now=5.0)
    overlay.wait()
    assert view.key == view.want and view.result is not None
    assert not np.array_equal(view.result, first), "the new tiling shows"


def test_switching_objects_cancels_the_other_preparation_and_drops_its_result(clean):
    """Another object made active while one is prepared: the first preparation is
    cancelled, and a result or error of an object no longer shown is not kept (it
    would take the single prepared slot, or show the old object's error)."""
    first, second = _sphere(), _sphere("rivets")
    overlay.refresh(first, [(1, 40, 30, _region())], now=0.0)
    job = overlay._preparations.builds[first.session_uid].job
    overlay.refresh(second, [(1, 40, 30, _region())], now=1.0)
    assert job.cancelled and overlay._preparations.running(second)
    overlay.wait()
    assert overlay._state["prepared"][0] == overlay.content_key(second)
    kept = overlay._state["prepared"]
    build = types.SimpleNamespace(read=overlay.content_key(first))
    overlay._preparations.write(first, build, object())  # what a late landing of the first calls
    overlay._preparations.fail(first, ValueError("the first object's error"))
    assert overlay._state["prepared"] is kept and overlay._state["error"] == ""


def test_the_content_key_follows_the_field_tree_and_not_the_panel(clean):
    """The preview keys on what the stale check reads: a field node tree's edit (no
    depsgraph counter sees it) prepares again; renaming or expanding an item does not."""
    tree, ball = field_tree()
    cube = add("cube", size=2.0)
    api.add_volumetric_texture(
        cube, field_tree_json=tree, shell_thickness=0.1, texture_size=16, resolution=4, depth_steps=6, follow_texture=False, triangle_budget=0
    )
    cube.thicket.auto_update = False
    key = overlay.content_key(cube)
    item = cube.thicket.items[-1]
    item.show_expanded = not item.show_expanded
    item.name = "Renamed"
    assert overlay.content_key(cube) == key
    ball.radius = 0.15
    assert overlay.content_key(cube) != key


def test_a_file_load_turns_the_preview_off(clean):
    """Blender drops the preview's timer on a file load: the load ends the preview
    (draw handler, images, native handle), so it does not show as on while dead."""
    overlay.watch()
    assert overlay.on_load_pre in bpy.app.handlers.load_pre
    overlay._state.update(handle=bpy.types.SpaceView3D.draw_handler_add(overlay._draw, (), "WINDOW", "POST_PIXEL"), prepared=("key", object()))
    overlay._state["views"][1] = overlay.View(1)
    assert overlay.is_enabled()
    overlay.on_load_pre()
    assert not overlay.is_enabled() and overlay._state["prepared"] is None and overlay._state["views"] == {}
    overlay.unwatch()


def test_a_file_load_stops_the_depsgraph_scan_until_the_preview_restarts(clean):
    """The load's stop takes the preview's depsgraph (and undo) handlers with it: the
    new file's updates are not scanned for a preview that is off. Its own `load_pre`
    handler stays (Blender is running that list); watching again (`enable`) adds the
    rest back."""
    overlay.watch()
    try:
        overlay._state["generations"][123] = 4
        overlay.on_load_pre()
        assert overlay.on_depsgraph_update not in bpy.app.handlers.depsgraph_update_post
        assert overlay.on_undo_pre not in bpy.app.handlers.undo_pre and overlay.on_undo_pre not in bpy.app.handlers.redo_pre
        assert overlay.on_load_pre in bpy.app.handlers.load_pre and overlay._state["generations"] == {}
        sphere = _sphere()
        sphere.data.vertices[0].co.x += 0.1
        sphere.data.update()
        bpy.context.evaluated_depsgraph_get().update()
        assert overlay.generation(sphere) == 0, "nothing scanned while off"
        overlay.watch()
        assert overlay.on_depsgraph_update in bpy.app.handlers.depsgraph_update_post
        sphere.data.vertices[0].co.x += 0.1
        sphere.data.update()
        bpy.context.evaluated_depsgraph_get().update()
        assert overlay.generation(sphere) == 1
    finally:
        overlay.unwatch()


def _field_cube():
    tree, ball = field_tree()
    cube = add("cube", size=2.0)
    api.add_volumetric_texture(
        cube, field_tree_json=tree, shell_thickness=0.1, texture_size=16, resolution=4, depth_steps=6, follow_texture=False, triangle_budget=0
    )
    cube.thicket.auto_update = False
    bpy.context.view_layer.objects.active = cube
    return cube, ball


def test_the_timer_reads_a_field_trees_contents_only_when_they_may_have_changed(clean, monkeypatch):
    """A field node tree's JSON is what the timer's key cost: read on every tick (and
    three times per preparation: its inputs, its start, its landing). Now the key is
    kept while the object's changes (`generation`) and item values stay the same, the
    tree read again at most every CONTENTS_SECONDS; once per preparation."""
    cube, ball = _field_cube()
    clock = [100.0]
    monkeypatch.setattr(overlay, "_clock", lambda: clock[0])
    real, reads = overlay.content_key, []
    monkeypatch.setattr(overlay, "content_key", lambda obj: reads.append(obj) or real(obj))
    overlay.refresh(cube, [], now=clock[0])
    assert overlay._preparations.running(cube)
    overlay.wait()
    assert overlay._state["prepared"] is not None and overlay._state["error"] == ""
    assert len(reads) == 2, "the tick's look, then the preparation's read: nothing at its start or landing"
    reads.clear()
    for _ in range(20):  # two seconds of ticks, nothing changed
        clock[0] += 0.1
        overlay.refresh(cube, [], now=clock[0])
    assert 1 <= len(reads) <= 2.0 / overlay.CONTENTS_SECONDS + 1
    assert not overlay._preparations.running(cube)
    # An item's value counts at once; a tree's edit within CONTENTS_SECONDS.
    cube.thicket.items[-1].tiling = 2.0
    overlay.refresh(cube, [], now=clock[0])
    assert overlay._preparations.running(cube)
    overlay.wait()
    ball.radius = 0.15
    clock[0] += overlay.CONTENTS_SECONDS
    overlay.refresh(cube, [], now=clock[0])
    assert overlay._preparations.running(cube)
    overlay.wait()
    assert overlay._state["prepared"][0] == real(cube)


def test_another_objects_change_leaves_the_preparation_running(clean):
    """Changes are counted per object: editing another stack's mesh does not cancel
    the shown object's preparation (steady changes elsewhere, such as drivers, would
    keep it preparing for ever)."""
    shown = _sphere()
    other = add("cube", size=1.0, location=(4, 0, 0))
    api.add_thick_surface(other, kind="OFFSET_SHELL")
    other.thicket.auto_update = False
    bpy.context.view_layer.objects.active = shown
    overlay.watch()
    try:
        bpy.context.evaluated_depsgraph_get()
        key = overlay.content_key(shown)
        overlay.refresh(shown, [(1, 40, 30, _region())], now=0.0)
        job = overlay._preparations.builds[shown.session_uid].job
        other.data.vertices[0].co.x += 0.1
        other.data.update()
        bpy.context.evaluated_depsgraph_get().update()
        assert overlay.generation(other) > 0 and overlay.content_key(shown) == key
        overlay.refresh(shown, [(1, 40, 30, _region())], now=0.1)
        assert not job.cancelled
        shown.data.vertices[0].co.x += 0.1  # its own change still counts
        shown.data.update()
        bpy.context.evaluated_depsgraph_get().update()
        assert overlay.content_key(shown) != key
    finally:
        overlay.unwatch()


def test_closed_views_are_dropped_with_their_renders(clean):
    sphere = _sphere()
    overlay.refresh(sphere, [(1, 40, 30, _region())], now=0.0)
    overlay.wait()
    (view,) = overlay.refresh(sphere, [(1, 40, 30, _region())], now=1.0)
    job = overlay._renders.builds[1].job
    overlay.refresh(sphere, [(2, 40, 30, _region())], now=2.0)  # area 1 closed, another opened
    assert set(overlay._state["views"]) == {2} and job.cancelled
    overlay.wait()
    assert view.result is None, "the closed view's render is dropped"


def test_the_preparation_key_is_taken_after_its_read(clean, monkeypatch):
    """A read that itself counted a change (temporary objects of a sculpt's read)
    still lands a key equal to the content after it: nothing prepares again."""
    from thicket.stack import regenerate

    sphere = _sphere()
    real = regenerate.read_source

    def counting_read(obj, *args, **kwargs):
        generations = overlay._state["generations"]
        generations[obj.session_uid] = generations.get(obj.session_uid, 0) + 1
        return real(obj, *args, **kwargs)

    monkeypatch.setattr(regenerate, "read_source", counting_read)
    overlay.refresh(sphere, [(1, 40, 30, _region())], now=0.0)
    overlay.wait()
    assert overlay._state["prepared"] is not None and overlay._state["prepared"][0] == overlay.content_key(sphere)
    overlay.refresh(sphere, [(1, 40, 30, _region())], now=10.0)
    assert not overlay._preparations.running(sphere)


EXIT_SCRIPT = """
import atexit, os, sys
sys.path.insert(0, {tests!r})
import bpy
from conftest import add
from thicket import api
from thicket.render import overlay
import test_live_overlay as t

s = add("uv_sphere", segments=48, ring_count=24)
api.add_volumetric_texture(s, "chain_mail", shell_thickness=0.08, resolution=8, depth_steps=16)
s.thicket.auto_update = False
overlay._state["started"] = -1e9  # no throttle at the first look
overlay.refresh(s, [(1, 800, 600, t._region())], now=0.0)
overlay.wait()
overlay.refresh(s, [(1, 800, 600, t._region())], now=1.0)
assert overlay._renders.running(overlay._state["views"][1])
overlay.cancel()  # left running: the exit must wait for it
print("exiting")
if bpy.app.version < (4, 3, 0):  # that module crashes in teardown (see conftest): exit as the tests do
    sys.stdout.flush()
    atexit._run_exitfuncs()
    os._exit(0)
"""


def test_a_cancelled_render_is_waited_for_at_exit(tmp_path):
    """A cancelled frame still running when Python ends would call back into Python
    (its progress) after it ended, which aborts the process: the exit waits for it."""
    import pathlib
    import subprocess
    import sys

    script = tmp_path / "exit_while_rendering.py"
    script.write_text(EXIT_SCRIPT.format(tests=str(pathlib.Path(__file__).parent)))
    proc = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=300)
    assert "exiting" in proc.stdout, proc.stderr[-2000:]
    assert proc.returncode == 0, proc.stderr[-2000:]
