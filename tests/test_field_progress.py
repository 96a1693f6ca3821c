"""Field Mesh builds before and while they run (issue 17): the core's estimate
(shown in the node editor's sidebar, asked about above "Ask Above") against the
real triangle count; builds over a memory limit refused with the message and nothing
changed, the node tree's live regeneration included; progress through `thicket.api`
and cancels from the callback leaving the previous mesh; the operators' watched
(modal) builds completing and cancelled by Esc. Background mode has no window, so
the modal's events are fed here to the watch `invoke` starts, as the Add Thick
Surface tests do."""

import json
import time

import bpy
import numpy as np
import pytest
from conftest import run_modal

import thicket_native as tn
from thicket import api, mesh_io
from thicket.fields import field_mesh
from thicket.nodes import live
from thicket.nodes.live import tree_estimate
from thicket.operators.field_mesh_add import THICKET_OT_field_mesh_add, watched_field_build
from thicket.operators.field_mesh_regenerate import THICKET_OT_field_mesh_regenerate, regeneration_build
from thicket.pure.field_tree import CONFIRM_ABOVE, estimate_text, needs_confirmation

SPHERE = {"op": "sphere", "center": [0, 0, 0], "radius": 1.0}
SOFT = {
    "op": "union_wp",
    "p": 6.0,
    "children": [
        {"op": "sphere", "center": [-0.375, 0, 0], "radius": 0.625, "color": [1, 0, 0, 1]},
        {"op": "box", "center": [0.5, 0, 0], "half_size": [0.25, 0.375, 0.5], "radius": 0.0625, "color": [0, 0, 1, 1]},
        {"op": "torus", "center": [0, 0, 0.6], "axis": [0, 0, 1], "major": 0.5, "minor": 0.15},
    ],
}


def triangles(obj):
    mesh = obj.data
    mesh.calc_loop_triangles()
    return len(mesh.loop_triangles)


def snapshot(obj):
    arrays = mesh_io.read_mesh(obj.data)
    return arrays.vertices.copy(), arrays.face_sizes.copy(), arrays.corners.copy(), dict(obj["thicket_field"].to_dict())


def assert_unchanged(before, obj):
    after = snapshot(obj)
    for a, b in zip(before[:3], after[:3]):
        np.testing.assert_array_equal(a, b)
    assert before[3] == after[3]


def node_tree(resolution=24):
    tree = bpy.data.node_groups.new("Field", "ThicketFieldTree")
    tree.auto_update = False
    tree.resolution = resolution
    sphere = tree.nodes.new("ThicketNodeSphere")
    out = tree.nodes.new("ThicketNodeOutput")
    tree.links.new(sphere.outputs[0], out.inputs[0])
    return tree


@pytest.mark.parametrize("tree", [SPHERE, SOFT], ids=["sphere", "soft_union"])
@pytest.mark.parametrize("resolution,adaptive", [(32, True), (96, True), (48, False)])
def test_the_estimate_is_within_1_5x_of_the_real_triangles(scene, tree, resolution, adaptive):
    text = json.dumps(tree)
    guess = api.estimate_field_mesh(text, resolution=resolution, adaptive=adaptive)
    assert guess["fits"] and guess["max_bytes"] == 4_000_000_000
    real = triangles(api.build_field_mesh(text, resolution=resolution, adaptive=adaptive))
    assert real > 0
    assert real / 1.5 <= guess["triangles"] <= real * 1.5, (guess["triangles"], real)
    assert f"about {int(guess['triangles']):,} triangles" in estimate_text(guess)


def test_the_node_editor_shows_the_estimate_of_its_tree(scene):
    tree = node_tree(resolution=64)
    guess = tree_estimate(tree)
    obj = api.build_field_nodes_mesh(tree)
    real = triangles(obj)
    assert real / 1.5 <= guess["triangles"] <= real * 1.5, (guess["triangles"], real)
    tree.resolution = 128  # a finer tree: a larger estimate (cached per tree and resolution)
    finer = tree_estimate(tree)
    assert finer["triangles"] > 2 * guess["triangles"] and tree_estimate(tree) is finer
    remove_output(tree)
    assert tree_estimate(tree) is None  # no output: no tree to estimate (the status says why)


