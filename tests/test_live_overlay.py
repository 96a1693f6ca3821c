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

from thicket import api
from thicket.render import lights, overlay

VIEW = ((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, -6), (0, 0, 0, 1))  # looking along +y from y = -6
PROJECTION = ((2, 0, 0, 0), (0, 2, 0, 0), (0, 0, -1.02, -0.2), (0, 0, -1, 0))
REFERENCE = dict(method="reference")


@pytest.fixture
def clean(scene):
    overlay.cancel()
    overlay._state.update(views={}, prepared=None, error="", note="", failed=None, started=-1e9)
    yield scene
    overlay.cancel()
    overlay.wait()
    overlay._state.update(views={}, prepared=None, error="", note="", failed=None, started=-1e9)


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
