"""Thicket's Python API for scripts (headless batch processing and the UI alike).

    import thicket.api as th            # or: from bl_ext.user_default.thicket import api
    result = th.add_thick_surface(obj, thickness=0.05, output="SOLID")
    th.regenerate(obj)                   # after editing obj or its stack in a script
    mesh_obj = th.apply(obj)             # result becomes an ordinary mesh
    th.remove(obj)                       # stack and result deleted
    th.process_file("in.blend", out_blend="out.blend", out_glb="out.glb", thickness=0.02)
    th.add_volumetric_texture(obj, pattern="chain_mail", tiling=4)   # shell + baked texture
    th.bake_frames(obj, 1, 48, "//frames")    # animated textures: one .glb per frame
    th.export_texture(obj, "//chain_mail.exr")  # the texture as an OpenEXR volume
    th.render_preview(obj, "//preview.exr")     # render the thick surface without baking
    field = th.build_field_mesh(tree_json, resolution=128)   # an implicit field tree's mesh
    th.regenerate_field_mesh(field)             # after editing its stored tree or Text
    th.add_solid_texture(obj, tree_json, mode="COLOR")        # the tree's colours on a mesh
    th.render_field(tree_json, camera=cam)      # the tree sphere-traced into an image
    th.add_procedural_detail(obj, model="ROCK", levels=4)   # subdivision levels with detail

Every function raises `ThicketError` (from thicket_native, a ValueError) for bad
geometry or settings, `TypeError` for non-mesh objects and `KeyError` for missing
vertex groups; the source mesh is never modified by any of them except `apply`,
which only removes its stack.

Progress and cancel: the functions that build shells, bake or render take
`progress`, a callable given the share done as a float in [0, 1] that never
decreases (at once, about ten times a second during shells and bakes, and 1.0 at the
end). Returning False cancels: the work stops at its next check and
`thicket_native.Cancelled` (a `ThicketError`) is raised, or the exception the
callback raised; Ctrl-C cancels too. A cancelled call leaves the source and the
previous result as they were. The callback runs on the calling thread:

    th.regenerate(obj, progress=lambda f: print(f"{f:.0%}"))
    th.regenerate(obj, progress=lambda f: f < 0.5)   # stops halfway: Cancelled
"""

import os

import bpy

from .pure import live_shells, native
from .pure import settings as S
from .pure.kinds.volumetric_texture import BakeNeedsConfirmation  # noqa: F401 (raised by regenerate(ask=True))
from .stack.regenerate import regenerate as _regenerate

__all__ = [
    "crossing_faces",
    "add_thick_surface",
    "add_volumetric_texture",
    "bake_frames",
    "export_texture",
    "render_preview",
    "render_frames",
    "regenerate",
    "fit_bake_tiles",
    "apply",
    "remove",
    "process_file",
    "export_glb",
    "result_of",
    "build_field_mesh",
    "regenerate_field_mesh",
    "estimate_field_mesh",
    "add_solid_texture",
    "render_field",
    "add_procedural_detail",
    "analyze_multires",
    "ThicketError",  # noqa: F822 (module __getattr__)
    "BakeNeedsConfirmation",
]


def __getattr__(name):
    if name == "ThicketError":
        return native.get().ThicketError
    raise AttributeError(name)


def _require_mesh(obj):
    if obj is None or obj.type != "MESH":
        kind = "nothing" if obj is None else f"a {obj.type.lower()}"
        raise TypeError(f"Thicket works on mesh objects; '{getattr(obj, 'name', obj)}' is {kind}")
    if obj.thicket.source is not None:
        raise TypeError(f"'{obj.name}' is a Thicket result; add thick surfaces to its source '{obj.thicket.source.name}'")