def test_large_builds_ask_and_builds_over_the_limit_are_refused_by_the_core():
    text = json.dumps(SPHERE)
    small, large, over = (api.estimate_field_mesh(text, resolution=r) for r in (64, 1024, 2048))
    assert small["triangles"] < CONFIRM_ABOVE < large["triangles"] and large["fits"] and not over["fits"]
    assert not needs_confirmation(small, CONFIRM_ABOVE) and needs_confirmation(large, CONFIRM_ABOVE)
    assert needs_confirmation(small, 1000) and not needs_confirmation(large, large["triangles"])
    assert not needs_confirmation(over, CONFIRM_ABOVE), "the core refuses it: nothing to ask"
    assert "over the 4,000 MB limit (resolution" in estimate_text(over) and "limit" not in estimate_text(large)


def test_a_build_over_the_memory_limit_is_refused_and_changes_nothing(scene):
    text = json.dumps(SOFT)
    small = api.estimate_field_mesh(text, resolution=24)["peak_bytes"] * 2
    assert api.estimate_field_mesh(text, resolution=96, max_bytes=small)["fits"] is False
    objects, meshes = len(bpy.data.objects), len(bpy.data.meshes)
    with pytest.raises(tn.InvalidInput, match="memory limit"):
        api.build_field_mesh(text, resolution=96, max_bytes=small)
    assert (len(bpy.data.objects), len(bpy.data.meshes)) == (objects, meshes)
    obj = api.build_field_mesh(text, resolution=24, max_bytes=small)  # under it: built
    before = snapshot(obj)
    obj["thicket_field"]["resolution"] = 96
    with pytest.raises(tn.InvalidInput, match="memory limit"):
        api.regenerate_field_mesh(obj, max_bytes=small)
    obj["thicket_field"]["resolution"] = 24
    assert_unchanged(before, obj)
    # The operator reports it (a RuntimeError in scripts) and makes nothing.
    bpy.data.texts.new("big").write(json.dumps(SPHERE))
    with pytest.raises(RuntimeError, match="memory limit"):
        bpy.ops.thicket.field_mesh_add(text="big", resolution=2048)
    assert (len(bpy.data.objects), len(bpy.data.meshes)) == (objects + 1, meshes + 1)


def test_live_regeneration_refused_by_the_estimate_keeps_the_mesh_and_says_why(scene):
    tree = node_tree(resolution=24)
    obj = api.build_field_nodes_mesh(tree)
    before = snapshot(obj)
    assert tree_estimate(tree)["fits"]
    tree.resolution = 2048  # a sphere at 2048 cells: about 4.6 GB at its peak, over 4 GB
    assert not tree_estimate(tree)["fits"]
    start = time.monotonic()
    message = live.regenerate_tree(tree)
    assert time.monotonic() - start < 5.0, "refused before meshing"
    assert "memory limit" in message and tree.status == message
    assert_unchanged(before, obj)
    tree.resolution = 32
    assert live.regenerate_tree(tree) == "" and tree.status == ""
    assert snapshot(obj)[3]["resolution"] == 32


def test_live_regeneration_in_the_interface_leaves_a_large_mesh_to_the_regenerate_button(scene):
    """Live updates in the interface (`ask`) do not mesh a tree estimated above the
    confirmation threshold: that would hold Blender for seconds on every node tweak.
    The status says so with the estimate, the mesh stays; small trees regenerate."""
    from thicket.pure.field_tree import CONFIRM_ABOVE

    tree = node_tree(resolution=24)
    obj = api.build_field_nodes_mesh(tree)
    before = snapshot(obj)
    tree.resolution = 1536  # a sphere: about 14 M triangles, within the memory limit
    estimate = tree_estimate(tree)
    assert estimate["fits"] and estimate["triangles"] > CONFIRM_ABOVE, estimate
    start = time.monotonic()
    message = live.regenerate_tree(tree, ask=True)
    assert time.monotonic() - start < 5.0, "left before meshing"
    assert message.startswith("Not regenerated live") and "Regenerate" in message and tree.status == message
    assert f"{int(estimate['triangles']):,} triangles" in message
    assert_unchanged(before, obj)
    tree.resolution = 32  # small again: regenerated live, the status cleared
    assert live.regenerate_tree(tree, ask=True) == "" and tree.status == ""
    assert len(obj.data.vertices) > len(before[0]) and obj["thicket_field"]["resolution"] == 32


