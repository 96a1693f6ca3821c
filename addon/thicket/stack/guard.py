"""The re-entrancy guard of regeneration: while Thicket writes a result (or anything
else that would look like a user's edit), changes schedule no regeneration.

Its own module so that auto-update (which regenerates) and regeneration (which
suspends auto-update) do not import each other."""

from contextlib import contextmanager

_busy = False


@contextmanager
def suspended():
    """While inside, changes schedule nothing (used around every regeneration)."""
    global _busy
    was = _busy
    _busy = True
    try:
        yield
    finally:
        _busy = was


def busy() -> bool:
    """Whether a regeneration (or another guarded write) is under way."""
    return _busy
