import bpy

from .. import api
from .common import StackOperator, active_stack_source, error_text, progress, user_errors


class THICKET_OT_regenerate(StackOperator, bpy.types.Operator):
    """Recompute the Thicket result of the active object from its mesh and stack"""

    bl_idname = "thicket.regenerate"
    bl_label = "Regenerate"
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
