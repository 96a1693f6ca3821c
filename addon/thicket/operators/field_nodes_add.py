import bpy
from bpy.props import StringProperty

from .common import error_text, user_errors


def default_tree(name="Thicket Field"):
    """A new field node tree: a Sphere linked to a Field Output."""
    from ..nodes.tree import TREE_IDNAME

    tree = bpy.data.node_groups.new(name, TREE_IDNAME)
    sphere = tree.nodes.new("ThicketNodeSphere")
    output = tree.nodes.new("ThicketNodeOutput")
    sphere.location, output.location = (-200, 0), (100, 0)
    tree.links.new(sphere.outputs[0], output.inputs[0])
    return tree


class THICKET_OT_field_nodes_add(bpy.types.Operator):
    """Add a Field Mesh object meshing a Thicket field node tree: the node editor's
    tree (or the one named), else a new tree with a sphere; it regenerates when a
    node, a link or a handle object changes"""

    bl_idname = "thicket.field_nodes_add"
    bl_label = "Add Field Mesh from Nodes"
    bl_options = {"REGISTER", "UNDO"}

    tree: StringProperty(name="Node Tree", description="The Thicket field node tree to mesh (default: the node editor's, else a new one)")

    @classmethod
    def poll(cls, context):
        return context.scene is not None and context.mode == "OBJECT"

    def _tree(self, context):
        from ..nodes.tree import TREE_IDNAME

        if self.tree:
            tree = bpy.data.node_groups.get(self.tree)
            if tree is None or tree.bl_idname != TREE_IDNAME:
                raise KeyError(f"no Thicket field node tree named '{self.tree}'")
            return tree, False
        edited = getattr(context.space_data, "edit_tree", None)
        if edited is not None and edited.bl_idname == TREE_IDNAME:
            return edited, False
        return default_tree(), True

    def execute(self, context):
        from ..nodes import live

        try:
            tree, made = self._tree(context)
        except KeyError as exc:
            self.report({"ERROR"}, f"Add Field Mesh from Nodes: {error_text(exc)}")
            return {"CANCELLED"}
        try:
            obj = live.build(tree, collection=context.collection)
        except user_errors() as exc:
            if made:
                bpy.data.node_groups.remove(tree)
            else:
                tree.status = error_text(exc)
            self.report({"ERROR"}, f"Add Field Mesh from Nodes: {error_text(exc)}")
            return {"CANCELLED"}
        space = context.space_data
        if space is not None and space.type == "NODE_EDITOR":
            space.tree_type = tree.bl_idname
            space.node_tree = tree
        for other in context.view_layer.objects:
            other.select_set(False)
        obj.select_set(True)
        context.view_layer.objects.active = obj
        return {"FINISHED"}
