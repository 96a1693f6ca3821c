"""Settings of each stack item kind as plain data, independent of Blender."""

from dataclasses import dataclass, field

from .arrays import SELECTED_VERTICES


class _Item:
    def vertex_groups(self):
        """The vertex groups this item reads from the source."""
        return [self.vertex_group] if self.vertex_group else []


@dataclass(frozen=True)
class OffsetShell(_Item):
    """Offset Shell (normal displacement): the baseline shell.

    thickness: a length, or a fraction of the bounding-box diagonal when `relative`;
    negative offsets inward. vertex_group scales it per vertex (0 = no offset).
    output: "outer" (offset surface), "solid" (closed with the base and rims) or
    "layers" (`surfaces` evenly spaced surfaces, the last one the offset surface).
    """

    thickness: float = 0.05
    relative: bool = True
    vertex_group: str = ""
    output: str = "outer"
    surfaces: int = 4

    kind = "OFFSET_SHELL"
    label = "Offset Shell"


@dataclass(frozen=True)
class FieldShell(_Item):
    """Shell: directors integrated along the L_p-averaged distance field (chapter 4).

    Unlike the Offset Shell it does not fold over itself in concavities: where the
    surface is close to itself the thickness is reduced locally instead. side:
    "exterior", "interior" or "envelope" (both, half each). thickness as for
    OffsetShell but its magnitude only (the side gives the direction).
    """

    thickness: float = 0.05
    relative: bool = True
    vertex_group: str = ""
    output: str = "outer"
    surfaces: int = 4
    side: str = "exterior"

    kind = "SHELL"
    label = "Shell"


@dataclass(frozen=True)
class VolumetricTexture(_Item):
    """Volumetric Texture: detail mapped into the shell above it, baked to geometry.

    pattern: "chain_mail", "weave", "rivets", "grass", "fur" or "bubbles" (chapter 3);
    (s, t) come from the active UV map times `tiling`; without UVs, `no_uv_tiles`
    says how: "face" (one tile per face) or "world" (generated charts, one tile every
    `tile_size` units of the mesh's own coordinates along the surface, 0: `auto_tile_size` of the base; the
    generated coordinates stand in for the UV map, so `tiling` still multiplies them),
    r runs along the shell's directors. resolution: lattice steps per base edge;
    depth_steps: lattice steps across the shell. vertex_group: where the texture exists (elsewhere a
    thin base slab, blended smoothly). combine: a second pattern united with the first
    (chapter 7), shifted by `offset` in (s, t). time: animated patterns' time.
    filepath: a texture file instead of the pattern (a folder of PNG slices, or an
    .exr volume). field_tree: a field tree's JSON instead of the pattern (README,
    Volumetric Texture from a field tree): authored in the unit texture cell, its
    point (x, y, z) is (s, t, r); sampled at texture_size (half across the shell), alpha only. Editing (chapter 7): hole_group zeroes the texture by weight, cutter
    (vertices, triangles) of a closed mesh in the source's space zeroes it inside;
    move_group's piece of texture moves by move_offset (UV units), its trace showing
    the base. follow_texture: sample at the texture's own texel spacing (at least
    `resolution` and `depth_steps` steps), so thin features survive; triangle_budget: the
    bake is simplified toward it (0: no simplification); max_triangles: the most
    triangles the lattice may make before simplification (a texture-following lattice
    is coarsened to fit; over it even at `resolution`, refused). confirm_above: bakes
    estimated above it raise BakeNeedsConfirmation when the caller asks (the UI).
    """

    pattern: str = "chain_mail"
    filepath: str = ""
    field_tree: str = ""
    seed: int = 0
    time: float = 1.0
    feature_thickness: float = 1.0
    texture_size: int = 64
    tiling: float = 1.0
    no_uv_tiles: str = "face"
    tile_size: float = 0.0
    resolution: int = 8
    depth_steps: int = 16
    vertex_group: str = ""
    combine: str = ""
    offset: tuple = (0.0, 0.0)
    hole_group: str = ""
    cutter: object = None
    move_group: str = ""
    move_offset: tuple = (0.0, 0.0)
    follow_texture: bool = True
    triangle_budget: int = 1_000_000
    confirm_above: int = 3_000_000
    max_triangles: int = 20_000_000

    def vertex_groups(self):
        return [g for g in (self.vertex_group, self.hole_group, self.move_group) if g]

    kind = "VOLUMETRIC_TEXTURE"
    label = "Volumetric Texture"


@dataclass(frozen=True)
class SolidTexture(_Item):
    """Solid Texture: a field tree's texture function evaluated on the mesh.

    tree: the field tree's JSON (README, Implicit shapes), in the source's object
    space. mode: "color" writes the tree's colour at each vertex ("point") or face
    corner ("corner") into the colour attribute `attribute` (and the texture value
    into `thicket_texture`); "displace" moves each vertex along its normal by
    `amplitude` times the texture value (Akleman-Chen section 7). Follows any item
    (a shell, a baked texture) and keeps its vertices' provenance.
    """

    tree: str = ""
    mode: str = "color"
    domain: str = "point"
    amplitude: float = 0.1
    attribute: str = "thicket_color"

    def vertex_groups(self):
        return []

    kind = "SOLID_TEXTURE"
    label = "Solid Texture"