def test_the_live_gate_looks_at_every_field_mesh_of_the_tree(scene):
    """A tree whose first Field Mesh fits (its stored bounds are eight times as
    wide, so its cells are too) but whose second is estimated above the threshold
    waits for Regenerate, in scripts (`regenerate_tree(ask=True)`) as in the
    interface (`start_live`): one gate, every mesh."""
    tree = node_tree(resolution=24)
    tree.auto_update = False
    wide, own = api.build_field_nodes_mesh(tree, name="A wide"), api.build_field_nodes_mesh(tree, name="B own")
    side = 8 * float(np.ptp(mesh_io.read_mesh(wide.data).vertices, axis=0).max())
    wide["thicket_field"]["bounds"] = [-side / 2] * 3 + [side / 2] * 3
    before = snapshot(wide), snapshot(own)
    tree.resolution = 800  # the sphere in its own bound: about 3.8 M triangles
    assert tree_estimate(tree)["triangles"] < CONFIRM_ABOVE  # the first mesh's bounds fit
    for regenerate in (lambda: live.regenerate_tree(tree, ask=True), lambda: live.start_live(tree)):
        start = time.monotonic()
        message = regenerate()
        assert time.monotonic() - start < 5.0, "left before meshing"
        assert message.startswith("Not regenerated live") and tree.status == message, message
        assert_unchanged(before[0], wide)
        assert_unchanged(before[1], own)


def test_scripts_regenerate_each_distinct_setting_once_and_every_field_mesh(scene, monkeypatch):
    """`regenerate_tree` meshes Field Meshes with the same stored bounds once and
    writes that mesh into each; one with bounds of its own is meshed on its own."""
    tree = node_tree(resolution=24)
    tree.auto_update = False
    a, b, wide = (api.build_field_nodes_mesh(tree, name=name) for name in ("A", "B", "Wide"))
    side = 8 * float(np.ptp(mesh_io.read_mesh(wide.data).vertices, axis=0).max())
    wide["thicket_field"]["bounds"] = [-side / 2] * 3 + [side / 2] * 3
    meshed = []
    real = live.mesh_arrays
    monkeypatch.setattr(live, "mesh_arrays", lambda prepared, *args, **kw: meshed.append(prepared) or real(prepared, *args, **kw))
    tree.resolution = 40
    assert live.regenerate_tree(tree) == "" and tree.status == ""
    assert len(meshed) == 2 and meshed[0] != meshed[1], meshed
    assert a["thicket_field"]["resolution"] == b["thicket_field"]["resolution"] == wide["thicket_field"]["resolution"] == 40
    np.testing.assert_array_equal(mesh_io.read_mesh(a.data).corners, mesh_io.read_mesh(b.data).corners)
    assert triangles(wide) < triangles(a) / 8  # its own, wider cells


def increasing_to_one(seen):
    assert seen and seen[0] == 0.0 and seen[-1] == 1.0, seen
    assert all(b >= a for a, b in zip(seen, seen[1:])), seen


def test_progress_through_the_api_increases_to_one(scene):
    text = json.dumps(SPHERE)
    seen = []
    obj = api.build_field_mesh(text, resolution=320, progress=seen.append)  # long enough to report midway
    increasing_to_one(seen)
    assert any(0.0 < f < field_mesh.MESHING_SHARE for f in seen), "the core reports while it meshes"
    seen.clear()
    api.regenerate_field_mesh(obj, progress=seen.append)
    increasing_to_one(seen)
    tree = node_tree(resolution=24)
    seen.clear()
    linked = api.build_field_nodes_mesh(tree, progress=seen.append)
    increasing_to_one(seen)
    seen.clear()
    api.regenerate_field_nodes(linked, progress=seen.append)
    increasing_to_one(seen)


@pytest.mark.parametrize("stop_at", [0.0, 0.3])
def test_cancelling_from_the_callback_raises_and_keeps_the_previous_mesh(scene, stop_at):
    text = json.dumps(SPHERE)
    obj = api.build_field_mesh(text, resolution=24)
    before = snapshot(obj)
    obj["thicket_field"]["resolution"] = 320  # long enough for the core to report midway
    seen = []
    with pytest.raises(tn.Cancelled):
        api.regenerate_field_mesh(obj, progress=lambda f: seen.append(f) or f <= stop_at)
    assert seen[0] == 0.0 and stop_at < seen[-1] < 1.0, seen
    obj["thicket_field"]["resolution"] = 24
    assert_unchanged(before, obj)
    objects, meshes = len(bpy.data.objects), len(bpy.data.meshes)
    with pytest.raises(tn.Cancelled):
        api.build_field_mesh(text, resolution=320, progress=lambda f: f <= stop_at)
    assert (len(bpy.data.objects), len(bpy.data.meshes)) == (objects, meshes)
    tree = node_tree(resolution=24)
    linked = api.build_field_nodes_mesh(tree)
    before = snapshot(linked)
    tree.resolution = 320
    with pytest.raises(tn.Cancelled):
        api.regenerate_field_nodes(linked, progress=lambda f: f <= stop_at)
    assert_unchanged(before, linked)


