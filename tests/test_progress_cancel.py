"""Progress and cancel (issue 15): shells and bakes report a share done that only
grows and ends at 1.0; a callback answering False (or raising, or Ctrl-C) stops the
work in the core, and nothing changes: not the source, not the previous result."""

import os
import signal
import threading
import time

import bpy
import numpy as np
import pytest
from conftest import add, select_only

from thicket import api, mesh_io
from thicket.operators.common import Job, JobWatch
from thicket.operators.regenerate import watched_regeneration
from thicket.pure import live_shells
from thicket.pure.evaluate import progress_spans
from thicket.stack.regenerate import enabled_settings

tn = pytest.importorskip("thicket_native")


def arrays_of(obj):
    mesh = mesh_io.read_mesh(obj.data)
    return mesh.vertices.copy(), mesh.face_sizes.copy(), mesh.corners.copy()


def same(before, obj):
    return all(np.array_equal(a, b) for a, b in zip(before, arrays_of(obj)))


def assert_same(before, obj):
    assert same(before, obj)


def big_sphere():
    """A sphere whose field shell takes many of the callback's 100 ms periods (about
    a second on 2 cores)."""
    return add("ico_sphere", subdivisions=8)  # 163,842 vertices


def shelled(obj):
    """`obj` with a field Shell and its result, then a thicker setting not applied yet
    (auto-update off), so that a regeneration that goes through changes the result."""
    api.add_thick_surface(obj, kind="SHELL", thickness=0.05)
    obj.thicket.auto_update = False
    obj.thicket.items[0].thickness = 0.08
    return api.result_of(obj)


def textured(obj, **settings):
    """`obj` with a Shell and a Volumetric Texture item and a result of them, then a
    changed setting (not applied: auto-update off), so that a regeneration that goes
    through changes the result."""
    api.add_volumetric_texture(obj, "weave", shell_thickness=0.05, triangle_budget=0, **settings)
    obj.thicket.auto_update = False
    obj.thicket.items[1].tiling = 2.0
    return api.result_of(obj)


def test_a_shell_reports_monotone_progress_ending_at_one(scene):
    sphere = big_sphere()
    base = mesh_io.read_mesh(sphere.data)
    seen = []
    tn.shell(base.vertices, base.face_sizes, base.corners, 0.05, relative=True, progress=seen.append)
    assert seen == sorted(seen), seen
    assert seen[0] < 1.0 and any(0.0 < f < 1.0 for f in seen) and seen[-1] == 1.0, seen
    # The same from build_shell and from a kept (incremental) shell, and watching
    # changes nothing in the result.
    base = mesh_io.read_mesh(add("ico_sphere", subdivisions=4).data)
    out = tn.shell(base.vertices, base.face_sizes, base.corners, 0.05, relative=True, progress=lambda f: None)
    plain = tn.shell(base.vertices, base.face_sizes, base.corners, 0.05, relative=True)
    assert np.array_equal(out["directors"], plain["directors"])
    tris = np.asarray(base.corners, np.int32).reshape(-1, 3)
    small = []
    tn.build_shell(base.vertices, tris, 0.02, "envelope", progress=small.append)
    assert small == sorted(small) and small[-1] == 1.0, small
    kept = []
    tn.IncrementalShell(base.vertices, base.face_sizes, base.corners, 0.05, relative=True, progress=kept.append)
    assert kept == sorted(kept) and kept[-1] == 1.0, kept


def test_a_shell_stops_in_the_core_when_the_callback_says_so(scene):
    sphere = big_sphere()
    base = mesh_io.read_mesh(sphere.data)
    args = (base.vertices, base.face_sizes, base.corners, 0.05)
    seen = []

    def stop_after_start(fraction):
        seen.append(fraction)
        return fraction == 0.0

    with pytest.raises(tn.Cancelled, match="cancelled"):
        tn.shell(*args, relative=True, progress=stop_after_start)
    # Cancelled at the first report of a vertex traced: the core stopped then (the
    # last report, 1.0, only comes from a finished shell).
    assert set(seen[:-1]) == {0.0} and 0.0 < seen[-1] < 1.0, seen
    with pytest.raises(tn.Cancelled):
        tn.IncrementalShell(*args, relative=True, progress=lambda f: False)

    class Stop(Exception):
        pass

    def stop(fraction):
        raise Stop

    small = mesh_io.read_mesh(add("ico_sphere", subdivisions=2).data)
    with pytest.raises(Stop):
        tn.build_shell(small.vertices, np.asarray(small.corners, np.int32).reshape(-1, 3), 0.05, "exterior", progress=stop)
    assert issubclass(tn.Cancelled, tn.ThicketError)