def crossing_faces(obj):
    """Indices (int32 array) of the faces of `obj`'s mesh that cross another part of
    the same mesh: a shell inherits those crossings (it cannot remove them)."""
    if obj is None or obj.type != "MESH":
        raise TypeError(f"'{getattr(obj, 'name', obj)}' is not a mesh object")
    if obj.mode == "EDIT":
        obj.update_from_editmode()
    from . import mesh_io

    arrays = mesh_io.read_mesh(obj.data)
    if arrays.face_count == 0:
        return arrays.face_sizes[:0]
    return native.get().self_intersections(arrays.vertices, arrays.face_sizes, arrays.corners)["faces"]


def add_item(obj, kind="OFFSET_SHELL", **settings):
    """Appends a stack item of `kind` with the given settings (names of `ThicketItem`;
    a former name, e.g. `layers` or `texture_layers`, works with a DeprecationWarning
    for one release). A name that is no `ThicketItem` property raises TypeError and
    adds nothing."""
    _require_mesh(obj)
    cls = S.KINDS[kind]
    from .stack.guard import suspended
    from .stack.versioning import current_names

    settings = current_names(settings)
    _refuse_unknown(settings)
    with suspended():
        item = obj.thicket.items.add()
        try:
            item.kind = kind
            item.name = cls.label
            for key, value in settings.items():
                setattr(item, key, value)
        except (TypeError, ValueError, AttributeError):
            obj.thicket.items.remove(len(obj.thicket.items) - 1)  # no half-set item left behind
            raise
        obj.thicket.active_index = len(obj.thicket.items) - 1
    return item


def _refuse_unknown(settings):
    """A TypeError naming each setting that is not a property of a stack item (a typo
    would otherwise land as a plain Python attribute on the item and change nothing)."""
    import difflib

    from .stack.properties import ThicketItem

    known = {p.identifier for p in ThicketItem.bl_rna.properties if p.identifier != "rna_type"}
    unknown = sorted(set(settings) - known)
    if unknown:
        hints = []
        for name in unknown:
            close = difflib.get_close_matches(name, sorted(known), n=1)
            hints.append(f"'{name}'" + (f" (did you mean '{close[0]}'?)" if close else ""))
        raise TypeError(f"not a stack item setting: {', '.join(hints)}")


def add_thick_surface(
    obj,
    thickness=S.OffsetShell.thickness,
    thickness_mode="RELATIVE",
    output="OUTER",
    surfaces=None,
    vertex_group="",
    kind="OFFSET_SHELL",
    side="EXTERIOR",
    progress=None,
    **former,
):
    """Gives `obj` a stack with one item of `kind` ("OFFSET_SHELL", or "SHELL" with a
    `side`) if it has none yet, and generates its result object, which is returned.
    `surfaces`: how many surfaces output "LAYERS" (Stacked Surfaces) makes (default
    `OffsetShell.surfaces`; formerly `layers`, still taken in `former` with a
    DeprecationWarning for one release, a TypeError together with `surfaces`).
    `progress`: see the module docs (a cancel keeps the new stack, without result)."""
    from .stack.versioning import current_names

    unexpected = [k for k in former if k != "layers"]
    if unexpected:
        raise TypeError(f"add_thick_surface() got an unexpected keyword argument '{unexpected[0]}'")
    if former and surfaces is not None:
        raise TypeError("add_thick_surface() got 'surfaces' and its former name 'layers': pass 'surfaces' only")
    surfaces = current_names(former).get("surfaces", S.OffsetShell.surfaces if surfaces is None else surfaces)
    _require_mesh(obj)
    if not obj.thicket.items:
        extra = {"side": side} if kind == "SHELL" else {}
        add_item(obj, kind, thickness=thickness, thickness_mode=thickness_mode, output=output, surfaces=surfaces, vertex_group=vertex_group, **extra)
    return _regenerate(obj, progress=progress)


