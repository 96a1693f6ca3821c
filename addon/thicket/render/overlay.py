"""Live preview in the 3D view: the active source's thick surface, rendered by the
native renderer from each 3D view's angle and drawn over it (chapter 5: seen without
baking). A timer watches the views and what is shown; when either changes (the view,
the object's placement, its stack settings, or anything that changes its result: mesh
edits, modifiers, vertex groups, a cutter object), it is rendered again (at most every
THROTTLE seconds, at half resolution) on a worker thread — the native call releases
the GIL — so the interface never waits for it."""

import threading
import time

import bpy
import numpy as np

from ..pure import native
from . import camera, lights

THROTTLE = 0.25
SCALE = 0.5

_state = {"handle": None, "views": {}, "prepared": None, "error": "", "note": "", "generation": 0}


def is_enabled():
    return _state["handle"] is not None


def enable():
    if is_enabled() or bpy.app.background:
        return
    watch()
    _state["handle"] = bpy.types.SpaceView3D.draw_handler_add(_draw, (), "WINDOW", "POST_PIXEL")
    bpy.app.timers.register(_tick, first_interval=0.05)


def disable():
    if _state["handle"] is not None:
        bpy.types.SpaceView3D.draw_handler_remove(_state["handle"], "WINDOW")
    unwatch()
    _state.update(handle=None, views={}, prepared=None, error="", note="")
    if bpy.app.timers.is_registered(_tick):
        bpy.app.timers.unregister(_tick)
    _redraw_all()


def _has_stack(obj):
    return obj is not None and obj.type == "MESH" and len(obj.thicket.items) > 0


@bpy.app.handlers.persistent
def on_depsgraph_update(scene, depsgraph):
    """Counts the updates that change what a preview shows (see `generation`)."""
    from ..stack.auto_update import changed_sources

    if changed_sources(scene, depsgraph, _has_stack):
        _state["generation"] += 1


def watch():
    """Follows changes of every stack's result (`generation`), for the preview."""
    if on_depsgraph_update not in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.append(on_depsgraph_update)


def unwatch():
    if on_depsgraph_update in bpy.app.handlers.depsgraph_update_post:
        bpy.app.handlers.depsgraph_update_post.remove(on_depsgraph_update)


def generation():
    """How many changes of a stack source's result were seen since watching began."""
    return _state["generation"]


def _plain(value):
    """A property value as plain, comparable data (an ID, such as a cutter, by its
    session id: another object of the same name is another content)."""
    if isinstance(value, bpy.types.ID):
        return ("ID", value.session_uid)
    if hasattr(value, "__len__") and not isinstance(value, str):
        return tuple(value)
    return value


def content_key(obj):
    """What `obj`'s preview shows, besides the view and the object's placement: its
    stack items' properties (read as stored, without reading a cutter's mesh: its
    changes count in `generation`) and the changes of its result seen so far. The
    object is named by its session id, which a file loaded anew or an object made
    again under the same name does not share."""
    items = tuple(tuple((name, _plain(getattr(item, name))) for name in item.bl_rna.properties.keys() if name != "rna_type") for item in obj.thicket.items)
    return (obj.session_uid, obj.data.session_uid, items, _state["generation"])


def _redraw_all():
    for window in getattr(bpy.context.window_manager, "windows", ()):
        for area in window.screen.areas:
            if area.type == "VIEW_3D":
                area.tag_redraw()


def _source():
    from ..stack.query import active_stack_source

    return active_stack_source(bpy.context)


def _prepared(obj):
    """(key, native handle) of `obj` (a `thicket_native.TexturedShell` for a Volumetric
    Texture; the drawn kind's `draw_setup` says): one handle, rendered frame after
    frame, made again only when its `content_key` changed (the shell, the native
    read and checks, and the renderers' scene, which the handle makes on its first
    frame and keeps, are the expensive parts)."""
    from ..pure.evaluate import render_setup
    from ..stack.guard import suspended
    from ..stack.regenerate import enabled_settings, read_source

    items = enabled_settings(obj)
    key = content_key(obj)
    cached = _state["prepared"]
    if cached is None or cached[0] != key:
        with suspended():
            # As a regeneration reads it (a Procedural Detail's sculpt included).
            source, items = read_source(obj, bpy.context.evaluated_depsgraph_get(), items)
        _state["prepared"] = (key, render_setup(source, items).handle())
    return _state["prepared"]


