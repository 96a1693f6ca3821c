import bpy

from .. import api
from ..stack.query import active_stack_source
from .common import StackOperator


class THICKET_OT_remove(StackOperator, bpy.types.Operator):
    """Delete the Thicket stack of the active object and its result object"""

    bl_idname = "thicket.remove"
    bl_label = "Remove Thick Surface"

    def execute(self, context):
        obj = active_stack_source(context)
        api.remove(obj)
        if context.view_layer.objects.active is None:
            context.view_layer.objects.active = obj
        return {"FINISHED"}
