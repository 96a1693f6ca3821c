"""Regenerates results when a source mesh or a stack setting changes.

Debounced: changes are collected by object name and flushed once things are quiet
(a timer in UI sessions; at once in background mode, where timers never run).
Re-entrancy guarded: the writes a regeneration makes never schedule another one.
"""

import bpy
from bpy.app.handlers import persistent

from ..pure import live_shells, native
from .debounce import Debounced
from .guard import busy, suspended


def _is_source(obj) -> bool:
    return obj is not None and obj.type == "MESH" and len(obj.thicket.items) > 0 and obj.thicket.auto_update


def schedule(obj) -> None:
    """Asks for `obj`'s result to be regenerated soon."""
    if busy() or not isinstance(obj, bpy.types.Object) or not _is_source(obj):
        return
    _sources.add(obj.name)


def _regenerate(name: str) -> None:
    """Regenerates a pending source. Failures are kept on the stack (`last_error`,
    shown in the panel), never raised into Blender's event loop."""
    from ..pure.kinds.volumetric_texture import BakeNeedsConfirmation
    from .regenerate import regenerate

    obj = bpy.data.objects.get(name)
    if not _is_source(obj):
        return
    try:
        # In the interface, very large bakes wait for the user (Regenerate asks).
        regenerate(obj, ask=not bpy.app.background)
    except (KeyError, TypeError, ValueError, BakeNeedsConfirmation, *native.error_types()) as exc:
        with suspended():
            obj.thicket.last_error = str(exc)


_sources = Debounced(_regenerate)
flush = _sources.flush


def changed_sources(scene, depsgraph, is_source=_is_source):
    """The objects passing `is_source` whose result this depsgraph update changes: those
    whose geometry changed (mesh edits, modifiers, vertex groups, shape keys), and
    those with an item watching an object that moved or changed (a Volumetric Texture's
    cutter, a Procedural Detail's local center). Each
    once, though an update can name a source twice (its object and its mesh). The
    scene's stacks are looked up once per call (nothing to do without any)."""
    stacks = [obj for obj in scene.objects if obj.type == "MESH" and len(obj.thicket.items) > 0 and is_source(obj)]
    if not stacks:
        return []
    by_object = {obj.as_pointer(): [obj] for obj in stacks}
    by_mesh, by_watched = {}, {}
    for obj in stacks:
        by_mesh.setdefault(obj.data.as_pointer(), []).append(obj)
        for item in obj.thicket.items:
            for watched in item.watched_objects():
                by_watched.setdefault(watched.as_pointer(), []).append(obj)
    sources = []
    for update in depsgraph.updates:
        original = update.id.original
        found = []
        if isinstance(original, bpy.types.Object) and (update.is_updated_geometry or update.is_updated_transform):
            found += by_watched.get(original.as_pointer(), [])  # a cutter or local center moved or changed
        if update.is_updated_geometry:
            if isinstance(original, bpy.types.Object):
                found += by_object.get(original.as_pointer(), [])
            elif isinstance(original, bpy.types.Mesh):
                found += by_mesh.get(original.as_pointer(), [])
        sources.extend(obj for obj in found if obj not in sources)
    return sources


@persistent
def on_depsgraph_update(scene, depsgraph):
    if busy():
        return
    for obj in changed_sources(scene, depsgraph):
        schedule(obj)


@persistent
def on_frame_change(scene, depsgraph=None):
    """Animated sources (shape keys, armatures, keyframed item settings), textures and
    tentacles following the frame regenerate on frame change."""
    if busy():
        return
    for obj in scene.objects:
        if _is_source(obj) and (obj.animation_data is not None or any(i.follows_frame() for i in obj.thicket.items)):
            schedule(obj)


@persistent
def on_load(*_args):
    """Shells kept for incremental updates and analysed sculpts belong to the file that
    was open."""
    from .. import sculpt

    live_shells.clear()
    sculpt.clear()


HANDLERS = (
    (bpy.app.handlers.depsgraph_update_post, on_depsgraph_update),
    (bpy.app.handlers.frame_change_post, on_frame_change),
    (bpy.app.handlers.load_post, on_load),
)


def register_handlers():
    for handler_list, fn in HANDLERS:
        if fn not in handler_list:
            handler_list.append(fn)


def unregister_handlers():
    for handler_list, fn in reversed(HANDLERS):
        if fn in handler_list:
            handler_list.remove(fn)
    _sources.pending.clear()
    live_shells.clear()
    from .. import sculpt

    sculpt.clear()