def test_a_bake_reports_monotone_progress_ending_at_one(scene):
    sphere = add("ico_sphere", subdivisions=3)
    base = mesh_io.read_mesh(sphere.data)
    shell = tn.shell(base.vertices, base.face_sizes, base.corners, 0.05, relative=True)
    args = (base.vertices, base.face_sizes, base.corners, shell["base_offset"], shell["directors"], [tn.texture("weave")])
    seen = []
    tn.bake_texture(*args, triangle_budget=0, progress=seen.append)
    assert len(seen) >= 2 and seen == sorted(seen) and seen[0] < 1.0 and seen[-1] == 1.0, seen


def test_regenerate_reports_the_whole_stack_monotone_ending_at_one(scene):
    sphere = add("ico_sphere", subdivisions=4)
    textured(sphere, resolution=16)  # a bake of about a second: reports on its way
    seen = []
    api.regenerate(sphere, progress=seen.append, fresh=True)
    assert seen == sorted(seen) and seen[0] == 0.0 and seen[-1] == 1.0, seen
    # The shell's share ends where the bake's begins: the end of the first item is heard.
    shell_end = progress_spans(enabled_settings(sphere))[0][1]
    assert 0.0 < shell_end < 1.0 and shell_end in seen, (shell_end, seen)
    assert any(shell_end < f < 1.0 for f in seen), seen  # the bake reported on its way


@pytest.mark.parametrize("where", ["shell", "bake", "start"])
def test_cancelling_regenerate_keeps_the_source_and_the_previous_result(scene, where):
    if where == "shell":
        sphere = big_sphere()
        result = shelled(sphere)
    else:
        sphere = add("ico_sphere", subdivisions=4)
        result = textured(sphere, resolution=16)  # a bake of about a second
    source_before, result_before = arrays_of(sphere), arrays_of(result)
    assert len(result_before[0]) > 0
    shell_end = progress_spans(enabled_settings(sphere))[0][1]
    seen = []

    def answer(fraction):
        seen.append(fraction)
        if where == "start":
            return False
        if where == "shell":
            return fraction == 0.0  # the first report inside the shell cancels
        return fraction <= shell_end  # the first report inside the bake cancels

    with pytest.raises(tn.Cancelled):
        api.regenerate(sphere, progress=answer, fresh=True)
    if where == "start":
        assert seen == [0.0]
    elif where == "shell":
        assert shell_end == 1.0 and 0.0 < max(seen) < 1.0, seen  # stopped inside the shell
        assert not live_shells._kept  # a cancelled shell is not kept for edits
    else:
        assert shell_end < max(seen) < 1.0, seen  # stopped inside the bake
    assert_same(source_before, sphere)
    assert_same(result_before, result)
    assert api.result_of(sphere) == result
    # Not cancelled, the same regeneration goes through and changes the result.
    api.regenerate(sphere)
    assert not same(result_before, result)


def test_an_exception_in_the_callback_cancels_and_comes_back(scene):
    sphere = add("ico_sphere", subdivisions=4)
    result = textured(sphere)
    before = arrays_of(result)

    class Stop(Exception):
        pass

    def stop(fraction):
        if fraction > 0.0:
            raise Stop(fraction)

    with pytest.raises(Stop):
        api.regenerate(sphere, progress=stop, fresh=True)
    assert_same(before, result)


