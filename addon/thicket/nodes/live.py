"""Field Mesh objects linked to a node tree, regenerated live (debounced with the
stack's debounce and re-entrancy guard: `stack.debounce.Debounced`,
`stack.guard`) when a node value or a link changes (`schedule_tree`) or a handle
object moves (`on_depsgraph_update`); in the interface the meshing runs on a
worker thread (`start_live`, `live_worker`). A failed regeneration leaves the mesh as it
was and keeps the message on the tree (`status`, shown in the editor's sidebar)."""

import bpy
from bpy.app.handlers import persistent

from ..fields.field_mesh import build_field_mesh, estimate, field_settings, mesh_arrays, prepare, prepare_regeneration, regenerate_field_mesh
from ..pure import native
from ..pure.field_nodes import TREE_IDNAME
from ..stack.debounce import Debounced
from ..stack.guard import busy, suspended
from . import live_worker
from .graph import tree_json

#: The Field Mesh object's ID property pointing at its node tree.
NODES_PROPERTY = "thicket_field_nodes"


def node_tree_of(obj):
    tree = obj.get(NODES_PROPERTY) if obj is not None else None
    return tree if isinstance(tree, bpy.types.NodeTree) and tree.bl_idname == TREE_IDNAME else None


def linked_objects(tree):
    """The Field Mesh objects showing `tree`."""
    return [obj for obj in bpy.data.objects if node_tree_of(obj) == tree]


def stack_users(tree):
    """The stack sources with a Volumetric Texture item whose source is `tree`."""
    return [
        obj
        for obj in bpy.data.objects
        if obj.type == "MESH" and any(i.kind == "VOLUMETRIC_TEXTURE" and i.source == "FIELD_NODES" and i.field_nodes == tree for i in obj.thicket.items)
    ]


def _used_trees():
    """The node trees shown by a Field Mesh or filling a Volumetric Texture."""
    trees = {node_tree_of(obj) for obj in bpy.data.objects}
    for obj in bpy.data.objects:
        if obj.type == "MESH":
            trees.update(i.field_nodes for i in obj.thicket.items if i.kind == "VOLUMETRIC_TEXTURE" and i.source == "FIELD_NODES")
    return trees - {None}


def errors():
    return (TypeError, KeyError, ValueError, RuntimeError, *native.error_types())


def build(tree, name=None, collection=None, progress=None, max_bytes=None):
    """A new Field Mesh object of the node tree `tree`, linked to it. Errors (a
    GraphError or ThicketError, both ValueErrors), a build over `max_bytes` and a
    cancel (`progress` returning False) leave the file as it was."""
    text = tree_json(tree)
    obj = build_field_mesh(
        text, name=name or tree.name, resolution=tree.resolution, adaptive=tree.adaptive, collection=collection, progress=progress, max_bytes=max_bytes
    )
    link(obj, tree)
    return obj


def link(obj, tree):
    """Makes `obj` the Field Mesh of `tree` (its regenerations follow the tree)."""
    with suspended():
        obj[NODES_PROPERTY] = tree
        tree.status = ""


def regenerate(obj, progress=None, max_bytes=None):
    """Rebuilds `obj` from its node tree's current nodes, handles and settings. On
    error, over `max_bytes` (the estimate refuses it before meshing) or on a cancel
    the mesh and its stored tree stay as they were; the error is raised."""
    tree = node_tree_of(obj)
    if tree is None:
        raise TypeError(f"'{obj.name}' is not linked to a Thicket field node tree")
    text = tree_json(tree)
    with suspended():
        regenerate_field_mesh(obj, tree=text, resolution=tree.resolution, adaptive=tree.adaptive, progress=progress, max_bytes=max_bytes)
    return obj


def tree_estimate(tree):
    """The core's estimate of meshing `tree` at its settings, within the stored
    bounds of its first Field Mesh (the tree's own bound when it has none); None
    when the graph is not a valid tree (its status says why). Cached by tree,
    settings and bounds (`pure.field_tree.field_mesh_estimate`): the sidebar asks
    on every redraw."""
    linked = linked_objects(tree)
    try:
        if linked:
            prepared = prepare_regeneration(linked[0], tree_json(tree), tree.resolution, tree.adaptive)[0]
        else:
            prepared = prepare(tree_json(tree), tree.resolution, None, tree.adaptive)
        return estimate(prepared)
    except errors():
        return None


NOT_LIVE = "Not regenerated live"


def _not_live(guess) -> str:
    """The status of a tree whose estimate `guess` is too large to mesh live."""
    from ..pure.field_tree import estimate_text

    return f"{NOT_LIVE}: {estimate_text(guess)}; press Regenerate to build it (with progress, Esc cancels)"


def regenerate_tree(tree, ask=False):
    """Regenerates every Field Mesh of `tree` at once (background scripts' live
    regeneration; the interface's is `start_live`), meshing each distinct setting
    once (Field Meshes with the same stored bounds share one mesh); the first error
    goes to `tree.status` (empty on success), never raised. `ask`: with the live gate
    of `start_live` (any Field Mesh estimated above `CONFIRM_ABOVE` triangles)
    nothing is meshed, the status says so and the meshes stay as they were, as a
    stack's large bake waits for Regenerate."""
    message, targets, distinct = _plan(tree, gate=ask)
    arrays = []
    for index, prepared in enumerate(distinct):
        try:
            arrays.append(mesh_arrays(prepared))
        except errors() as exc:
            arrays.append(None)
            first = next(obj for obj in linked_objects(tree) if (obj.session_uid, index) in targets)
            message = message or f"{first.name}: {exc}"
    written = live_worker.write_targets(tree, targets, distinct, arrays, lambda obj, tree: True)
    message = message or written
    with suspended():
        if tree.status != message:
            tree.status = message
    return message


