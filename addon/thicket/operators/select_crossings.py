import bpy

from .. import api, mesh_io
from ..stack.query import active_source
from .common import error_text, user_errors


class THICKET_OT_select_crossings(bpy.types.Operator):
    """Select the faces of the active mesh that cross another part of the same mesh (a shell keeps those crossings: fix them in the source)"""

    bl_idname = "thicket.select_crossings"
    bl_label = "Select Crossing Faces"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return active_source(context) is not None

    def execute(self, context):
        obj = active_source(context)
        editing = obj.mode == "EDIT"
        try:
            faces = api.crossing_faces(obj)
        except user_errors() as exc:
            self.report({"ERROR"}, f"{obj.name}: {error_text(exc)}")
            return {"CANCELLED"}
        if editing:
            bpy.ops.object.mode_set(mode="OBJECT")
        mesh_io.select_faces(obj.data, faces)
        if obj == context.view_layer.objects.active:
            bpy.ops.object.mode_set(mode="EDIT")
            context.tool_settings.mesh_select_mode = (False, False, True)
        if len(faces):
            self.report({"WARNING"}, f"{obj.name}: {len(faces):,} faces cross another part of the mesh (selected)")
        else:
            self.report({"INFO"}, f"{obj.name}: no face crosses another part of the mesh")
        return {"FINISHED"}