def add_volumetric_texture(obj, pattern="chain_mail", shell_thickness=0.05, side="EXTERIOR", progress=None, field_tree_json=None, **texture_settings):
    """Adds a Volumetric Texture item (names of `ThicketItem`: tiling, resolution,
    depth_steps, vertex_group, combine, offset, time, follow_frame...) to `obj`'s
    stack, after a Shell item of `shell_thickness` (relative) that is added first when
    the stack has no shell yet; regenerates and returns the result object.
    Without a UV map, `no_uv_tiles="WORLD"` generates world-size coordinates, one
    tile every `tile_size` units of the object's own (unscaled) coordinates,
    like the shell's thickness (0: 1/32 of the bounding-box diagonal);
    "FACE" (the default) makes each face one tile.
    `field_tree_json`: the texture from a field tree instead of `pattern` (README,
    Volumetric Texture from a field tree): JSON text, a dict, a Blender Text holding
    the JSON or a Thicket field node tree, authored in the unit texture cell (x, y, z
    = s, t, depth from the base), sampled at `texture_size` texels (half across the
    shell). A bad tree raises a ThicketError before the stack is touched.
    `progress`: see the module docs (a cancel keeps the new items, and the previous
    result)."""
    from .stack.versioning import current_names

    texture_settings = current_names(texture_settings)  # warns at the caller's line
    _require_mesh(obj)
    if field_tree_json is not None:
        texture_settings.update(_field_texture_source(field_tree_json))
    if not any(i.kind in ("SHELL", "OFFSET_SHELL") for i in obj.thicket.items):
        add_item(obj, "SHELL", thickness=shell_thickness, side=side)
    add_item(obj, "VOLUMETRIC_TEXTURE", pattern=pattern, **texture_settings)
    return _regenerate(obj, progress=progress)


def _field_texture_source(tree):
    """The Volumetric Texture item settings that make `tree` its source, the tree checked first."""
    from .pure.field_nodes import TREE_IDNAME
    from .pure.field_tree import check_tree

    if isinstance(tree, bpy.types.NodeTree) and tree.bl_idname == TREE_IDNAME:
        from .nodes.graph import tree_json

        check_tree(tree_json(tree))
        return {"source": "FIELD_NODES", "field_nodes": tree}
    if isinstance(tree, bpy.types.Text):
        check_tree(tree.as_string())
        return {"source": "FIELD_JSON", "tree_text": tree}
    return {"source": "FIELD_JSON", "tree": check_tree(tree)}


def build_field_mesh(tree_json, name="Field Mesh", resolution=128, bounds=None, adaptive=True, collection=None, progress=None, max_bytes=None):
    """A new mesh object of an implicit field tree's zero set (issue 17; the tree's
    JSON schema is in the README's Implicit shapes), returned. `tree_json`: JSON text,
    a dict, or a Blender Text holding the JSON (kept on the object: regenerating reads
    its current content). `resolution`: cells along the longest side of `bounds`
    ((min x, y, z), (max x, y, z); default the tree's own bound), 2 to 2048.
    `adaptive`: manifold dual contouring on the cells the tree's bounds cannot rule
    out (quads, creases and corners kept sharp); False: marching prisms on the whole grid
    (triangles). `collection`: where the
    object is linked (default the active collection).

    The mesh carries the tree's colour per vertex as the colour attribute
    `thicket_color` (FLOAT_COLOR, active and rendered; the object gets a material
    reading it), the texture value as `thicket_texture` and the primitive id as
    `thicket_primitive_id`. The tree and settings are stored on the object (saved in
    the .blend) for `regenerate_field_mesh`. Bad JSON, p <= 0, NaN and the like, or a
    resolution out of range raise a ThicketError before anything is made, and so
    does a resolution whose estimate (`estimate_field_mesh`) passes `max_bytes`
    (default 4 GB): an OverLimit (an InvalidInput) naming the estimate and the limit.
    `progress`: see the module docs (a cancel makes nothing)."""
    from .fields import build_field_mesh as build

    source_text = tree_json if isinstance(tree_json, bpy.types.Text) else None
    tree = source_text.as_string() if source_text is not None else tree_json
    return build(tree, name, resolution, bounds, adaptive, collection, progress, source_text, max_bytes)


