"""An artist's Multires sculpt as the base of a Procedural Detail item (Use Sculpt): the
sculpt analysed into a coarse mesh and per-level details in local frames (Velho,
Perlin, Ying and Biermann, section 2), so procedural detail lands at any level on top
of it and the sculpt follows.

Blender is read on its main thread (`thicket.sculpt.read`: the base, the evaluated
sculpt and, when the base changed, the numbering's Subdivision Surface positions) into
a `Sculpt`; the numbering match and the analysis run here, in the stack's evaluation
(`Sculpt.analysis`, on whatever thread evaluates, with progress and cancel).

Analysis is too slow for live regeneration, so it is cached: one entry per source (its
`key`, the object's `session_uid`), keyed on the modifier's total levels and digests
of the base mesh (positions, faces) and of the sculpt's evaluated positions. A lock
guards the cache, as evaluations run on the main thread and on workers at once. An
evaluation stores its analysis only if its keys are still the ones Blender was read
with last for that source (a later read for a newer sculpt wins) and the source was
not forgotten meanwhile; a cancelled analysis stores nothing and the entry before it
stays.
"""

import hashlib
import threading
from typing import NamedTuple

import numpy as np

from .. import native
from ..arrays import MeshArrays

#: Multiresolution analyses run (cache misses): tests and the curious read it.
analyses = 0
#: Numberings matched (misses of the base part of the key).
numberings = 0


class Entry(NamedTuple):
    base_key: tuple
    order: np.ndarray
    fine_key: bytes
    analysis: dict


# source key -> Entry
_cache = {}
# source key -> (base key, fine key) of Blender's latest read: the only analysis stored.
_wanted = {}
_lock = threading.Lock()


def digest(*arrays) -> bytes:
    """A short digest of the arrays' bytes (cache keys)."""
    h = hashlib.blake2b(digest_size=16)
    for a in arrays:
        h.update(np.ascontiguousarray(a).tobytes())
    return h.digest()


def clear():
    """Forgets every cached analysis (a file was loaded)."""
    with _lock:
        _cache.clear()
        _wanted.clear()


def forget(key):
    """Forgets a source's cached analysis (it no longer uses its sculpt)."""
    with _lock:
        _cache.pop(key, None)
        _wanted.pop(key, None)


def prune(alive):
    """Drops the entries of sources whose keys are not in `alive`."""
    with _lock:
        for key in [k for k in _cache if k not in alive]:
            del _cache[key]
        for key in [k for k in _wanted if k not in alive]:
            del _wanted[key]


def match_numbering(base, levels: int, sculpted, numbering, name: str) -> np.ndarray:
    """The permutation from Blender's Multires numbering of `base` (MeshArrays) at
    `levels` to Thicket's (int32: Thicket's vertex i is the sculpt's vertex `order[i]`):
    `numbering` is Blender's Subdivision Surface (Use Limit Surface) of the same base at
    as many levels, which numbers the vertices as Multires does and whose positions
    Thicket's limit positions match (`thicket_native.match_subdivision`, nearest
    position); `sculpted` the sculpt (MeshArrays, Blender's numbering). `name` (the
    object's) goes in the messages."""
    if len(sculpted.vertices) != len(numbering):
        raise ValueError(f"the Multires of '{name}' has {len(sculpted.vertices)} vertices at {levels} levels where a Subdivision Surface has {len(numbering)}")
    # Blender puts an open mesh's corners (Boundary Smooth "All") short of the limit, by
    # up to 5.5e-4 of the size at Quality 3: matched within 1e-3, one to one (checked).
    tn = native.get()
    order = tn.match_subdivision(base.vertices, base.face_sizes, base.corners, levels, numbering, tolerance=1e-3)
    # Matched positions could still swap two close vertices: the sculpt's faces, renumbered,
    # must be exactly Thicket's faces of those levels.
    ours = np.empty_like(order)
    ours[order] = np.arange(len(order), dtype=order.dtype)
    made = tn.procedural_detail(base.vertices, base.face_sizes, base.corners, "rock", levels, params={"amplitude": 0.0})
    if not np.array_equal(_canonical_quads(ours[sculpted.corners]), _canonical_quads(made["corners"])):
        raise ValueError(f"the Multires of '{name}' could not be matched face for face to Thicket's subdivision (vertices too close to tell apart)")
    return order


