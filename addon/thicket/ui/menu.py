import bpy


class THICKET_MT_object(bpy.types.Menu):
    """Object > Thicket"""

    bl_idname = "THICKET_MT_object"
    bl_label = "Thicket"

    def draw(self, context):
        layout = self.layout
        layout.operator("thicket.add_thick_surface", icon="MOD_SOLIDIFY")
        layout.operator_menu_enum("thicket.procedural_detail_add", "preset", icon="MOD_SUBSURF")
        layout.operator("thicket.regenerate", icon="FILE_REFRESH")
        layout.operator("thicket.render_preview", icon="RENDER_STILL")
        layout.operator("thicket.apply", icon="CHECKMARK")
        layout.operator("thicket.remove", icon="X")
        layout.separator()
        layout.operator("thicket.field_mesh_add", icon="META_BALL")


def mesh_add_entry(self, context):
    """Add > Mesh > Field Mesh (Thicket)."""
    self.layout.operator("thicket.field_mesh_add", text="Field Mesh (Thicket)", icon="META_BALL")


def menu_entry(self, context):
    self.layout.menu(THICKET_MT_object.bl_idname)
