import bpy

from ..render import overlay
from ..stack.query import active_stack_source


class THICKET_OT_live_preview(bpy.types.Operator):
    """Show the active object's thick surface, rendered without baking, over the 3D
    views, following every change of view (toggle)"""

    bl_idname = "thicket.live_preview"
    bl_label = "Live Preview"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return not bpy.app.background and (overlay.is_enabled() or active_stack_source(context) is not None)

    def execute(self, context):
        if overlay.is_enabled():
            overlay.disable()
        else:
            overlay.enable()
        return {"FINISHED"}
