"""Type stub of thicket_native, the pyo3 adapter over thicket-core.

Arrays: vertices float32 (n, 3); face_sizes and corners int32 or uint32 (one size
per face, the faces' vertex indices in order). Per-vertex values (thickness,
factors, weights) are a float or float32 (n,). tests/test_native.py checks these
signatures against the module's own.
"""

from collections.abc import Callable, Sequence
from typing import Any, TypedDict, Unpack

import numpy as np
from numpy.typing import NDArray

__version__: str

Floats = NDArray[np.float32]
Indices = NDArray[np.int32] | NDArray[np.uint32]
PerVertex = float | NDArray[np.float32]
Progress = Callable[[float], bool | None] | None
Cutter = tuple[Floats, Indices] | None
#: The placed textures of a textured shell, united: `Texture` handles or float32
#: (nz, ny, nx) alpha arrays, each at offset (0, 0) or given with its (ds, dt) offset
#: in texture space.
PlacedTextures = Sequence[Texture | Floats | tuple[Texture | Floats, tuple[float, float]]]

class ThicketError(ValueError):
    """Invalid input or a failure inside Thicket's geometry core; the message says which."""

class InvalidInput(ThicketError):
    """A mesh, array or setting Thicket cannot use; the message says which."""

class OverLimit(InvalidInput):
    """Work whose estimated output would pass a limit (Sample Limit, memory limit)."""

class FileError(ThicketError):
    """A file or folder that cannot be read or written; the message names it."""

class DeviceError(ThicketError):
    """The GPU could not render; the CPU reference can."""

class Cancelled(ThicketError):
    """The work was cancelled through its progress callback or by Ctrl-C."""

class InternalError(ThicketError):
    """A bug inside thicket-native (a Rust panic, caught); please report it."""

def mesh_report(vertices: Floats, face_sizes: Indices, corners: Indices) -> dict[str, Any]: ...
def offset_shell(
    vertices: Floats,
    face_sizes: Indices,
    corners: Indices,
    thickness: PerVertex,
    relative: bool = False,
    factors: Floats | None = None,
    output: str = "outer",
    surfaces: int | None = None,  # 1 when neither it nor `layers` is given
    *,
    layers: int | None = None,  # deprecated: the former name of `surfaces`
) -> dict[str, Any]: ...
def build_shell(vertices: Floats, triangles: Indices, thickness: PerVertex, side: str, progress: Progress = None) -> dict[str, Any]: ...
def shell(
    vertices: Floats,
    face_sizes: Indices,
    corners: Indices,
    thickness: PerVertex,
    side: str = "exterior",
    relative: bool = False,
    factors: Floats | None = None,
    output: str = "outer",
    surfaces: int | None = None,  # 1 when neither it nor `layers` is given
    p: float = 3.0,
    progress: Progress = None,
    *,
    layers: int | None = None,  # deprecated: the former name of `surfaces`
) -> dict[str, Any]: ...
def shell_report(
    vertices: Floats,
    face_sizes: Indices,
    corners: Indices,
    directors: Floats,
    target: Floats,
    base_offset: Floats | None = None,
    side: str = "exterior",
) -> dict[str, Any]: ...
def self_intersections(vertices: Floats, face_sizes: Indices, corners: Indices) -> dict[str, Any]: ...

class IncrementalShell:
    """A shell kept up to date while its base mesh is edited (thick surfaces, 7.1)."""

    def __init__(
        self,
        vertices: Floats,
        face_sizes: Indices,
        corners: Indices,
        thickness: PerVertex,
        side: str = "exterior",
        relative: bool = False,
        factors: Floats | None = None,
        output: str = "outer",
        surfaces: int | None = None,  # 1 when neither it nor `layers` is given
        p: float = 3.0,
        tolerance: float = 0.03,
        progress: Progress = None,
        *,
        layers: int | None = None,  # deprecated: the former name of `surfaces`
    ) -> None: ...
    def update(self, vertices: Floats, factors: Floats | None = None) -> dict[str, Any]: ...
    def result(self) -> dict[str, Any]: ...
    @property
    def vertex_count(self) -> int: ...
    @property
    def tolerance(self) -> float: ...
    @tolerance.setter
    def tolerance(self, tolerance: float) -> None: ...