def estimate_field_mesh(tree_json, resolution=128, bounds=None, adaptive=True, max_bytes=None):
    """The core's estimate of `build_field_mesh` with these settings, without
    building (tens of milliseconds; cached): a dict with `triangles`, `vertices`,
    `faces`, `peak_bytes`, `max_bytes`, `fits` (the build would run) and
    `resolution_within` (the finest resolution that fits)."""
    from .pure.field_tree import field_mesh_estimate

    tree = tree_json.as_string() if isinstance(tree_json, bpy.types.Text) else tree_json
    return field_mesh_estimate(tree, resolution, bounds, adaptive, max_bytes)


def regenerate_field_mesh(obj, progress=None, max_bytes=None):
    """Rebuilds a Field Mesh object (`build_field_mesh`) in place from its stored tree
    (its Text's current content when built from one) and settings; returns it. A
    bad tree, a build over `max_bytes` or a cancel (`progress`, see the module docs)
    raises and leaves the mesh as it was."""
    from .fields import regenerate_field_mesh as rebuild

    return rebuild(obj, progress, max_bytes=max_bytes)


def field_nodes_json(node_tree):
    """The field tree JSON of a Thicket field node tree (the node editor's
    `ThicketFieldTree`), handle objects read from their world matrices. A cycle, an
    unlinked input, a missing handle, p <= 0 or a NaN raise a ValueError naming the
    node."""
    from .nodes.graph import tree_json

    return tree_json(node_tree)


def build_field_nodes_mesh(node_tree, name=None, collection=None, progress=None, max_bytes=None):
    """A new Field Mesh object of a Thicket field node tree (its resolution and
    adaptive settings), linked to it: it regenerates when a node, a link or a handle
    object changes (`regenerate_field_nodes` does it at once). Errors raise before
    anything is made; `progress` and `max_bytes` as in `build_field_mesh`."""
    from .nodes.live import build

    return build(node_tree, name=name, collection=collection, progress=progress, max_bytes=max_bytes)


def regenerate_field_nodes(obj, progress=None, max_bytes=None):
    """Rebuilds a Field Mesh linked to a node tree from the tree's current state;
    errors, a build over `max_bytes` and a cancel (`progress`) raise and leave the
    mesh as it was."""
    from .nodes.live import regenerate

    return regenerate(obj, progress=progress, max_bytes=max_bytes)


def render_field(tree_json, camera=None, width=512, height=512, image="Thicket Field"):
    """Renders an implicit field tree (JSON text, a dict, or a Blender Text) with its
    colours and texture functions by the core's sphere tracer
    (`thicket_native.field_render`) into the float image `image` (created, or resized
    and overwritten), which is returned. `camera`: a camera object (its view and
    `calc_matrix_camera` for width x height); None frames the tree's surface from the
    front right, above (a bounded tree only). Bad trees or sizes raise a ThicketError
    before any image is made."""
    from .fields.render import render_field as render

    return render(tree_json, camera, width, height, image)


def add_solid_texture(obj, tree_json, mode="COLOR", domain="POINT", amplitude=0.1, progress=None, **settings):
    """Appends a Solid Texture item to `obj`'s stack and regenerates; returns the
    result object. The field tree (`tree_json`: JSON text, a dict, or a Blender Text,
    read in `obj`'s object space) is evaluated at the current mesh's vertices:
    `mode` "COLOR" writes its colour per vertex (`domain` "POINT") or face corner
    ("CORNER") into the colour attribute `color_attribute` (default `thicket_color`),
    "DISPLACE" moves each vertex along its normal by `amplitude` times the tree's
    texture value; both write the texture value as `thicket_texture`. Other
    `settings`: names of `ThicketItem`. Chains after a Shell or Volumetric Texture
    item; the source mesh is never modified. A bad tree raises a ThicketError before
    the item is added."""
    from .pure.field_tree import check_tree

    _require_mesh(obj)
    if isinstance(tree_json, bpy.types.Text):
        check_tree(tree_json.as_string())
        settings["tree_text"] = tree_json
    else:
        settings["tree"] = check_tree(tree_json)
    if mode not in ("COLOR", "DISPLACE"):
        raise ValueError(f"mode must be 'COLOR' or 'DISPLACE', got {mode!r}")
    if domain not in ("POINT", "CORNER"):
        raise ValueError(f"domain must be 'POINT' or 'CORNER', got {domain!r}")
    add_item(obj, "SOLID_TEXTURE", mode=mode, domain=domain, amplitude=amplitude, **settings)
    return _regenerate(obj, progress=progress)


