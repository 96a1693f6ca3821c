"""Regenerates results when a source mesh or a stack setting changes.

Debounced: changes are collected by object name and flushed once things are quiet
(a timer in UI sessions; at once in background mode, where timers never run).
Re-entrancy guarded: the writes a regeneration makes never schedule another one.

In the interface the stack evaluates off Blender's main thread (`live_build`): the
source is read here, `evaluate_stack` runs on a worker, and a timer writes the result
when done, only while the source and its stack still read as when the build started
(`source_state`). A newer change cancels the build in flight and starts once that
cancel has landed, so two builds of one source never run at once (the incremental
shells, `pure.live_shells`, are updated by one at a time). Undo, redo, a file load
and Regenerate drop the builds in flight. Background scripts, renders (which need
the frame's result before it renders) and animation playback regenerate at once; a
render starting while builds are in flight waits for them (`on_render_init`).
"""

import threading
import time

import bpy
import numpy as np
from bpy.app.handlers import persistent

from ..operators.common import error_text
from ..pure import live_shells, native
from .debounce import Debounced
from .guard import busy, suspended
from .live_build import Build, Builds, by_uid, redraw_panels


def _is_source(obj) -> bool:
    return obj is not None and obj.type == "MESH" and len(obj.thicket.items) > 0 and obj.thicket.auto_update


def schedule(obj) -> None:
    """Asks for `obj`'s result to be regenerated soon."""
    if busy() or not isinstance(obj, bpy.types.Object) or not _is_source(obj):
        return
    _sources.add(obj.name)


def _errors():
    from ..pure.kinds.volumetric_texture import BakeNeedsConfirmation

    return (KeyError, TypeError, ValueError, BakeNeedsConfirmation, *native.error_types())


def _failed(obj, exc) -> None:
    """Failures are kept on the stack (`last_error`, shown in the panel), never raised
    into Blender's event loop; the previous result stays."""
    with suspended():
        obj.thicket.last_error = error_text(exc)


def _synchronous() -> bool:
    """Background scripts (timers never run), renders (the frame renders next) and
    animation playback (each frame's result, as before: a build would be stale, so
    dropped, by the next frame)."""
    if bpy.app.background or bpy.app.is_job_running("RENDER"):
        return True
    return any(w.screen is not None and w.screen.is_animation_playing for w in bpy.context.window_manager.windows)


def _regenerate(name: str) -> None:
    """Regenerates a pending source: at once when `_synchronous()`, else as a live
    build (`start`)."""
    from .regenerate import regenerate

    obj = bpy.data.objects.get(name)
    if not _is_source(obj):
        return
    if not _synchronous():
        start(obj)
        return
    cancel(obj)  # a build in flight read an older state than this
    try:
        # In the interface, very large bakes wait for the user (Regenerate asks).
        regenerate(obj, ask=not bpy.app.background)
    except _errors() as exc:
        _failed(obj, exc)


_sources = Debounced(_regenerate)
flush = _sources.flush

#: Bumped for a stack's object by every depsgraph update that changes what its stack
#: reads (`changed_sources`), scheduled or not (auto-update off): part of `source_state`.
_versions: dict = {}


#: Item properties the result does not depend on (the panel's, the label): a change
#: of them leaves a live build's result current.
_NOT_READ = frozenset({"rna_type", "name", "show_expanded"})


def _value(value, contents=False):
    """A property value as plain data that compares by content: an ID by its
    `session_uid` (with `contents`, a Text or a field node tree by what it holds as
    well, as their edits reach no depsgraph counter; a tree that cannot be read by its
    error, which the build reports), arrays as tuples, enum flags as sorted tuples, a
    NaN as `_NAN` (equal to itself, so an unchanged NaN leaves a build current)."""
    if isinstance(value, bpy.types.ID):
        if contents and isinstance(value, bpy.types.Text):
            return value.session_uid, hash(value.as_string())
        if contents and isinstance(value, bpy.types.NodeTree):
            from ..nodes.graph import tree_json

            try:
                return value.session_uid, tree_json(value)
            except Exception as exc:  # noqa: BLE001 - the build reading it reports it; a state never raises
                return value.session_uid, error_text(exc)
        return value.session_uid
    if isinstance(value, (set, frozenset)):
        return tuple(sorted(value))
    if isinstance(value, float):
        return _float(value)
    if isinstance(value, (str, int, bool)) or value is None:
        return value
    return tuple(_element(v) for v in value)


