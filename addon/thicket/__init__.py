"""Thicket: thick surfaces for Blender meshes.

Registration only: one class tuple registered in order, unregistered in reverse.
Geometry lives in the Rust core (`thicket_native`); `mesh_io` is the only module
touching mesh data; scripts use `thicket.api`.
"""

import bpy

from . import cli
from .operators import CLASSES as OPERATOR_CLASSES
from .stack import auto_update
from .stack.properties import CLASSES as PROPERTY_CLASSES
from .stack.properties import register_properties, unregister_properties
from .ui import CLASSES as UI_CLASSES
from .ui import MENU_ENTRIES

CLASSES = PROPERTY_CLASSES + OPERATOR_CLASSES + UI_CLASSES

_cli_handle = None


def register():
    global _cli_handle
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    register_properties()
    for menu, entry in MENU_ENTRIES:
        getattr(bpy.types, menu).append(entry)
    auto_update.register_handlers()
    _cli_handle = cli.register()


def unregister():
    global _cli_handle
    from .render import overlay

    overlay.disable()
    cli.unregister(_cli_handle)
    _cli_handle = None
    auto_update.unregister_handlers()
    for menu, entry in reversed(MENU_ENTRIES):
        getattr(bpy.types, menu).remove(entry)
    unregister_properties()
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