def add_procedural_detail(obj, model=None, levels=None, preset=None, progress=None, **settings):
    """Adds a Procedural Detail item (Velho, Perlin, Ying and Biermann) to `obj`'s
    stack, before its first shell or texture item (the detail shapes their base), and
    regenerates; returns the result object. `model`: "ROCK", "BERRY", "TENTACLE",
    "SPUR", "MUSHROOM" or "FUSE"; `levels`: 1 to
    6 Catmull-Clark levels (each has four times the faces of the last). `preset`:
    "ROCK", "BERRY", "TENTACLE", "MUSHROOM" or "PLANET", the starting settings (`model`, `levels` and
    `settings` override them). Other `settings`: `seed`; the rock's `amplitude` and
    the berry's and mushroom cloud's `radius`, the tentacle's, spur's and mushroom
    cloud's `length`, the tentacle's `theta` (radians) and the tentacles' and spurs'
    `spacing` (lengths as fractions of the bounding-box diagonal), the fuse's `span` and
    `axis`, the berry's `children`, and `seeds` ("RANDOM", "GROUP" with
    `vertex_group`, or "SELECTED": the source's selected vertices); `at`, the levels the model acts at (a list, e.g. [1, 3]); a
    blend: `blend_model`, `blend_seed`, `blend_gain`, `blend_alpha` ("PLANE" with
    `blend_point` and `blend_direction`, or "GROUP" with `blend_group`),
    `blend_width`; a local modification: `local_object` (its location the center),
    `local_radius` (base edges), `local_gain`, `local_at`; `shader` ("PLANET") with
    `sea` and `snow`; `use_sculpt` (on by default where the item comes first and `obj` has
    a Multires sculpt): start from the sculpt, the model's detail added on top of it at
    its levels (`levels`, when not given, is raised to the sculpt's); or any `ThicketItem` name. Results over 4 GB are refused with a ThicketError before
    anything is made; `regenerate(obj, ask=True)` raises `BakeNeedsConfirmation` over
    `confirm_above` triangles. The source mesh is never modified."""
    from .pure.kinds.procedural_detail import PRESETS, api_values

    _require_mesh(obj)
    if preset is not None and preset.upper() not in PRESETS:
        raise ValueError(f"preset must be one of {', '.join(PRESETS)}, got {preset!r}")
    values = dict(PRESETS[preset.upper()]) if preset is not None else {}
    given = {key: value for key, value in dict(settings, model=model, levels=levels).items() if value is not None}
    values.update(api_values(given))
    if values.get("use_sculpt"):
        from .mesh_io import multires_modifier

        if multires_modifier(obj) is None:
            raise ValueError(f"'{obj.name}' has no Multires modifier whose sculpt the detail could use (use_sculpt)")
    add_detail_item(obj, fit_levels=levels is None, **values)
    return _regenerate(obj, progress=progress)


def analyze_multires(obj):
    """Multiresolution analysis (Velho, Perlin, Ying and Biermann, section 2) of `obj`'s
    Multires sculpt: its evaluated mesh at the modifier's total levels, split into a coarse
    mesh and per-level details in local frames. Returns `thicket_native.analyze`'s dict
    (`vertices`, `face_sizes`, `corners` of the coarse mesh; `details`, a list of float64
    (n_l, 3) arrays) plus `levels` and `order` (int32: Thicket's fine vertex i is the
    Multires mesh's vertex `order[i]`). `thicket_native.synthesize_multires` of it rebuilds
    the sculpt; `thicket_native.procedural_detail(it["vertices"], it["face_sizes"],
    it["corners"], ..., sculpt=it)` adds procedural detail at any level over it (the base
    must be the dict's own fitted coarse mesh, or an edit of it, not `obj.data`). The
    object is not modified; an object in Sculpt Mode is refused."""
    from . import mesh_io
    from .pure.kinds.procedural_detail_sculpt import analyse
    from .stack.guard import suspended

    _require_mesh(obj)
    with suspended():
        base, levels, sculpted, order = mesh_io.read_multires(obj)
    out = analyse(base, levels, sculpted, order, obj.name)
    out["levels"] = levels
    out["order"] = order
    return out


