"""Live preview in the 3D view: the active source's thick surface, rendered by the
native renderer from each 3D view's angle and drawn over it (chapter 5: seen without
baking). A timer watches the views and what is shown; when either changes (the view,
the object's placement, its stack settings, or anything that changes its result: mesh
edits, modifiers, vertex groups, a cutter object), it is rendered again (at most every
THROTTLE seconds, at half resolution).

Only reading Blender and drawing run on the main thread. The heavy parts run on the
stack's worker machinery (`stack.live_build`): the preparation (the stack's items
before the drawn one, shells included, and the native handle: `prepare_work`) as one
build per source, and each view's frame as one build per view. A newer change cancels
the build in flight, a result is kept only while its source (or view) still reads as
when its build started, `progress()` says how far the builds are (drawn in the view,
shown on the sidebar's button) and the timer that writes the results redraws the 3D
views."""

import time

import bpy
import numpy as np

from ..stack.live_build import Build, Builds, by_uid, redraw_panels
from . import camera, lights

THROTTLE = 0.25
SCALE = 0.5

_state = {"handle": None, "views": {}, "prepared": None, "error": "", "note": "", "generations": {}, "failed": None, "started": 0.0, "shown": None}


def is_enabled():
    return _state["handle"] is not None


def enable():
    if is_enabled() or bpy.app.background:
        return
    watch()
    _state["handle"] = bpy.types.SpaceView3D.draw_handler_add(_draw, (), "WINDOW", "POST_PIXEL")
    bpy.app.timers.register(_tick, first_interval=0.05)


def disable():
    _stop()
    unwatch()


def _stop():
    """Ends the preview (its draw handler, timer, builds and images), its handlers kept."""
    if _state["handle"] is not None:
        bpy.types.SpaceView3D.draw_handler_remove(_state["handle"], "WINDOW")
    cancel()
    _state.update(handle=None, views={}, prepared=None, error="", note="", failed=None, shown=None)
    if bpy.app.timers.is_registered(_tick):
        bpy.app.timers.unregister(_tick)
    redraw_panels()


def _has_stack(obj):
    return obj is not None and obj.type == "MESH" and len(obj.thicket.items) > 0


@bpy.app.handlers.persistent
def on_depsgraph_update(scene, depsgraph):
    """Counts, per object, the updates that change what its preview shows (see
    `generation`)."""
    from ..stack.auto_update import changed_sources

    generations = _state["generations"]
    for obj in changed_sources(scene, depsgraph, _has_stack):
        generations[obj.session_uid] = generations.get(obj.session_uid, 0) + 1


@bpy.app.handlers.persistent
def on_undo_pre(*_args):
    """An undo or a redo replaces the data the builds in flight read: they are dropped
    (the next tick prepares what the view shows then)."""
    cancel()


@bpy.app.handlers.persistent
def on_load_pre(*_args):
    """A file load ends the preview (Blender drops its timer; the images and native
    handle are the old file's): the button shows it off, and turning it on starts anew
    (`enable` watches again). Its other handlers go with it, so no depsgraph update of
    the new file is scanned for a preview that is off; this one stays (Blender is
    running the `load_pre` list, which must not change under it) and does nothing more
    until then."""
    _stop()
    for handlers, fn in HANDLERS:
        if fn is not on_load_pre and fn in handlers:
            handlers.remove(fn)
    _state["generations"].clear()  # the old file's objects
    _keys.clear()


#: The handlers `watch` adds: the depsgraph's, and those that drop builds in flight.
HANDLERS = (
    (bpy.app.handlers.depsgraph_update_post, on_depsgraph_update),
    (bpy.app.handlers.undo_pre, on_undo_pre),
    (bpy.app.handlers.redo_pre, on_undo_pre),
    (bpy.app.handlers.load_pre, on_load_pre),
)


def watch():
    """Follows changes of every stack's result (`generation`), for the preview."""
    for handlers, fn in HANDLERS:
        if fn not in handlers:
            handlers.append(fn)


def unwatch():
    for handlers, fn in HANDLERS:
        if fn in handlers:
            handlers.remove(fn)


def generation(obj):
    """How many changes of `obj`'s result were seen since watching began."""
    return _state["generations"].get(obj.session_uid, 0)


