"""The Thicket node editor (issue 17) in real Blender: node trees built with bpy mesh
like the hand-written JSON; handle empties move the mesh after a depsgraph update;
the operator undoes; trees and meshes save and reload; bad graphs are errors, not
crashes. Also the pure graph -> tree conversion."""

import json

import bpy
import numpy as np
import pytest
from conftest import positions

import thicket_native as tn
from thicket import api
from thicket.nodes import live
from thicket.operators.field_nodes_add import THICKET_OT_field_nodes_add
from thicket.pure.field_nodes import GraphError, tree_from_graph

RED, BLUE = [1.0, 0.0, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0]


def volume(obj_or_arrays):
    if isinstance(obj_or_arrays, dict):
        v = np.asarray(obj_or_arrays["vertices"], np.float64).reshape(-1, 3)
        sizes, corners = np.asarray(obj_or_arrays["face_sizes"]), np.asarray(obj_or_arrays["corners"])
    else:
        mesh = obj_or_arrays.data
        v = positions(mesh).astype(np.float64)
        sizes = np.array([len(p.vertices) for p in mesh.polygons])
        corners = np.array([i for p in mesh.polygons for i in p.vertices])
    total, start = 0.0, 0
    for n in sizes:
        face = v[corners[start : start + n]]
        for i in range(1, n - 1):
            total += np.dot(face[0], np.cross(face[i], face[i + 1])) / 6.0
        start += n
    return total


def new_tree(name="Field"):
    tree = bpy.data.node_groups.new(name, "ThicketFieldTree")
    tree.auto_update = False  # built node by node here; regenerated explicitly
    tree.resolution = 24
    return tree


def link(tree, a, b, socket=0):
    tree.links.new(a.outputs[0], b.inputs[socket])


def soft_union(tree, handle=None):
    """Sphere (red) and box (blue; placed by `handle` when given) in a w_p union (p = 6);
    numbers exact in float32, so the JSON equals the hand-written one."""
    sphere = tree.nodes.new("ThicketNodeSphere")
    sphere.center, sphere.radius, sphere.use_color, sphere.color = (-0.375, 0, 0), 0.625, True, RED
    box = tree.nodes.new("ThicketNodeBox")
    box.center, box.half_size, box.radius, box.use_color, box.color = (0.5, 0, 0), (0.25, 0.375, 0.5), 0.0625, True, BLUE
    box.handle = handle
    op = tree.nodes.new("ThicketNodeOperation")
    op.operation, op.p = "union_wp", 6.0
    out = tree.nodes.new("ThicketNodeOutput")
    link(tree, sphere, op, 0)
    link(tree, box, op, 1)
    link(tree, op, out)
    return sphere, box, op, out


def hand_written(box_center=(0.5, 0, 0), rotation=None, half_size=(0.25, 0.375, 0.5)):
    box = {"op": "box", "center": list(box_center), "half_size": list(half_size), "radius": 0.0625, "color": BLUE}
    if rotation is not None:
        box["rotation"] = list(rotation)
    return {
        "op": "union_wp",
        "p": 6.0,
        "children": [{"op": "sphere", "center": [-0.375, 0, 0], "radius": 0.625, "color": RED}, box],
    }


def test_pure_graph_to_tree_and_its_errors():
    nodes = {
        "S": {"op": "sphere", "fields": {"center": [0, 0, 0], "radius": 1}},
        "P": {"op": "plane", "fields": {"point": [0, 0, 0], "normal": [0, 0, 1]}, "color": RED},
        "D": {"op": "difference_wp", "fields": {"p": 4}, "inputs": {"children": ["S", "P"]}},
        "O": {"op": "offset", "fields": {"amount": 0.1}, "inputs": {"child": "D"}},
    }
    tree = tree_from_graph(nodes, "O")
    assert tree["op"] == "offset" and tree["child"]["op"] == "difference_wp"
    assert tree["child"]["children"][1] == {"op": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "color": RED}
    tn.field_eval(json.dumps(tree), np.zeros((1, 3), np.float32))  # the core reads it
    with pytest.raises(GraphError, match="cycle: O -> D -> O"):
        tree_from_graph({**nodes, "D": {**nodes["D"], "inputs": {"children": ["S", "O"]}}}, "O")
    with pytest.raises(GraphError, match="p must be > 0"):
        tree_from_graph({**nodes, "D": {**nodes["D"], "fields": {"p": 0}}}, "O")
    with pytest.raises(GraphError, match="not a finite number"):
        tree_from_graph({**nodes, "S": {"op": "sphere", "fields": {"center": [0, float("nan"), 0], "radius": 1}}}, "O")
    with pytest.raises(GraphError, match="no linked input"):
        tree_from_graph({**nodes, "O": {"op": "offset", "fields": {"amount": 0.1}, "inputs": {}}}, "O")
    with pytest.raises(GraphError, match="no linked field"):
        tree_from_graph(nodes, None)


