import bpy
from bpy.props import EnumProperty

from .. import api
from ..pure.kinds.procedural_detail import PRESETS
from ..pure.settings import ProceduralDetail
from ..stack import auto_update
from ..stack.query import active_source


class THICKET_OT_procedural_detail_add(bpy.types.Operator):
    """Add procedural detail on subdivision levels to the active object's Thicket stack,
    before its shells (the result regenerates; the source mesh is not changed)"""

    bl_idname = "thicket.procedural_detail_add"
    bl_label = "Add Procedural Detail"
    bl_options = {"REGISTER", "UNDO"}

    preset: EnumProperty(name="Preset", items=[(k, k.title(), f"Start from the {k.lower()} settings") for k in PRESETS], default="ROCK")

    @classmethod
    def poll(cls, context):
        return active_source(context) is not None

    def execute(self, context):
        obj = active_source(context)
        item = api.add_detail_item(obj, **PRESETS[self.preset])
        item.name = f"{ProceduralDetail.label} ({self.preset.title()})"
        auto_update.schedule(obj)
        return {"FINISHED"}
