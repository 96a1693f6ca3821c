"""An artist's Multires sculpt as the base of a Procedural Detail item (Use Sculpt):
the sculpt analysed into a coarse mesh and per-level details in local frames (Velho,
Perlin, Ying and Biermann, section 2), so procedural detail lands at any level on top
of it and the sculpt follows.

Analysis is too slow for live regeneration, so it is cached: one entry per source
object (by `session_uid`), keyed on the modifier's total levels and digests of the
base mesh (positions, faces) and of the sculpt's evaluated positions. Changing an
item's own settings reads the sculpt again (Blender's Multires evaluation, a copy)
but neither matches the numbering nor analyses; editing the base (topology or
positions) or the sculpt does. Entries of objects gone are dropped at every read,
and all of them when a file is loaded (`clear`).
"""

import hashlib

import bpy
import numpy as np

from . import mesh_io
from .pure import native
from .pure.arrays import MeshArrays

#: Multiresolution analyses run (cache misses): tests and the curious read it.
analyses = 0
#: Numberings matched (misses of the base part of the key).
numberings = 0

# session_uid -> (base key, order, sculpt digest, analysis)
_cache = {}


def clear():
    """Forgets every cached analysis (a file was loaded)."""
    _cache.clear()


def forget(obj):
    """Forgets `obj`'s cached analysis (it no longer uses its sculpt)."""
    _cache.pop(obj.session_uid, None)


def _prune():
    """Drops the entries of objects that no longer exist."""
    if _cache:
        alive = {o.session_uid for o in bpy.data.objects}
        for uid in [uid for uid in _cache if uid not in alive]:
            del _cache[uid]


def has_sculpt(obj) -> bool:
    """Whether `obj` has a Multires modifier with at least one level."""
    modifier = mesh_io.multires_modifier(obj) if obj is not None and obj.type == "MESH" else None
    return modifier is not None and modifier.total_levels > 0


def _digest(*arrays) -> bytes:
    h = hashlib.blake2b(digest_size=16)
    for a in arrays:
        h.update(np.ascontiguousarray(a).tobytes())
    return h.digest()


def read(obj, depsgraph=None, vertex_groups=(), label="Procedural Detail"):
    """`(base, analysis, notes)` for a Procedural Detail item on `obj`'s sculpt, read on
    the main thread (call it with auto-update suspended): `base`, the object's own mesh
    (UV maps, material indices, the weights of `vertex_groups`) with the analysis' fitted
    coarse positions; `analysis`, `thicket_native.analyze`'s dict plus `levels` and
    `order`, what `procedural_detail` takes as `sculpt`; `notes` for the user. Refused
    (ValueError naming the item) in Sculpt Mode, without a Multires or with no levels,
    or when the sculpt cannot be matched to the base; nothing of `obj` is modified."""
    global analyses, numberings
    try:
        _, levels = mesh_io._checked_multires(obj)
    except ValueError as exc:
        raise ValueError(f"'{label}' (Use Sculpt): {exc}") from None
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    base = mesh_io.read_evaluated(obj, depsgraph, vertex_groups, modifiers=False)
    sculpted = mesh_io.read_sculpt(obj, depsgraph)
    _prune()
    base_key = (levels, _digest(base.vertices, base.face_sizes, base.corners))
    fine_key = _digest(sculpted.vertices, sculpted.corners)
    entry = _cache.get(obj.session_uid)
    if entry is not None and len(entry[1]) != len(sculpted.vertices):
        entry = None  # the numbering checks the counts: it must run again
    if entry is not None and entry[0] == base_key and entry[2] == fine_key:
        order, analysis = entry[1], entry[3]
    else:
        tn = native.get()
        try:
            if entry is not None and entry[0] == base_key:
                order = entry[1]
            else:
                numberings += 1
                order = mesh_io.multires_order(obj, base, levels, sculpted)
            analyses += 1
            analysis = tn.analyze(base.vertices, base.face_sizes, base.corners, np.ascontiguousarray(sculpted.vertices[order]), levels)
        except (ValueError, *native.error_types()) as exc:
            _cache.pop(obj.session_uid, None)
            raise type(exc)(f"'{label}' (Use Sculpt): {exc}") from None
        analysis["levels"] = levels
        analysis["order"] = order
        _cache[obj.session_uid] = (base_key, order, fine_key, analysis)
    if not np.array_equal(np.asarray(analysis["corners"]), base.corners):
        raise ValueError(f"'{label}' (Use Sculpt): the analysed sculpt's faces are not the base mesh's")
    coarse = MeshArrays(
        np.ascontiguousarray(analysis["vertices"], dtype=np.float32),
        base.face_sizes,
        base.corners,
        point_attributes=base.point_attributes,
        uvs=base.uvs,
        uv_maps=base.uv_maps,
        material_index=base.material_index,
        uv_name=base.uv_name,
    )
    modifier = mesh_io.multires_modifier(obj)
    others = [m.name for m in obj.modifiers if m.show_viewport and m != modifier]
    notes = []
    if others:
        notes.append(f"'{label}' (Use Sculpt) starts from the Multires sculpt alone: {', '.join(others)} on the source not applied")
    return coarse, analysis, notes
