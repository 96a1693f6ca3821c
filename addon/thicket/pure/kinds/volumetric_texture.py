"""The Volumetric Texture kind (thick surfaces, chapters 3 and 7): a texture placed
in the latest shell, with its region, holes, cutter and moved region, baked to
geometry; renderers draw it from the shell instead."""

import functools
import os
from typing import NamedTuple

import numpy as np

from .. import native
from .. import settings as S
from ..arrays import MeshArrays
from ..field_tree import check_tree
from ..state import NeedsConfirmation as BakeNeedsConfirmation  # the name the API has exported since bakes asked first
from ..state import ShellContext, State, group_weights

TEXCOORD_ATTRIBUTE = "thicket_texcoord"


_loaded = {}  # (path, modification time) -> Texture handle: files are read once
_LOADED_KEEP = 8


def _modified(path):
    """Newest modification time of a texture file, or of a PNG stack's folder and
    slices (a .png path stands for its folder, as `load_texture` reads it)."""
    folder = path if os.path.isdir(path) else os.path.dirname(path) if path.lower().endswith(".png") else None
    files = [path] if folder is None else [folder] + [os.path.join(folder, f) for f in os.listdir(folder)]
    return max(map(os.path.getmtime, files))


def _texture_file(tn, path):
    """A texture file as a `thicket_native.Texture`, cached while the file is unchanged."""
    try:
        key = (path, _modified(path))
    except OSError:
        return tn.Texture.load(path)  # the loader names what is missing
    if key not in _loaded:
        if len(_loaded) >= _LOADED_KEEP:
            _loaded.pop(next(iter(_loaded)))
        _loaded[key] = tn.Texture.load(path)
    return _loaded[key]


@functools.lru_cache(maxsize=4)
def _pattern(tn, pattern, size, seed, time, thickness):
    """A procedural texture as a `thicket_native.Texture`: generated once per
    arguments (handles are immutable, so evaluations and previews share one)."""
    return tn.Texture.pattern(pattern, size=size, seed=seed, time=time, thickness=thickness)


@functools.lru_cache(maxsize=4)
def _field(tn, tree, size):
    """A field tree's texture as a `thicket_native.Texture`, made once per tree and size."""
    return tn.Texture.from_field(tree, resolution=size)