def content_key(obj):
    """What `obj`'s preview shows, besides the view and the object's placement: its
    stack items' values as the stale check reads them (`auto_update.item_values`: no
    mesh read, a cutter's changes count in `generation`; the field node tree or Text
    an item reads by its contents; no panel-only property) and the changes of its
    result seen so far. The object is named by its session id, which a file loaded
    anew or an object made again under the same name does not share. Read anew (the
    preparation's read); `current_key` is what the timer looks at."""
    from ..stack.auto_update import item_values

    items = tuple(item_values(item) for item in obj.thicket.items)
    key = (obj.session_uid, obj.data.session_uid, items, generation(obj))
    _keys[obj.session_uid] = (_stamp(obj), _clock(), key)
    return key


#: How long `current_key` keeps the contents of a field node tree or a Text that the
#: items read (seconds): their edits reach no change counter, so they are read again
#: this often (the stack's Text watcher looks as often), not on every tick.
CONTENTS_SECONDS = 0.5

#: The clock of `CONTENTS_SECONDS` (tests replace it).
_clock = time.monotonic

#: Each object's last `content_key`: (stamp, when, key), by session id.
_keys: dict = {}


def _stamp(obj):
    """What `content_key` reads but its contents (a field node tree's JSON, a Text's
    digest): cheap, read on every tick."""
    from ..stack.auto_update import item_values

    items = tuple(item_values(item, contents=False) for item in obj.thicket.items)
    return (obj.data.session_uid, generation(obj), items)


def current_key(obj):
    """`content_key(obj)` as the timer and the stale checks look at it: the last one
    read while `obj`'s changes (`generation`) and items' own values are unchanged,
    its field tree or Text contents read again at most every `CONTENTS_SECONDS`
    (serialising a tree on every tick and twice per preparation was the tick's cost)."""
    kept = _keys.get(obj.session_uid)
    if kept is not None and kept[0] == _stamp(obj) and (_clock() - kept[1] < CONTENTS_SECONDS or not _reads_contents(obj)):
        return kept[2]
    return content_key(obj)


def _reads_contents(obj):
    from ..stack.auto_update import contents_read

    return any(getattr(item, name) is not None for item in obj.thicket.items for name in contents_read(item))


def _source():
    from ..stack.query import active_stack_source

    return active_stack_source(bpy.context)


def _error_text(exc):
    from ..pure.native import error_text

    return error_text(exc)


def _failed(owner, exc):
    """A build's error, shown in the view; what it shows stays as it was."""
    _state["error"] = _error_text(exc)


# --- The preparation: one build per source -------------------------------------------


def prepare_inputs(obj):
    """What preparing `obj` reads from Blender (main thread): (content key, source
    arrays, enabled items' settings), as a regeneration reads them (a Procedural
    Detail's sculpt included); the key taken after the read, as the stale check's."""
    from ..stack.guard import suspended
    from ..stack.regenerate import enabled_settings, read_source

    with suspended():
        source, items = read_source(obj, bpy.context.evaluated_depsgraph_get(), enabled_settings(obj))
    return content_key(obj), source, items


def prepare_work(source, items, progress=None):
    """The native handle the views render frame after frame (any thread, no bpy): a
    `thicket_native.TexturedShell` for a Volumetric Texture (the drawn kind's
    `draw_setup` says), after the items before it (their shells are the expensive part,
    with the handle's checks of its arrays). `progress`: as `evaluate_stack`'s."""
    from ..pure.evaluate import render_setup

    return render_setup(source, items, progress).handle()


def _shown(obj):
    """Whether `obj` is the object the views show (the last `refresh`'s)."""
    return _state["shown"] == obj.session_uid


def _prepared_lands(obj, build, handle):
    """Kept when `obj` is still the one shown; its key is the one its stale check read
    (`build.read`, after the read of its inputs)."""
    if _shown(obj):
        _state["prepared"] = (build.read, handle)
        _state["error"] = ""


def _preparation_failed(obj, exc):
    """Shown in the view (when `obj` is still the one shown); not tried again until
    `obj`'s content changes (the build only fails while it still reads as it did, so
    its content is the failed one)."""
    if _shown(obj):
        _state["failed"] = current_key(obj)
        _failed(obj, exc)


