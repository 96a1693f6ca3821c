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
(`live.start_live`). An undo or redo, a file load and Regenerate drop the builds in
flight, and a result is written only while the tree still reads as it did when its
build started."""

import bpy

from ..fields import field_mesh
from ..operators.common import error_text, user_errors
from ..stack.guard import suspended
from ..stack.live_build import POLL_SECONDS, Build, Builds, by_uid


def _write(tree, build, arrays) -> None:
    targets, distinct, still_shows, note = build.extra
    set_status(tree, write_targets(tree, targets, distinct, arrays, still_shows) or note)


_live = Builds(lambda uid: by_uid(bpy.data.node_groups, uid), _write, lambda tree, exc: set_status(tree, error_text(exc)))
#: Builds in flight by their tree's session_uid.
_builds = _live.builds


def start(tree, targets, distinct, state, still_shows, note="") -> None:
    """Meshes each of `distinct` (`fields.field_mesh.prepare`d settings) on a worker
    thread for `targets`, (object session_uid, index into `distinct`) pairs of
    Field Meshes of `tree`, cancelling the build of `tree` in flight. When done,
    the timer writes each mesh whose object `still_shows(obj, tree)`, if
    `state(tree)` has not changed since; `note` (an error met while reading the
    targets) is the tree's status then, or the first error of the writes."""

    def work(job):
        return [field_mesh.mesh_arrays(p, job.progress) for p in distinct]

    _live.start(tree, lambda: Build(tree, state, work, (targets, distinct, still_shows, note)))


def cancel(tree=None) -> None:
    """Cancels the build of `tree` in flight (every build for None); its result is
    never written."""
    _live.cancel(tree)


def running(tree) -> bool:
    return _live.running(tree)


def poll():
    """Writes the builds that are done (main thread); the timer's next interval, or
    None once nothing is in flight."""
    return _live.poll()


def write_targets(tree, targets, distinct, arrays, still_shows) -> str:
    """Writes `arrays[index]` (the mesh of `distinct[index]`) into each target
    `(object session_uid, index)` that `still_shows(obj, tree)`; targets whose
    arrays are None (their meshing failed) are skipped. Returns the first error."""
    message = ""
    with suspended():
        for obj_uid, index in targets:
            obj = by_uid(bpy.data.objects, obj_uid)
            if arrays[index] is None or obj is None or not still_shows(obj, tree):
                continue  # not meshed, or deleted or relinked while it meshed
            source = obj.get(field_mesh.TEXT_PROPERTY)
            source = source if isinstance(source, bpy.types.Text) else None
            try:
                field_mesh.write_existing(obj, distinct[index], arrays[index], source)
            except user_errors() as exc:
                message = message or f"{obj.name}: {error_text(exc)}"
    return message


def set_status(tree, message) -> None:
    with suspended():
        if tree.status != message:
            tree.status = message


def wait(timeout=60.0) -> None:
    """Waits for every build in flight and writes them (tests and scripts that
    started a live build by hand)."""
    _live.wait(timeout)


__all__ = ["POLL_SECONDS", "cancel", "poll", "running", "set_status", "start", "wait", "write_targets"]