def test_node_tree_meshes_like_the_hand_written_json(scene):
    tree = new_tree()
    soft_union(tree)
    assert json.loads(api.field_nodes_json(tree)) == hand_written()
    obj = api.build_field_nodes_mesh(tree)
    ref = tn.field_mesh(json.dumps(hand_written()), resolution=24)
    assert len(obj.data.vertices) == len(ref["vertices"]) // (3 if np.ndim(ref["vertices"]) == 1 else 1)
    assert volume(obj) == pytest.approx(volume(ref), rel=1e-4)
    assert volume(obj) > 0.5
    assert obj["thicket_field_nodes"] == tree and tree.status == ""


def test_moving_a_handle_empty_regenerates_after_the_depsgraph_update(scene):
    empty = bpy.data.objects.new("BoxHandle", None)
    scene.collection.objects.link(empty)
    empty.empty_display_type = "CUBE"
    empty.location, empty.scale = (0.5, 0, 0), (0.25, 0.375, 0.5)
    bpy.context.view_layer.update()
    tree = new_tree()
    soft_union(tree, handle=empty)
    tree.auto_update = True
    obj = api.build_field_nodes_mesh(tree)
    before = positions(obj).copy()
    assert json.loads(api.field_nodes_json(tree))["children"][1]["center"] == pytest.approx([0.5, 0, 0])

    empty.location = (1.2, 0.3, 0)
    empty.rotation_euler = (0, 0, 0.5)
    bpy.context.view_layer.update()  # the depsgraph update the handler sees (background: regenerated at once)
    after = positions(obj)
    assert after.shape != before.shape or not np.allclose(after, before)
    rotation = list(empty.matrix_world.to_quaternion())
    ref = tn.field_mesh(json.dumps(hand_written((1.2, 0.3, 0), rotation)), resolution=24)
    assert volume(obj) == pytest.approx(volume(ref), rel=1e-3)
    assert after[:, 0].max() > before[:, 0].max() + 0.5


def test_a_node_value_change_regenerates_and_bad_values_keep_the_mesh(scene):
    tree = new_tree()
    sphere, _box, op, _out = soft_union(tree)
    obj = api.build_field_nodes_mesh(tree)
    tree.auto_update = True
    small = volume(obj)
    sphere.radius = 0.9  # the property's update schedules (background: at once)
    assert volume(obj) > small * 1.3 and tree.status == ""
    good = positions(obj).copy()
    op.p = 0.0  # p <= 0: refused, mesh kept, message on the tree
    assert "p must be > 0" in tree.status
    assert np.array_equal(positions(obj), good)
    op.p = 6.0
    assert tree.status == ""


def test_cycles_missing_handles_and_unlinked_inputs_are_errors(scene):
    tree = new_tree()
    sphere, box, op, out = soft_union(tree)
    obj = api.build_field_nodes_mesh(tree)
    good = positions(obj).copy()
    neg = tree.nodes.new("ThicketNodeNegate")
    tree.links.new(op.outputs[0], neg.inputs[0])
    tree.links.new(neg.outputs[0], op.inputs[0])  # op -> neg -> op
    with pytest.raises(ValueError, match="cycle"):
        api.regenerate_field_nodes(obj)
    assert "cycle" in live.regenerate_tree(tree)
    assert np.array_equal(positions(obj), good)
    tree.nodes.remove(neg)
    tree.links.new(sphere.outputs[0], op.inputs[0])

    empty = bpy.data.objects.new("Gone", None)
    box.handle = empty  # never linked to a scene
    with pytest.raises(ValueError, match="handle object 'Gone' is missing"):
        api.regenerate_field_nodes(obj)
    box.handle = None
    tree.links.remove(out.inputs[0].links[0])
    with pytest.raises(ValueError, match="no linked field"):
        api.regenerate_field_nodes(obj)
    assert np.array_equal(positions(obj), good)
    with pytest.raises(ValueError, match="no linked field"):
        api.build_field_nodes_mesh(tree)
    assert len([o for o in bpy.data.objects if o.type == "MESH"]) == 1