_preparations = Builds(lambda uid: by_uid(bpy.data.objects, uid), _prepared_lands, _preparation_failed, exclusive=True, on_poll=redraw_panels)


def start_prepare(obj):
    """Prepares `obj` on a worker (`prepare_work`), its inputs read here; the timer
    keeps the handle once it is done, while `obj`'s content still reads the same.
    Cancels the preparation in flight (this one starts once that cancel landed) and
    those of other objects: `obj` is the one shown now. An unreadable source shows its
    error at once."""
    uid = _state["shown"] = obj.session_uid
    _preparations.cancel_others(obj)  # another object was shown: its result is not wanted

    def starter():
        source_obj = by_uid(bpy.data.objects, uid)
        if source_obj is None:
            return None
        try:
            _key, source, items = prepare_inputs(source_obj)
            return Build(source_obj, current_key, lambda job: prepare_work(source, items, job.progress))
        except Exception as exc:  # noqa: BLE001 - also run by the timer, which must never raise
            _preparation_failed(source_obj, exc)
            return None

    _preparations.start(obj, starter)


def _prepared(obj):
    """(key, native handle) of `obj`, made now on this thread when its content changed
    since the handle kept (scripts and tests; the interface uses `start_prepare`)."""
    key = content_key(obj)
    cached = _state["prepared"]
    if cached is None or cached[0] != key:
        key, source, items = prepare_inputs(obj)
        _state["prepared"] = (key, prepare_work(source, items))
    return _state["prepared"]


# --- The frames: one build per view --------------------------------------------------


class View:
    """One 3D view's preview: the key it wants shown (`want`: view, size, placement,
    content), the key of the image it shows (`key`), when its last render started, the
    image waiting to be uploaded (`result`, rows from the top) and its GPU texture.
    Named by its area's pointer (`session_uid`, as `Builds` names owners)."""

    def __init__(self, uid):
        self.session_uid = uid
        self.want = self.key = self.result = self.texture = None
        self.last = 0.0


def _wanted(view):
    return view.want


def _rendered(view, build, out):
    view.result, view.key = out["rgba"], build.extra
    _state["error"], _state["note"] = "", out["fallback"]


_renders = Builds(lambda uid: _state["views"].get(uid), _rendered, _failed, on_poll=redraw_panels)


def start_render(view, handle, frame, settings):
    """Renders `handle` for `view` from `frame` (view matrix, projection, width,
    height) with the frame `settings` on a worker; the timer keeps the image once it is
    done, while the view still wants the key it wanted at the start (`view.want`).
    Cancels the view's render in flight."""
    _renders.start(view, lambda: Build(view, _wanted, lambda job: handle.render(*frame, **settings, progress=job.progress), view.want))


def refresh(obj, views, now=None):
    """One look at `obj`'s preview from `views`, (uid, width, height, RegionView3D)
    of each 3D view at its preview's size: prepares `obj` when its content changed
    (the views keep showing their last images meanwhile; another object's preparation
    is cancelled), drops the views not among `views` (areas closed), cancels the
    renders the views no longer want, and starts one for each view whose image is not what it wants
    (at most every THROTTLE seconds). Returns the `View`s, for their uploads."""
    now = time.monotonic() if now is None else now
    content, placed = current_key(obj), tuple(map(tuple, obj.matrix_world))
    _state["shown"] = obj.session_uid
    _preparations.cancel_others(obj)  # another object was shown: its result is not wanted
    prepared = _state["prepared"]
    ready = prepared is not None and prepared[0] == content
    preparing = _preparations.builds.get(obj.session_uid)
    if preparing is not None and preparing.read != content:
        _preparations.cancel(obj)  # a newer change: the next start prepares it
    if not ready and not _preparations.running(obj) and _state["failed"] != content and now - _state["started"] >= THROTTLE:
        _state.update(started=now, failed=None)
        start_prepare(obj)
    for uid in set(_state["views"]) - {uid for uid, *_rest in views}:
        _renders.cancel(_state["views"].pop(uid))  # its area closed: its image and texture go
    out = []
    for uid, width, height, r3d in views:
        view = _state["views"].get(uid)
        if view is None:
            view = _state["views"][uid] = View(uid)
        view.want = (tuple(map(tuple, r3d.view_matrix)), tuple(map(tuple, r3d.window_matrix)), width, height, placed, content)
        out.append(view)
        rendering = _renders.builds.get(uid)
        if rendering is not None and rendering.extra != view.want:
            _renders.cancel(view)  # the view moved on: a newer render starts below
        if not ready or view.key == view.want or _renders.running(view) or now - view.last < THROTTLE:
            continue
        try:
            v, p = camera.viewport_camera(r3d, obj)
            light = lights.scene_light(bpy.context.evaluated_depsgraph_get(), obj)
        except Exception as exc:  # noqa: BLE001 - shown in the view; never raised into Blender's loop
            _state["error"] = _error_text(exc)
            continue
        view.last = now
        start_render(view, prepared[1], (v, p, width, height), dict(light=light))
    return out


