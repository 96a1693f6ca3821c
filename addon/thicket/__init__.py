"""Thicket: thick surfaces for Blender meshes.

Registration only: the classes (`classes()`) registered in order, unregistered in
reverse.
Geometry lives in the Rust core (`thicket_native`); `mesh_io` is the only module
touching mesh data; scripts use `thicket.api`.

The Blender side is imported when the add-on registers, not with the package, so the
modules that need no Blender, all in `pure/` (the stack's settings, kinds and walk,
arrays, the native loader), import in plain Python too (`tests/test_pure_modules.py`).
"""

_cli_handle = None
#: What `register` registered (classes, menu entries), so `unregister` removes exactly
#: those, even after the modules were reloaded in between.
_registered = ((), ())


def classes():
    """Every class to register, in order: PropertyGroups, operators, panels."""
    from .nodes.tree import CLASSES as NODE_CLASSES
    from .operators import CLASSES as OPERATOR_CLASSES
    from .stack.properties import CLASSES as PROPERTY_CLASSES
    from .ui import CLASSES as UI_CLASSES

    return PROPERTY_CLASSES + NODE_CLASSES + OPERATOR_CLASSES + UI_CLASSES


def register():
    global _cli_handle, _registered
    import bpy

    from . import cli
    from .nodes import live
    from .nodes.tree import MENU_ENTRIES as NODE_MENU_ENTRIES
    from .stack import auto_update, text_watch, versioning
    from .stack.properties import register_properties
    from .ui import MENU_ENTRIES

    _registered = (classes(), tuple(MENU_ENTRIES) + NODE_MENU_ENTRIES)
    for cls in _registered[0]:
        bpy.utils.register_class(cls)
    register_properties()
    for menu, entry in _registered[1]:
        getattr(bpy.types, menu).append(entry)
    versioning.register()
    auto_update.register_handlers()
    text_watch.register()
    live.register_handlers()
    _cli_handle = cli.register()


def unregister():
    global _cli_handle, _registered
    import bpy

    from . import cli
    from .nodes import live
    from .render import overlay
    from .stack import auto_update, text_watch, versioning
    from .stack.properties import unregister_properties

    overlay.disable()
    cli.unregister(_cli_handle)
    _cli_handle = None
    auto_update.unregister_handlers()
    text_watch.unregister()
    live.unregister_handlers()
    versioning.unregister()
    classes_done, menu_entries = _registered
    _registered = ((), ())
    for menu, entry in reversed(menu_entries):
        getattr(bpy.types, menu).remove(entry)
    unregister_properties()
    for cls in reversed(classes_done):
        bpy.utils.unregister_class(cls)