def texture(pattern: str, size: tuple[int, int, int] = (64, 64, 32), seed: int = 0, time: float = 1.0, thickness: float = 1.0) -> Floats: ...

class _MappedSettings(TypedDict, total=False):
    """How textures map into a shell: every textured-shell entry point takes these
    (defaults in the comments)."""

    tiling: float  # 1.0
    resolution: int  # 8
    depth_steps: int  # 16 (formerly `layers`, still taken with a DeprecationWarning)
    region: PerVertex | None  # None
    base_layer: float  # 0.1
    holes: PerVertex | None  # None
    cutter: Cutter  # None
    move_region: PerVertex | None  # None
    move_offset: tuple[float, float]  # (0.0, 0.0)
    follow_texture: bool  # True

class _TextureSettings(_MappedSettings, total=False):
    """The keyword settings of a textured shell that `bake_texture`, `estimate_bake`,
    `render_shell` and `TexturedShell` share: the mesh's UVs come with them (a `Mesh`
    handle carries its own)."""

    uvs: Floats | None  # None

class _BakeLimits(TypedDict, total=False):
    """A bake's size: a render takes neither of these."""

    triangle_budget: int  # 1_000_000
    max_triangles: int  # 20_000_000

class _BakeSettings(_TextureSettings, _BakeLimits, total=False):
    """A bake's settings (`bake_texture`, `estimate_bake`, `TexturedShell`)."""

class _HandleBakeSettings(_MappedSettings, _BakeLimits, total=False):
    """`Shell.textured`'s settings: a bake's, the UVs being the `Mesh`'s."""

class _FrameSettings(TypedDict, total=False):
    """How `render_shell` and `TexturedShell.render` draw a frame."""

    method: str  # "auto"
    slices: int  # 16
    light: tuple[float, float, float]  # (0.3, -0.5, 0.8)
    ambient: float  # 0.25
    step: float  # 0.05
    mipmaps: str  # "double"

class _RenderSettings(_TextureSettings, _FrameSettings, total=False):
    """`render_shell`'s settings: the textured shell's and the frame's."""

def bake_texture(
    vertices: Floats,
    face_sizes: Indices,
    corners: Indices,
    base_offset: Floats,
    directors: Floats,
    textures: PlacedTextures,
    *,
    progress: Progress = None,
    **settings: Unpack[_BakeSettings],
) -> dict[str, Any]: ...
def estimate_bake(
    vertices: Floats, face_sizes: Indices, corners: Indices, base_offset: Floats, directors: Floats, textures: PlacedTextures, **settings: Unpack[_BakeSettings]
) -> int: ...
def fit_bake_tiles(
    vertices: Floats,
    face_sizes: Indices,
    corners: Indices,
    base_offset: Floats,
    directors: Floats,
    textures: PlacedTextures,
    *,
    tile_size: float | None = None,
    progress: Progress = None,
    **settings: Unpack[_BakeSettings],
) -> dict[str, Any]: ...

class TexturedShell:
    """A textured shell read and checked once; baked, estimated and rendered many times."""

    def __init__(
        self,
        vertices: Floats,
        face_sizes: Indices,
        corners: Indices,
        base_offset: Floats,
        directors: Floats,
        textures: PlacedTextures,
        **settings: Unpack[_BakeSettings],
    ) -> None: ...
    def bake(self, progress: Progress = None) -> dict[str, Any]: ...
    def estimate(self) -> int: ...
    def fit_budget(self, progress: Progress = None) -> dict[str, Any]: ...
    def render(
        self, view: Floats, projection: Floats, width: int, height: int, *, progress: Progress = None, **settings: Unpack[_FrameSettings]
    ) -> dict[str, Any]: ...
    @property
    def vertex_count(self) -> int: ...

class Mesh:
    """A polygon mesh read and checked once (handles: passed on without numpy)."""

    def __init__(self, vertices: Floats, face_sizes: Indices, corners: Indices, uvs: Floats | None = None) -> None: ...
    @property
    def vertex_count(self) -> int: ...
    @property
    def face_count(self) -> int: ...
    def arrays(self) -> dict[str, Any]: ...
    def vertex_normals(self) -> Floats: ...
    def world_size_uvs(self, tile_size: float) -> dict[str, Any]: ...
    def with_world_size_uvs(self, tile_size: float) -> Mesh: ...
    @property
    def uvs(self) -> Floats | None: ...
    def shell(
        self, thickness: float, side: str = "exterior", relative: bool = False, factors: Floats | None = None, p: float = 3.0, progress: Progress = None
    ) -> Shell: ...

