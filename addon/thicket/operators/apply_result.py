import bpy

from .. import api
from ..stack.query import active_stack_source
from .common import StackOperator, error_text, user_errors


class THICKET_OT_apply(StackOperator, bpy.types.Operator):
    """Turn the Thicket result into an ordinary mesh object and remove the stack"""

    bl_idname = "thicket.apply"
    bl_label = "Apply"

    def execute(self, context):
        obj = active_stack_source(context)
        try:
            result = api.apply(obj)
        except user_errors() as exc:
            self.report({"ERROR"}, f"{obj.name}: {error_text(exc)}")
            return {"CANCELLED"}
        self.report({"INFO"}, f"Applied: '{result.name}' is now an ordinary mesh")
        return {"FINISHED"}
