import bpy
from bpy.props import EnumProperty, FloatProperty

from .. import api
from ..stack.properties import ThicketItem
from .common import error_text, progress, user_errors


class THICKET_OT_add_thick_surface(bpy.types.Operator):
    """Give every selected mesh a thick-surface stack (Offset Shell) and generate its result"""

    bl_idname = "thicket.add_thick_surface"
    bl_label = "Add Thick Surface"
    bl_options = {"REGISTER", "UNDO"}

    thickness: FloatProperty(name="Thickness", default=0.05, precision=4, step=0.1,
                             description=ThicketItem.__annotations__["thickness"].keywords["description"])
    thickness_mode: EnumProperty(name="Mode", items=ThicketItem.__annotations__["thickness_mode"].keywords["items"], default="RELATIVE")
    output: EnumProperty(name="Output", items=ThicketItem.__annotations__["output"].keywords["items"], default="OUTER")
    kind: EnumProperty(name="Kind", items=ThicketItem.__annotations__["kind"].keywords["items"], default="OFFSET_SHELL")
    side: EnumProperty(name="Side", items=ThicketItem.__annotations__["side"].keywords["items"], default="EXTERIOR")

    @classmethod
    def poll(cls, context):
        return any(o.type == "MESH" for o in context.selected_objects)

    def execute(self, context):
        selected = list(context.selected_objects)
        meshes = [o for o in selected if o.type == "MESH" and o.thicket.source is None]
        skipped = len(selected) - len(meshes)
        failed = []
        with progress(context, len(meshes)) as update:
            for i, obj in enumerate(meshes):
                try:
                    api.add_thick_surface(obj, thickness=self.thickness, thickness_mode=self.thickness_mode, output=self.output,
                                          kind=self.kind, side=self.side, progress=lambda f, i=i: update(i + f))
                except user_errors() as exc:
                    obj.thicket.last_error = error_text(exc)
                    failed.append(f"{obj.name}: {error_text(exc)}")
                update(i + 1)
        if skipped:
            self.report({"INFO"}, f"Skipped {skipped} selected object(s) that are not source meshes")
        if failed and len(failed) == len(meshes):
            self.report({"ERROR"}, "; ".join(failed))
            return {"CANCELLED"}
        for message in failed:  # some objects worked: keep them, warn about the rest
            self.report({"WARNING"}, message)
        return {"FINISHED"}
