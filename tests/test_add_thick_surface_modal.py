"""Add Thick Surface from the interface (issue 15): the shells of every selected mesh
are built on a worker thread that a modal operator watches, with one progress over
all objects; Esc keeps the objects already finished and leaves the others as they
were. Background mode has no window, so the modal's events are fed here, as the
Regenerate tests do, to the watch the operator's `invoke` runs."""

import threading

import bpy
import numpy as np
import pytest
from conftest import add, mesh_object, run_modal, select_only

from thicket import api, mesh_io
from thicket.operators.add_thick_surface import watched_thick_surfaces
from thicket.pure import live_shells

pytest.importorskip("thicket_native")


def arrays_of(obj):
    mesh = mesh_io.read_mesh(obj.data)
    return mesh.vertices.copy(), mesh.face_sizes.copy(), mesh.corners.copy()


def assert_same(before, obj):
    for a, b in zip(before, arrays_of(obj)):
        np.testing.assert_array_equal(a, b)


def watch_for(objects, kind="OFFSET_SHELL", **item):
    """The watch `invoke` starts for these selected objects, and its reports."""
    reports = []
    item = dict(dict(thickness=0.05, thickness_mode="RELATIVE", output="OUTER"), **item)
    watch = watched_thick_surfaces(objects, kind, item, lambda kind, text: reports.append((kind, text)))
    return watch, reports


def two_pairs():
    """Two identical selections: a monkey with no stack and a sphere whose stack was
    set up but not generated (the operator keeps an existing stack)."""
    pairs = []
    for x in (0, 6):
        monkey = add("monkey", location=(x, 0, 0))
        sphere = add("ico_sphere", subdivisions=3, location=(x, 3, 0))
        api.add_item(sphere, "OFFSET_SHELL", thickness=0.1, thickness_mode="ABSOLUTE", output="LAYERS", surfaces=2)
        pairs.append((monkey, sphere))
    return pairs


@pytest.mark.parametrize("kind,output", [("OFFSET_SHELL", "SOLID"), ("SHELL", "OUTER")])
def test_modal_run_makes_what_execute_makes(scene, kind, output):
    (a, b), (c, d) = two_pairs()
    sources = {o.name: arrays_of(o) for o in (a, b, c, d)}
    live_shells.clear()
    select_only(a, b)
    assert bpy.ops.thicket.add_thick_surface(kind=kind, output=output, thickness=0.03, side="ENVELOPE") == {"FINISHED"}
    live_shells.clear()
    watch, reports = watch_for([c, d], kind, thickness=0.03, output=output, side="ENVELOPE")
    assert run_modal(watch) == {"FINISHED"} and watch.job.fraction == 1.0
    assert not any(k & {"ERROR", "WARNING"} for k, _ in reports), reports
    for blocking, modal in ((a, c), (b, d)):
        assert len(modal.thicket.items) == 1 and modal.thicket.last_error == ""
        assert modal.thicket.items[0].to_settings() == blocking.thicket.items[0].to_settings()
        result = modal.thicket.result
        assert result is not None and result.parent == modal and result.name == f"{modal.name}_thicket"
        expected = arrays_of(blocking.thicket.result)
        source = sources[blocking.name][0]
        assert not np.allclose(expected[0][: len(source)], source)  # a shell, not a copy
        assert_same(expected, result)
        assert set(result.data.attributes.keys()) == set(blocking.thicket.result.data.attributes.keys())
        assert modal.thicket.last_report == blocking.thicket.last_report
    for obj in (a, b, c, d):
        assert_same(sources[obj.name], obj)  # sources untouched
    assert a.thicket.items[0].kind == kind and b.thicket.items[0].output == "LAYERS"  # the kept stack


