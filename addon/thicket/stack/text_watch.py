"""Stacks whose field tree lives in a Text follow edits of that Text.

Texts are not in the depsgraph: typing in the Text editor sends no update that the
stack's handlers could see. A timer (twice a second, in UI sessions) compares each
Text's content with what it held at the last look and schedules the stacks that read
a changed Text (a Solid Texture's, or a Field JSON Volumetric Texture's, *Tree Text*)
like any other change: debounced, and a tree broken halfway through typing is the
stack's error on the panel, the last result kept. Background scripts, where timers
never run, call `poll()` or `thicket.api.regenerate` themselves.
"""

import bpy
from bpy.app.handlers import persistent

from . import auto_update

POLL_SECONDS = 0.5

#: Each Text's content digest at the last look, by the Text's address.
_seen: dict[int, int] = {}


def reads_text(item) -> bool:
    """Whether the stack item's result comes from its Tree Text (when one is set)."""
    return item.tree_text is not None and "tree_text" in auto_update.contents_read(item)


def _read_texts():
    """The Texts some stack item reads, by address, with the sources reading each.
    Only Texts with a real user are looked at, and only the objects Blender's own
    `user_map` names as their users: no Python loop over the scene's objects
    (`user_map` still visits every ID, in C: 0.9 ms against 3.4 ms for the Python
    walk at 3,000 objects)."""
    used = [text for text in bpy.data.texts if text.users > int(text.use_fake_user)]
    if not used:
        return {}
    read = {}
    for text, users in bpy.data.user_map(subset=used, value_types={"OBJECT"}).items():
        for obj in users:
            if obj.type == "MESH" and any(reads_text(item) and item.tree_text == text for item in obj.thicket.items):
                read.setdefault(text.as_pointer(), (text, []))[1].append(obj)
    return read


def poll():
    """Schedules the stacks reading a Text edited since the last call (a Text seen
    for the first time is only remembered) and returns them. Only Texts that a stack
    reads are compared (scripts in other Texts cost nothing)."""
    read = _read_texts()
    current = {key: hash(text.as_string()) for key, (text, _) in read.items()}
    changed = [key for key, digest in current.items() if _seen.get(key, digest) != digest]
    _seen.clear()
    _seen.update(current)
    sources = []
    for key in changed:
        sources.extend(obj for obj in read[key][1] if obj not in sources)
    for obj in sources:
        auto_update.schedule(obj)
    return sources


def _tick():
    # An exception would unregister the timer for the rest of the session.
    try:
        poll()
    except Exception as exc:  # noqa: BLE001  (reported, never raised into Blender's loop)
        print(f"Thicket: watching Texts failed: {exc}")
    return POLL_SECONDS


@persistent
def _on_load(*_args):
    """Texts of another file: nothing seen yet (addresses are reused)."""
    _seen.clear()


def register():
    if not bpy.app.timers.is_registered(_tick):
        bpy.app.timers.register(_tick, first_interval=POLL_SECONDS, persistent=True)
    if _on_load not in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.append(_on_load)


def unregister():
    if bpy.app.timers.is_registered(_tick):
        bpy.app.timers.unregister(_tick)
    if _on_load in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(_on_load)
    _seen.clear()


def is_watching() -> bool:
    return bpy.app.timers.is_registered(_tick)
