import bpy
from bpy.props import BoolProperty, IntProperty, StringProperty

from .. import api
from ..pure.field_tree import MAX_RESOLUTION
from .common import error_text, user_errors


def _text(context, name):
    """The Text named `name`, else the Text editor's, else the only one."""
    if name:
        return bpy.data.texts.get(name)
    space = context.space_data
    if space is not None and space.type == "TEXT_EDITOR" and space.text is not None:
        return space.text
    return bpy.data.texts[0] if len(bpy.data.texts) == 1 else None


class THICKET_OT_field_mesh_add(bpy.types.Operator):
    """Add a mesh of an implicit field tree read from a Text holding its JSON (the
    tree and settings are kept on the object, so it can be regenerated)"""

    bl_idname = "thicket.field_mesh_add"
    bl_label = "Add Field Mesh"
    bl_options = {"REGISTER", "UNDO"}

    text: StringProperty(name="Text", description="The Text holding the field tree's JSON (default: the Text editor's, or the only Text)")
    resolution: IntProperty(
        name="Resolution", description="Cells along the longest side of the tree's bounds", min=2, max=MAX_RESOLUTION, soft_max=512, default=128
    )
    adaptive: BoolProperty(
        name="Adaptive",
        description="Dual contouring on the cells that may hold the surface: quads, sharp creases and corners (off: marching prisms on the whole grid, triangles)",
        default=True,
    )

    @classmethod
    def poll(cls, context):
        return len(bpy.data.texts) > 0

    def execute(self, context):
        text = _text(context, self.text)
        if text is None:
            which = f"no Text named '{self.text}'" if self.text else "several Texts: name the one holding the field tree"
            self.report({"ERROR"}, f"Add Field Mesh: {which}")
            return {"CANCELLED"}
        try:
            obj = api.build_field_mesh(text, name=text.name.rsplit(".", 1)[0] or "Field Mesh", resolution=self.resolution, adaptive=self.adaptive)
        except user_errors() as exc:
            self.report({"ERROR"}, f"Add Field Mesh: {error_text(exc)}")
            return {"CANCELLED"}
        for other in context.view_layer.objects:
            other.select_set(False)
        obj.select_set(True)
        context.view_layer.objects.active = obj
        return {"FINISHED"}
