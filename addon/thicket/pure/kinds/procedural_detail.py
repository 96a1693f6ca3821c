"""The Procedural Detail kind (Velho, Perlin, Ying and Biermann, sections 2 and 4;
issue 18): the current mesh subdivided by Catmull-Clark levels with a procedural
model's detail added at each, by `thicket_native.procedural_detail`. It comes before
the shells in a stack: its vertices keep a source vertex each (the base vertex whose
quarter of a base face they lie in), so the vertex groups of later items still apply.
With Use Sculpt the current mesh is an artist's analysed Multires sculpt's coarse mesh
and its details go in at their levels under the model's (section 2): the analysis runs
here, in the evaluation (`procedural_detail_sculpt`), read from Blender by
`thicket.sculpt`."""

import numpy as np

from .. import native
from .. import settings as S
from ..arrays import SELECTED_VERTICES, MeshArrays
from ..field_tree import COLOR_ATTRIBUTE
from ..state import NeedsConfirmation, State, group_weights
from .procedural_detail_sculpt import Sculpt

#: The per-vertex detail the levels added along their normals (signed), for shading.
DETAIL_ATTRIBUTE = "thicket_detail"
#: The blend parameter (0: the first model, 1: the second), for shading.
BLEND_ATTRIBUTE = "thicket_blend"

#: Each model's settings, by their `thicket_native.procedural_detail` names.
MODEL_SETTINGS = {
    "rock": ("amplitude",),
    "berry": ("radius", "children"),
    "tentacle": ("length", "theta", "spacing"),
    "spur": ("length", "spacing"),
    "mushroom": ("radius", "length"),
    "fuse": ("amplitude", "span", "axis"),
}
#: The settings that are lengths (a blend's gain scales them).
LENGTHS = ("amplitude", "radius", "length")
#: Models whose seeds may be chosen (a vertex group or the selection).
SEEDED = ("berry", "tentacle", "spur", "mushroom")
SEED_SOURCES = ("random", "group", "selected")

#: Starting points for the Add Procedural Detail menu and `thicket.api`, as stack item
#: property values (the paper's figures 3 and 4).
PRESETS = {
    "ROCK": dict(detail_model="ROCK", levels=4, detail_amplitude=0.03),
    "BERRY": dict(detail_model="BERRY", levels=4, detail_radius=0.12, detail_children=3),
    # Two rocky sub-planets blended across a plane, coloured by the planet shader (6.2).
    "TENTACLE": dict(detail_model="TENTACLE", levels=4, detail_length=0.012, detail_theta=0.0, detail_spacing=0.25),
    "MUSHROOM": dict(detail_model="MUSHROOM", levels=4, detail_radius=0.1, detail_length=0.04),
    "PLANET": dict(
        detail_model="ROCK",
        levels=4,
        detail_amplitude=0.03,
        blend_model="ROCK",
        blend_seed=2,
        blend_gain=1.6,
        blend_width=0.3,
        detail_shader="PLANET",
        shader_snow=0.03,
    ),
}

#: `thicket.api.add_procedural_detail` keywords and the stack item properties they set.
API_NAMES = {
    "model": "detail_model",
    "amplitude": "detail_amplitude",
    "radius": "detail_radius",
    "children": "detail_children",
    "seeds": "detail_seeds",
    "at": "detail_at",
    "shader": "detail_shader",
    "sea": "shader_sea",
    "length": "detail_length",
    "theta": "detail_theta",
    "spacing": "detail_spacing",
    "span": "fuse_span",
    "axis": "fuse_axis",
    "snow": "shader_snow",
    "spin": "detail_spin",
    "grow": "detail_grow",
    "sweep": "blend_sweep",
    "sea_rate": "shader_sea_rate",
    "snow_rate": "shader_snow_rate",
}
#: Those given as names, which the item stores as Blender enum identifiers (upper case).
API_ENUMS = ("model", "seeds", "blend_model", "blend_alpha", "shader")
#: Those given as lists of levels, which the item stores as one flag per level 1 to 6.
API_LEVELS = ("at", "local_at")