def _tick():
    """Starts a render for every 3D view whose angle changed; returns the next delay."""
    if not is_enabled():
        return None
    obj = _source()
    if obj is None:
        return 0.5
    now = time.monotonic()
    placed, content = tuple(map(tuple, obj.matrix_world)), content_key(obj)
    for window in bpy.context.window_manager.windows:
        for area in window.screen.areas:
            if area.type != "VIEW_3D":
                continue
            region = next((r for r in area.regions if r.type == "WINDOW"), None)
            r3d = area.spaces.active.region_3d
            if region is None or r3d is None or region.width < 2 or region.height < 2:
                continue
            view = _state["views"].setdefault(area.as_pointer(), {"key": None, "busy": False, "last": 0.0, "result": None, "texture": None})
            width, height = max(1, int(region.width * SCALE)), max(1, int(region.height * SCALE))
            key = (tuple(map(tuple, r3d.view_matrix)), tuple(map(tuple, r3d.window_matrix)), width, height, placed, content)
            view["want"] = key  # a render for another key stops (see `_work`)
            if view["result"] is not None:
                _upload(view)
                area.tag_redraw()
            if view["busy"] or (key == view["key"] and _state["prepared"] is not None) or now - view["last"] < THROTTLE:
                continue
            try:
                _, handle = _prepared(obj)
                v, p = camera.viewport_camera(r3d, obj)
                light = lights.scene_light(bpy.context.evaluated_depsgraph_get(), obj)
            except Exception as exc:  # shown in the view; never raised into Blender's loop
                _state["error"] = str(exc)
                area.tag_redraw()
                continue
            view.update(key=key, busy=True, last=now)
            threading.Thread(target=_work, args=(view, key, handle, (v, p, width, height), dict(light=light)), daemon=True).start()
    return 0.1


def _work(view, key, handle, camera, settings):
    """Renders a frame of `handle` (a `thicket_native.TexturedShell`) for `key` from
    `camera` (view, projection, width, height) with the frame `settings`; stops
    (keeping the last image) once the view wants another."""
    tn = native.get()
    try:
        out = handle.render(*camera, **settings, progress=lambda _: view.get("want") == key)
        view["result"] = out["rgba"]
        _state["error"], _state["note"] = "", out["fallback"]
    except tn.Cancelled:
        view["key"] = None  # rendered again for what the view wants now
    except Exception as exc:  # reported in the view
        _state["error"] = str(exc)
    finally:
        view["busy"] = False


def _upload(view):
    import gpu

    rgba = view.pop("result")
    view["result"] = None
    h, w = rgba.shape[:2]
    data = np.ascontiguousarray(rgba[::-1], dtype=np.float32).ravel()
    view["texture"] = gpu.types.GPUTexture((w, h), format="RGBA16F", data=gpu.types.Buffer("FLOAT", data.size, data))


def _draw():
    import blf
    import gpu
    from gpu_extras.batch import batch_for_shader

    area = bpy.context.area
    view = _state["views"].get(area.as_pointer()) if area else None
    region = bpy.context.region
    if view is not None and view.get("texture") is not None:
        shader = gpu.shader.from_builtin("IMAGE")
        w, h = region.width, region.height
        batch = batch_for_shader(shader, "TRI_FAN", {"pos": ((0, 0), (w, 0), (w, h), (0, h)), "texCoord": ((0, 0), (1, 0), (1, 1), (0, 1))})
        gpu.state.blend_set("ALPHA")
        shader.bind()
        shader.uniform_sampler("image", view["texture"])
        batch.draw(shader)
        gpu.state.blend_set("NONE")
    line = _state["error"] or _state["note"]
    if line:
        blf.position(0, 20, 30, 0)
        blf.size(0, 13)
        blf.draw(0, f"Thicket preview: {line}" if _state["error"] else f"Thicket preview ({line})")
