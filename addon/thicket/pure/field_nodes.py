"""Node graphs of the Thicket node editor as field trees (issue 17), without Blender.

A graph is a plain description: `{name: {"op": op, "fields": {...}, "inputs":
{...}, "color": [r, g, b, a] or None}}` and the name of the node linked to the
Output. `inputs` maps the op's child fields to node names: `"children"` a list (h,
min, max, the w_p operations: the linked ones are used, at least one; difference_wp
exactly two), `"child"` one name (offset,
negate), `"shape"` and `"texture"` (displace, fractal). `tree_from_graph` turns it
into the JSON tree the core reads (README's schema); cycles, unlinked inputs (an
operation with none, a difference short of two, a unary node's or a displacement's),
p <= 0 and non-finite numbers are refused with `GraphError` (a ValueError) naming
the node, before the core sees anything.
"""

import math

#: The node editor's tree type (`bpy.types.NodeTree.bl_idname`).
TREE_IDNAME = "ThicketFieldTree"
#: Ops without children (their skeletons come from numbers or handle objects).
PRIMITIVES = ("plane", "sphere", "point", "segment", "rectangle", "box", "torus")
#: Ops with a list of children.
NARY = ("h", "min", "max", "intersection_wp", "union_wp", "difference_wp")
#: Ops with one `child`.
UNARY = ("offset", "negate")
#: Ops with a `shape` and a `texture`.
TEXTURED = ("displace", "fractal")
OPS = PRIMITIVES + NARY + UNARY + TEXTURED


class GraphError(ValueError):
    """A node graph that is no field tree (the message names the node)."""


def _finite(name, key, value):
    if isinstance(value, bool):
        raise GraphError(f"node '{name}': {key} must be a number, got {value!r}")
    if isinstance(value, (int, float)):
        if not math.isfinite(value):
            raise GraphError(f"node '{name}': {key} is not a finite number ({value})")
        return float(value)
    if isinstance(value, (list, tuple)):
        return [_finite(name, key, v) for v in value]
    raise GraphError(f"node '{name}': {key} must be numbers, got {type(value).__name__}")


def _fields(name, node):
    out = {}
    for key, value in (node.get("fields") or {}).items():
        out[key] = _finite(name, key, value)
    if "p" in out and not out["p"] > 0:
        raise GraphError(f"node '{name}': p must be > 0, got {out['p']:g}")
    return out


def tree_from_graph(nodes, output):
    """The field tree (a dict) of the node `output` in the graph `nodes` (see the
    module doc). Raises GraphError for an unknown op, a missing or unlinked input,
    a cycle, p <= 0 or a non-finite number."""
    if output is None:
        raise GraphError("the Output node has no linked field")
    visiting = []

    def build(name):
        if name not in nodes:
            raise GraphError(f"no node named '{name}'")
        if name in visiting:
            cycle = " -> ".join([*visiting[visiting.index(name) :], name])
            raise GraphError(f"the node graph has a cycle: {cycle}")
        node = nodes[name]
        op = node.get("op")
        if op not in OPS:
            raise GraphError(f"node '{name}': unknown op {op!r}")
        visiting.append(name)
        tree = {"op": op, **_fields(name, node)}
        inputs = node.get("inputs") or {}
        if op in NARY:
            children = [c for c in inputs.get("children") or [] if c is not None]
            if not children:
                raise GraphError(f"node '{name}' ({op}) has no linked input")
            if op == "difference_wp" and len(children) != 2:
                raise GraphError(f"node '{name}' (difference): link both inputs")
            tree["children"] = [build(c) for c in children]
        elif op in UNARY:
            if inputs.get("child") is None:
                raise GraphError(f"node '{name}' ({op}) has no linked input")
            tree["child"] = build(inputs["child"])
        elif op in TEXTURED:
            for key in ("shape", "texture"):
                if inputs.get(key) is None:
                    raise GraphError(f"node '{name}' ({op}): its {key} input is not linked")
                tree[key] = build(inputs[key])
        color = node.get("color")
        if color is not None:
            tree["color"] = _finite(name, "color", list(color))
        visiting.pop()
        return tree

    return build(output)


def fractal_terms(octaves, amplitude, omega, gain=0.5, lacunarity=2.0):
    """The `terms` of a fractal sum of `octaves` terms: amplitudes `amplitude *
    gain^j`, frequencies `omega * lacunarity^j`."""
    return [[amplitude * gain**j, omega * lacunarity**j] for j in range(int(octaves))]
