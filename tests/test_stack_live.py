"""The stack's live regeneration off the main thread (`stack.auto_update.start`, the
interface's path; background mode regenerates at once, so the tests drive the worker
path by hand and call what its timer calls: `auto_update.poll`/`wait`)."""

import json
import math
import threading
import time
import types

import bpy
import numpy as np
from conftest import add, positions

from thicket import api, mesh_io
from thicket.pure import live_shells
from thicket.stack import auto_update, live_build
from thicket.stack.guard import suspended


def _edit(obj, offset):
    """Moves the source's first vertices without a depsgraph update (nothing is
    scheduled: background mode would regenerate at once)."""
    co = positions(obj).copy()
    co[: len(co) // 3] += offset
    obj.data.vertices.foreach_set("co", co.ravel())
    obj.data.update()


def _synchronous(obj):
    """The result a synchronous regeneration writes now."""
    api.regenerate(obj)
    return positions(obj.thicket.result).copy()


def _monkey(kind="OFFSET_SHELL", **settings):
    monkey = add("monkey")
    api.add_thick_surface(monkey, kind=kind, thickness=0.05, **settings)
    return monkey


def test_a_change_builds_on_a_worker_and_writes_only_when_polled(scene):
    monkey = _monkey()
    before = positions(monkey.thicket.result).copy()
    _edit(monkey, (0.0, 0.0, 0.2))
    auto_update.start(monkey)
    assert auto_update.running(monkey) and auto_update.progress(monkey) is not None
    np.testing.assert_array_equal(positions(monkey.thicket.result), before)  # nothing written before the timer
    auto_update.wait()
    assert not auto_update.running(monkey) and auto_update.poll() is None  # the timer stops
    live = positions(monkey.thicket.result).copy()
    assert not np.array_equal(live, before)
    np.testing.assert_array_equal(live, _synchronous(monkey))
    assert monkey.thicket.last_error == ""


def test_a_newer_change_cancels_the_build_in_flight(scene):
    monkey = _monkey()
    _edit(monkey, (0.0, 0.0, 0.2))
    auto_update.start(monkey)
    first = auto_update._live.builds[monkey.session_uid].job
    _edit(monkey, (0.0, 0.3, 0.0))
    auto_update.start(monkey)
    assert first.cancelled
    if not first.done:  # the newer waits for the older's cancel to land: never two at once
        assert monkey.session_uid not in auto_update._live.builds and auto_update.running(monkey)
    auto_update.wait()
    assert not auto_update.running(monkey)
    live = positions(monkey.thicket.result).copy()
    np.testing.assert_array_equal(live, _synchronous(monkey))  # the second state's result, not the first's


def test_a_stale_result_is_dropped(scene):
    """A source changed behind the build (nothing scheduled it), an undo (its handler
    drops builds) and a stack setting changed since: none writes the build's result."""
    monkey = _monkey()
    before = positions(monkey.thicket.result).copy()
    _edit(monkey, (0.0, 0.0, 0.2))
    auto_update.start(monkey)
    _edit(monkey, (0.0, 0.0, 0.2))  # nothing scheduled this
    auto_update.wait()
    np.testing.assert_array_equal(positions(monkey.thicket.result), before)

    assert auto_update.on_undo_pre in bpy.app.handlers.undo_pre and auto_update.on_undo_pre in bpy.app.handlers.redo_pre
    auto_update.start(monkey)
    auto_update.on_undo_pre()
    assert not auto_update.running(monkey)
    auto_update.wait()
    np.testing.assert_array_equal(positions(monkey.thicket.result), before)

    auto_update.start(monkey)
    monkey.thicket.auto_update = False  # so the change below schedules nothing
    monkey.thicket.items[0].thickness = 0.2
    monkey.thicket.auto_update = True
    auto_update.wait()
    np.testing.assert_array_equal(positions(monkey.thicket.result), before)


def test_an_error_lands_in_last_error(scene):
    """A bake over its Ask Above stops on the worker: the question goes to the
    stack's last error, the result stays."""
    sphere = add("ico_sphere", subdivisions=2)
    api.add_volumetric_texture(sphere, "weave", resolution=4, depth_steps=8)
    before = positions(sphere.thicket.result).copy()
    sphere.thicket.auto_update = False
    sphere.thicket.items[1].resolution = 12
    sphere.thicket.items[1].confirm_above = 1000
    sphere.thicket.auto_update = True
    auto_update.start(sphere)
    _edit(sphere, (0.0, 0.0, 0.1))  # stale: its error is dropped with it
    auto_update.wait()
    assert sphere.thicket.last_error == ""
    auto_update.start(sphere)
    auto_update.wait()
    assert "(over 1,000): click Regenerate to confirm" in sphere.thicket.last_error, sphere.thicket.last_error
    np.testing.assert_array_equal(positions(sphere.thicket.result), before)


def test_an_unreadable_source_sets_last_error_at_once(scene):
    monkey = _monkey()
    monkey.thicket.auto_update = False
    monkey.thicket.items[0].vertex_group = "missing"
    monkey.thicket.auto_update = True
    auto_update.start(monkey)
    assert not auto_update.running(monkey) and "missing" in monkey.thicket.last_error


def test_a_cancelled_build_leaves_the_kept_shells_whole(scene):
    """Incremental shells: after a cancelled build the kept shells are still there,
    one per source, and the next regeneration updates from them to what a build from
    scratch gives."""
    monkey = _monkey("SHELL")
    kept = len(live_shells._kept)
    assert kept >= 1
    _edit(monkey, (0.0, 0.0, 0.02))
    auto_update.start(monkey)
    job = auto_update._live.builds[monkey.session_uid].job
    auto_update.cancel(monkey)
    job.join(60)
    assert job.done and auto_update.poll() is None
    assert len(live_shells._kept) == kept
    live_shells.recent.clear()
    live = _synchronous(monkey)
    assert None not in live_shells.recent, "updated from the kept shell"
    api.regenerate(monkey, fresh=True)
    fresh = positions(monkey.thicket.result)
    diag = float(np.linalg.norm(np.ptp(positions(monkey), axis=0)))
    differs = np.linalg.norm(live - fresh, axis=1)
    # As in test_shell: a few vertices may be given back their length in one only.
    assert np.median(differs) < 1e-4 * diag and np.count_nonzero(differs > 0.01 * diag) <= len(differs) // 100


def test_regenerate_drops_the_build_in_flight(scene):
    monkey = _monkey()
    _edit(monkey, (0.0, 0.0, 0.2))
    auto_update.start(monkey)
    job = auto_update._live.builds[monkey.session_uid].job
    bpy.context.view_layer.objects.active = monkey
    assert bpy.ops.thicket.regenerate() == {"FINISHED"}
    assert job.cancelled and not auto_update.running(monkey)
    written = positions(monkey.thicket.result).copy()
    auto_update.wait()
    np.testing.assert_array_equal(positions(monkey.thicket.result), written)
    np.testing.assert_array_equal(written, _synchronous(monkey))


def test_animation_renders_regenerate_per_frame_only_with_the_interface_locked(scene):
    """In the interface the frame-change handler runs on the render thread during an
    animation render: results are regenerated there only with Lock Interface on, and
    the panel says so for a source that changes with the frame."""
    obj = add("cube")
    assert auto_update.animation_render_hint(obj, scene, background=False) == ""  # no stack
    item = api.add_detail_item(obj, detail_model="TENTACLE", levels=1)
    assert auto_update.animation_render_hint(obj, scene, background=False) == ""  # still
    item.follow_frame = True
    item.detail_spin = 1.0
    scene.render.use_lock_interface = False
    assert "Lock Interface" in auto_update.animation_render_hint(obj, scene, background=False)
    assert auto_update.animation_render_hint(obj, scene) == ""  # background: renders run here
    scene.render.use_lock_interface = True
    assert auto_update.animation_render_hint(obj, scene, background=False) == ""
    assert not auto_update.renders_each_frame(scene)  # no render running


def test_the_stale_check_keys_on_item_properties_and_reads_no_mesh(scene, monkeypatch):
    """`source_state` (taken when a build starts and again before it writes) reads
    the items' own property values, not their evaluated settings: a Volumetric
    Texture's cutter mesh is read once per build (by the source's read), not by the
    check; a property changed in flight makes the build stale; a panel-only one
    (Expanded) does not."""
    sphere = add("ico_sphere", subdivisions=2)
    api.add_volumetric_texture(sphere, "weave", resolution=4, depth_steps=8)
    sphere.thicket.items[1].cutter = add("uv_sphere", segments=64, ring_count=32, radius=0.4, location=(0.8, 0.0, 0.0))
    api.regenerate(sphere)
    before = positions(sphere.thicket.result).copy()
    reads = []
    real = mesh_io.read_solid
    monkeypatch.setattr(mesh_io, "read_solid", lambda *args: reads.append(args) or real(*args))
    state = auto_update.source_state(sphere)
    assert auto_update.source_state(sphere) == state and reads == []
    # A property changed in flight (nothing scheduled it): stale, dropped.
    auto_update.start(sphere)
    assert len(reads) == 1, "the build's own read of the cutter"
    sphere.thicket.auto_update = False
    sphere.thicket.items[1].feature_thickness *= 1.5
    sphere.thicket.auto_update = True
    assert auto_update.source_state(sphere) != state
    auto_update.wait()
    np.testing.assert_array_equal(positions(sphere.thicket.result), before)
    assert len(reads) == 1, "the check at the write read no mesh"
    # A panel-only property changed in flight: written, as a synchronous regeneration.
    auto_update.start(sphere)
    sphere.thicket.items[1].show_expanded = not sphere.thicket.items[1].show_expanded
    auto_update.wait()
    live = positions(sphere.thicket.result).copy()
    assert not np.array_equal(live, before)
    np.testing.assert_array_equal(live, _synchronous(sphere))
    assert len(reads) == 3


def field_tree(with_output=True):
    """A field node tree of one ball (`ball`, returned with it), its Output linked unless not `with_output`."""
    tree = bpy.data.node_groups.new("Texture Field", "ThicketFieldTree")
    ball = tree.nodes.new("ThicketNodeSphere")
    ball.center, ball.radius = (0.5, 0.5, 0.5), 0.3
    if with_output:
        tree.links.new(ball.outputs[0], tree.nodes.new("ThicketNodeOutput").inputs[0])
    return tree, ball


def test_a_field_tree_or_text_edited_behind_the_build_makes_it_stale(scene):
    """Edits of a field node tree or of a Text reach no depsgraph counter: the state
    holds what they hold (the tree's JSON, the Text's digest)."""
    tree, ball = field_tree()
    settings = dict(shell_thickness=0.1, texture_size=16, resolution=4, depth_steps=6, follow_texture=False, triangle_budget=0)
    by_nodes, by_text = add("cube", size=2.0), add("cube", size=2.0, location=(3, 0, 0))
    api.add_volumetric_texture(by_nodes, field_tree_json=tree, **settings)
    text = bpy.data.texts.new("field")
    text.write(json.dumps({"op": "sphere", "center": [0.5, 0.5, 0.5], "radius": 0.3}))
    api.add_volumetric_texture(by_text, field_tree_json=text, **settings)
    assert by_text.thicket.items[-1].tree_text == text
    states = [auto_update.source_state(obj) for obj in (by_nodes, by_text)]
    for obj in (by_nodes, by_text):
        obj.thicket.auto_update = False
    ball.radius = 0.15
    text.clear()
    text.write(json.dumps({"op": "sphere", "center": [0.5, 0.5, 0.5], "radius": 0.2}))
    assert [auto_update.source_state(obj) != state for obj, state in zip((by_nodes, by_text), states)] == [True, True]


def test_a_tree_the_item_no_longer_reads_leaves_its_build_current(scene):
    """A pattern texture still pointing at a field node tree (left from when it was
    the source) does not read it: an edit of that tree behind a mesh edit's build
    leaves the build current (nothing else would redo it: only items whose source is
    the tree follow its edits), and the mesh edit's result is written."""
    sphere = add("ico_sphere", subdivisions=2)
    api.add_volumetric_texture(sphere, "weave", resolution=4, depth_steps=8)
    tree, ball = field_tree()
    item = sphere.thicket.items[-1]
    item.field_nodes = tree
    assert item.source == "PATTERN"
    api.regenerate(sphere)
    before = positions(sphere.thicket.result).copy()
    _edit(sphere, (0.0, 0.0, 0.2))
    auto_update.start(sphere)
    ball.radius = 0.2
    auto_update.wait()
    live = positions(sphere.thicket.result).copy()
    assert not np.array_equal(live, before), "the mesh edit's result is written"
    np.testing.assert_array_equal(live, _synchronous(sphere))


def test_an_unreadable_tree_never_raises_out_of_a_build_start(scene):
    """A field node tree without an Output: left on a pattern item, it is not read
    (the build writes); as the item's source, the build's error is the item's
    `last_error`, never raised into the timer that starts builds."""
    sphere = add("ico_sphere", subdivisions=2)
    api.add_volumetric_texture(sphere, "weave", resolution=4, depth_steps=8)
    tree, _ball = field_tree(with_output=False)
    item = sphere.thicket.items[-1]
    sphere.thicket.auto_update = False
    item.field_nodes = tree
    sphere.thicket.auto_update = True
    auto_update.source_state(sphere)  # does not raise
    _edit(sphere, (0.0, 0.0, 0.2))
    auto_update.start(sphere)
    auto_update.wait()
    assert sphere.thicket.last_error == ""
    sphere.thicket.auto_update = False
    item.source = "FIELD_NODES"
    sphere.thicket.auto_update = True
    auto_update.source_state(sphere)  # does not raise either
    auto_update.start(sphere)
    auto_update.wait()
    assert sphere.thicket.last_error != ""


def test_moving_the_source_makes_a_build_with_a_cutter_stale(scene):
    """A cutter is read in the source's space: the source moved behind the build
    changes its result, so the build is dropped (no depsgraph counter names it: a
    move is no geometry change)."""
    sphere = add("ico_sphere", subdivisions=2)
    api.add_volumetric_texture(sphere, "weave", resolution=4, depth_steps=8)
    state = auto_update.source_state(sphere)
    sphere.location.x += 0.5
    bpy.context.view_layer.update()
    assert auto_update.source_state(sphere) == state, "no cutter: the placement is not read"
    sphere.thicket.items[1].cutter = add("uv_sphere", segments=16, ring_count=8, radius=0.4, location=(0.8, 0.0, 0.0))
    bpy.context.view_layer.update()
    state = auto_update.source_state(sphere)
    sphere.location.x += 0.5
    bpy.context.view_layer.update()
    assert auto_update.source_state(sphere) != state


def test_moving_the_source_with_a_cutter_regenerates_it(scene):
    """The cut is read in the source's space, so moving the source moves it: the move
    schedules a regeneration (background: at once), not only a stale check that drops
    a build in flight with nothing to redo it."""
    sphere = add("ico_sphere", subdivisions=2)
    api.add_volumetric_texture(sphere, "weave", resolution=4, depth_steps=8)
    sphere.thicket.items[1].cutter = add("uv_sphere", segments=16, ring_count=8, radius=0.4, location=(0.8, 0.0, 0.0))
    bpy.context.view_layer.update()
    api.regenerate(sphere)
    before = positions(sphere.thicket.result).copy()
    sphere.location.x += 0.5
    bpy.context.view_layer.update()  # the depsgraph update the handler sees
    auto_update.wait()
    moved = positions(sphere.thicket.result).copy()
    assert moved.shape != before.shape or not np.array_equal(moved, before), "the cut followed the move"
    np.testing.assert_array_equal(moved, _synchronous(sphere))


def test_an_unchanged_nan_setting_leaves_the_build_current(scene):
    """NaN != NaN: a state holding a NaN read as it was must still equal itself, or
    every build of that stack is stale and its result is never written."""
    monkey = _monkey()
    with suspended():
        monkey.thicket.items[-1].time = math.nan  # a setting the shell does not read, still compared
    assert math.isnan(monkey.thicket.items[-1].time)
    assert auto_update.source_state(monkey) == auto_update.source_state(monkey)
    _edit(monkey, (0.0, 0.0, 0.2))
    auto_update.start(monkey)
    auto_update.wait()
    live = positions(monkey.thicket.result).copy()
    np.testing.assert_array_equal(live, _synchronous(monkey))
    with suspended():
        monkey.thicket.items[-1].time = 1.0  # a NaN that changes still makes the build stale
    state = auto_update.source_state(monkey)
    with suspended():
        monkey.thicket.items[-1].time = math.nan
    assert auto_update.source_state(monkey) != state


def _in_flight(monkey):
    """A live build of `monkey` started after an edit, and what it must write."""
    _edit(monkey, (0.0, 0.0, 0.2))
    expected = _synchronous(monkey)
    _edit(monkey, (0.0, 0.0, -0.2))
    before = _synchronous(monkey)
    assert not np.array_equal(before, expected)
    _edit(monkey, (0.0, 0.0, 0.2))
    auto_update.start(monkey)
    assert auto_update.running(monkey)
    return before, expected


def test_a_render_starting_during_a_build_renders_its_result(scene):
    """A render that holds the main thread (a script's, a background one) while a
    live build runs: the render's handler (`render_init`) writes the build before the
    render reads the scene."""
    monkey = _monkey()
    assert auto_update.on_render_init in bpy.app.handlers.render_init
    before, expected = _in_flight(monkey)
    np.testing.assert_array_equal(positions(monkey.thicket.result), before)
    auto_update.on_render_init(bpy.context.scene)
    assert not auto_update.running(monkey)
    np.testing.assert_array_equal(positions(monkey.thicket.result), expected)


def test_an_interface_render_touches_nothing_and_says_so(scene, capsys):
    """F12 runs the handler on the render's thread: writing there would race the
    interface's timers, and waiting for them could hold Blender at quit, so it writes
    nothing, says the render shows the previous result, and the build lands later on
    the interface's timer. A main-thread render that cannot wait that long says so too."""
    monkey = _monkey()
    before, expected = _in_flight(monkey)
    thread = threading.Thread(target=auto_update.on_render_init, args=(bpy.context.scene,))
    thread.start()
    thread.join(60.0)
    assert not thread.is_alive()
    assert "previous result" in capsys.readouterr().out
    np.testing.assert_array_equal(positions(monkey.thicket.result), before)
    auto_update.wait()
    np.testing.assert_array_equal(positions(monkey.thicket.result), expected)
    before, _ = _in_flight(monkey)
    assert auto_update.finish_for_render(timeout=0.0) is False
    assert "previous result" in capsys.readouterr().out
    np.testing.assert_array_equal(positions(monkey.thicket.result), before)
    auto_update.wait()


def test_one_deadline_bounds_the_wait_for_all_builds(scene):
    """`Builds.wait(timeout)` bounds the wait for every build together: three builds
    that outlast it return after about `timeout` (it waited `timeout` for each build
    in turn, 3x as long), and they are written once they end."""
    from thicket.stack.live_build import Build, Builds, by_uid

    release, written = threading.Event(), []
    builds = Builds(lambda uid: by_uid(bpy.data.objects, uid), lambda owner, build, result: written.append(result), lambda owner, exc: None)
    for k in range(3):
        bpy.ops.mesh.primitive_cube_add(location=(3.0 * k, 0.0, 0.0))
        builds.start(bpy.context.object, lambda k=k: Build(bpy.context.object, lambda owner: 0, lambda job, k=k: release.wait(60.0) and k))
    started = time.monotonic()
    builds.wait(2.0)
    waited = time.monotonic() - started
    assert not written
    release.set()
    builds.wait(60.0)
    assert sorted(written) == [0, 1, 2]
    assert waited < 4.5, waited


def test_the_views_redraw_only_when_a_build_changes(monkeypatch):
    """The builds' timer looks every POLL_SECONDS; it redraws the panels and views
    only when a build started, landed or ended, and for progress alone at most every
    PROGRESS_SECONDS (it tagged every view 20 times a second per kind of build)."""
    clock = [0.0]
    monkeypatch.setattr(live_build, "_clock", lambda: clock[0])
    release, redraws, written = threading.Event(), [], []
    owner = types.SimpleNamespace(session_uid=-7)
    builds = live_build.Builds(lambda uid: owner, lambda o, b, result: written.append(result), None, on_poll=lambda: redraws.append(clock[0]))
    builds.start(owner, lambda: live_build.Build(owner, lambda o: "state", lambda job: release.wait(60) and "done"))
    try:
        job = builds.builds[owner.session_uid].job

        def look():
            clock[0] += live_build.POLL_SECONDS
            return builds.poll()

        for _ in range(20):  # a second of nothing new
            look()
        assert len(redraws) == 1, "the start only"
        for step in range(40):  # two seconds of moving progress
            job.progress(step / 100)
            look()
        assert 2 <= len(redraws) - 1 <= 2.0 / live_build.PROGRESS_SECONDS + 1
        assert all(b - a >= live_build.PROGRESS_SECONDS - 1e-9 for a, b in zip(redraws[1:], redraws[2:]))
        count = len(redraws)
        release.set()
        job.join(60)
        assert look() is None and written == ["done"]
        assert len(redraws) == count + 1, "the landing redraws at once"
    finally:
        release.set()
        if bpy.app.timers.is_registered(builds._tick):
            bpy.app.timers.unregister(builds._tick)


def test_the_exit_tells_every_build_first_then_waits_within_one_deadline(monkeypatch):
    """At exit every build is cancelled before any is joined, and the joins share one
    deadline (they took up to the timeout each, in turn)."""
    clock, events = [0.0], []
    monkeypatch.setattr(live_build, "_clock", lambda: clock[0])

    class Stuck:
        """A worker that never ends."""

        done = cancelled = False

        def __init__(self, name):
            self.name = name

        def cancel(self):
            events.append(("cancel", self.name))

        def join(self, timeout=None):
            events.append(("join", self.name, timeout))
            clock[0] += timeout

    kinds = [live_build.Builds(None, None, None, exclusive=True), live_build.Builds(None, None, None)]
    for i, builds in enumerate(kinds):
        for j in range(2):
            builds.builds[(i, j)] = types.SimpleNamespace(job=Stuck((i, j)))
    live_build._end_all(timeout=4.0)
    mine = [e for e in events if isinstance(e[1], tuple)]
    assert [e[0] for e in mine] == ["cancel"] * 4 + ["join"] * 4
    assert sum(e[2] for e in mine if e[0] == "join") <= 4.0