def _element(value):
    """An element of an array or a collection as `_value` reads arrays: a float
    through `_float`, a row of a matrix as a tuple, anything else (an item) as it is."""
    if isinstance(value, float):
        return _float(value)
    if isinstance(value, (str, bpy.types.bpy_struct)) or not hasattr(value, "__iter__"):
        return value
    return tuple(map(_element, value))


#: What a NaN reads as in a state: NaN != NaN, so an unchanged NaN setting would make
#: every build stale (its result never written).
_NAN = ("nan",)


def _float(value: float):
    """`value`, or `_NAN` for a NaN (of any bits: none of them means anything else)."""
    return _NAN if value != value else value


def contents_read(item) -> frozenset:
    """The item's pointers whose contents its result reads: its field node tree or
    Text only while its source is that (a tree left set under another source is not
    read, and its edits leave the result current; `text_watch` follows the same Texts)."""
    if item.kind == "SOLID_TEXTURE" or (item.kind == "VOLUMETRIC_TEXTURE" and item.source == "FIELD_JSON"):
        return frozenset({"tree_text"})
    if item.kind == "VOLUMETRIC_TEXTURE" and item.source == "FIELD_NODES":
        return frozenset({"field_nodes"})
    return frozenset()


def item_values(item, contents=True) -> tuple:
    """The values of an item's own properties (`bl_rna`) that its result depends on:
    no evaluated settings, so no mesh (a cutter's) is read; the contents of the field
    node tree or Text its source reads (`contents_read`; with `contents` False, those
    pointers by their ID only)."""
    read = contents_read(item) if contents else frozenset()
    return tuple(_value(getattr(item, p.identifier), p.identifier in read) for p in item.bl_rna.properties if p.identifier not in _NOT_READ)


def source_state(obj):
    """What a live build of `obj` must still read for its result to be written: its
    enabled items' property values (`item_values`; the scene's frame and frame rate
    where one follows the frame), its own mesh's size and positions, and its
    depsgraph changes (`_versions`: modifiers, watched objects such as a cutter or a
    local center, sculpts), and its placement where an item watches another object
    (a cutter, a local center: read in the source's space)."""
    mesh = obj.data
    positions = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", positions)
    enabled = [item for item in obj.thicket.items if item.show_viewport]
    settings = tuple((item.kind, item_values(item)) for item in enabled)
    scene = bpy.context.scene
    if scene is not None and any(item.follow_frame for item in enabled):
        settings += ((scene.frame_current, scene.render.fps, scene.render.fps_base),)
    if any(item.watched_objects() for item in enabled):
        # A cutter or local center is read in the source's space: moving the source changes the result.
        settings += (tuple(tuple(map(_float, row)) for row in obj.matrix_world),)
    counts = (len(mesh.vertices), len(mesh.edges), len(mesh.polygons), len(mesh.loops))
    return mesh.session_uid, counts, hash(positions.tobytes()), _versions.get(obj.session_uid, 0), settings


def _write(obj, build, result_arrays) -> None:
    from .regenerate import write_result

    write_result(obj, result_arrays)


_live = Builds(lambda uid: by_uid(bpy.data.objects, uid), _write, _failed, exclusive=True, on_poll=redraw_panels)


def start(obj) -> None:
    """Regenerates `obj`'s result without holding the interface: the source read
    here (when the build starts), `evaluate_stack` on a worker, the result written by
    a timer when done (`poll`). Cancels `obj`'s build in flight; this one starts once
    that cancel has landed. A source that cannot be read sets `last_error` at once.
    Bakes over their item's Ask Above stop with `BakeNeedsConfirmation` in `last_error`
    (Regenerate asks)."""
    uid = obj.session_uid

    def starter():
        from ..pure.evaluate import evaluate_stack
        from .regenerate import read_source
        from .versioning import ensure_upgraded

        source = by_uid(bpy.data.objects, uid)
        if not _is_source(source):
            return None
        ensure_upgraded()
        try:
            arrays, items = read_source(source)
            return Build(source, source_state, lambda job: evaluate_stack(arrays, items, job.progress, ask=True))
        except Exception as exc:  # noqa: BLE001 - also run by the timer, which must never raise
            _failed(source, exc)
            return None

    _live.start(obj, starter)


