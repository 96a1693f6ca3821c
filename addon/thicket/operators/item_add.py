import bpy
from bpy.props import EnumProperty

from .. import api
from ..pure import settings as S
from ..stack import auto_update
from ..stack.query import active_source


class THICKET_OT_item_add(bpy.types.Operator):
    """Append an item to the active object's Thicket stack"""

    bl_idname = "thicket.item_add"
    bl_label = "Add Stack Item"
    bl_options = {"REGISTER", "UNDO"}

    kind: EnumProperty(name="Kind", items=[(k, c.label, "") for k, c in S.KINDS.items()])

    @classmethod
    def poll(cls, context):
        return active_source(context) is not None

    def execute(self, context):
        obj = active_source(context)
        api.add_item(obj, self.kind)
        auto_update.schedule(obj)
        return {"FINISHED"}
