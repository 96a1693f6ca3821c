"""Implicit field trees (issue 17, Akleman-Chen) as the add-on uses them: a tree's
JSON checked once, its mesh as `MeshArrays` with the carried colour, texture and
primitive id as attributes, and the vertex normals a displacement moves along."""

import json
import math

import numpy as np

from . import native
from .arrays import MeshArrays

#: Attributes a field mesh or a Solid Texture writes (names of Blender attributes).
COLOR_ATTRIBUTE = "thicket_color"
TEXTURE_ATTRIBUTE = "thicket_texture"
PRIMITIVE_ATTRIBUTE = "thicket_primitive_id"

#: The most cells along the longest side `field_mesh` takes (the core refuses more).
MAX_RESOLUTION = 2048


def invalid(message):
    """The core's InvalidInput (a ThicketError) with `message`."""
    return native.get().InvalidInput(message)


def tree_text(tree) -> str:
    """A tree given as JSON text or as the parsed object (dict), as JSON text; the
    core reads and checks it (`check_tree`)."""
    if isinstance(tree, (dict, list)):
        try:
            return json.dumps(tree, allow_nan=False)
        except (TypeError, ValueError) as exc:
            raise invalid(f"field tree: {exc}") from None
    if isinstance(tree, bytes):
        tree = tree.decode("utf-8")
    if not isinstance(tree, str):
        raise invalid(f"field tree: expected JSON text or a dict, got {type(tree).__name__}")
    if not tree.strip():
        raise invalid('field tree: empty (a tree is a JSON object with an "op")')
    return tree


def check_tree(tree) -> str:
    """The tree's JSON text, read and checked by the core (bad JSON, unknown ops or
    fields, p <= 0, NaN or infinite numbers... raise InvalidInput naming the fault)."""
    text = tree_text(tree)
    native.get().field_eval(text, np.zeros((0, 3), np.float32))
    return text


def check_mesh_settings(resolution, bounds):
    """`resolution` as an int and `bounds` as a float tuple (min xyz, max xyz) or None,
    refused with InvalidInput before anything is built."""
    if isinstance(resolution, bool) or not isinstance(resolution, (int, np.integer)):
        raise invalid(f"resolution must be a whole number of cells, got {resolution!r}")
    resolution = int(resolution)
    if not 2 <= resolution <= MAX_RESOLUTION:
        raise invalid(f"resolution must be between 2 and {MAX_RESOLUTION} cells along the longest side, got {resolution}")
    if bounds is None:
        return resolution, None
    try:
        flat = [float(v) for v in np.asarray(bounds, dtype=np.float64).ravel()]
    except (TypeError, ValueError):
        raise invalid(f"bounds must be six numbers (min x, y, z, max x, y, z), got {bounds!r}") from None
    if len(flat) != 6 or not all(math.isfinite(v) for v in flat):
        raise invalid(f"bounds must be six finite numbers (min x, y, z, max x, y, z), got {bounds!r}")
    if any(flat[i] >= flat[i + 3] for i in range(3)):
        raise invalid(f"bounds must have min < max on every axis, got {flat}")
    return resolution, (tuple(flat[:3]), tuple(flat[3:]))


#: Interactive builds estimated above this many triangles ask first (the default of
#: the Volumetric Texture's "Ask Above").
CONFIRM_ABOVE = 3_000_000

_estimates: dict = {}


def field_mesh_estimate(tree, resolution=128, bounds=None, adaptive=True, max_bytes=None) -> dict:
    """`thicket_native.field_mesh_estimate` of the build (triangles, peak_bytes,
    max_bytes, fits, ...), cached by tree, resolution, bounds, adaptivity and limit
    (the interface asks on every redraw; one estimate costs tens of milliseconds)."""
    text = check_tree(tree)
    resolution, bounds = check_mesh_settings(resolution, bounds)
    key = (text, resolution, bounds, bool(adaptive), max_bytes)
    found = _estimates.get(key)
    if found is None:
        found = dict(native.get().field_mesh_estimate(text, bounds=bounds, resolution=resolution, adaptive=bool(adaptive), max_bytes=max_bytes))
        if len(_estimates) > 64:
            _estimates.clear()
        _estimates[key] = found
    return found


def estimate_text(estimate) -> str:
    """'about 1,234,567 triangles, 310 MB' (and the limit when it does not fit)."""
    text = f"about {int(estimate['triangles']):,} triangles, {estimate['peak_bytes'] / 1e6:,.0f} MB"
    if not estimate["fits"]:
        text += f": over the {estimate['max_bytes'] / 1e6:,.0f} MB limit (resolution {int(estimate['resolution_within'])} fits)"
    return text


def needs_confirmation(estimate, confirm_above) -> bool:
    """Whether an interactive build of this estimate asks first: it fits the memory
    limit (else the core refuses it, nothing to ask) and passes `confirm_above`
    triangles."""
    return bool(estimate["fits"]) and int(estimate["triangles"]) > int(confirm_above)


def field_mesh_arrays(tree, resolution=128, bounds=None, adaptive=True, progress=None, max_bytes=None) -> MeshArrays:
    """The tree's zero set meshed by the core (`thicket_native.field_mesh`): faces as
    returned, vertex normals from the field, and per-vertex colour (RGBA), texture
    value and primitive id as attributes (`attributes`, name -> (domain, type, values)).
    `progress` and `max_bytes`: as the core's (a cancel raises `Cancelled`, a build
    estimated over the limit raises `OverLimit`, an `InvalidInput`, before anything big is made)."""
    text = check_tree(tree)
    resolution, bounds = check_mesh_settings(resolution, bounds)
    out = native.get().field_mesh(text, bounds=bounds, resolution=resolution, adaptive=bool(adaptive), progress=progress, max_bytes=max_bytes)
    arrays = MeshArrays.from_native(out)
    arrays.normals = out["normals"]
    arrays.attributes = {
        COLOR_ATTRIBUTE: ("POINT", "FLOAT_COLOR", out["colors"]),
        TEXTURE_ATTRIBUTE: ("POINT", "FLOAT", out["texture"]),
        PRIMITIVE_ATTRIBUTE: ("POINT", "INT", out["primitive_id"]),
    }
    arrays.active_color = COLOR_ATTRIBUTE
    return arrays


def vertex_normals(mesh: MeshArrays):
    """Unit vertex normals of `mesh` as Blender computes them: each face's (Newell)
    normal weighted by the corner angle at the vertex (float32 (n, 3); zero for
    vertices on no face or only on degenerate faces). The core's
    (`thicket_native.Mesh.vertex_normals`, the normals its shells start from)."""
    vertices = np.ascontiguousarray(mesh.vertices, dtype=np.float32)
    sizes, corners = (np.ascontiguousarray(a, dtype=np.int32) for a in (mesh.face_sizes, mesh.corners))
    return native.get().Mesh(vertices, sizes, corners).vertex_normals()