def add_detail_item(obj, fit_levels=True, **values):
    """Adds a Procedural Detail item with `values` (names of `ThicketItem`) before the
    first item of `obj`'s stack that is not one (the detail shapes the shells' base);
    returns it, active, without regenerating.

    `use_sculpt`, when not given, is on where the item comes first and `obj` has a
    Multires sculpt (levels above 0): an artist who sculpted wants detail on the sculpt,
    not Catmull-Clark levels on its already dense mesh; but not where the caller chose
    levels (`fit_levels` False) below the sculpt's. With it on, `fit_levels` raises the
    item's levels to the sculpt's when fewer (a preset's levels are a start)."""
    from .sculpt import has_sculpt

    stack = obj.thicket
    at = next((i for i, item in enumerate(stack.items) if item.kind != S.ProceduralDetail.kind), None)
    first = (len(stack.items) if at is None else at) == 0
    if "use_sculpt" not in values and first and has_sculpt(obj):
        from .mesh_io import multires_modifier

        # Levels the caller chose below the sculpt's keep the item off the sculpt (as
        # before Use Sculpt existed): only an explicit use_sculpt=True refuses them.
        sculpt_levels = multires_modifier(obj).total_levels
        values["use_sculpt"] = fit_levels or int(values.get("levels", S.ProceduralDetail.levels)) >= sculpt_levels
    values.setdefault("use_sculpt", False)
    if values["use_sculpt"] and fit_levels and has_sculpt(obj):
        from .mesh_io import multires_modifier

        values["levels"] = max(int(values.get("levels", S.ProceduralDetail.levels)), multires_modifier(obj).total_levels)
    item = add_item(obj, S.ProceduralDetail.kind, **values)
    if at is not None:
        from .stack.guard import suspended

        with suspended():
            stack.items.move(len(stack.items) - 1, at)
            stack.active_index = at
        item = stack.items[at]
    return item


def bake_frames(obj, frame_start, frame_end, directory, step=1, progress=None):
    """Bakes `obj`'s stack at every frame of the range (animated textures follow the
    frame when their item has `follow_frame`) and writes `<object>_<frame>.glb` files
    into `directory`; returns the paths. The scene's frame is restored afterwards.
    `progress`: over all frames (see the module docs); a cancel keeps the files
    already written."""
    _require_mesh(obj)
    scene = bpy.context.scene
    previous = scene.frame_current
    directory = bpy.path.abspath(directory)
    frames = range(int(frame_start), int(frame_end) + 1, max(1, int(step)))
    paths = []
    try:
        for i, frame in enumerate(frames):
            scene.frame_set(frame)
            result = _regenerate(obj, progress=_part(progress, i, len(frames)))
            paths.append(export_glb([result], os.path.join(directory, f"{obj.name}_{frame:04d}.glb")))
    finally:
        scene.frame_set(previous)
    return paths


def export_texture(obj, path, index=None):
    """Writes the texture of `obj`'s Volumetric Texture item (`index`, or the last one)
    to `path`: an OpenEXR volume when it ends in .exr, else PNG slices in that folder.
    Returns the paths written."""
    from .pure.kinds.volumetric_texture import item_texture

    _require_mesh(obj)
    items = [i for i in obj.thicket.items if i.kind == "VOLUMETRIC_TEXTURE"]
    if not items:
        raise ValueError(f"'{obj.name}' has no Volumetric Texture item")
    item = obj.thicket.items[index] if index is not None else items[-1]
    if item.kind != "VOLUMETRIC_TEXTURE":
        raise ValueError(f"item {index} of '{obj.name}' is a {item.name}, not a Volumetric Texture")
    return native.get().save_texture(bpy.path.abspath(path), item_texture(item.to_settings()))


