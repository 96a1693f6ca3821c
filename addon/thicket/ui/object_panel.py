import bpy

from ..stack.query import active_source
from .item_settings import draw_item_settings, draw_status


class THICKET_UL_items(bpy.types.UIList):
    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index):
        row = layout.row(align=True)
        icon = {"OFFSET_SHELL": "MOD_SOLIDIFY", "SOLID_TEXTURE": "TEXTURE", "PROCEDURAL_DETAIL": "MOD_SUBSURF"}.get(item.kind, "MOD_SKIN")
        row.prop(item, "name", text="", emboss=False, icon=icon)
        row.prop(item, "show_viewport", text="", emboss=False, icon="RESTRICT_VIEW_OFF" if item.show_viewport else "RESTRICT_VIEW_ON")


class THICKET_PT_stack(bpy.types.Panel):
    """Properties > Object: the Thicket stack, listed like modifiers."""

    bl_label = "Thicket"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "object"

    @classmethod
    def poll(cls, context):
        return active_source(context) is not None

    def draw(self, context):
        layout = self.layout
        obj = active_source(context)
        stack = obj.thicket
        if not stack.items:
            layout.operator("thicket.add_thick_surface", icon="MOD_SOLIDIFY")
            return
        row = layout.row()
        row.template_list("THICKET_UL_items", "", stack, "items", stack, "active_index", rows=3)
        col = row.column(align=True)
        col.operator_menu_enum("thicket.item_add", "kind", text="", icon="ADD")
        col.operator("thicket.item_remove", text="", icon="REMOVE")
        col.separator()
        col.operator("thicket.item_move", text="", icon="TRIA_UP").direction = "UP"
        col.operator("thicket.item_move", text="", icon="TRIA_DOWN").direction = "DOWN"
        if 0 <= stack.active_index < len(stack.items):
            draw_item_settings(layout.box(), obj, stack.items[stack.active_index])
        row = layout.row(align=True)
        row.prop(stack, "auto_update")
        row.operator("thicket.regenerate", icon="FILE_REFRESH")
        row.operator("thicket.render_preview", text="Preview", icon="RENDER_STILL")
        row = layout.row(align=True)
        row.operator("thicket.apply", icon="CHECKMARK")
        row.operator("thicket.remove", icon="X")
        draw_status(layout, obj)
