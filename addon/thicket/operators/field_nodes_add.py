import bpy
from bpy.props import StringProperty

from ..fields import field_mesh
from .common import error_text, user_errors
from .field_mesh_add import FieldBuildOperator


def default_tree(name="Thicket Field"):
    """A new field node tree: a Sphere linked to a Field Output."""
    from ..nodes.tree import TREE_IDNAME

    tree = bpy.data.node_groups.new(name, TREE_IDNAME)
    sphere = tree.nodes.new("ThicketNodeSphere")
    output = tree.nodes.new("ThicketNodeOutput")
    sphere.location, output.location = (-200, 0), (100, 0)
    tree.links.new(sphere.outputs[0], output.inputs[0])
    return tree


class THICKET_OT_field_nodes_add(FieldBuildOperator, bpy.types.Operator):
    """Add a Field Mesh object meshing a Thicket field node tree: the node editor's
    tree (or the one named), else a new tree with a sphere; it regenerates when a
    node, a link or a handle object changes (Esc cancels the build)"""

    bl_idname = "thicket.field_nodes_add"
    bl_label = "Add Field Mesh from Nodes"
    bl_options = {"REGISTER", "UNDO"}

    tree: StringProperty(name="Node Tree", description="The Thicket field node tree to mesh (default: the node editor's, else a new one)")
    _draw_properties = ("tree",)

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

    def _build(self, context):
        tree, made = self._tree(context)
        self.tree = tree.name  # a confirmation's second run meshes the same tree
        return nodes_build(tree, made, context.collection, context.space_data, self.bl_label)


def nodes_build(tree, made, collection, space, label):
    """(prepared, label, write) of a new Field Mesh linked to the node tree `tree`
    (`made`: the tree is new, removed again when its graph is refused)."""
    from ..nodes import live
    from ..nodes.graph import tree_json

    try:
        prepared = field_mesh.prepare(tree_json(tree), tree.resolution, None, tree.adaptive)
    except user_errors() as exc:
        if made:
            bpy.data.node_groups.remove(tree)
        else:
            tree.status = error_text(exc)
        raise
    tree_name = tree.name

    def write(arrays):
        tree = bpy.data.node_groups.get(tree_name)
        if tree is None:
            raise KeyError(f"the node tree '{tree_name}' was deleted while it meshed")
        obj = field_mesh.write_new(prepared, arrays, tree.name, collection)
        live.link(obj, tree)
        if space is not None and space.type == "NODE_EDITOR":
            space.tree_type = tree.bl_idname
            space.node_tree = tree
        return obj

    return prepared, label, write