def progress():
    """How far the preview's builds in flight are (0 to 1; the preparation, else the
    slowest frame), None when none runs (the view's text, the sidebar's button)."""
    fractions = [b.job.fraction for b in _preparations.builds.values()] or [b.job.fraction for b in _renders.builds.values()]
    return min(fractions) if fractions else None


def cancel():
    """Drops every build in flight: their results are never kept."""
    _preparations.cancel()
    _renders.cancel()


def wait(timeout=60.0):
    """Waits for the builds in flight and keeps their results (tests, scripts)."""
    _preparations.wait(timeout)
    _renders.wait(timeout)


def _tick():
    """The timer: `refresh` from every 3D view, uploading the images that landed;
    returns the next delay."""
    if not is_enabled():
        return None
    obj = _source()
    if obj is None:
        return 0.5
    areas, views = {}, []
    for window in bpy.context.window_manager.windows:
        for area in window.screen.areas:
            if area.type != "VIEW_3D":
                continue
            region = next((r for r in area.regions if r.type == "WINDOW"), None)
            r3d = area.spaces.active.region_3d
            if region is None or r3d is None or region.width < 2 or region.height < 2:
                continue
            areas[area.as_pointer()] = area
            views.append((area.as_pointer(), max(1, int(region.width * SCALE)), max(1, int(region.height * SCALE)), r3d))
    try:
        for view in refresh(obj, views):
            if view.result is not None:
                _upload(view)
                areas[view.session_uid].tag_redraw()
    except Exception as exc:  # noqa: BLE001 - a timer that raises is unregistered by Blender
        _state["error"] = _error_text(exc)
    return 0.1


def _upload(view):
    import gpu

    rgba, view.result = view.result, None
    h, w = rgba.shape[:2]
    data = np.ascontiguousarray(rgba[::-1], dtype=np.float32).ravel()
    view.texture = gpu.types.GPUTexture((w, h), format="RGBA16F", data=gpu.types.Buffer("FLOAT", data.size, data))


def status_line():
    """The text drawn in the view: the error, else the progress, else the renderer's note."""
    if _state["error"]:
        return f"Thicket preview: {_state['error']}"
    fraction = progress()
    if fraction is not None:
        return f"Thicket preview: {'preparing' if _preparations.builds else 'rendering'}... {fraction:.0%}"
    return f"Thicket preview ({_state['note']})" if _state["note"] else ""


def _draw():
    import blf
    import gpu
    from gpu_extras.batch import batch_for_shader

    area = bpy.context.area
    view = _state["views"].get(area.as_pointer()) if area else None
    region = bpy.context.region
    if view is not None and view.texture is not None:
        shader = gpu.shader.from_builtin("IMAGE")
        w, h = region.width, region.height
        batch = batch_for_shader(shader, "TRI_FAN", {"pos": ((0, 0), (w, 0), (w, h), (0, h)), "texCoord": ((0, 0), (1, 0), (1, 1), (0, 1))})
        gpu.state.blend_set("ALPHA")
        shader.bind()
        shader.uniform_sampler("image", view.texture)
        batch.draw(shader)
        gpu.state.blend_set("NONE")
    line = status_line()
    if line:
        blf.position(0, 20, 30, 0)
        blf.size(0, 13)
        blf.draw(0, line)
