import bpy

from ..stack import auto_update
from ..stack.query import active_stack_source
from .common import StackOperator


class THICKET_OT_item_remove(StackOperator, bpy.types.Operator):
    """Remove the active item from the Thicket stack"""

    bl_idname = "thicket.item_remove"
    bl_label = "Remove Stack Item"

    def execute(self, context):
        obj = active_stack_source(context)
        stack = obj.thicket
        index = min(stack.active_index, len(stack.items) - 1)
        stack.items.remove(index)
        stack.active_index = max(0, index - 1)
        auto_update.schedule(obj)
        return {"FINISHED"}
