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
stays, except a numbering it matched, kept (with no analysis) in place of an entry of
another base.
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
#: The share of a sculpt's analysis progress the numbering match takes when it runs
#: (after a base edit): timed against the analysis on a 126k-vertex sculpt (README).
MATCH_SHARE = 0.25


class Entry(NamedTuple):
    """A source's numbering (`order`, of the base `base_key`) and the analysis of its
    sculpt `fine_key`; both None where the analysis was cancelled after the match."""

    base_key: tuple
    order: np.ndarray
    fine_key: bytes | None
    analysis: dict | None


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
    position); `sculpted` the sculpt (MeshArrays, Blender's numbering). Matched
    positions could still swap two close vertices: `analyse` checks the renumbered
    faces. `name` (the object's) goes in the messages."""
    if len(sculpted.vertices) != len(numbering):
        raise ValueError(f"the Multires of '{name}' has {len(sculpted.vertices)} vertices at {levels} levels where a Subdivision Surface has {len(numbering)}")
    # Blender puts an open mesh's corners (Boundary Smooth "All") short of the limit, by
    # up to 5.5e-4 of the size at Quality 3: matched within 1e-3, one to one (checked).
    return native.get().match_subdivision(base.vertices, base.face_sizes, base.corners, levels, numbering, tolerance=1e-3)


def analyse(base, levels: int, sculpted, order, name: str, progress=None) -> dict:
    """`thicket_native.analyze` of the sculpt `sculpted` (MeshArrays, Blender's
    numbering) renumbered by `order` (`match_numbering`) over `base` at `levels`, its
    renumbered faces checked in the core to be Thicket's subdivision's (a wrong match
    is refused, not analysed as noise: ValueError naming the object `name`).
    `progress` as `analyze`'s."""
    tn = native.get()
    ours = np.empty_like(order)
    ours[order] = np.arange(len(order), dtype=order.dtype)
    fine = np.ascontiguousarray(sculpted.vertices[order])
    try:
        return tn.analyze(
            base.vertices,
            base.face_sizes,
            base.corners,
            fine,
            levels,
            fine_face_sizes=sculpted.face_sizes,
            fine_corners=ours[sculpted.corners],
            progress=progress,
        )
    except tn.InvalidInput as exc:
        if "in Thicket's numbering" not in str(exc):
            raise
        raise ValueError(f"the Multires of '{name}' could not be matched face for face to Thicket's subdivision (vertices too close to tell apart)") from None


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
        matched (when the base changed; the first `MATCH_SHARE` of the progress) and
        analysed now, `progress` as `evaluate_stack`'s (False cancels: `Cancelled`,
        checked before and after the match; a numbering matched before the cancel is
        kept in the cache, the analysis before it dropped only if of another base).
        Errors name the item (`label`)."""
        global analyses, numberings
        if self.ready is None:
            self._take_cached()  # another evaluation may have analysed it meanwhile
        if self.ready is not None:
            return self.ready
        tn = native.get()
        matched = False
        share = 0.0

        def check(fraction):
            if progress is not None and progress(fraction) is False:
                raise tn.Cancelled("cancelled")

        try:
            check(0.0)  # before the match, which has no checks of its own
            order = self.order
            if order is None:
                if self.numbering is None:
                    raise ValueError("Blender's numbering was not read (announce)")
                with _lock:
                    numberings += 1
                order = self.order = match_numbering(self.base, self.levels, self.sculpted, self.numbering, self.name)
                matched, share = True, MATCH_SHARE
                check(share)
            with _lock:
                analyses += 1
            inside = None if progress is None else (lambda f: progress(share + (1.0 - share) * f))
            analysis = analyse(self.base, self.levels, self.sculpted, order, self.name, progress=inside)
            if not np.array_equal(np.asarray(analysis["corners"]), self.base.corners):
                raise ValueError("the analysed sculpt's faces are not the base mesh's")
        except tn.Cancelled:
            if matched:
                self._keep_numbering()
            raise
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

    def _keep_numbering(self):
        """Stores the numbering this evaluation matched (its analysis was cancelled) with
        no analysis, if Blender's latest read of the source has this base and the cache
        has no entry of it: the next read of this base takes it and skips Blender's
        numbering and the match. Keyed on the base alone (`base_key`: the levels and the
        base's positions and faces), all the numbering depends on."""
        with _lock:
            wanted, entry = _wanted.get(self.key), _cache.get(self.key)
            if wanted is not None and wanted[0] == self.base_key and (entry is None or entry.base_key != self.base_key):
                _cache[self.key] = Entry(self.base_key, self.order, None, None)

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