def prepared_add(text, resolution=64):
    prepared = field_mesh.prepare(text, resolution)

    def write(arrays):
        return field_mesh.write_new(prepared, arrays, "Watched", bpy.context.collection)

    return prepared, write


def test_the_watched_build_completes_like_the_api(scene):
    text = json.dumps(SOFT)
    reports = []
    prepared, write = prepared_add(text)
    watch = watched_field_build(prepared, "Add Field Mesh", lambda kind, message: reports.append((kind, message)), write)
    fractions = []
    assert run_modal(watch, before_each_timer=lambda: fractions.append(watch.job.fraction)) == {"FINISHED"}
    assert watch.job.fraction == 1.0 or watch.job.fraction >= field_mesh.MESHING_SHARE
    assert all(b >= a for a, b in zip(fractions, fractions[1:]))
    assert not reports, reports
    obj = bpy.data.objects["Watched"]
    assert bpy.context.view_layer.objects.active == obj
    reference = api.build_field_mesh(text, resolution=64)
    np.testing.assert_array_equal(mesh_io.read_mesh(obj.data).corners, mesh_io.read_mesh(reference.data).corners)
    np.testing.assert_allclose(mesh_io.read_mesh(obj.data).vertices, mesh_io.read_mesh(reference.data).vertices)
    # The operators: `invoke` without a window runs the same watch blocking.
    bpy.data.texts.new("soft").write(text)
    assert {"REGISTER", "UNDO"} <= THICKET_OT_field_mesh_add.bl_options and bpy.ops.thicket.field_mesh_add.get_rna_type().properties[
        "confirm_above"
    ].default == CONFIRM_ABOVE
    assert bpy.ops.thicket.field_mesh_add("INVOKE_DEFAULT", text="soft", resolution=64) == {"FINISHED"}
    made = bpy.context.active_object
    assert made.name == "soft" and triangles(made) == triangles(reference)
    made["thicket_field"]["resolution"] = 32
    assert {"REGISTER", "UNDO"} <= THICKET_OT_field_mesh_regenerate.bl_options
    assert bpy.ops.thicket.field_mesh_regenerate("INVOKE_DEFAULT") == {"FINISHED"}
    assert triangles(made) < triangles(reference) and made["thicket_field"]["resolution"] == 32


def test_esc_cancels_the_watched_build_and_changes_nothing(scene):
    text = json.dumps(SOFT)
    objects, meshes = len(bpy.data.objects), len(bpy.data.meshes)
    reports = []
    prepared, write = prepared_add(text, resolution=200)
    watch = watched_field_build(prepared, "Add Field Mesh", lambda kind, message: reports.append((kind, message)), write)
    watch.job.start()
    assert watch.event(bpy.context, "MIDDLEMOUSE", "PRESS") == {"PASS_THROUGH"}  # navigation goes on
    assert watch.event(bpy.context, "ESC", "PRESS") == {"RUNNING_MODAL"} and watch.job.cancelled
    status, end = {"RUNNING_MODAL"}, time.monotonic() + 60
    while status == {"RUNNING_MODAL"}:
        assert time.monotonic() < end
        watch.job._thread.join(0.02)
        status = watch.event(bpy.context, "TIMER")
    assert status == {"CANCELLED"}
    assert reports == [({"WARNING"}, "Add Field Mesh: Cancelled; nothing was changed")]
    assert (len(bpy.data.objects), len(bpy.data.meshes)) == (objects, meshes)
    # Regenerating a node tree's mesh: Esc keeps the previous mesh and the tree's state.
    tree = node_tree(resolution=24)
    obj = api.build_field_nodes_mesh(tree)
    before = snapshot(obj)
    tree.resolution = 200
    prepared, label, write = regeneration_build(obj, "Regenerate Field Mesh")
    reports.clear()
    watch = watched_field_build(prepared, label, lambda kind, message: reports.append((kind, message)), write)
    status = run_modal(watch, before_each_timer=lambda: watch.event(bpy.context, "ESC", "PRESS"))
    assert status == {"CANCELLED"} and reports == [({"WARNING"}, "Regenerate Field Mesh 'Field': Cancelled; nothing was changed")]
    assert_unchanged(before, obj)
    # Not cancelled, the same watch rebuilds it from the tree.
    prepared, label, write = regeneration_build(obj, "Regenerate Field Mesh")
    watch = watched_field_build(prepared, label, lambda kind, message: reports.append((kind, message)), write)
    assert run_modal(watch) == {"FINISHED"} and obj["thicket_field"]["resolution"] == 200