def _canonical_quads(corners) -> np.ndarray:
    """Quads (rows of 4 vertex indices) each rotated to start at its smallest index, and
    sorted: equal arrays for the same oriented faces in any order."""
    quads = np.asarray(corners, dtype=np.int64).reshape(-1, 4)
    start = np.argmin(quads, axis=1)
    rotated = quads[np.arange(len(quads))[:, None], (start[:, None] + np.arange(4)) % 4]
    return rotated[np.lexsort(rotated.T[::-1])]


class Sculpt:
    """A source's sculpt as Blender gave it (plain data, any thread may analyse it):
    `base` the source's own mesh (MeshArrays), `levels` the Multires' total levels,
    `sculpted` its evaluated sculpt (MeshArrays, Blender's numbering), and
    `numbering` the Subdivision Surface positions to match it with, read when the
    cache had no numbering of this base (`announce`). Made by `thicket.sculpt.read`."""

    def __init__(self, key, label, name, base, levels, sculpted):
        self.key, self.label, self.name = key, label, name
        self.base, self.levels, self.sculpted = base, int(levels), sculpted
        self.base_key = (self.levels, digest(base.vertices, base.face_sizes, base.corners))
        self.fine_key = digest(sculpted.vertices, sculpted.corners)
        self.numbering = self.order = self.ready = None

    def announce(self) -> bool:
        """Records this as Blender's latest read of the source (the analysis the cache
        may store next) and takes what the cache has of it: the numbering of its base,
        and its analysis when the sculpt is the same. Whether Blender's numbering
        (`numbering`) must be read too."""
        with _lock:
            _wanted[self.key] = (self.base_key, self.fine_key)
        self._take_cached()
        return self.order is None

    def _take_cached(self):
        """Takes the cache's numbering of this base and analysis of this sculpt, if any."""
        with _lock:
            entry = _cache.get(self.key)
        if entry is not None and entry.base_key == self.base_key and len(entry.order) == len(self.sculpted.vertices):
            self.order = entry.order
            if entry.fine_key == self.fine_key:
                self.ready = entry.analysis

    def analysis(self, progress=None) -> dict:
        """`thicket_native.analyze`'s dict plus `levels` and `order` (what
        `procedural_detail` takes as `sculpt`): the cache's (costs nothing), else
        matched (when the base changed) and analysed now, `progress` as
        `evaluate_stack`'s (False cancels: `Cancelled`, nothing stored). Errors name the
        item (`label`)."""
        global analyses, numberings
        if self.ready is None:
            self._take_cached()  # another evaluation may have analysed it meanwhile
        if self.ready is not None:
            return self.ready
        tn = native.get()
        try:
            if progress is not None and progress(0.0) is False:
                raise tn.Cancelled("cancelled")  # before the match, which has no checks of its own
            order = self.order
            if order is None:
                if self.numbering is None:
                    raise ValueError("Blender's numbering was not read (announce)")
                with _lock:
                    numberings += 1
                order = self.order = match_numbering(self.base, self.levels, self.sculpted, self.numbering, self.name)
            if progress is not None and progress(0.0) is False:
                raise tn.Cancelled("cancelled")
            with _lock:
                analyses += 1
            fine = np.ascontiguousarray(self.sculpted.vertices[order])
            analysis = tn.analyze(self.base.vertices, self.base.face_sizes, self.base.corners, fine, self.levels, progress=progress)
            if not np.array_equal(np.asarray(analysis["corners"]), self.base.corners):
                raise ValueError("the analysed sculpt's faces are not the base mesh's")
        except tn.Cancelled:
            raise  # nothing stored: the entry before stays
        except (ValueError, *native.error_types()) as exc:
            with _lock:
                if _wanted.get(self.key) == (self.base_key, self.fine_key):
                    _cache.pop(self.key, None)
            raise type(exc)(f"'{self.label}' (Use Sculpt): {exc}") from None
        analysis["levels"] = self.levels
        analysis["order"] = order
        with _lock:
            if _wanted.get(self.key) == (self.base_key, self.fine_key):
                _cache[self.key] = Entry(self.base_key, order, self.fine_key, analysis)
        self.ready = analysis
        return analysis

    def coarse(self, analysis):
        """The base with the analysis' fitted coarse positions (its UV maps, material
        indices and vertex-group weights kept)."""
        return MeshArrays(
            np.ascontiguousarray(analysis["vertices"], dtype=np.float32),
            self.base.face_sizes,
            self.base.corners,
            point_attributes=self.base.point_attributes,
            uvs=self.base.uvs,
            uv_maps=self.base.uv_maps,
            material_index=self.base.material_index,
            uv_name=self.base.uv_name,
        )