def _part(progress, i, n):
    """`progress` for part `i` of `n` equal parts of the work."""
    return None if progress is None else (lambda f: progress((i + f) / n))


def render_preview(obj, path=None, width=None, height=None, method="auto", slices=16, image="Thicket Preview", mipmaps="double", progress=None):
    """Renders `obj`'s thick surface (its first Volumetric Texture over its shell, not
    baked) from the scene camera into the Blender image `image`, which is returned.
    Size: the scene's output size unless given. `method`: "auto" (GPU slices, or the
    CPU reference without a GPU), "interpolating", "plain" or "reference".
    `mipmaps`: "double" (far detail turns semi-transparent instead of vanishing),
    "linear" or "off". `path`:
    also written to a file: .exr (colour, alpha, depth and normal layers) or .png.
    `progress`: see the module docs; it covers the shells and then the render (rows
    of the CPU reference; a GPU frame in one step, dropped when cancelled while drawn),
    both cancellable."""
    from .render import camera, preview

    _require_mesh(obj)
    scene = bpy.context.scene
    depsgraph = bpy.context.evaluated_depsgraph_get()
    if width is None or height is None:
        width, height = camera.render_size(scene)
    view, projection = camera.scene_camera(scene, depsgraph, obj, width, height)
    out = preview.render_arrays(obj, view, projection, width, height, depsgraph=depsgraph, method=method, slices=slices, mipmaps=mipmaps, progress=progress)
    result = preview.to_image(out["rgba"], image)
    if path:
        native.get().save_render(bpy.path.abspath(path), out["rgba"], out["depth"], out["normal"])
    return result


def render_frames(obj, frame_start, frame_end, directory, step=1, extension=".png", **options):
    """Renders the preview at every frame of the range (animated textures follow the
    frame) to `<object>_<frame><extension>` files in `directory`; returns the paths.
    The scene's frame is restored afterwards."""
    scene = bpy.context.scene
    previous = scene.frame_current
    paths = []
    try:
        for frame in range(int(frame_start), int(frame_end) + 1, max(1, int(step))):
            scene.frame_set(frame)
            path = os.path.join(bpy.path.abspath(directory), f"{obj.name}_{frame:04d}{extension}")
            os.makedirs(os.path.dirname(path), exist_ok=True)
            render_preview(obj, path=path, **options)
            paths.append(path)
    finally:
        scene.frame_set(previous)
    return paths


def regenerate(obj, progress=None, ask=False, fresh=False):
    """Recomputes `obj`'s result from its current mesh and stack; returns the result.
    `progress(fraction)`: the share of the stack done, in [0, 1]; returning False
    cancels with `thicket_native.Cancelled`, leaving the previous result (module docs).
    `ask`: raise `BakeNeedsConfirmation` (with `.estimate`) instead of baking more
    triangles than a Volumetric Texture item's `confirm_above`. Shells follow edits
    incrementally (only the directors an edit can reach are traced again); `fresh`
    builds them from scratch instead."""
    _require_mesh(obj)
    if fresh:
        live_shells.clear()
    return _regenerate(obj, progress=progress, ask=ask)


def texture_item_index(obj, index=-1, label=""):
    """The stack index of `obj`'s Volumetric Texture item to fit to its budget:
    `index` where it is one; else the enabled one named `label`; else the active item
    where it is an enabled one; else the last enabled one (None without any)."""
    items = obj.thicket.items
    if 0 <= index < len(items) and items[index].kind == "VOLUMETRIC_TEXTURE":
        return index
    textures = [i for i, item in enumerate(items) if item.kind == "VOLUMETRIC_TEXTURE" and item.show_viewport]
    named = [i for i in textures if items[i].name == label]
    if named:
        return named[0]
    if obj.thicket.active_index in textures:
        return obj.thicket.active_index
    return textures[-1] if textures else None


