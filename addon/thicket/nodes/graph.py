"""A `ThicketFieldTree` read into the plain graph description of
`pure.field_nodes` (handle objects resolved to numbers from their world matrices),
then into the tree's JSON."""

import json

from ..pure.field_nodes import TREE_IDNAME, GraphError, fractal_terms, tree_from_graph


def _linked(socket, depth=0):
    """The node name feeding `socket` (None if unlinked or muted), through reroute
    nodes. Links Blender marks invalid (a cycle) are kept, so the graph's check names
    the cycle."""
    for link in socket.links:
        if not link.is_muted and not link.from_node.mute:
            node = link.from_node
            if node.bl_idname == "NodeReroute":
                # A loop of reroutes alone feeds nothing.
                return _linked(node.inputs[0], depth + 1) if depth < 64 and node.inputs else None
            return node.name
    return None


def _handle(node, obj, role="handle"):
    if obj.name not in _scene_objects():
        raise GraphError(f"node '{node.name}': its {role} object '{obj.name}' is missing (not in the file's scenes)")
    return obj.matrix_world


def _scene_objects():
    import bpy

    return {o.name for scene in bpy.data.scenes for o in scene.objects}


def _primitive_fields(node):
    op = node.op
    fields = {}
    m = _handle(node, node.handle) if node.handle is not None else None
    if op == "segment":
        if m is not None and node.handle.type == "CURVE":
            points = _curve_ends(node, node.handle)
            fields["a"], fields["b"] = points
        elif node.handle is not None or node.handle_b is not None:
            if node.handle is None or node.handle_b is None:
                raise GraphError(f"node '{node.name}': a segment needs two handle objects (or one curve)")
            fields["a"] = list(m.translation)
            fields["b"] = list(_handle(node, node.handle_b, "handle B").translation)
        else:
            fields["a"], fields["b"] = list(node.a), list(node.b)
        fields["radius"] = node.radius
        return fields
    if m is None:
        for name in node.numeric:
            fields[name] = list(getattr(node, name))
    else:
        location, rotation, scale = m.decompose()
        z_axis = list(m.to_3x3().normalized().col[2])
        if op == "plane":
            fields["point"], fields["normal"] = list(location), z_axis
        elif op == "torus":
            fields["center"], fields["axis"] = list(location), z_axis
        else:
            fields["center"] = list(location)
        if op in ("box", "rectangle"):
            size = node.handle.empty_display_size if node.handle.type == "EMPTY" else 1.0
            fields["rotation"] = list(rotation)
            fields["half_size"] = [abs(s) * size for s in scale][: 3 if op == "box" else 2]
    for name in node.always:
        fields[name] = getattr(node, name)
    return fields


def _curve_ends(node, obj):
    splines = obj.data.splines
    if len(splines) == 0:
        raise GraphError(f"node '{node.name}': the curve '{obj.name}' has no spline")
    spline = splines[0]
    points = spline.bezier_points if spline.type == "BEZIER" else spline.points
    if len(points) < 2:
        raise GraphError(f"node '{node.name}': the curve '{obj.name}' needs two points")
    ends = [points[0].co, points[-1].co]
    return [list(obj.matrix_world @ co.to_3d()) if len(co) == 4 else list(obj.matrix_world @ co) for co in ends]


def describe(node):
    """One node's entry of the graph description."""
    entry = {"op": None, "fields": {}, "inputs": {}, "color": list(node.color) if node.use_color else None}
    idname = node.bl_idname
    if hasattr(node, "op") and idname not in ("ThicketNodeOperation",):
        entry["op"] = node.op
        entry["fields"] = _primitive_fields(node)
    elif idname == "ThicketNodeOperation":
        entry["op"] = node.operation
        if node.operation.endswith("_wp"):
            entry["fields"]["p"] = node.p
        entry["inputs"]["children"] = [c for c in (_linked(s) for s in node.inputs) if c is not None]
        if node.operation == "difference_wp" and any(_linked(s) is None for s in node.inputs):
            entry["inputs"]["children"] = []
    elif idname in ("ThicketNodeOffset", "ThicketNodeNegate"):
        entry["op"] = "offset" if idname == "ThicketNodeOffset" else "negate"
        if idname == "ThicketNodeOffset":
            entry["fields"]["amount"] = node.amount
        entry["inputs"]["child"] = _linked(node.inputs[0])
    elif idname in ("ThicketNodeDisplace", "ThicketNodeFractal"):
        if idname == "ThicketNodeDisplace":
            entry["op"] = "displace"
            entry["fields"] = {"amplitude": node.amplitude, "omega": node.omega}
        else:
            entry["op"] = "fractal"
            entry["fields"] = {"terms": fractal_terms(node.octaves, node.amplitude, node.omega, node.gain, node.lacunarity)}
        entry["fields"]["tau"] = node.tau
        entry["inputs"] = {"shape": _linked(node.inputs[0]), "texture": _linked(node.inputs[1])}
        entry["ramp"] = [[0.0, list(node.ramp_low)], [1.0, list(node.ramp_high)]] if node.use_ramp else None
    return entry


def output_node(tree):
    outputs = [n for n in tree.nodes if n.bl_idname == "ThicketNodeOutput"]
    if not outputs:
        raise GraphError(f"the node tree '{tree.name}' has no Field Output node")
    active = tree.nodes.active
    return active if active in outputs else outputs[0]


def tree_dict(tree):
    """The field tree (dict) of the node tree `tree`'s Output. Raises GraphError
    (a ValueError) naming what is wrong."""
    if getattr(tree, "bl_idname", None) != TREE_IDNAME:
        raise GraphError(f"expected a Thicket field node tree, got {getattr(tree, 'name', tree)!r}")
    output = output_node(tree)
    nodes = {}
    for node in tree.nodes:
        if node.bl_idname == "ThicketNodeOutput" or node.bl_idname.startswith("NodeReroute") or node.type == "FRAME":
            continue
        entry = describe(node)
        ramp = entry.pop("ramp", None)
        nodes[node.name] = entry
        if ramp is not None:
            entry["fields"]["ramp"] = ramp
    result = tree_from_graph(nodes, _linked(output.inputs[0]))
    return result


def tree_json(tree):
    """`tree_dict` as JSON text."""
    return json.dumps(tree_dict(tree), allow_nan=False)