class Shell:
    """A shell of a `Mesh` kept in Rust: its surfaces on demand, textured without re-reading."""

    def __init__(self, mesh: Mesh, base_offset: Floats, directors: Floats) -> None: ...
    @property
    def mesh(self) -> Mesh: ...
    def geometry(self, output: str = "outer", surfaces: int = 1) -> dict[str, Any]: ...
    def textured(self, textures: PlacedTextures, **settings: Unpack[_HandleBakeSettings]) -> TexturedShell: ...

class Texture:
    """A volumetric texture kept in Rust: stands for its alpha array wherever textures are taken."""

    def __init__(self, alpha: Floats) -> None: ...
    @staticmethod
    def pattern(pattern: str, size: tuple[int, int, int] = (64, 64, 32), seed: int = 0, time: float = 1.0, thickness: float = 1.0) -> Texture: ...
    @staticmethod
    def load(path: str) -> Texture: ...
    @staticmethod
    def from_field(tree_json: str, resolution: tuple[int, int, int] = (64, 64, 32)) -> Texture: ...
    @property
    def size(self) -> tuple[int, int, int]: ...
    def array(self) -> Floats: ...

def load_texture(path: str) -> Floats: ...
def save_texture(path: str, alpha: Floats | Texture) -> list[str]: ...
def render_shell(
    vertices: Floats,
    face_sizes: Indices,
    corners: Indices,
    base_offset: Floats,
    directors: Floats,
    textures: PlacedTextures,
    view: Floats,
    projection: Floats,
    width: int,
    height: int,
    *,
    progress: Progress = None,
    **settings: Unpack[_RenderSettings],
) -> dict[str, Any]: ...
def save_render(path: str, rgba: Floats, depth: Floats | None = None, normal: Floats | None = None) -> None: ...

# Implicit field trees (issue 17): `tree_json` is a tree's JSON (schema: rust/core/src/implicit/mod.rs).
#: A box: its lowest and highest corner.
Bounds = tuple[tuple[float, float, float], tuple[float, float, float]] | Sequence[Sequence[float]]

def field_eval(tree_json: str, points: Floats) -> dict[str, Any]: ...
def field_mesh(
    tree_json: str, bounds: Bounds | None = None, resolution: int = 128, adaptive: bool = True, progress: Progress = None, max_bytes: float | None = None
) -> dict[str, Any]:
    """The tree's zero set, closed and manifold: adaptive=True quads by manifold dual contouring (sharp creases and corners), adaptive=False triangles by marching prisms on the grid.
    Refused (InvalidInput) where its estimate passes max_bytes (None: 4 GB), stopped where it would pass it while meshing; progress as for the shell.
    Returns vertices, face_sizes, corners, normals, colors, texture, primitive_id, cells and bounds (the box meshed: the given one or the tree's own grown by two cells)."""

def field_mesh_estimate(
    tree_json: str, bounds: Bounds | None = None, resolution: int = 128, adaptive: bool = True, max_bytes: float | None = None
) -> dict[str, Any]:
    """field_mesh's vertices, faces, triangles and peak_bytes, estimated in milliseconds without meshing, with the limit used (max_bytes: the given one or 4 GB), whether it fits, the finest resolution within it and the coarse lattice's cells."""

#: A 4x4 matrix as rows (a mathutils.Matrix, nested sequences or a numpy array).
Matrix4 = Sequence[Sequence[float]] | NDArray[np.floating[Any]]

def field_render(tree_json: str, view: Matrix4, projection: Matrix4, width: int = 512, height: int = 512, device: str = "cpu") -> NDArray[np.float32]: ...

# Catmull-Clark subdivision (issue 18).
def subdivide(
    vertices: Floats,
    face_sizes: Indices,
    corners: Indices,
    levels: int = 1,
    limit: bool = False,
    uvs: Floats | None = None,
    *,
    material_index: Indices | None = None,
    boundary_smooth: str = "ALL",
    uv_smooth: str = "PRESERVE_BOUNDARIES",
) -> dict[str, Any]:
    """Blender's Subdivision Surface (levels 1-6, limit = Use Limit Surface, boundary_smooth "ALL" or "PRESERVE_CORNERS",
    uv_smooth "PRESERVE_BOUNDARIES" or "NONE"); non-manifold input refused.
    Returns vertices, face_sizes, corners (all quads), source_face; when material_index (one per base face) is given, material_index
    per face; when uvs (float32 (corners, 2)) is given, uvs per corner of the result."""

