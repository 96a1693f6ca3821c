"""The Solid Texture kind (Akleman-Chen section 7's remark; issue 17): a field tree's
colour and texture function evaluated at the current mesh's vertices, written as a
colour attribute (per vertex or per face corner) or used to displace the vertices
along their normals. Topology, UVs, materials and provenance are kept, so it chains
after the shells and after a baked Volumetric Texture; a displacement before a shell
shapes its base, but a colour written before a shell is not carried into it."""

import dataclasses

import numpy as np

from .. import native
from .. import settings as S
from ..arrays import MeshArrays
from ..field_tree import TEXTURE_ATTRIBUTE, check_tree, invalid, vertex_normals
from ..state import State

MODES = ("color", "displace")
DOMAINS = ("point", "corner")


def evaluate_at(tree_text: str, points):
    """`thicket_native.field_eval` at `points` ((n, 3), read as float32)."""
    return native.get().field_eval(tree_text, np.ascontiguousarray(points, dtype=np.float32).reshape(-1, 3))


def solid_texture(mesh: MeshArrays, item: S.SolidTexture) -> MeshArrays:
    """`mesh` with the item applied (a new MeshArrays; `mesh` and its dicts unchanged)."""
    if not item.tree.strip():
        raise invalid(f"'{item.label}' has no field tree: give it the tree's JSON or a Text holding it")
    if item.mode not in MODES:
        raise invalid(f"'{item.label}': mode must be one of {', '.join(MODES)}, got {item.mode!r}")
    if item.domain not in DOMAINS:
        raise invalid(f"'{item.label}': domain must be one of {', '.join(DOMAINS)}, got {item.domain!r}")
    if not np.isfinite(item.amplitude):
        raise invalid(f"'{item.label}': amplitude must be finite, got {item.amplitude}")
    text = check_tree(item.tree)
    field = evaluate_at(text, mesh.vertices)
    texture = np.asarray(field["texture"], dtype=np.float32)
    attributes = dict(mesh.attributes)
    attributes[TEXTURE_ATTRIBUTE] = ("POINT", "FLOAT", texture)
    if item.mode == "displace":
        normals = vertex_normals(mesh)
        moved = np.asarray(mesh.vertices, dtype=np.float32) + normals * (np.float32(item.amplitude) * texture)[:, None]
        # The custom normals of what came before no longer fit the moved surface.
        return dataclasses.replace(mesh, vertices=moved, normals=None, attributes=attributes, point_attributes=dict(mesh.point_attributes), notes=[])
    if not item.attribute:
        raise invalid(f"'{item.label}' needs an attribute name to write its colour into")
    taken = set(mesh.uv_maps) | set(mesh.point_attributes) | {TEXTURE_ATTRIBUTE, "position", "material_index"}
    if item.attribute.startswith(".") or item.attribute in taken:
        raise invalid(f"'{item.label}': the colour attribute cannot be called {item.attribute!r} (a UV map, Thicket's or Blender's own attribute)")
    colors = np.asarray(field["colors"], dtype=np.float32)
    if item.domain == "corner":
        colors = colors[np.asarray(mesh.corners, dtype=np.int64)]
    attributes.pop(item.attribute, None)  # replaced, possibly on another domain
    attributes[item.attribute] = (item.domain.upper(), "FLOAT_COLOR", colors)
    return dataclasses.replace(mesh, attributes=attributes, active_color=item.attribute, point_attributes=dict(mesh.point_attributes), notes=[])


def solid_texture_step(state: State, item: S.SolidTexture, ask, progress):
    if progress is not None and progress(0.0) is False:
        raise native.get().Cancelled("cancelled")
    state.current = solid_texture(state.current, item)