@dataclass(frozen=True)
class ProceduralDetail(_Item):
    """Procedural Detail: Catmull-Clark levels with procedural detail added at each.

    Velho, Perlin, Ying and Biermann, section 4: the current mesh is subdivided
    `levels` times and `model`'s detail added at every level ("rock": a random value
    per control point, amplitude halving per level; "berry": domes around seeds with
    smaller clusters at each finer level; "tentacle": seeds pulled out `length` times
    the level, turning by `theta` plus `spin` times `time` radians; "spur": the same, straight;
    "mushroom": a vortex ring of `radius` carrying the surface around each seed for
    `length` times the level; "fuse": the surface of revolution about `axis` with the
    fuse profile, `amplitude`, its argument reaching `span` at the farthest vertex).
    amplitude, radius, length and spacing (the tentacles' and spurs' Poisson-disk
    spacing) are fractions of the mesh's bounding-box diagonal; children: seeds each
    berry seed grows at the next level. seeds: "random" (Poisson-disk points, or the
    rock's random values from `seed`), "group" (the vertices of `vertex_group` with
    weight at least one half) or "selected" (the source's selected vertices).
    confirm_above: results estimated above this many triangles raise
    NeedsConfirmation when the caller asks (the UI). The result's vertices keep the
    group weights of the base vertex whose quarter of a face they lie in.

    Operations (sections 5-6): `at`, the levels the model adds detail at (None: all);
    `blend_model` (empty: none), a second model with the item's own settings times
    `blend_gain` and random values from `blend_seed`, blended in where the alpha is 1:
    `blend_alpha` "plane" (through `blend_point`, object space, facing
    `blend_direction`; `blend_width` a fraction of the diagonal) or "group"
    (`blend_group`'s weights; `blend_width` in weight units), the transition halving per
    level. `local_center` (object space, or None): the detail within `local_radius`
    base edges of the vertex nearest it scaled by `local_gain` at `local_at` (None:
    all). `shader` "planet": colours from the scalar and the blend parameter, oceans
    below `sea`, snow above `snow` (fractions of the diagonal).

    Time (section 3 feeds it to the models, the alpha and the shader): at `time` a
    tentacle has turned by `spin` times it; every model but the berry has grown to
    `time / grow` of its size (full from `grow` on; `grow` 0: full at once); the blend's
    second side has grown by `blend_sweep` times it; the sea level and snow line have
    risen by `sea_rate` and `snow_rate` times it.

    `use_sculpt`: the item starts from the source's Multires sculpt (section 2): the
    stack reads the object's own base mesh as the source and sets `sculpt`, the sculpt
    as read from Blender (`procedural_detail_sculpt.Sculpt`, analysed in the
    evaluation, or from its cache) or an analysis already made (`thicket_native.analyze`'s
    dict plus `levels`); the analysis' fitted coarse mesh replaces the source and its
    details are added at their levels under the model's; `sculpt_notes` are passed on
    to the user.
    Without `sculpt` (no Multires on the source) the item works as without it.
    """

    model: str = "rock"
    levels: int = 3
    seed: int = 0
    amplitude: float = 0.02
    radius: float = 0.15
    children: int = 3
    length: float = 0.01
    theta: float = 0.0
    spacing: float = 0.25
    span: float = 1.5
    axis: tuple = (0.0, 0.0, 1.0)
    time: float = 0.0
    spin: float = 1.0
    grow: float = 0.0
    seeds: str = "random"
    vertex_group: str = ""
    confirm_above: int = 3_000_000
    at: tuple | None = None
    blend_model: str = ""
    blend_seed: int = 1
    blend_gain: float = 1.0
    blend_alpha: str = "plane"
    blend_point: tuple = (0.0, 0.0, 0.0)
    blend_direction: tuple = (1.0, 2.0, 0.0)
    blend_width: float = 0.2
    blend_sweep: float = 0.0
    blend_group: str = ""
    local_center: tuple | None = None
    local_radius: float = 2.0
    local_gain: float = 0.0
    local_at: tuple | None = None
    shader: str = ""
    sea: float = 0.0
    snow: float = 0.025
    sea_rate: float = 0.0
    snow_rate: float = 0.0
    use_sculpt: bool = False
    sculpt: "Sculpt | dict | None" = field(default=None, compare=False, repr=False)  # noqa: F821 (pure.kinds.procedural_detail_sculpt)
    sculpt_notes: tuple = ()

    def vertex_groups(self):
        groups = [self.blend_group] if self.blend_model and self.blend_alpha == "group" and self.blend_group else []
        if self.model in ("rock", "fuse") or self.seeds == "random":
            return groups
        if self.seeds == "selected":
            return groups + [SELECTED_VERTICES]
        return groups + ([self.vertex_group] if self.seeds == "group" and self.vertex_group else [])

    kind = "PROCEDURAL_DETAIL"
    label = "Procedural Detail"


# Appended, never reordered: the enum stores each kind by its position in saved files.
KINDS = {cls.kind: cls for cls in (OffsetShell, FieldShell, VolumetricTexture, SolidTexture, ProceduralDetail)}


def shell_settings(kind, thickness, thickness_mode="RELATIVE", vertex_group="", output="OUTER", surfaces=OffsetShell.surfaces, side="EXTERIOR"):
    """A Shell ("SHELL") or Offset Shell item's settings from its properties' values
    (enum values as Blender stores them: "RELATIVE", "OUTER", "EXTERIOR"...)."""
    common = dict(thickness=thickness, relative=thickness_mode == "RELATIVE", vertex_group=vertex_group, output=output.lower(), surfaces=surfaces)
    return FieldShell(side=side.lower(), **common) if kind == FieldShell.kind else OffsetShell(**common)
