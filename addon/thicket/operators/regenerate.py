import bpy

from .. import api
from .common import active_stack_source, error_text, progress, user_errors


class THICKET_OT_regenerate(bpy.types.Operator):
    """Recompute the Thicket result of the active object from its mesh and stack"""

    bl_idname = "thicket.regenerate"
    bl_label = "Regenerate"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return active_stack_source(context) is not None

    def execute(self, context):
        obj = active_stack_source(context)
        try:
            with progress(context, len(obj.thicket.items)) as update:
                api.regenerate(obj, progress=update)
        except user_errors() as exc:
            obj.thicket.last_error = error_text(exc)
            self.report({"ERROR"}, f"{obj.name}: {error_text(exc)}")
            return {"CANCELLED"}
        return {"FINISHED"}
