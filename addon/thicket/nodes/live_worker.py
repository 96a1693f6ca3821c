"""Live regeneration of a node tree's Field Meshes off the main thread (the
interface; background scripts regenerate at once, `live.regenerate_tree`).

A change to a tree (debounced) reads the tree and its Field Meshes' settings on
the main thread (`live.start_live`), then meshes on a worker thread (`operators.common.Job`; the core
releases the GIL), so dragging a handle never holds Blender while a tree meshes.
A timer on the main thread writes the meshes once they are done. A newer change to
the same tree cancels the build in flight (the core stops at its next progress
check) and its result is dropped, so only the latest state is written. Errors go to
the tree's status and leave the meshes as they were, as a synchronous
regeneration does; a tree estimated too large to mesh live waits for Regenerate
(`live.waits_for_the_user`)."""

import bpy

from ..fields import field_mesh
from ..operators.common import Job, cancel_errors, error_text, user_errors
from ..stack.guard import suspended

#: How often the main thread looks for finished builds (seconds).
POLL_SECONDS = 0.05

#: Builds in flight by tree name: (job, targets, the distinct prepared settings,
#: `still_shows(obj, tree)`); a target is (object name, its Text's name or None,
#: index into the distinct settings).
_builds: dict = {}


def start(tree, targets, distinct, still_shows) -> None:
    """Meshes each of `distinct` (`fields.field_mesh.prepare`d settings) on a worker
    thread for the Field Meshes `targets` of `tree` (see `_builds`), cancelling the
    build of `tree` in flight; `still_shows(obj, tree)` tells at writing time
    whether an object still shows the tree (it may have been relinked)."""
    cancel(tree.name)

    def work(job):
        return [field_mesh.mesh_arrays(p, job.progress) for p in distinct]

    _builds[tree.name] = (Job(work).start(), targets, distinct, still_shows)
    if not bpy.app.timers.is_registered(poll):
        bpy.app.timers.register(poll, first_interval=POLL_SECONDS)


def cancel(name=None) -> None:
    """Cancels the build of the tree named `name` in flight (every build for None);
    its result is never written."""
    for key in list(_builds) if name is None else [name]:
        build = _builds.pop(key, None)
        if build is not None:
            build[0].cancel()


def running(name) -> bool:
    return name in _builds


def poll():
    """Writes the builds that are done (main thread); the timer's next interval, or
    None once nothing is in flight."""
    for name, (job, targets, distinct, still_shows) in list(_builds.items()):
        if not job.done:
            continue
        del _builds[name]
        tree = bpy.data.node_groups.get(name)
        if tree is None:
            continue  # the tree went (a file was loaded, or it was deleted)
        try:
            arrays = job.outcome()
        except cancel_errors():
            continue
        except user_errors() as exc:
            set_status(tree, error_text(exc))
            continue
        set_status(tree, _write(tree, targets, distinct, arrays, still_shows))
    return POLL_SECONDS if _builds else None


def _write(tree, targets, distinct, arrays, still_shows) -> str:
    message = ""
    with suspended():
        for obj_name, text_name, index in targets:
            obj = bpy.data.objects.get(obj_name)
            if obj is None or not still_shows(obj, tree):
                continue  # deleted or relinked while it meshed
            source = bpy.data.texts.get(text_name) if text_name is not None else None
            try:
                field_mesh.write_existing(obj, distinct[index], arrays[index], source)
            except user_errors() as exc:
                message = message or f"{obj_name}: {error_text(exc)}"
    return message


def set_status(tree, message) -> None:
    with suspended():
        if tree.status != message:
            tree.status = message


def wait(timeout=60.0) -> None:
    """Waits for every build in flight and writes them (tests and scripts that
    started a live build by hand)."""
    for build in list(_builds.values()):
        build[0].join(timeout)
    poll()


__all__ = ["POLL_SECONDS", "cancel", "poll", "running", "set_status", "start", "wait"]