def _size(item: S.VolumetricTexture):
    size = int(item.texture_size)
    return (size, size, max(2, size // 2))


def _texture(tn, pattern, item: S.VolumetricTexture):
    size = int(item.texture_size)
    return _pattern(tn, pattern, (size, size, max(2, size // 2)), int(item.seed), float(item.time), float(item.feature_thickness))


def item_texture(item: S.VolumetricTexture):
    """The item's texture as a `thicket_native.Texture` handle (its `array()` is the
    float32 (nz, ny, nx) alpha): its field tree, its file or its pattern."""
    tn = native.get()
    if item.field_tree:
        return _field(tn, check_tree(item.field_tree), _size(item))
    return _texture_file(tn, item.filepath) if item.filepath else _texture(tn, item.pattern, item)


def placed_textures(item: S.VolumetricTexture):
    """The item's texture, and the texture it combines with at its offset (united), as
    `thicket_native.Texture` handles."""
    textures = [item_texture(item)]
    if item.combine:
        textures.append((_texture(native.get(), item.combine, item), tuple(float(v) for v in item.offset)))
    return textures


#: The automatic Tile Size (World-Size Tiles, tile_size 0) as a fraction of the base's
#: bounding-box diagonal: a closed, roundish surface of diagonal D has an area near D²,
#: so about 32² = 1000 tiles: the tile count of a one-tile-per-face mesh of 1000 faces,
#: the size the library's patterns were tuned on (the demo's bunny has 3k faces).
AUTO_TILE_FRACTION = 1 / 32


def auto_tile_size(base: MeshArrays) -> float:
    """The automatic Tile Size of `base`: `AUTO_TILE_FRACTION` of its bounding-box diagonal."""
    v = np.asarray(base.vertices, dtype=np.float64)
    diagonal = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0))) if len(v) else 0.0
    return diagonal * AUTO_TILE_FRACTION if diagonal > 0 else 1.0


def world_tile_size(shell: ShellContext, item: S.VolumetricTexture):
    """The tile size the item's coordinates are generated at, or None where they are
    not (the base has a UV map, or the item keeps one tile per face)."""
    if shell.base.uvs is not None or str(item.no_uv_tiles).lower() != "world":
        return None
    return float(item.tile_size) if item.tile_size > 0 else auto_tile_size(shell.base)


def texture_settings(shell: ShellContext, item: S.VolumetricTexture, weights):
    """What the bake, its estimate and the renderers take besides the shell and the
    textures: one argument list, so a preview shows what the bake makes (UVs, tiling,
    region, holes, cutter, moved region). `weights`: per-vertex region, holes and
    move arrays (or None) by name. `world_tile_size`: the tile size of generated
    world-size UVs (None: the base's own UVs, or one tile per face)."""
    tile = world_tile_size(shell, item)
    return dict(
        uvs=shell.base.uvs if tile is None else shell.world_size(tile)[1],
        world_tile_size=tile,
        tiling=float(item.tiling),
        resolution=int(item.resolution),
        depth_steps=int(item.depth_steps),
        region=weights["region"],
        holes=weights["holes"],
        cutter=item.cutter,
        move_region=weights["move"],
        move_offset=tuple(float(v) for v in item.move_offset),
        follow_texture=bool(item.follow_texture),
    )


def native_settings(settings, drop=()):
    """`texture_settings` as the array functions take them (`thicket_native.bake_texture`,
    `estimate_bake`, `render_shell`): the UVs already generated, without their tile size;
    without the keys in `drop` too."""
    return {key: value for key, value in settings.items() if key != "world_tile_size" and key not in drop}


def native_shell(shell: ShellContext, textures, settings):
    """The native handle (`thicket_native.TexturedShell`) of `shell` with the placed
    `textures` and `settings` (`texture_settings`, plus a bake's budget): made from the
    shell's kind's `Shell` handle and the `Texture` handles (the base's UVs are its
    mesh's own), then estimated, baked or rendered as often as wanted (the renderers'
    scene is made on its first frame and kept). With `world_tile_size`, the shell is
    the same one over the base with generated world-size UVs."""
    tile = settings.get("world_tile_size")
    handle = shell.handle if tile is None else shell.world_size(tile)[0]
    return handle.textured(textures, **native_settings(settings, drop=("uvs",)))  # the handle's mesh has its UVs


#: What a bake refused over the sample limit on a mesh without UVs adds to its message.
WORLD_SIZE_HINT = (
    "the mesh has no UV map, so each face is one whole tile: set Without UV Map to World-Size Tiles "
    "(Volumetric Texture settings, or no_uv_tiles='WORLD' in scripts) for tiles of a world size instead"
)


def _pointing_at_world_size(error, shell: ShellContext, settings):
    """`error` (a bake refused over the sample limit) with `WORLD_SIZE_HINT` where the
    base has no UVs and its faces are tiles; otherwise `error` itself."""
    tn = native.get()
    if isinstance(error, tn.OverLimit) and shell.base.uvs is None and settings.get("world_tile_size") is None:
        return tn.OverLimit(f"{error}; {WORLD_SIZE_HINT}")
    return error


def bake(shell: ShellContext, item: S.VolumetricTexture, weights, ask=False, progress=None):
    """Bakes the item's texture(s) over `shell` (thick surfaces, chapter 3);
    `weights`: per-vertex region, holes and move arrays (or None) by name;
    `progress`: the bake's callback (see `evaluate_stack`)."""
    textures = placed_textures(item)
    base = shell.base
    # Read and checked once, estimated and baked from the same handle, so the estimate
    # sees what the bake will (UVs, region, holes, cutter, moved region).
    settings = dict(texture_settings(shell, item, weights), triangle_budget=int(item.triangle_budget), max_triangles=int(item.max_triangles))
    textured = native_shell(shell, textures, settings)
    try:
        if ask:
            estimate = textured.estimate()
            if estimate > item.confirm_above:
                raise BakeNeedsConfirmation(item.label, estimate, item.confirm_above, int(item.triangle_budget))
        out = textured.bake(progress=progress)
    except native.get().ThicketError as error:
        hinted = _pointing_at_world_size(error, shell, settings)
        if hinted is error:
            raise
        raise hinted from error
    result = MeshArrays.from_native(out)
    result.normals = out["normals"]
    result.point_attributes = {TEXCOORD_ATTRIBUTE: out["texcoords"]}
    # Shaded like the base: each triangle takes the material of the face it grew from,
    # and a UV map carries the base's UVs (the texture's (s, t) over Tiling), the
    # generated world-size UVs likewise, or each face's own tile where the base has no
    # UV map.
    if base.material_index is not None:
        result.material_index = base.material_index[out["source_face"]]
    st = out["corner_texcoords"][:, :2]
    per_face = base.uvs is None and settings["world_tile_size"] is None
    result.uv_maps = {base.uv_name: st if per_face else st / np.float32(item.tiling)}
    notes = []
    if out["per_face_tiles"]:
        notes.append("the mesh has no UV map: each face got its own texture tile")
    if out["texture_finer_than_lattice"]:
        steps = out["lattice_steps"][0]
        notes.append(
            f"'{item.label}': the texture is finer than the bake lattice ({steps} steps per face edge) on many faces, so thin features may be lost; "
            "raise Sample Limit or lower Tiling or Texture Size"
            + (", or set Without UV Map to World-Size Tiles (one tile per face makes as many tiles as faces)" if out["per_face_tiles"] else "")
        )
    if out.get("over_budget"):
        count, error, budget = len(out["source_face"]), out["simplify_error"], int(item.triangle_budget)
        notes.append(
            f"'{item.label}': {count:,} triangles, {count / budget:.1f} times the Triangle Budget of {budget:,}: fewer would move the surface "
            f"more than {error:g} lattice steps and lose the texture's silhouette"
            + (", and with one tile per face every face's rim stays as sampled (World-Size Tiles simplify across faces)" if out["per_face_tiles"] else "")
            + "; lower Tiling or Texture Size for a smaller bake"
        )
    return result, notes


class BudgetFit(NamedTuple):
    """Tiles grown to an item's Triangle Budget (`fit_budget`): the item settings that
    give them (`tiling` for a UV map; `no_uv_tiles` and `tile_size` for World-Size
    Tiles) and the search's result (`thicket_native.TexturedShell.fit_budget`: scale,
    triangles, fits...)."""

    settings: dict
    found: dict


def fit_budget(shell: ShellContext, item: S.VolumetricTexture, weights, progress=None) -> BudgetFit:
    """The smallest tiles (within 5%) at which the item's bake over `shell` is
    estimated within its Triangle Budget, from its tiles now: a UV map's Tiling
    shrinks, World-Size Tiles grow, and one tile per face turns into World-Size Tiles
    grown from the automatic size (per-face tiles cannot grow). `weights`: as
    `bake`'s; `progress`: the search's callback (False cancels)."""
    settings = dict(texture_settings(shell, item, weights), triangle_budget=int(item.triangle_budget), max_triangles=int(item.max_triangles))
    tile = settings["world_tile_size"]
    if shell.base.uvs is None and tile is None:
        tile = auto_tile_size(shell.base)
        settings.update(world_tile_size=tile, uvs=shell.world_size(tile)[1])
    found = native_shell(shell, placed_textures(item), settings).fit_budget(progress=progress)
    if tile is None:
        return BudgetFit({"tiling": float(item.tiling) / found["scale"]}, found)
    return BudgetFit({"no_uv_tiles": "WORLD", "tile_size": tile * found["scale"]}, found)


def texture_weights(state: State, item: S.VolumetricTexture):
    """The item's per-vertex region, holes and move weights at the shell's base vertices."""
    at, group = state.shell.origin, lambda name: group_weights(state.source, name, at)
    return {"region": group(item.vertex_group), "holes": group(item.hole_group), "move": group(item.move_group)}


class TexturedShell(NamedTuple):
    """What a renderer draws of a Volumetric Texture item: the shell, the item, the
    placed textures and the settings the bake would take (`texture_settings`)."""

    shell: ShellContext
    item: S.VolumetricTexture
    textures: list
    settings: dict

    def handle(self):
        """Its native handle (`native_shell`), to render from."""
        return native_shell(self.shell, self.textures, self.settings)


def texture_draw_setup(state: State, item: S.VolumetricTexture) -> TexturedShell:
    """The kind's `draw_setup`: the textured shell the renderers draw, not baked."""
    return TexturedShell(state.shell, item, placed_textures(item), texture_settings(state.shell, item, texture_weights(state, item)))


def texture_step(state: State, item: S.VolumetricTexture, ask, progress):
    state.current, notes = bake(state.shell, item, texture_weights(state, item), ask, progress)
    state.notes.extend(notes)
    if state.current.face_count == 0:
        # Not an error (a hole group may cut everything away), but rarely wanted.
        state.notes.append(
            f"'{item.label}' baked no geometry: its features may be finer than the bake lattice; raise Resolution or Feature Thickness, or lower Tiling"
        )
