"""Runs a stack of item settings over a mesh (numpy arrays in, numpy arrays out).

No bpy here: the same function serves operators, the headless API and tests.
"""

import numpy as np

from .. import native
from ..arrays import MeshArrays, weight_attribute
from . import settings as S

DIRECTOR_ATTRIBUTE = "thicket_director"
LAYER_ATTRIBUTE = "thicket_layer"
THICKNESS_ATTRIBUTE = "thicket_thickness"


def _shell_result(out):
    """Mesh arrays of a native shell result, with per-vertex shell attributes."""
    result = MeshArrays.from_native(out)
    source = out["source_vertex"]
    result.point_attributes = {
        DIRECTOR_ATTRIBUTE: out["directors"][source],
        LAYER_ATTRIBUTE: out["layer"],
    }
    if "achieved" in out:
        result.point_attributes[THICKNESS_ATTRIBUTE] = out["achieved"][source]
    return result, source


def _common_args(mesh: MeshArrays, item, factors):
    args = (mesh.vertices, mesh.face_sizes, mesh.corners, float(item.thickness))
    kwargs = dict(relative=item.relative, factors=factors, output=item.output, layers=int(item.layers))
    return args, kwargs


def _offset_shell(mesh: MeshArrays, item: S.OffsetShell, factors):
    args, kwargs = _common_args(mesh, item, factors)
    return _shell_result(native.get().offset_shell(*args, **kwargs))


def _field_shell(mesh: MeshArrays, item: S.FieldShell, factors):
    args, kwargs = _common_args(mesh, item, factors)
    return _shell_result(native.get().shell(*args, side=item.side, **kwargs))


STEPS = {S.OffsetShell: _offset_shell, S.FieldShell: _field_shell}


def evaluate_stack(source: MeshArrays, items, progress=None) -> MeshArrays:
    """Applies `items` in order; each item's input is the previous item's output.

    Vertex-group weights are looked up on the source mesh and followed through the
    items by provenance (`source_vertex`), so a group keeps meaning after the first
    item. `progress(i)` is called after each item. An empty list returns the source.
    """
    current = source
    origin = np.arange(source.vertex_count)  # source vertex of each current vertex
    for i, item in enumerate(items):
        factors = None
        if getattr(item, "vertex_group", ""):
            weights = source.point_attributes.get(weight_attribute(item.vertex_group))
            if weights is None:
                raise KeyError(f"vertex group '{item.vertex_group}' was not read from the source")
            factors = np.ascontiguousarray(weights[origin], dtype=np.float32)
        current, provenance = STEPS[type(item)](current, item, factors)
        origin = origin[provenance]
        if progress:
            progress(i + 1)
    if current is source:
        current = MeshArrays(source.vertices, source.face_sizes, source.corners)
    return current
