import bpy
from bpy.props import StringProperty
from bpy_extras.io_utils import ExportHelper

from .. import api
from ..stack.query import active_stack_source
from .common import error_text, user_errors


class THICKET_OT_export_texture(bpy.types.Operator, ExportHelper):
    """Write the active Volumetric Texture item's texture to an OpenEXR volume"""

    bl_idname = "thicket.export_texture"
    bl_label = "Export Texture"
    bl_options = {"REGISTER", "UNDO"}

    filename_ext = ".exr"
    filter_glob: StringProperty(default="*.exr", options={"HIDDEN"})

    @classmethod
    def poll(cls, context):
        obj = active_stack_source(context)
        if obj is None:
            return False
        items = obj.thicket.items
        return 0 <= obj.thicket.active_index < len(items) and items[obj.thicket.active_index].kind == "VOLUMETRIC_TEXTURE"

    def execute(self, context):
        obj = active_stack_source(context)
        try:
            api.export_texture(obj, self.filepath, obj.thicket.active_index)
        except user_errors() as exc:
            self.report({"ERROR"}, f"{obj.name}: {error_text(exc)}")
            return {"CANCELLED"}
        self.report({"INFO"}, f"Texture written to {self.filepath}")
        return {"FINISHED"}