def test_the_modal_watch_cancels_on_esc_and_reports(scene):
    # What the Regenerate operator's modal handler runs (windows and events are
    # missing in background mode, so the events are fed here): Esc cancels the job on
    # its worker thread, the timer sees it end, and nothing was written.
    sphere = big_sphere()
    result = shelled(sphere)
    source_before, result_before = arrays_of(sphere), arrays_of(result)
    reports = []
    watch = watched_regeneration(bpy.context, sphere, False, lambda kind, text: reports.append((kind, text)))
    watch.job.start()
    assert watch.event(bpy.context, "TIMER") == {"RUNNING_MODAL"}  # running: waits
    assert watch.event(bpy.context, "A", "PRESS") == {"RUNNING_MODAL"}  # other keys wait too
    assert watch.event(bpy.context, "MIDDLEMOUSE", "PRESS") == {"PASS_THROUGH"}  # navigation goes on
    status = watch.event(bpy.context, "ESC", "PRESS")
    while status == {"RUNNING_MODAL"}:
        watch.job._thread.join(0.05)
        status = watch.event(bpy.context, "TIMER")
    assert status == {"CANCELLED"}
    assert any(kind == {"WARNING"} and "cancelled" in text for kind, text in reports), reports
    assert watch.job.fraction < 1.0  # stopped inside the shell
    assert not live_shells._kept
    assert_same(source_before, sphere)
    assert_same(result_before, result)
    # Without Esc the same watch writes the result.
    watch = watched_regeneration(bpy.context, sphere, False, lambda kind, text: reports.append((kind, text)))
    watch.job.start()
    status = {"RUNNING_MODAL"}
    while status == {"RUNNING_MODAL"}:
        watch.job._thread.join(0.05)
        status = watch.event(bpy.context, "TIMER")
    assert status == {"FINISHED"} and watch.job.fraction == 1.0
    assert not same(result_before, result)


def test_a_job_cancelled_after_its_work_ended_still_changes_nothing():
    job = Job(lambda job: "done").start()
    job._thread.join()
    job.cancel()
    finished = []
    watch = JobWatch(job, "Work", lambda kind, text: None, lambda result: finished.append(result) or {"FINISHED"})
    assert watch.conclude() == {"CANCELLED"} and finished == []


def test_the_operator_cancels_on_ctrl_c_with_a_report(scene, capfd):
    # Headless, `execute` runs the job on the main thread, where Ctrl-C cancels it.
    sphere = big_sphere()
    start = time.perf_counter()
    result = shelled(sphere)
    took = time.perf_counter() - start  # about what the operator will take
    source_before, before = arrays_of(sphere), arrays_of(result)
    select_only(sphere)
    armed = threading.Event()

    def interrupt(signum, frame):
        if armed.is_set():
            raise KeyboardInterrupt

    previous = signal.signal(signal.SIGINT, interrupt)
    timer = threading.Timer(took / 4, lambda: os.kill(os.getpid(), signal.SIGINT))
    try:
        armed.set()
        timer.start()
        status = bpy.ops.thicket.regenerate()
        armed.clear()
    finally:
        armed.clear()
        timer.cancel()
        signal.signal(signal.SIGINT, previous)
    assert status == {"CANCELLED"}
    assert "cancelled; nothing was changed" in capfd.readouterr().out
    assert_same(before, result)
    assert_same(source_before, sphere)
    assert sphere.thicket.last_error == ""  # a cancel is no error
    # And without Ctrl-C the operator finishes.
    assert bpy.ops.thicket.regenerate() == {"FINISHED"}
    assert not same(before, result)


def test_a_reference_render_reports_its_rows_and_stops_when_cancelled(scene):
    # The CPU reference render (what previews with holes, regions or cutters use)
    # counts its rows; answering False stops it in the core with Cancelled.
    sphere = add("uv_sphere", segments=32, ring_count=16)
    a = mesh_io.read_mesh(sphere.data)
    out = tn.shell(a.vertices, a.face_sizes, a.corners, 0.05, relative=True)
    texture = tn.texture("chain_mail", (32, 32, 16))
    view = np.array(((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, -5), (0, 0, 0, 1)), np.float32)
    projection = np.array(((2, 0, 0, 0), (0, 2, 0, 0), (0, 0, -1.02, -0.2), (0, 0, -1, 0)), np.float32)
    args = (a.vertices, a.face_sizes, a.corners, out["base_offset"], out["directors"], [texture], view, projection, 96, 72)
    seen = []
    frame = tn.render_shell(*args, method="reference", progress=lambda f: seen.append(f))
    assert seen[-1] == 1.0 and all(x <= y for x, y in zip(seen, seen[1:]))
    assert (frame["rgba"][:, :, 3] > 0.5).mean() > 0.05
    asked = []

    def stop(fraction):
        asked.append(fraction)
        return len(asked) < 2  # answers False on the second call

    big = args[:-2] + (640, 480)  # long enough for the callback's second call
    with pytest.raises(tn.Cancelled):
        tn.render_shell(*big, method="reference", step=0.01, progress=stop)
    assert len(asked) >= 2 and max(asked) < 1.0