def cancel(obj=None) -> None:
    """Cancels `obj`'s live build (every one for None): its result is never written."""
    _live.cancel(obj)


def running(obj) -> bool:
    """Whether `obj` has a live build in flight or waiting to start."""
    return _live.running(obj)


def progress(obj):
    """How far `obj`'s live build is (0 to 1), None when none runs (the panel)."""
    return _live.fraction(obj)


def poll():
    """What the timer calls: writes the finished builds, starts the waiting ones;
    the next interval, or None when nothing is left in flight."""
    return _live.poll()


def wait(timeout=60.0) -> None:
    """Waits for the builds in flight and writes them (tests, scripts)."""
    _live.wait(timeout)


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
    for obj in changed_sources(scene, depsgraph, is_source=lambda _obj: True):
        _versions[obj.session_uid] = _versions.get(obj.session_uid, 0) + 1
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
    if renders_each_frame(scene):
        flush()  # the frame renders next: its results now, not after a debounce


def renders_each_frame(scene) -> bool:
    """Whether an animation render in progress can regenerate each frame's results in
    the frame-change handler: in background renders, and in the interface only with
    Render > Lock Interface, since the handler then runs on the render thread and the
    interface must not touch the data it writes. Without the lock, results follow by
    the debounce as before (the panel says so: `animation_render_hint`)."""
    return bpy.app.is_job_running("RENDER") and (bpy.app.background or scene.render.use_lock_interface)


def animation_render_hint(obj, scene, background=None) -> str:
    """The panel's advice for a source whose result changes with the frame, when an
    animation render in the interface would not get each frame's result (`background`:
    whether Blender runs without one, `bpy.app.background` when None)."""
    background = bpy.app.background if background is None else background
    if background or scene is None or scene.render.use_lock_interface or not _is_source(obj):
        return ""
    if obj.animation_data is None and not any(i.follows_frame() for i in obj.thicket.items):
        return ""
    return "Animation renders get each frame's result with Render > Lock Interface on"


@persistent
def on_undo_pre(*_args):
    """An undo, a redo or a file load is about to replace the data: builds in flight
    read the state it leaves, so they are dropped (with regenerations still waiting
    for the debounce)."""
    _live.cancel()
    _sources.pending.clear()


#: How long a render waits for the live builds in flight when it starts (seconds).
RENDER_WAIT_SECONDS = 30.0


def _in_flight() -> bool:
    return bool(_sources.pending or _live.builds or _live._next or _live._ending)


@persistent
def on_render_init(scene, *_args):
    """A render renders the current results where that is safe. A render that holds
    the main thread (a script's `bpy.ops.render.render()`, a background render) lands
    the live builds in flight and the changes waiting for the debounce before it reads
    the scene (`finish_for_render`). An interface render (F12) runs this on its own
    thread: writing Blender data there races the interface's timers (which Blender
    runs even with Lock Interface), and waiting for them can hold Blender for the
    whole wait at quit or file load, so it only says that the render shows the
    previous result."""
    if threading.current_thread() is threading.main_thread():
        finish_for_render()
    elif _in_flight():
        print("Thicket: a stack is still regenerating; this render shows its previous result (render again once it is done)")


def finish_for_render(timeout=None) -> bool:
    """Makes the results current for a render starting now, on the main thread (whose
    timers cannot run meanwhile): regenerates what waits for the debounce, then waits
    for the builds in flight and writes them until `RENDER_WAIT_SECONDS` after it
    began; whether they are current. Past it the render shows the previous result
    and says so on the console."""
    if not _in_flight():
        return True
    timeout = RENDER_WAIT_SECONDS if timeout is None else timeout
    started = time.monotonic()
    flush()
    _live.wait(max(0.0, timeout - (time.monotonic() - started)))
    if _in_flight():
        print(f"Thicket: a stack was still regenerating after {time.monotonic() - started:.1f} s; this render shows its previous result")
        return False
    return True


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
    (bpy.app.handlers.load_pre, on_undo_pre),
    (bpy.app.handlers.undo_pre, on_undo_pre),
    (bpy.app.handlers.redo_pre, on_undo_pre),
    (bpy.app.handlers.render_init, on_render_init),
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
    _live.cancel()
    live_shells.clear()
    from .. import sculpt

    sculpt.clear()
