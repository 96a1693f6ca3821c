"""Field shells kept between evaluations (thick surfaces 7.1), so that editing a
source mesh retraces only the directors the edit can reach.

A kept shell is found again by its topology and settings; positions and vertex-group
factors may change. A few shells are kept (most recently used first);
`clear()` drops them, so that the next evaluation builds from scratch.
"""

import threading
from collections import OrderedDict, deque

import numpy as np

from . import native

KEEP = 4

_kept: "OrderedDict[tuple, tuple]" = OrderedDict()  # key -> (face_sizes, corners, IncrementalShell)

#: Guards `_kept`: stacks evaluate on the main thread (auto-update, frame changes,
#: the live preview) and on operators' worker threads at once. A shell is taken out
#: while it is updated, so two evaluations never share one (the second builds its own).
_lock = threading.Lock()

#: What the latest evaluations did, newest last: an update's counts (changed,
#: retraced, kept, resettled, rebuilt, field_rebuilt), or None for a shell built from scratch.
recent: deque = deque(maxlen=8)


def clear() -> None:
    with _lock:
        _kept.clear()


def _keep(key, entry) -> None:
    with _lock:
        _kept[key] = entry
        _kept.move_to_end(key, last=False)
        while len(_kept) > KEEP:
            _kept.popitem(last=True)


def field_shell(args, kwargs, progress=None) -> dict:
    """`thicket_native.shell(*args, **kwargs)`'s result, updated from a kept shell of
    the same topology and settings when there is one (only the positions in `args`
    and the `factors` may differ). `progress`: the callback of a shell built from
    scratch (`thicket_native.shell`'s); a cancelled build keeps nothing. Safe to call
    from several threads."""
    vertices, face_sizes, corners, thickness = args
    factors = kwargs["factors"]
    settings = (thickness, *(kwargs[k] for k in sorted(kwargs) if k != "factors"), factors is None)
    key = (len(vertices), len(corners), hash(face_sizes.tobytes()), hash(corners.tobytes()), settings)
    with _lock:
        kept = _kept.pop(key, None)
    if kept is not None and np.array_equal(kept[0], face_sizes) and np.array_equal(kept[1], corners):
        shell = kept[2]
        try:
            stats = shell.update(vertices, factors=factors)
        except native.error_types():
            pass  # rebuilt below; the error, if real, comes again from there
        else:
            result = shell.result()
            _keep(key, kept)
            recent.append(stats)
            return result
    shell = native.get().IncrementalShell(*args, **kwargs, progress=progress)
    recent.append(None)
    result = shell.result()
    _keep(key, (face_sizes.copy(), corners.copy(), shell))
    return result