def test_operator_adds_tree_and_mesh_and_undoes(scene):
    assert {"REGISTER", "UNDO"} <= THICKET_OT_field_nodes_add.bl_options
    assert bpy.ops.thicket.field_nodes_add.poll()
    trees_before = len(bpy.data.node_groups)
    bpy.ops.ed.undo_push(message="before")
    assert bpy.ops.thicket.field_nodes_add() == {"FINISHED"}
    obj = bpy.context.active_object
    tree = obj["thicket_field_nodes"]
    assert tree.bl_idname == "ThicketFieldTree" and len(bpy.data.node_groups) == trees_before + 1
    assert len(obj.data.vertices) > 100 and obj.name == "Thicket Field"
    bpy.ops.ed.undo_push(message="added")
    bpy.ops.ed.undo()
    # the step the interface pushes after an UNDO operator (scripts push it themselves)
    assert "Thicket Field" not in bpy.data.objects
    assert len(bpy.data.node_groups) == trees_before
    with pytest.raises(RuntimeError, match="no Thicket field node tree named 'nope'"):
        bpy.ops.thicket.field_nodes_add(tree="nope")


def test_save_reload_keeps_tree_and_mesh_and_regenerates_identically(scene, tmp_path):
    empty = bpy.data.objects.new("BoxHandle", None)
    scene.collection.objects.link(empty)
    empty.empty_display_type = "CUBE"
    empty.location, empty.scale = (0.5, 0.125, 0), (0.25, 0.375, 0.5)
    bpy.context.view_layer.update()
    tree = new_tree("Saved")
    soft_union(tree, handle=empty)
    obj = api.build_field_nodes_mesh(tree, name="Saved Mesh")
    before = positions(obj).copy()
    path = str(tmp_path / "nodes.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.open_mainfile(filepath=path)
    obj = bpy.data.objects["Saved Mesh"]
    tree = obj["thicket_field_nodes"]
    assert tree.name == "Saved" and len(tree.nodes) == 4 and tree.nodes["Box"].handle.name == "BoxHandle"
    assert np.array_equal(positions(obj), before)
    api.regenerate_field_nodes(obj)
    assert np.array_equal(positions(obj), before)


def test_every_node_kind_reads_into_the_schema_and_meshes(scene):
    """Each primitive with numbers and with handles (two empties and a curve for the
    segment), the unary, textured and n-ary nodes: the JSON is what the node shows and
    the core meshes it."""
    a, b = bpy.data.objects.new("A", None), bpy.data.objects.new("B", None)
    for obj, loc in ((a, (-0.5, 0, 0.25)), (b, (0.5, 0, 0.25))):
        scene.collection.objects.link(obj)
        obj.location = loc
    curve_data = bpy.data.curves.new("Path", "CURVE")
    spline = curve_data.splines.new("POLY")
    spline.points.add(2)
    for point, co in zip(spline.points, ((0, -0.5, 0, 1), (0, 0, 0, 1), (0, 0.5, 0, 1)), strict=True):
        point.co = co
    curve = bpy.data.objects.new("Path", curve_data)
    scene.collection.objects.link(curve)
    curve.location = (0, 0, -0.25)
    tilted = bpy.data.objects.new("Tilted", None)
    scene.collection.objects.link(tilted)
    tilted.rotation_euler = (0.5, 0, 0)
    bpy.context.view_layer.update()

    tree = new_tree()
    n = tree.nodes
    seg_empties, seg_curve = n.new("ThicketNodeSegment"), n.new("ThicketNodeSegment")
    seg_empties.handle, seg_empties.handle_b, seg_empties.radius = a, b, 0.125
    seg_curve.handle, seg_curve.radius = curve, 0.125
    torus = n.new("ThicketNodeTorus")
    torus.handle, torus.major, torus.minor = tilted, 0.75, 0.125
    point, rect, plane = n.new("ThicketNodePoint"), n.new("ThicketNodeRectangle"), n.new("ThicketNodePlane")
    point.center, point.radius = (0, 0, 0.5), 0.25
    rect.center, rect.half_size, rect.radius = (0, 0, -0.5), (0.5, 0.25), 0.125
    plane.normal = (0, 0, 1)
    union = n.new("ThicketNodeOperation")
    union.operation, union.inputs_count = "min", 5
    assert len(union.inputs) == 5
    for i, node in enumerate((seg_empties, seg_curve, torus, point, rect)):
        link(tree, node, union, i)
    offset, negate, h = n.new("ThicketNodeOffset"), n.new("ThicketNodeNegate"), n.new("ThicketNodeOperation")
    offset.amount = 0.0625
    link(tree, union, offset)
    h.operation = "h"
    link(tree, plane, negate)
    link(tree, negate, h, 0)
    link(tree, plane, h, 1)  # h[-f, f] = |f|: a slab around the plane
    fractal = n.new("ThicketNodeFractal")
    fractal.octaves, fractal.amplitude, fractal.omega = 2, 0.015625, 16.0
    fractal.use_ramp, fractal.ramp_low, fractal.ramp_high = True, RED, BLUE
    link(tree, offset, fractal, 0)
    link(tree, h, fractal, 1)
    out = n.new("ThicketNodeOutput")
    link(tree, fractal, out)

    got = json.loads(api.field_nodes_json(tree))
    assert got["op"] == "fractal" and got["terms"] == [[0.015625, 16.0], [0.0078125, 32.0]]
    assert got["ramp"] == [[0.0, RED], [1.0, BLUE]]
    assert got["texture"] == {"op": "h", "children": [{"op": "negate", "child": got["texture"]["children"][1]}, got["texture"]["children"][1]]}
    assert got["texture"]["children"][1] == {"op": "plane", "point": [0.0, 0.0, 0.0], "normal": [0.0, 0.0, 1.0]}
    children = got["shape"]["child"]["children"]
    assert [c["op"] for c in children] == ["segment", "segment", "torus", "point", "rectangle"]
    assert children[0]["a"] == pytest.approx([-0.5, 0, 0.25]) and children[0]["b"] == pytest.approx([0.5, 0, 0.25])
    assert children[1]["a"] == pytest.approx([0, -0.5, -0.25]) and children[1]["b"] == pytest.approx([0, 0.5, -0.25])
    assert children[2]["axis"] == pytest.approx(list(tilted.matrix_world.col[2].xyz))
    obj = api.build_field_nodes_mesh(tree)
    ref = tn.field_mesh(json.dumps(got), resolution=24)
    assert len(obj.data.vertices) > 100
    assert volume(obj) == pytest.approx(volume(ref), rel=1e-4)
    # a curve handle that moves regenerates the mesh too
    tree.auto_update = True
    before = volume(obj)
    curve.location = (0, 0, -1.0)
    bpy.context.view_layer.update()
    assert volume(obj) != pytest.approx(before, rel=1e-3)


def test_deleting_a_handle_or_a_nan_value_reports_and_keeps_the_mesh(scene):
    empty = bpy.data.objects.new("BoxHandle", None)
    scene.collection.objects.link(empty)
    empty.location, empty.scale = (0.5, 0, 0), (0.25, 0.375, 0.5)
    bpy.context.view_layer.update()
    tree = new_tree()
    sphere, box, _op, _out = soft_union(tree, handle=empty)
    obj = api.build_field_nodes_mesh(tree)
    tree.auto_update = True
    good = positions(obj).copy()
    for other in bpy.context.view_layer.objects:
        other.select_set(other == empty)
    bpy.context.view_layer.objects.active = empty
    assert bpy.ops.object.delete() == {"FINISHED"}  # the node still points at it: it is out of every scene
    assert box.handle is not None
    assert "handle object 'BoxHandle' is missing" in live.regenerate_tree(tree)
    assert "BoxHandle" in tree.status
    assert np.array_equal(positions(obj), good)
    box.handle = None
    assert tree.status == ""
    good = positions(obj).copy()
    sphere.radius = float("nan")  # Blender keeps a NaN in a float property: the graph check refuses it
    assert "node 'Sphere': radius is not a finite number" in tree.status
    assert np.array_equal(positions(obj), good)


def test_enabling_the_add_on_again_with_trees_in_the_file_keeps_blender_running(scene):
    """Blender calls a tree's `update` while the tree's class registers: with Thicket
    Field trees in the open file, enabling the add-on again crashed Blender (the
    update read the tree's properties then). Now it waits for the handlers."""
    import thicket

    tree = new_tree()
    soft_union(tree)
    tree.auto_update = True
    obj = api.build_field_nodes_mesh(tree)
    name, before = tree.name, len(obj.data.vertices)
    thicket.unregister()
    thicket.register()
    tree = bpy.data.node_groups[name]
    assert tree.bl_idname == "ThicketFieldTree" and tree.auto_update
    api.regenerate_field_nodes(obj)
    assert len(obj.data.vertices) == before


def test_links_through_reroutes_and_partly_linked_operations(scene):
    """A reroute between nodes is followed; an operation uses its linked inputs."""
    tree = new_tree()
    sphere, box, op, out = soft_union(tree)
    tree.links.remove(op.outputs[0].links[0])
    reroute = tree.nodes.new("NodeReroute")
    tree.links.new(op.outputs[0], reroute.inputs[0])
    tree.links.new(reroute.outputs[0], out.inputs[0])
    assert json.loads(api.field_nodes_json(tree)) == hand_written()
    tree.links.remove(box.outputs[0].links[0])  # the union's second input unlinked
    only_sphere = hand_written()
    only_sphere["children"] = only_sphere["children"][:1]
    assert json.loads(api.field_nodes_json(tree)) == only_sphere
