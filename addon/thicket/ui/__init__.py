from .menu import THICKET_MT_object, menu_entry, mesh_add_entry
from .object_panel import THICKET_PT_stack, THICKET_UL_items
from .sidebar_panel import THICKET_PT_sidebar

CLASSES = (THICKET_UL_items, THICKET_PT_stack, THICKET_PT_sidebar, THICKET_MT_object)
MENU_ENTRIES = (("VIEW3D_MT_object", menu_entry), ("VIEW3D_MT_mesh_add", mesh_add_entry))
