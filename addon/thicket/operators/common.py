"""What every Thicket operator shares: error reporting, progress, stack polls."""

from contextlib import contextmanager

from .. import native

#: Exceptions that mean bad input or settings; reported, never raised into Blender.
USER_ERRORS = (TypeError, KeyError, ValueError, RuntimeError)


def user_errors():
    return USER_ERRORS + native.error_types()


def error_text(exc) -> str:
    text = exc.args[0] if isinstance(exc, KeyError) and exc.args else str(exc)
    return str(text) or type(exc).__name__


@contextmanager
def progress(context, total):
    """Blender's progress cursor over `total` steps; yields an `update(i)` function."""
    wm = context.window_manager
    wm.progress_begin(0, max(total, 1))
    try:
        yield wm.progress_update
    finally:
        wm.progress_end()


def active_source(context):
    """The active object if it is a mesh that can carry a stack (not a result)."""
    obj = context.active_object
    if obj is None or obj.type != "MESH":
        return None
    if obj.thicket.source is not None:  # a result: act on its source
        return obj.thicket.source
    return obj


def active_stack_source(context):
    obj = active_source(context)
    return obj if obj is not None and len(obj.thicket.items) > 0 else None


class StackOperator:
    """Mixin for operators on the active object's existing stack: undoable, and
    available only when the active object (or the source of an active result) has one."""

    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return active_stack_source(context) is not None