def tree_state(tree):
    """What a live build reads of `tree`: its JSON and mesh settings (None when it
    is not a valid tree now)."""
    try:
        return tree_json(tree), tree.resolution, tree.adaptive
    except errors():
        return None


def _plan(tree, only=None, note="", gate=True):
    """What a live regeneration of `tree` builds: `(message, targets, distinct)`.
    `distinct`: the prepared builds with different settings; `targets`:
    `(session_uid, index into distinct)` per Field Mesh (those in `only` when
    given); `message`: the first error or `note`. `gate`: when one of the Field
    Meshes is estimated above `CONFIRM_ABOVE` triangles nothing is targeted and the
    message says the tree is too large to mesh live. The one gate of `start_live`
    and `regenerate_tree(ask=True)`."""
    from ..pure.field_tree import CONFIRM_ABOVE, needs_confirmation

    message, targets, distinct = note, [], []
    try:
        text = tree_json(tree)
    except errors() as exc:
        return message or str(exc), [], []
    for obj in linked_objects(tree):
        if only is not None and obj.session_uid not in only:
            continue
        try:
            prepared = prepare_regeneration(obj, text, tree.resolution, tree.adaptive)[0]
            if prepared not in distinct:
                guess = estimate(prepared) if gate else None
                if guess is not None and needs_confirmation(guess, CONFIRM_ABOVE):
                    return _not_live(guess), [], []
                distinct.append(prepared)
        except errors() as exc:
            message = message or f"{obj.name}: {exc}"
            continue
        targets.append((obj.session_uid, distinct.index(prepared)))
    return message, targets, distinct


def start_live(tree, only=None, note="") -> str:
    """Regenerates `tree`'s Field Meshes without holding the interface: their
    settings read here, the meshing on a worker thread, the meshes written by a
    timer when done (`live_worker`); a newer change cancels it. Returns the tree's
    status now: "" while it meshes, else why nothing was started: a tree too large
    for live regeneration (`_plan`'s gate), or an error (an object that cannot be
    read is left out and named in the status once the others are written).
    `only`: the session_uids of the Field Meshes to build (all for None); `note`:
    an earlier error for the status."""
    message, targets, distinct = _plan(tree, only, note)
    if not targets:
        live_worker.cancel(tree)
        live_worker.set_status(tree, message)
        return message
    live_worker.start(tree, targets, distinct, tree_state, lambda obj, shown: node_tree_of(obj) == shown, note=message)
    return ""


def schedule_tree(tree) -> None:
    """Asks for `tree`'s Field Meshes to regenerate soon (at once in background mode,
    where timers never run). Ignored until the add-on's handlers are registered:
    Blender calls a tree's `update` while its class is being registered, when
    reading the tree's properties crashes Blender (trees saved in the open file, on
    enabling the add-on again)."""
    if not _live or busy() or getattr(tree, "bl_idname", None) != TREE_IDNAME or not tree.auto_update:
        return
    _trees.add(tree.name)


def _regenerate_tree(name: str) -> None:
    tree = bpy.data.node_groups.get(name)
    if tree is None or tree.bl_idname != TREE_IDNAME:
        return
    if linked_objects(tree):
        if bpy.app.background:
            regenerate_tree(tree)  # scripts: at once (timers never run there)
        else:
            start_live(tree)
    from ..stack import auto_update

    for obj in stack_users(tree):  # their stacks regenerate as on any other change
        auto_update.schedule(obj)


_trees = Debounced(_regenerate_tree)
flush = _trees.flush


def _handles(tree):
    found = set()
    for node in tree.nodes:
        for name in ("handle", "handle_b"):
            obj = getattr(node, name, None)
            if obj is not None:
                found.add(obj.as_pointer())
                if obj.data is not None:
                    found.add(obj.data.as_pointer())
    return found


def changed_trees(depsgraph):
    """The linked trees one of whose handle objects (or their curves) this update moved or changed."""
    trees = _used_trees()
    if not trees:
        return []
    moved = set()
    for update in depsgraph.updates:
        if update.is_updated_transform or update.is_updated_geometry:
            moved.add(update.id.original.as_pointer())
    return [tree for tree in trees if moved & _handles(tree)]


@persistent
def on_depsgraph_update(scene, depsgraph):
    if busy():
        return
    for tree in changed_trees(depsgraph):
        schedule_tree(tree)


@persistent
def on_load_pre(*_args):
    """A file is about to be loaded: live builds and regenerations waiting for the
    debounce of the old file's trees are dropped."""
    live_worker.cancel()
    _trees.pending.clear()


@persistent
def on_undo_pre(*_args):
    """An undo or redo is about to restore the file: builds in flight read the
    state it leaves, so they are dropped (the restored meshes match the restored
    trees)."""
    live_worker.cancel()


_live = False
_HANDLERS = (
    (bpy.app.handlers.depsgraph_update_post, on_depsgraph_update),
    (bpy.app.handlers.load_pre, on_load_pre),
    (bpy.app.handlers.undo_pre, on_undo_pre),
    (bpy.app.handlers.redo_pre, on_undo_pre),
)


def register_handlers():
    global _live
    for handlers, handler in _HANDLERS:
        if handler not in handlers:
            handlers.append(handler)
    _live = True


def unregister_handlers():
    global _live
    _live = False
    live_worker.cancel()
    for handlers, handler in _HANDLERS:
        if handler in handlers:
            handlers.remove(handler)
    _trees.pending.clear()


__all__ = ["NODES_PROPERTY", "build", "regenerate", "regenerate_tree", "start_live", "schedule_tree", "field_settings", "linked_objects", "node_tree_of"]
