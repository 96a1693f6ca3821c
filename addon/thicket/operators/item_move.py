import bpy
from bpy.props import EnumProperty

from ..stack import auto_update
from ..stack.query import active_stack_source


class THICKET_OT_item_move(bpy.types.Operator):
    """Move the active item up or down the Thicket stack"""

    bl_idname = "thicket.item_move"
    bl_label = "Move Stack Item"
    bl_options = {"REGISTER", "UNDO"}

    direction: EnumProperty(items=[("UP", "Up", ""), ("DOWN", "Down", "")])

    @classmethod
    def poll(cls, context):
        obj = active_stack_source(context)
        return obj is not None and len(obj.thicket.items) > 1

    def execute(self, context):
        stack = active_stack_source(context).thicket
        index = stack.active_index
        target = index - 1 if self.direction == "UP" else index + 1
        if not 0 <= target < len(stack.items):
            return {"CANCELLED"}
        stack.items.move(index, target)
        stack.active_index = target
        auto_update.schedule(stack.id_data)
        return {"FINISHED"}