def procedural_detail(
    vertices: Floats,
    face_sizes: Indices,
    corners: Indices,
    model: str,
    levels: int,
    seed: int = 0,
    params: dict[str, Any] | None = None,
    *,
    at: list[int] | None = None,
    blend: dict[str, Any] | None = None,
    local: list[dict[str, Any]] | None = None,
    shader: dict[str, Any] | None = None,
    sculpt: dict[str, Any] | None = None,
    uvs: Floats | list[Floats] | None = None,
    uv_smooth: str = "PRESERVE_BOUNDARIES",
    time: float = 0.0,
) -> dict[str, Any]:
    """Procedural detail on Catmull-Clark levels (Velho et al. section 4): model "rock" (params amplitude) or "berry" (radius, seeds, children), lengths as fractions of the bounding-box diagonal.
    Operations (sections 5-6): `at` the levels the model acts at; `blend` a second model (model, params, seed, at, plane=(point, direction) or weights, width) blended level by level;
    `local` modifications (center, radius in base edges, gain, levels); `shader` {"name": "planet", "sea", "snow", "sea_rate", "snow_rate"} for colours.
    `time` (section 3) moves the models (params spin: tentacle radians per unit time; grow: time to full size, all but berry), the blend (sweep per unit time) and the shader (rates).
    `sculpt`: a dict from analyze() of this base (its details are added at their levels, in local frames, before each level's procedural detail).
    `uvs` (one float32 (corners, 2) map or a list of them) go through the levels by `uv_smooth` as subdivide's without the limit.
    Returns the finest level's vertices, face_sizes, corners (all quads), source_face, scalar (float32 per vertex: the detail added), blend (float32 per vertex),
    limited (float: the share of placed rock/berry detail the fold guard reduced so the surface cannot fold), shrunk
    (float: the share of it reduced by over a tenth), with a shader, colors ((n, 4) float32) and,
    with uvs, uvs per corner of the result (a list when a list was given)."""

def subdivision_estimate(face_sizes: Indices, levels: int) -> dict[str, int]:
    """What `levels` (1 or more) Catmull-Clark levels of a mesh with these face sizes make: faces (all quads) and bytes, the peak memory subdivide and procedural_detail hold (their 4 GB check)."""

def analyze(
    vertices: Floats,
    face_sizes: Indices,
    corners: Indices,
    fine_vertices: Floats,
    levels: int,
    fine_face_sizes: Indices | None = None,
    fine_corners: Indices | None = None,
    progress: Progress = None,
) -> dict[str, Any]:
    """Multiresolution analysis (Velho et al. section 2): fine_vertices are `levels` Catmull-Clark subdivisions of the base faces in procedural_detail's numbering.
    With fine_corners (and fine_face_sizes, all 4 when left out) the fine mesh's faces are checked against that numbering: InvalidInput when they differ.
    OverLimit when the analysis would need more memory than allowed (about 900 bytes per fine face).
    Returns the coarse mesh (vertices, face_sizes, corners) and details: a list of float64 (n_l, 3) arrays, offsets in the local frames (tangent, bitangent, normal) of each subdivided coarser level.
    progress: called with the share done about ten times a second; returning False (or raising) cancels with Cancelled."""

def match_subdivision(
    vertices: Floats, face_sizes: Indices, corners: Indices, levels: int, subdivided_vertices: Floats, tolerance: float = 1e-4
) -> NDArray[np.int32]:
    """Blender's numbering of `levels` subdivisions (Subdivision Surface with Use Limit Surface, or a Multires modifier's evaluated mesh): order (int32),
    Thicket's vertex i is Blender's order[i], matched by nearest limit position within tolerance times the bounding-box diagonal; refused unless one to one."""

def synthesize_multires(vertices: Floats, face_sizes: Indices, corners: Indices, details: list[Floats]) -> dict[str, Any]:
    """Multiresolution synthesis: subdivide once per level of details, adding each level's offsets in its local frames. Returns vertices, face_sizes, corners."""