def test_regenerate_rebuilds_every_field_mesh_of_the_tree_and_estimates_within_stored_bounds(scene):
    tree = node_tree(resolution=24)
    tree.auto_update = False  # the tree changes without live regeneration, as a large tree would
    first, second = api.build_field_nodes_mesh(tree, name="First"), api.build_field_nodes_mesh(tree, name="Second")
    tree.resolution = 40
    prepared, label, write = regeneration_build(first, "Regenerate Field Mesh")
    assert run_modal(watched_field_build(prepared, label, lambda *report: None, write)) == {"FINISHED"}
    # Both follow the tree, the second with the same mesh, and the tree's status is clear.
    assert first["thicket_field"]["resolution"] == second["thicket_field"]["resolution"] == 40
    np.testing.assert_array_equal(mesh_io.read_mesh(first.data).corners, mesh_io.read_mesh(second.data).corners)
    assert tree.status == ""
    # The sidebar's (and the live limit's) estimate meshes within the first Field Mesh's
    # stored bounds: in a box eight times as wide the cells are too, and the sphere
    # gets far fewer triangles, as the regeneration then makes.
    whole = tree_estimate(tree)["triangles"]
    side = 8 * float(np.ptp(mesh_io.read_mesh(first.data).vertices, axis=0).max())
    first["thicket_field"]["bounds"] = [-side / 2] * 3 + [side / 2] * 3
    guess = tree_estimate(tree)["triangles"]
    live.regenerate(first)
    real = triangles(first)
    assert guess < whole / 8 and real / 1.5 <= guess <= real * 1.5, (guess, whole, real)


def test_live_regeneration_meshes_on_a_worker_thread_and_writes_only_the_latest_state(scene):
    from thicket.nodes import live_worker

    tree = node_tree(resolution=24)
    first, second = api.build_field_nodes_mesh(tree, name="First"), api.build_field_nodes_mesh(tree, name="Second")
    before = snapshot(first)
    # A slow state (about a second of meshing), then the user moves on: the first
    # build is cancelled in flight (the core stops) and never written; the second is.
    tree.resolution = 400
    assert live.start_live(tree) == "" and live_worker.running(tree)
    assert_unchanged(before, first)  # returned at once: the interface is not held
    job = live_worker._builds[tree.session_uid].job
    tree.resolution = 40
    assert live.start_live(tree) == ""
    job.join(60)
    assert isinstance(job._error, tn.Cancelled), "the core stopped meshing the older state"
    assert live_worker.running(tree)
    tree.name = "Renamed"  # known by session_uid: a rename mid-build changes nothing
    live_worker.wait()
    assert not live_worker.running(tree) and tree.status == ""
    assert first["thicket_field"]["resolution"] == second["thicket_field"]["resolution"] == 40
    reference = api.build_field_mesh(tree_json_of(tree), resolution=40)
    np.testing.assert_array_equal(mesh_io.read_mesh(first.data).corners, mesh_io.read_mesh(reference.data).corners)
    np.testing.assert_array_equal(mesh_io.read_mesh(second.data).corners, mesh_io.read_mesh(reference.data).corners)
    # A tree that reads otherwise when the build ends (an undo, which schedules
    # nothing) keeps its meshes: the result of the older state is dropped.
    kept = snapshot(first)
    tree.resolution = 32
    live.start_live(tree)
    tree.resolution = 40
    live_worker.wait()
    assert_unchanged(kept, first)
    # An object deleted while its tree meshes is skipped; the other is written.
    tree.resolution = 32
    live.start_live(tree)
    bpy.data.objects.remove(second)
    live_worker.wait()
    assert first["thicket_field"]["resolution"] == 32 and tree.status == ""
    # A tree that cannot mesh says why and changes nothing, with nothing in flight.
    kept = snapshot(first)
    remove_output(tree)
    message = live.start_live(tree)
    assert message and tree.status == message and not live_worker.running(tree)
    assert_unchanged(kept, first)


def remove_output(tree):
    tree.nodes.remove(next(node for node in tree.nodes if node.bl_idname == "ThicketNodeOutput"))


def tree_json_of(tree):
    from thicket.nodes.graph import tree_json

    return tree_json(tree)
