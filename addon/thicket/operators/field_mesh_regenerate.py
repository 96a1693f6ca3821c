import bpy
from bpy.props import StringProperty

from ..fields import field_mesh
from .common import error_text, user_errors
from .field_mesh_add import FieldBuildOperator


def _target(context, name):
    """The Field Mesh named `name`, else the active object when it is one, else the
    first Field Mesh of the node editor's tree."""
    from ..nodes import live

    if name:
        return bpy.data.objects.get(name)
    active = context.active_object
    if field_mesh.field_settings(active) is not None:
        return active
    edited = getattr(context.space_data, "edit_tree", None)
    linked = live.linked_objects(edited) if edited is not None else []
    return linked[0] if linked else None


class THICKET_OT_field_mesh_regenerate(FieldBuildOperator, bpy.types.Operator):
    """Rebuild a Field Mesh from its node tree (or its stored tree or Text) with
    progress; Esc cancels and keeps the previous mesh"""

    bl_idname = "thicket.field_mesh_regenerate"
    bl_label = "Regenerate Field Mesh"
    bl_options = {"REGISTER", "UNDO"}

    object: StringProperty(name="Object", description="The Field Mesh to rebuild (default: the active object, else the node editor tree's)")
    _draw_properties = ("object",)

    @classmethod
    def poll(cls, context):
        return context.mode == "OBJECT" and _target(context, "") is not None

    def _build(self, context):
        obj = _target(context, self.object)
        if obj is None or field_mesh.field_settings(obj) is None:
            raise KeyError(f"no Field Mesh named '{self.object}'" if self.object else "no Field Mesh to regenerate")
        self.object = obj.name  # a confirmation's second run rebuilds the same object
        return regeneration_build(obj, self.bl_label)


def _follow(tree, done, prepared, arrays):
    """The other Field Meshes of `tree` follow `done`, rebuilt from `prepared` into
    `arrays`: those with the same settings take the same arrays; any other (stored
    bounds of its own) is meshed again, in the interface on the live worker
    (`nodes.live_worker`, written when done), in background scripts here. The
    tree's status clears, or names the first that failed."""
    from ..nodes import live, live_worker
    from ..nodes.graph import tree_json

    message, rest = "", set()
    for other in live.linked_objects(tree):
        if other == done:
            continue
        try:
            own, source_text = field_mesh.prepare_regeneration(other, tree_json(tree), tree.resolution, tree.adaptive)
            if own == prepared:
                field_mesh.write_existing(other, own, arrays, source_text)
            elif bpy.app.background:
                live.regenerate(other)
            else:
                rest.add(other.session_uid)
        except user_errors() as exc:
            message = message or f"{other.name}: {error_text(exc)}"
    live_worker.cancel(tree)  # a live build in flight read an older state than this one
    if rest:
        live.start_live(tree, only=rest, note=message)
    elif tree.status != message:
        tree.status = message


def regeneration_build(obj, label):
    """(prepared, label, write) rebuilding the Field Mesh `obj` in place: from its
    node tree's current state when it is linked to one (its status follows, and
    so do the tree's other Field Meshes: `_follow`), else from its stored tree or
    Text."""
    from ..nodes import live
    from ..nodes.graph import tree_json
    from ..stack.guard import suspended

    tree = live.node_tree_of(obj)
    try:
        if tree is not None:
            prepared, source_text = field_mesh.prepare_regeneration(obj, tree_json(tree), tree.resolution, tree.adaptive)
        else:
            prepared, source_text = field_mesh.prepare_regeneration(obj)
    except user_errors() as exc:
        if tree is not None:
            with suspended():
                tree.status = f"{obj.name}: {error_text(exc)}"
        raise
    name, label = obj.name, f"{label} '{obj.name}'"

    def write(arrays):
        target = bpy.data.objects.get(name)
        if target is None:
            raise KeyError(f"'{name}' was deleted while it meshed")
        with suspended():
            field_mesh.write_existing(target, prepared, arrays, source_text)
            linked = live.node_tree_of(target)
            if linked is not None:
                _follow(linked, target, prepared, arrays)
        return target

    return prepared, label, write
