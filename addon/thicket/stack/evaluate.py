"""Runs a stack of item settings over a mesh (numpy arrays in, numpy arrays out).

No bpy here: the same function serves operators, the headless API and tests.
"""

import os
from typing import NamedTuple

import numpy as np

from .. import native
from ..arrays import MeshArrays, weight_attribute
from . import live_shells
from . import settings as S

DIRECTOR_ATTRIBUTE = "thicket_director"
TEXCOORD_ATTRIBUTE = "thicket_texcoord"
LAYER_ATTRIBUTE = "thicket_layer"
THICKNESS_ATTRIBUTE = "thicket_thickness"
RATIO_ATTRIBUTE = "thicket_ratio"

#: Below this share of its target a vertex counts as compressed.
COMPRESSED_BELOW = 0.95


class ShellContext:
    """The shell a later Volumetric Texture maps into: the mesh it was built on and
    its base offsets and directors (layer r of vertex v at v + base_offset + r * director)."""

    def __init__(self, base: MeshArrays, out, origin):
        self.base = base
        self.directors = np.ascontiguousarray(out["directors"], dtype=np.float32)
        offset = out.get("base_offset")
        self.base_offset = np.zeros_like(self.directors) if offset is None else np.ascontiguousarray(offset, dtype=np.float32)
        self.origin = origin  # source vertex of each base vertex


def _shell_result(out, base: MeshArrays):
    """Mesh arrays of a native shell result, with per-vertex shell attributes and the
    base's UV maps and material indices (outer, inner and rim faces alike)."""
    result = base.carried_to(MeshArrays.from_native(out), out["source_corner"], out["source_face"])
    source = out["source_vertex"]
    result.point_attributes = {
        DIRECTOR_ATTRIBUTE: out["directors"][source],
        LAYER_ATTRIBUTE: out["layer"],
    }
    if "achieved" in out:
        result.point_attributes[THICKNESS_ATTRIBUTE] = out["achieved"][source]
        result.point_attributes[RATIO_ATTRIBUTE] = thickness_ratio(out)[source]
    return result, source


def thickness_ratio(out):
    """Achieved / target thickness per base vertex (1 where the target is zero)."""
    target = out["target"]
    ratio = np.ones_like(target)
    np.divide(out["achieved"], target, out=ratio, where=target > 0)
    return ratio


def shell_summary(label, out):
    """What a field shell's final check found and how much it compressed, for the panel."""
    ratio = thickness_ratio(out)[out["target"] > 0]
    check = out["check"]
    return {
        "label": label,
        "min_ratio": float(ratio.min()) if ratio.size else 1.0,
        "mean_ratio": float(ratio.mean()) if ratio.size else 1.0,
        "compressed": int((ratio < COMPRESSED_BELOW).sum()),
        "vertices": int(ratio.size),
        **check,
    }


def summary_text(s) -> str:
    """One panel line for a `shell_summary`."""
    verdict = "no folds or crossings" if s["clean"] else "defects left"
    text = (
        f"{s['label']}: thickness min {s['min_ratio']:.0%}, mean {s['mean_ratio']:.0%} of target; "
        f"{s['compressed']:,} of {s['vertices']:,} vertices compressed; final check: {verdict}"
    )
    if s["check_shortened"]:
        text += f" ({s['check_shortened']:,} shortened by it)"
    return text


def _common_args(mesh: MeshArrays, item, factors):
    args = (mesh.vertices, mesh.face_sizes, mesh.corners, float(item.thickness))
    kwargs = dict(relative=item.relative, factors=factors, output=item.output, layers=int(item.layers))
    return args, kwargs


def _offset_shell(mesh: MeshArrays, item: S.OffsetShell, factors, progress=None):
    args, kwargs = _common_args(mesh, item, factors)
    out = native.get().offset_shell(*args, **kwargs)
    return (*_shell_result(out, mesh), out)


def _field_shell(mesh: MeshArrays, item: S.FieldShell, factors, progress=None):
    args, kwargs = _common_args(mesh, item, factors)
    out = live_shells.field_shell(args, dict(kwargs, side=item.side), progress)
    return (*_shell_result(out, mesh), out)


_loaded = {}  # (path, modification time) -> texture array: files are read once
_LOADED_KEEP = 8


