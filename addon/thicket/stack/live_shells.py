"""Field shells kept between evaluations (thick surfaces 7.1), so that editing a
source mesh retraces only the directors the edit can reach.

A kept shell is found again by its topology and settings; positions and vertex-group
factors may change. No bpy here. A few shells are kept (most recently used first);
`clear()` drops them, so that the next evaluation builds from scratch.
"""

from collections import OrderedDict, deque

import numpy as np

from .. import native

KEEP = 4

_kept: "OrderedDict[tuple, tuple]" = OrderedDict()  # key -> (face_sizes, corners, IncrementalShell)

#: What the latest evaluations did, newest last: an update's counts (changed,
#: retraced, kept, rebuilt), or None for a shell built from scratch.
recent: deque = deque(maxlen=8)


def clear() -> None:
    _kept.clear()


def _key(mesh, item, factors):
    settings = (float(item.thickness), bool(item.relative), item.side, item.output, int(item.layers), factors is None)
    return (mesh.vertex_count, len(mesh.corners), hash(mesh.face_sizes.tobytes()), hash(mesh.corners.tobytes()), settings)


def field_shell(mesh, item, factors) -> dict:
    """`thicket_native.shell(...)`'s result for `mesh` and the Shell `item`, updated
    from a kept shell of the same topology and settings when there is one."""
    key = _key(mesh, item, factors)
    kept = _kept.get(key)
    if kept is not None and np.array_equal(kept[0], mesh.face_sizes) and np.array_equal(kept[1], mesh.corners):
        shell = kept[2]
        try:
            stats = shell.update(mesh.vertices, factors=factors)
        except native.error_types():
            del _kept[key]  # rebuilt below; the error, if real, comes again from there
        else:
            _kept.move_to_end(key, last=False)
            recent.append(stats)
            return shell.result()
    shell = native.get().IncrementalShell(
        mesh.vertices, mesh.face_sizes, mesh.corners, float(item.thickness),
        side=item.side, relative=item.relative, factors=factors, output=item.output, layers=int(item.layers),
    )
    recent.append(None)
    _kept[key] = (mesh.face_sizes.copy(), mesh.corners.copy(), shell)
    _kept.move_to_end(key, last=False)
    while len(_kept) > KEEP:
        _kept.popitem(last=True)
    return shell.result()
