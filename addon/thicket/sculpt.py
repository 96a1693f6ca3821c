"""An artist's Multires sculpt as the base of a Procedural Detail item (Use Sculpt):
what Blender must give, read on its main thread. The numbering match and the analysis
(Velho, Perlin, Ying and Biermann, section 2) run in the stack's evaluation, with
progress and cancel: on a worker in the interface (Regenerate, the live
auto-update and the viewport overlay's preparation), at once in scripts
(`thicket.api`) and background sessions; they and their cache are `pure.kinds.procedural_detail_sculpt`'s.

Changing an item's own settings reads the sculpt again (Blender's Multires
evaluation, a copy) but neither matches the numbering nor analyses; editing the base
(topology or positions) reads Blender's numbering here, and it and the sculpt are
matched and analysed in the evaluation (a numbering matched before a cancel is kept:
the next read of that base skips both). Entries of objects gone are dropped at every
read, and all of them when a file is loaded (`clear`).
"""

import bpy

from . import mesh_io
from .pure.kinds import procedural_detail_sculpt as cache
from .pure.kinds.procedural_detail_sculpt import Sculpt

clear = cache.clear


def __getattr__(name):
    """`analyses`, `numberings` (counters of cache misses) and `_cache` live with the
    cache."""
    if name in ("analyses", "numberings", "_cache"):
        return getattr(cache, name)
    raise AttributeError(name)


def forget(obj):
    """Forgets `obj`'s cached analysis (it no longer uses its sculpt)."""
    cache.forget(obj.session_uid)


def has_sculpt(obj) -> bool:
    """Whether `obj` has a Multires modifier with at least one level."""
    modifier = mesh_io.multires_modifier(obj) if obj is not None and obj.type == "MESH" else None
    return modifier is not None and modifier.total_levels > 0


def read(obj, depsgraph=None, vertex_groups=(), label="Procedural Detail"):
    """`(base, sculpt, notes)` for a Procedural Detail item on `obj`'s sculpt, read on
    the main thread (call it with auto-update suspended): `base`, the object's own mesh
    (UV maps, material indices, the weights of `vertex_groups`); `sculpt`, a `Sculpt`
    (plain data) that the item's evaluation analyses (or finds in the cache) and whose
    fitted coarse positions then replace the base's; `notes` for the user. Refused
    (ValueError naming the item) in Sculpt Mode, without a Multires or with no levels;
    a sculpt that cannot be matched to the base is refused by the evaluation. Nothing
    of `obj` is modified."""
    try:
        _, levels = mesh_io._checked_multires(obj)
    except ValueError as exc:
        raise ValueError(f"'{label}' (Use Sculpt): {exc}") from None
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    base = mesh_io.read_evaluated(obj, depsgraph, vertex_groups, modifiers=False)
    sculpted = mesh_io.read_sculpt(obj, depsgraph)
    cache.prune({o.session_uid for o in bpy.data.objects})
    sculpt = Sculpt(obj.session_uid, label, obj.name, base, levels, sculpted)
    if sculpt.announce():
        try:
            sculpt.numbering = mesh_io.multires_numbering(obj, levels)
        except ValueError as exc:
            raise ValueError(f"'{label}' (Use Sculpt): {exc}") from None
    modifier = mesh_io.multires_modifier(obj)
    others = [m.name for m in obj.modifiers if m.show_viewport and m != modifier]
    notes = []
    if others:
        notes.append(f"'{label}' (Use Sculpt) starts from the Multires sculpt alone: {', '.join(others)} on the source not applied")
    return base, sculpt, notes