def api_values(settings: dict) -> dict:
    """`thicket.api.add_procedural_detail`'s keywords as stack item property values."""
    out = {}
    for key, value in settings.items():
        if key in API_ENUMS:
            value = str(value).upper()
        elif key in API_LEVELS and not (len(value) == 6 and all(isinstance(v, bool) for v in value)):
            value = tuple(level in set(value) for level in range(1, 7))
        out[API_NAMES.get(key, key)] = value
    return out


#: The share of visibly shrunk detail (`procedural_detail`'s `shrunk`: vertices whose
#: detail the fold guard cut by more than a tenth) above which the user is told the
#: model's size was reduced. Not `limited`, every vertex the guard touched at all: a dome
#: kept at 95% of its height looks as asked, and a note about it would only send the user
#: after a setting that changes nothing one sees.
SHRUNK_NOTE = 0.01


def seed_vertices(state: State, item: S.ProceduralDetail):
    """The model's seeds, as vertex indices of the current mesh: None for Poisson-disk
    seeds; else the vertices of the item's group (weight at least one half) or of the
    source's selection."""
    if item.model not in SEEDED or item.seeds == "random":
        return None
    group = SELECTED_VERTICES if item.seeds == "selected" else item.vertex_group
    if not group:
        raise native.get().InvalidInput(f"'{item.label}': seeds from a vertex group need the group's name")
    chosen = group_weights(state.source, group, state.origin) >= 0.5
    # One current vertex per source vertex: after an earlier Procedural Detail its
    # vertices share their base vertex's weight blockwise (the base vertex, which keeps
    # its index, comes first).
    _, first = np.unique(state.origin, return_index=True)
    seeds = np.sort(first[chosen[first]])
    if seeds.size == 0:
        where = "no vertex is selected" if group == SELECTED_VERTICES else f"vertex group '{group}' has no vertex of weight 0.5 or more"
        raise native.get().InvalidInput(f"'{item.label}': {where}, so the {item.model} has no seeds")
    return seeds


def model_params(item: S.ProceduralDetail, model: str, gain: float = 1.0) -> dict:
    """`model`'s settings from the item, its lengths times `gain`, and how time moves it
    (a tentacle's `spin`, every model's but the berry's `grow`)."""
    out = {name: getattr(item, name) * gain if name in LENGTHS else getattr(item, name) for name in MODEL_SETTINGS[model]}
    if model == "tentacle":
        out["spin"] = float(item.spin)
    if model != "berry":
        out["grow"] = float(item.grow)
    if "axis" in out:
        out["axis"] = tuple(map(float, out["axis"]))
    return out


def params(state: State, item: S.ProceduralDetail) -> dict:
    """The model's `params` for `thicket_native.procedural_detail`."""
    if item.model not in MODEL_SETTINGS:
        raise native.get().InvalidInput(f"'{item.label}': model must be one of {', '.join(MODEL_SETTINGS)}, not {item.model!r}")
    if item.seeds not in SEED_SOURCES:
        raise native.get().InvalidInput(f"'{item.label}': seeds must be one of {', '.join(SEED_SOURCES)}, not {item.seeds!r}")
    out = model_params(item, item.model)
    seeds = seed_vertices(state, item)
    if seeds is not None:
        out["seeds"] = seeds.tolist()
    return out


#: The blend's alpha sources and the shaders the item takes.
BLEND_ALPHAS = ("plane", "group")
SHADERS = ("", "planet")


def _invalid(item, message):
    return native.get().InvalidInput(f"'{item.label}': {message}")


def _levels(item, at, what):
    """A level set as `thicket_native.procedural_detail` takes it (None: all); none at
    all is refused, naming the setting."""
    if at is None:
        return None
    if not at:
        raise _invalid(item, f"{what}: tick at least one level")
    return [int(level) for level in at]