def test_progress_covers_all_objects_monotone_to_one(scene):
    small = add("ico_sphere", subdivisions=3)
    big = add("ico_sphere", subdivisions=7, location=(3, 0, 0))  # a shell of about half a second
    watch, _ = watch_for([small, big], "SHELL")
    seen, polled = [], []
    watch.job.on_progress = seen.append  # from the worker thread
    assert run_modal(watch, lambda: polled.append(watch.job.fraction)) == {"FINISHED"}
    assert seen == sorted(seen) and seen[0] == 0.0 and seen[-1] == 1.0, seen
    assert polled == sorted(polled), polled
    assert 0.5 in seen  # the first object's end is the second one's start
    assert any(0.5 < f < 1.0 for f in seen), seen  # the big shell reported on its way
    assert small.thicket.result is not None and big.thicket.result is not None


@pytest.mark.parametrize("where", ["start", "between", "inside"])
def test_esc_keeps_finished_objects_and_leaves_the_rest_untouched(scene, where):
    first = add("ico_sphere", subdivisions=3)
    second = add("ico_sphere", subdivisions=7, location=(3, 0, 0))
    third = add("cube", location=(6, 0, 0))
    objects = (first, second, third)
    before = {o.name: arrays_of(o) for o in objects}
    watch, reports = watch_for(list(objects), "SHELL")
    held, release = threading.Event(), threading.Event()

    def hold(fraction):  # stops the worker at the chosen report until Esc was pressed
        at = {"start": fraction == 0.0, "between": fraction >= 1 / 3, "inside": 1 / 3 < fraction < 2 / 3}[where]
        if at and not held.is_set():
            held.set()
            release.wait(30)

    watch.job.on_progress = hold

    def esc_once_held():
        if held.is_set() and not release.is_set():
            assert watch.event(bpy.context, "ESC", "PRESS") == {"RUNNING_MODAL"}
            release.set()

    try:
        status = run_modal(watch, esc_once_held)
    finally:
        release.set()
    assert held.is_set()
    kept = [] if where == "start" else [first]
    assert status == ({"FINISHED"} if kept else {"CANCELLED"})
    for obj in objects:
        assert_same(before[obj.name], obj)
        assert obj.thicket.last_error == ""
        if obj in kept:
            assert len(obj.thicket.items) == 1 and obj.thicket.items[0].kind == "SHELL"
            assert len(arrays_of(obj.thicket.result)[0]) == len(obj.data.vertices)  # outer surface
        else:
            assert len(obj.thicket.items) == 0 and obj.thicket.result is None
            assert f"{obj.name}_thicket" not in bpy.data.objects
    cancelled = [text for kind, text in reports if kind == {"WARNING"} and "cancelled" in text]
    assert len(cancelled) == 1, reports
    assert f"{len(kept)} of 3 done" in cancelled[0]
    assert all(o.name in cancelled[0] for o in objects if o not in kept)
    # Not cancelled, the same objects get their thick surfaces.
    select_only(*objects)
    assert bpy.ops.thicket.add_thick_surface(kind="SHELL") == {"FINISHED"}
    assert all(o.thicket.result is not None for o in objects)


def test_failures_are_kept_and_reported_as_from_execute(scene):
    good = add("cube")
    bad = mesh_object("Empty", [], [])
    watch, reports = watch_for([good, bad])
    assert run_modal(watch) == {"FINISHED"}  # one worked
    assert good.thicket.result is not None and good.thicket.last_error == ""
    assert "empty" in bad.thicket.last_error and len(bad.thicket.items) == 1 and bad.thicket.result is None
    assert ({"WARNING"}, f"Empty: {bad.thicket.last_error}") in reports
    # All failed: CANCELLED with an ERROR report, the error kept on the stack.
    worse = mesh_object("Worse", [], [])
    watch, reports = watch_for([worse])
    assert run_modal(watch) == {"CANCELLED"}
    assert [kind for kind, _ in reports] == [{"ERROR"}] and "empty" in worse.thicket.last_error


def test_invoke_without_a_window_runs_blocking(scene):
    cube = add("cube")
    select_only(cube)
    assert bpy.ops.thicket.add_thick_surface("INVOKE_DEFAULT", thickness=0.1, thickness_mode="ABSOLUTE") == {"FINISHED"}
    assert len(cube.thicket.result.data.vertices) == 8
    select_only(cube.thicket.result)  # only a result selected: nothing to do
    assert bpy.ops.thicket.add_thick_surface() == {"CANCELLED"}
