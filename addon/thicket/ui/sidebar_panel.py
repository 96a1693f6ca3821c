import bpy

from ..stack.query import active_source
from .item_settings import draw_status


class THICKET_PT_sidebar(bpy.types.Panel):
    """3D View sidebar: the Thicket operators on the selection."""

    bl_label = "Thicket"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Thicket"

    def draw(self, context):
        layout = self.layout
        layout.operator("thicket.add_thick_surface", icon="MOD_SOLIDIFY")
        obj = active_source(context)
        if obj is not None and obj.thicket.items:
            col = layout.column(align=True)
            col.operator("thicket.regenerate", icon="FILE_REFRESH")
            col.operator("thicket.render_preview", icon="RENDER_STILL")
            from ..render import overlay

            fraction = overlay.progress() if overlay.is_enabled() else None
            text = "Live Preview" if fraction is None else f"Live Preview ({fraction:.0%})"  # its builds in flight
            col.operator("thicket.live_preview", text=text, icon="HIDE_OFF", depress=overlay.is_enabled())
            col.operator("thicket.apply", icon="CHECKMARK")
            col.operator("thicket.remove", icon="X")
            draw_status(layout, obj)
