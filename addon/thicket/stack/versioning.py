"""Files and scripts from earlier versions of Thicket: item properties that were
renamed keep their values.

A .blend stores each stack item's settings as ID properties under their property
names, so a file saved before a rename holds its values under the former names,
which the item no longer reads. `upgrade_file` moves them to the current names
when a file is loaded (`load_post`) and once when the add-on is enabled with a file
open (at once where a script enables it, headless too; after startup in the interface); scripts passing a former name to `api.add_item` get a DeprecationWarning.
"""

import warnings

import bpy
from bpy.app.handlers import persistent

#: Item properties by their former name. "layers" meant three things: the Stacked
#: Surfaces output's count (now `surfaces`), the bake's lattice steps across the shell
#: (`texture_layers`, now `depth_steps`) and, in the native core, the placed textures.
RENAMED_ITEM_PROPERTIES = {"layers": "surfaces", "texture_layers": "depth_steps"}


def current_names(settings: dict, stacklevel=3) -> dict:
    """`settings` (item property names to values) with former names replaced by the
    current ones, warning (DeprecationWarning) for each; both names given is a TypeError."""
    out = dict(settings)
    for old, new in RENAMED_ITEM_PROPERTIES.items():
        if old not in out:
            continue
        if new in out:
            raise TypeError(f"got '{new}' and its former name '{old}': pass '{new}' only")
        warnings.warn(f"Thicket item setting '{old}' is now called '{new}'; the old name goes in the next release", DeprecationWarning, stacklevel=stacklevel)
        out[new] = out.pop(old)
    return out


def saved_value(item, name):
    """The item's setting `name`, or the value a file from before the rename left
    under its former name where it could not be moved (linked data is read-only, see
    `upgrade_file`)."""
    keys = item.keys()
    if name not in keys:
        for old, new in RENAMED_ITEM_PROPERTIES.items():
            if new == name and old in keys:
                return item[old]
    return getattr(item, name)


def upgrade_item(item) -> bool:
    """Moves the item's values saved under former property names to the current
    names (as ID properties: no update callback runs, nothing regenerates). Whether
    anything moved."""
    keys = set(item.keys())
    moved = False
    for old, new in RENAMED_ITEM_PROPERTIES.items():
        if old in keys:
            if new not in keys:  # a value under the current name wins
                item[new] = item[old]
            del item[old]
            moved = True
    return moved


def upgrade_file() -> int:
    """Upgrades every stack item of the open file's local objects; how many items
    changed. Linked objects are read-only: their items keep the former names, which
    `saved_value` reads."""
    count = 0
    for obj in bpy.data.objects:
        if obj.library is None:
            count += sum(upgrade_item(item) for item in obj.thicket.items)
    return count


@persistent
def on_load(*_args):
    global _pending
    _pending = False
    upgrade_file()


def _upgrade_open_file():
    """Once after the add-on is enabled in the interface (bpy.data is not readable
    while it registers at startup), as one undo step so Ctrl+Z does not undo the
    user's last change together with it."""
    if upgrade_file():
        try:
            bpy.ops.ed.undo_push(message="Thicket: upgrade settings saved under former names")
        except RuntimeError:  # no window to push in (a script's context)
            pass
    return None


#: Whether the open file still awaits its upgrade: the add-on was enabled while
#: bpy.data could not be read (Blender's add-on enabling restricts it), in background
#: mode where no timer runs; the next stack regeneration upgrades it.
_pending = False


def ensure_upgraded():
    """Upgrades the open file if enabling the add-on could not (see `_pending`)."""
    global _pending
    if _pending and isinstance(bpy.data, bpy.types.BlendData):
        _pending = False
        upgrade_file()


def register():
    global _pending
    if on_load not in bpy.app.handlers.load_post:
        # First among Thicket's handlers: nothing reads a stack before it is upgraded.
        bpy.app.handlers.load_post.insert(0, on_load)
    if isinstance(bpy.data, bpy.types.BlendData):
        # Enabled by a script (headless ones too, where no timer runs): the open file
        # is readable now.
        upgrade_file()
    elif bpy.app.background:
        _pending = True
    else:
        bpy.app.timers.register(_upgrade_open_file, first_interval=0.0)


def unregister():
    if on_load in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(on_load)
    if bpy.app.timers.is_registered(_upgrade_open_file):
        bpy.app.timers.unregister(_upgrade_open_file)