def blend(state: State, item: S.ProceduralDetail):
    """The `blend` argument: the second model, with the item's settings times
    `blend_gain`, and its alpha (None without a blend)."""
    if not item.blend_model:
        return None
    if item.blend_model not in MODEL_SETTINGS:
        raise _invalid(item, f"the blend model must be one of {', '.join(MODEL_SETTINGS)}, not {item.blend_model!r}")
    if item.blend_alpha not in BLEND_ALPHAS:
        raise _invalid(item, f"the blend alpha must be one of {', '.join(BLEND_ALPHAS)}, not {item.blend_alpha!r}")
    partner = model_params(item, item.blend_model, float(item.blend_gain))
    out = dict(model=item.blend_model, params=partner, seed=int(item.blend_seed), width=float(item.blend_width), sweep=float(item.blend_sweep))
    if item.blend_alpha == "plane":
        out["plane"] = (tuple(map(float, item.blend_point)), tuple(map(float, item.blend_direction)))
    elif not item.blend_group:
        raise _invalid(item, "a blend by vertex group needs the group's name")
    else:
        out["weights"] = group_weights(state.source, item.blend_group, state.origin)
    return out


def local(mesh: MeshArrays, item: S.ProceduralDetail):
    """The `local` argument: one modification centred on the vertex nearest
    `local_center` (None without one)."""
    if item.local_center is None:
        return None
    center = np.asarray(item.local_center, dtype=np.float64)
    if center.shape != (3,) or not np.isfinite(center).all():
        raise _invalid(item, f"the local modification's center must be a finite point, not {item.local_center!r}")
    if mesh.vertex_count == 0:
        return None
    nearest = int(np.argmin(np.einsum("ij,ij->i", mesh.vertices - center, mesh.vertices - center)))
    return [dict(center=nearest, radius=float(item.local_radius), gain=float(item.local_gain), levels=_levels(item, item.local_at, "Local At Levels"))]


def shader(item: S.ProceduralDetail):
    if item.shader not in SHADERS:
        raise _invalid(item, f"shader must be one of {', '.join(s for s in SHADERS if s)} or none, not {item.shader!r}")
    if not item.shader:
        return None
    return dict(name=item.shader, sea=float(item.sea), snow=float(item.snow), sea_rate=float(item.sea_rate), snow_rate=float(item.snow_rate))


def provenance(mesh: MeshArrays, out, levels: int) -> np.ndarray:
    """The current mesh's vertex each detailed vertex stands for: its own (the base
    vertices keep their indices through the levels), else the vertex of the base
    corner whose quarter of a face it lies in. Each finest face `f` of `levels` lies in
    base corner `f >> 2 (levels - 1)`: `subdivide` makes corner `c` into child quad
    `c`, so quad `q`'s corners make quads `4 q` to `4 q + 3`."""
    corners = np.asarray(out["corners"], dtype=np.int64)
    faces = len(out["face_sizes"])
    base_corner = np.arange(faces, dtype=np.int64) >> (2 * (levels - 1))
    origin = np.empty(len(out["vertices"]), dtype=np.int64)
    origin[corners] = np.repeat(np.asarray(mesh.corners, dtype=np.int64)[base_corner], 4)
    origin[: mesh.vertex_count] = np.arange(mesh.vertex_count)
    return origin


#: The share of the item's progress its sculpt's analysis takes when it runs (1.4 s of
#: 1.65 s timed on a 126k-vertex sculpt at zero amplitude; README, Use Sculpt).
ANALYSIS_SHARE = 0.8


def analysed_sculpt(state: State, sculpt, progress=None):
    """The item's `sculpt` as `procedural_detail` takes it: a dict as given, or a
    `Sculpt` read from Blender analysed now (or from its cache; `progress` as
    `evaluate_stack`'s, False cancels), the current mesh then becoming its fitted
    coarse mesh (the item is first in its stack, so the current mesh is the source)."""
    if not isinstance(sculpt, Sculpt):
        return sculpt
    analysis = sculpt.analysis(progress)
    coarse = sculpt.coarse(analysis)
    if state.source is state.current:
        state.source = coarse
    state.current = coarse
    return analysis