def _modified(path):
    """Newest modification time of a texture file, or of a PNG stack's folder and
    slices (a .png path stands for its folder, as `load_texture` reads it)."""
    folder = path if os.path.isdir(path) else os.path.dirname(path) if path.lower().endswith(".png") else None
    files = [path] if folder is None else [folder] + [os.path.join(folder, f) for f in os.listdir(folder)]
    return max(map(os.path.getmtime, files))


def _texture_file(tn, path):
    """A texture file's alpha, cached while the file is unchanged."""
    try:
        key = (path, _modified(path))
    except OSError:
        return tn.load_texture(path)  # the loader names what is missing
    if key not in _loaded:
        if len(_loaded) >= _LOADED_KEEP:
            _loaded.pop(next(iter(_loaded)))
        _loaded[key] = tn.load_texture(path)
    return _loaded[key]


def _texture(tn, pattern, item: S.VolumetricTexture):
    size = int(item.texture_size)
    return tn.texture(pattern, size=(size, size, max(2, size // 2)), seed=int(item.seed), time=float(item.time), thickness=float(item.feature_thickness))


def item_texture(item: S.VolumetricTexture):
    """The item's texture as a float32 (nz, ny, nx) alpha array: its file or its pattern."""
    tn = native.get()
    return _texture_file(tn, item.filepath) if item.filepath else _texture(tn, item.pattern, item)


class BakeNeedsConfirmation(Exception):
    """A bake estimated above the item's `confirm_above`: the UI asks before baking."""

    def __init__(self, label, estimate, limit):
        super().__init__(f"'{label}' would make about {estimate:,} triangles (over {limit:,}): click Regenerate to confirm")
        self.estimate = estimate


def placed_textures(item: S.VolumetricTexture):
    """The item's texture, and the texture it combines with at its offset (united)."""
    textures = [item_texture(item)]
    if item.combine:
        textures.append((_texture(native.get(), item.combine, item), tuple(float(v) for v in item.offset)))
    return textures


def texture_settings(shell: ShellContext, item: S.VolumetricTexture, weights):
    """What the bake, its estimate and the renderers take besides the shell and the
    textures: one argument list, so a preview shows what the bake makes (UVs, tiling,
    region, holes, cutter, moved region). `weights`: per-vertex region, holes and
    move arrays (or None) by name."""
    return dict(
        uvs=shell.base.uvs,
        tiling=float(item.tiling),
        resolution=int(item.resolution),
        layers=int(item.layers),
        region=weights["region"],
        holes=weights["holes"],
        cutter=item.cutter,
        move_region=weights["move"],
        move_offset=tuple(float(v) for v in item.move_offset),
        follow_texture=bool(item.follow_texture),
    )


def _volumetric_texture(shell: ShellContext, item: S.VolumetricTexture, weights, ask=False, progress=None):
    """Bakes the item's texture(s) over `shell` (thick surfaces, chapter 3);
    `weights`: per-vertex region, holes and move arrays (or None) by name;
    `progress`: the bake's callback (see `evaluate_stack`)."""
    tn = native.get()
    textures = placed_textures(item)
    base = shell.base
    # One argument list for the estimate and the bake, so the estimate sees what the
    # bake will (UVs, region, holes, cutter, moved region).
    args = (base.vertices, base.face_sizes, base.corners, shell.base_offset, shell.directors, textures)
    settings = dict(texture_settings(shell, item, weights), triangle_budget=int(item.triangle_budget), max_triangles=int(item.max_triangles))
    if ask:
        estimate = tn.estimate_bake(*args, **settings)
        if estimate > item.confirm_above:
            raise BakeNeedsConfirmation(item.label, estimate, item.confirm_above)
    out = tn.bake_texture(*args, **settings, progress=progress)
    result = MeshArrays.from_native(out)
    result.normals = out["normals"]
    result.point_attributes = {TEXCOORD_ATTRIBUTE: out["texcoords"]}
    # Shaded like the base: each triangle takes the material of the face it grew from,
    # and a UV map carries the base's UVs (the texture's (s, t) over Tiling), or each
    # face's own tile where the base has no UV map.
    if base.material_index is not None:
        result.material_index = base.material_index[out["source_face"]]
    st = out["corner_texcoords"][:, :2]
    result.uv_maps = {base.uv_name: st if base.uvs is None else st / np.float32(item.tiling)}
    notes = []
    if out["per_face_tiles"]:
        notes.append("the mesh has no UV map: each face got its own texture tile")
    if out["texture_finer_than_lattice"]:
        steps = out["lattice_steps"][0]
        notes.append(
            f"'{item.label}': the texture is finer than the bake lattice ({steps} steps per face edge) on many faces, so thin features may be lost; "
            "raise Sample Limit or lower Tiling or Texture Size"
        )
    return result, notes


class StackError(ValueError):
    """A stack that cannot be evaluated as ordered (e.g. a texture without a shell)."""


def _group_weights(source: MeshArrays, name, at):
    """Vertex group `name`'s weights at the vertices `at` (source indices: the walk
    never reaches a kind that reads groups once they are gone); None without a name."""
    if not name:
        return None
    weights = source.point_attributes.get(weight_attribute(name))
    if weights is None:
        raise KeyError(f"vertex group '{name}' was not read from the source")
    return np.ascontiguousarray(weights[at], dtype=np.float32)


class _State:
    """What the items so far have made: the current mesh, the source vertex of each of
    its vertices (None once geometry comes from no single source vertex), the latest
    shell, notes for the user and the field shells' final checks."""

    def __init__(self, source: MeshArrays):
        self.source = source
        self.current = source
        self.origin = np.arange(source.vertex_count)
        self.shell = None
        self.made_by = ""  # the label of the kind that made geometry without provenance
        self.notes = []
        self.summaries = []


def _shell_step(build):
    """A shell kind's step: `build(mesh, item, factors, progress)` on the current mesh
    gives the shell's mesh, each vertex's provenance and the native output."""

    def step(state: _State, item, ask, progress):
        factors = _group_weights(state.source, item.vertex_group, state.origin)
        base, base_origin = state.current, state.origin
        state.current, provenance, out = build(base, item, factors, progress)
        state.shell = ShellContext(base, out, base_origin)
        if "check" in out:
            state.summaries.append(shell_summary(item.label, out))
        state.origin = base_origin[provenance]

    return step


def _texture_weights(state: _State, item: S.VolumetricTexture):
    """The item's per-vertex region, holes and move weights at the shell's base vertices."""
    at, group = state.shell.origin, lambda name: _group_weights(state.source, name, at)
    return {"region": group(item.vertex_group), "holes": group(item.hole_group), "move": group(item.move_group)}


def _texture_step(state: _State, item: S.VolumetricTexture, ask, progress):
    state.current, notes = _volumetric_texture(state.shell, item, _texture_weights(state, item), ask, progress)
    state.notes.extend(notes)
    if state.current.face_count == 0:
        # Not an error (a hole group may cut everything away), but rarely wanted.
        state.notes.append(
            f"'{item.label}' baked no geometry: its features may be finer than the bake lattice; raise Resolution or Feature Thickness, or lower Tiling"
        )


class Kind(NamedTuple):
    """How a stack item kind evaluates. `consumes`: "mesh" (the current mesh, whose
    vertices must come from the source's, so vertex groups follow them) or "shell"
    (the latest shell, which the renderers draw instead of running the step);
    `produces`: "shell" (a shell and its mesh), "mesh" (a mesh whose vertices are
    traced to the source's) or "geometry" (new geometry, from no single source
    vertex: vertex groups end there). `weight`: its share of the progress bar relative to the others
    (not from the papers: a bake usually takes longest, an offset shell is
    instantaneous). `step(state, item, ask, progress)` updates the state."""

    consumes: str
    produces: str
    weight: float
    step: object


#: Every item kind by its settings class. For the evaluator a new kind is its settings,
#: its step and one line here; Blender also needs it in `settings.KINDS`, the item
#: PropertyGroup and its panel.
KINDS = {
    S.OffsetShell: Kind("mesh", "shell", 0.1, _shell_step(_offset_shell)),
    S.FieldShell: Kind("mesh", "shell", 1.0, _shell_step(_field_shell)),
    S.VolumetricTexture: Kind("shell", "geometry", 3.0, _texture_step),
}


def _drawn(kind: Kind) -> bool:
    """Whether a renderer draws the kind's result directly from the shell it consumes."""
    return kind.consumes == "shell"


class TexturedShell(NamedTuple):
    """What a renderer draws: a shell, its Volumetric Texture item, the placed
    textures and the settings the bake would take (`texture_settings`)."""

    shell: ShellContext
    item: S.VolumetricTexture
    textures: list
    settings: dict


def texture_setup(source: MeshArrays, items, progress=None) -> TexturedShell:
    """Runs the shell items up to the first Volumetric Texture item and returns what a
    renderer draws directly, without baking. `progress`: as in `evaluate_stack`, over
    those shells."""
    state, stopped = _run(source, items, progress, stop=_drawn)
    if stopped is None:
        raise StackError("the stack has no enabled Volumetric Texture item to render")
    weights = _texture_weights(state, stopped)
    return TexturedShell(state.shell, stopped, placed_textures(stopped), texture_settings(state.shell, stopped, weights))


def progress_spans(items, bakes=True):
    """The (start, end) share of the whole that each item covers; items a renderer
    draws take none when nothing is baked (`bakes` False)."""
    weights = [KINDS[type(item)].weight if bakes or not _drawn(KINDS[type(item)]) else 0.0 for item in items]
    total = sum(weights) or 1.0
    ends = np.cumsum(weights) / total
    return [(float(end - w / total), float(end)) for w, end in zip(weights, ends)]


def cancelled_error():
    """The core's `Cancelled` error (a ThicketError), raised where Python stops work."""
    return native.get().Cancelled("cancelled")


def _scaled(progress, start, end):
    """`progress` seen by one item: its fractions mapped into [start, end]."""
    if progress is None:
        return None
    return lambda fraction: progress(start + (end - start) * min(max(float(fraction), 0.0), 1.0))


def evaluate_stack(source: MeshArrays, items, progress=None, ask=False) -> MeshArrays:
    """Applies `items` in order; each item's input is the previous item's output.

    Vertex-group weights are looked up on the source mesh and followed through the
    items by provenance (`source_vertex`), so a group keeps meaning after the first
    item. An empty list returns the source. `ask`: raise `BakeNeedsConfirmation`
    before a bake estimated over its item's `confirm_above` (the interface then asks
    the user).

    `progress`: a callable given the share of the whole stack done, a float in [0, 1]
    that never decreases: at once, during field shells and bakes (about ten times a
    second, from the calling thread), after each item, and 1.0 at the end (when the
    answer no longer matters). Returning False cancels: the work stops at its next
    check and `thicket_native.Cancelled` (a `ThicketError`) is raised, or the
    callback's own exception if it raised one. Nothing is returned, and a field shell
    whose build was cancelled is not kept for later edits.
    """
    state, _ = _run(source, items, progress, ask)
    current = state.current
    if current is source:
        current = MeshArrays(source.vertices, source.face_sizes, source.corners)
    current.notes = state.notes
    current.shell_summaries = state.summaries
    return current


def _run(source: MeshArrays, items, progress=None, ask=False, stop=None):
    """Walks the stack by each kind's declarations (`KINDS`): the state after the last
    item and None, or, where `stop(kind)` holds, the state before that item and the
    item (the progress spans then leave drawn items out)."""
    spans = progress_spans(items, bakes=stop is None)
    if progress is not None and progress(0.0) is False:
        raise cancelled_error()
    state = _State(source)
    for i, item in enumerate(items):
        kind = KINDS[type(item)]
        if kind.consumes == "shell" and state.shell is None:
            raise StackError(f"'{item.label}' needs a Shell or Offset Shell above it in the stack")
        if kind.consumes == "mesh" and state.origin is None:
            raise StackError(f"'{item.label}' cannot follow a {state.made_by}")
        if stop is not None and stop(kind):
            return state, item
        kind.step(state, item, ask, _scaled(progress, *spans[i]))
        if kind.produces == "geometry":
            state.origin, state.made_by = None, type(item).label
        if progress is not None and progress(spans[i][1]) is False and i + 1 < len(items):
            raise cancelled_error()
    if progress is not None:
        progress(1.0)
    return state, None


def evaluate_each(sources, progress=None, errors=(ValueError,)):
    """`evaluate_stack` over several `(source, items)` pairs, one after the other,
    yielding each one's result, or its error when it is one of `errors` (an entry may
    be such an error already: a source that could not be read). `progress` covers
    them all in equal parts, ending at 1.0; a cancel (see `evaluate_stack`) ends the
    iteration with its exception, the results yielded before it standing."""
    n = len(sources)
    for i, entry in enumerate(sources):
        part = _scaled(progress, i / n, (i + 1) / n)
        if isinstance(entry, BaseException):  # nothing to evaluate: passed at once
            if part is not None and part(0.0) is False:
                raise cancelled_error()
            outcome = entry
            if part is not None:
                part(1.0)
        else:
            try:
                outcome = evaluate_stack(*entry, part)
            except native.get().Cancelled:
                raise
            except errors as exc:
                outcome = exc
        yield outcome