def fit_bake_tiles(obj, index=None, progress=None, regenerate=True):
    """Grows the tiles of `obj`'s Volumetric Texture item (`index`, or the last
    enabled one) to the smallest size (within 5%) at which its bake is estimated
    within its Triangle Budget, and sets them on the item: with a UV map a smaller
    `tiling`; without one `no_uv_tiles="WORLD"` and a larger `tile_size` (one tile per
    face turns into World-Size Tiles grown from the automatic size). Then regenerates
    the result (`regenerate`). Returns the search's dict (`thicket_native.fit_bake_tiles`:
    scale, triangles, fits, below, estimates) with `settings`, what was set.
    `progress`: see the module docs (the shells, then the search); a cancel changes
    nothing."""
    from .pure.fit_budget import fit_texture_budget
    from .stack.guard import suspended
    from .stack.regenerate import read_source

    _require_mesh(obj)
    at = texture_item_index(obj, -1 if index is None else index)
    if at is None or (index is not None and at != index):
        raise ValueError(f"'{obj.name}' has no enabled Volumetric Texture item" + ("" if index is None else f" at {index}"))
    arrays, items = read_source(obj)
    enabled = sum(item.show_viewport for item in obj.thicket.items[:at])
    fit = fit_texture_budget(arrays, items, enabled, progress)
    with suspended():
        for key, value in fit.settings.items():
            setattr(obj.thicket.items[at], key, value)
    if regenerate:
        _regenerate(obj)
    return dict(fit.found, settings=dict(fit.settings))


def result_of(obj):
    """The result object of a source, or None."""
    result = obj.thicket.result
    return result if result is not None and result.name in bpy.data.objects else None


def apply(obj):
    """Makes the result an ordinary, independent mesh object (keeping its world
    transform) and removes the stack from `obj`. Returns the former result."""
    _require_mesh(obj)
    result = result_of(obj) or _regenerate(obj)
    world = result.matrix_world.copy()
    result.parent = None
    result.matrix_world = world
    result.thicket.source = None
    _clear_stack(obj)
    return result


def remove(obj):
    """Deletes `obj`'s stack and its result object (and the result's mesh)."""
    _require_mesh(obj)
    result = result_of(obj)
    _clear_stack(obj)
    if result is not None:
        mesh = result.data
        bpy.data.objects.remove(result, do_unlink=True)
        if mesh is not None and mesh.users == 0:
            bpy.data.meshes.remove(mesh)


def _clear_stack(obj):
    from .stack.guard import suspended

    with suspended():
        obj.thicket.items.clear()
        obj.thicket.result = None
        obj.thicket.last_error = ""


def export_glb(objects, path):
    """Writes `objects` to a binary glTF file with Blender's own exporter."""
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    for obj in bpy.context.view_layer.objects:
        obj.select_set(obj in objects)
    bpy.ops.export_scene.gltf(filepath=path, export_format="GLB", use_selection=True, export_apply=True)
    return path


def process_file(path, out_blend=None, out_glb=None, objects=None, **settings):
    """Opens `path`, adds thick surfaces to every mesh (or those named in `objects`),
    and saves the .blend and/or .glb. Returns {source name: result name}; objects
    that fail are reported in the dict as {name: "error: ..."} and skipped."""
    bpy.ops.wm.open_mainfile(filepath=path)
    done = {}
    sources = [o for o in bpy.context.scene.objects if o.type == "MESH" and o.thicket.source is None]
    if objects is not None:
        sources = [o for o in sources if o.name in objects]
    for obj in sources:
        try:
            done[obj.name] = add_thick_surface(obj, **settings).name
        except (TypeError, KeyError, ValueError, *native.error_types()) as exc:
            done[obj.name] = f"error: {exc}"
    if out_blend:
        os.makedirs(os.path.dirname(os.path.abspath(out_blend)), exist_ok=True)
        bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(out_blend), copy=True)
    if out_glb:
        results = [bpy.data.objects[n] for n in done.values() if not n.startswith("error:")]
        export_glb(results, out_glb)
    return done