def procedural_detail(state: State, item: S.ProceduralDetail, ask=False, progress=None) -> tuple:
    """The detailed mesh (material indices carried by face, every UV map through the
    levels, the detail as a point attribute) and each vertex's provenance in the current mesh. `ask`: raise
    NeedsConfirmation first when the finest level is estimated over `confirm_above`
    triangles. `progress`: the sculpt's analysis (`analysed_sculpt`), when it runs."""
    settings = params(state, item)
    sculpt = item.sculpt if item.use_sculpt else None
    depth = None if sculpt is None else int(sculpt.levels if isinstance(sculpt, Sculpt) else sculpt["levels"])
    if depth is not None and depth > int(item.levels):
        raise _invalid(
            item,
            f"the Multires sculpt has {depth} levels, more than the item's {item.levels}: set Levels to {depth} or more, or turn Use Sculpt off",
        )
    triangles = 2 * native.get().subdivision_estimate(state.current.face_sizes, int(item.levels))["faces"]
    if ask and triangles > item.confirm_above:
        raise NeedsConfirmation(item.label, triangles, item.confirm_above, making="subdivision")
    sculpt = analysed_sculpt(state, sculpt, progress)
    mesh = state.current
    tn = native.get()
    at = _levels(item, item.at, "Detail At Levels")
    if at is not None and min(at) > item.levels:
        state.notes.append(f"'{item.label}': Detail At Levels names no level up to {item.levels}, so the model adds nothing")
    operations = dict(at=at, blend=blend(state, item), local=local(mesh, item), shader=shader(item), time=float(item.time))
    if sculpt is not None:
        # The sculpt's details at their levels, in local frames, under the model's (2).
        operations["sculpt"] = sculpt
    uv_maps = dict(mesh.uv_maps)
    if mesh.uvs is not None and mesh.uv_name not in uv_maps:
        uv_maps[mesh.uv_name] = mesh.uvs
    if uv_maps:
        # Every UV map through the levels as face-varying data (Blender's default UV smooth).
        operations["uvs"] = [np.ascontiguousarray(uv, dtype=np.float32) for uv in uv_maps.values()]
    out = tn.procedural_detail(mesh.vertices, mesh.face_sizes, mesh.corners, item.model, int(item.levels), int(item.seed), settings, **operations)
    result = MeshArrays.from_native(out)
    if "colors" in out:
        result.attributes = {COLOR_ATTRIBUTE: ("POINT", "FLOAT_COLOR", out["colors"])}
        result.active_color = COLOR_ATTRIBUTE
    if mesh.material_index is not None:
        result.material_index = mesh.material_index[out["source_face"]]
    result.point_attributes = {DETAIL_ATTRIBUTE: np.asarray(out["scalar"], dtype=np.float32)}
    shrunk = float(out.get("shrunk", 0.0))  # an older thicket_native has no such count
    if shrunk > SHRUNK_NOTE:
        result.notes.append(
            f"'{item.label}': the {item.model} detail was made visibly smaller (by over a tenth) at {shrunk:.0%} of its vertices so"
            " the surface does not fold (rock: at most a quarter of the local edge and half the radius of curvature; berry domes: flattened under the"
            " curvature, clear of other parts and lowered where a face would overhang; tentacles and spurs: shortened likewise); a"
            " smaller amplitude, radius or length, or a coarser base, keeps it as set"
        )
    if item.blend_model:
        result.point_attributes[BLEND_ATTRIBUTE] = np.asarray(out["blend"], dtype=np.float32)
    if uv_maps:
        result.uv_maps = dict(zip(uv_maps, out["uvs"]))
        result.uvs = result.uv_maps.get(mesh.uv_name)
        result.uv_name = mesh.uv_name
    return result, provenance(mesh, out, int(item.levels))


def procedural_detail_step(state: State, item: S.ProceduralDetail, ask, progress):
    if progress is not None and progress(0.0) is False:
        raise native.get().Cancelled("cancelled")
    analysis = None if progress is None else (lambda f: progress(ANALYSIS_SHARE * f))
    result, origin = procedural_detail(state, item, ask, analysis)
    state.notes.extend(item.sculpt_notes if item.use_sculpt else ())
    state.notes.extend(result.notes)
    result.notes = []
    state.current, state.origin = result, state.origin[origin]
