"""The compiled core, imported once, with a message users can act on when it is missing."""

try:
    import thicket_native as _native
except ImportError as exc:  # pragma: no cover - depends on installation
    _native = None
    IMPORT_ERROR = str(exc)
else:
    IMPORT_ERROR = ""


class NativeMissing(RuntimeError):
    pass


def get():
    """The `thicket_native` module, or NativeMissing with a clear message."""
    if _native is None:
        raise NativeMissing(
            f"Thicket's compiled core (thicket_native) is not installed for this Blender: reinstall the extension from its .zip ({IMPORT_ERROR})"
        )
    return _native


def error_types():
    """Exceptions that mean 'bad input or failed geometry', reported to the user as such."""
    if _native is None:
        return (NativeMissing,)
    return (_native.ThicketError, NativeMissing)


def error_text(exc) -> str:
    """What the user reads for an exception: its message (a KeyError's key without the
    quotes `str` adds), or its type's name when it has none."""
    text = exc.args[0] if isinstance(exc, KeyError) and exc.args else str(exc)
    return str(text) or type(exc).__name__
