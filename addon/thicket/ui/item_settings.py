"""Draws one stack item's settings (shared by the Properties and sidebar panels)."""

import bpy

from ..mesh_io import multires_modifier
from ..pure.kinds.procedural_detail import API_NAMES, MODEL_SETTINGS
from ..stack import auto_update


def draw_item_settings(layout, obj, item):
    col = layout.column()
    col.use_property_split = True
    col.use_property_decorate = False
    if item.kind == "VOLUMETRIC_TEXTURE":
        _draw_texture_settings(col, obj, item)
        return
    if item.kind == "SOLID_TEXTURE":
        _draw_solid_texture_settings(col, item)
        return
    if item.kind == "PROCEDURAL_DETAIL":
        _draw_detail_settings(col, obj, item)
        return
    if item.kind == "SHELL":
        col.prop(item, "side")
    col.prop(item, "thickness_mode")
    col.prop(item, "thickness")
    col.prop_search(item, "vertex_group", obj, "vertex_groups")
    col.prop(item, "output")
    if item.output == "LAYERS":
        col.prop(item, "surfaces")


def _draw_solid_texture_settings(col, item):
    col.prop(item, "tree_text")
    row = col.row()
    row.active = item.tree_text is None
    row.prop(item, "tree")
    col.prop(item, "mode")
    if item.mode == "DISPLACE":
        col.prop(item, "amplitude")
    else:
        col.prop(item, "domain")
        col.prop(item, "color_attribute")


#: Each Procedural Detail model's own settings, as the panel shows them (the item
#: properties of the settings the model takes).
DETAIL_PROPS = {model.upper(): tuple(API_NAMES[name] for name in names) for model, names in MODEL_SETTINGS.items()}


def _draw_detail_settings(col, obj, item):
    col.prop(item, "detail_model")
    col.prop(item, "levels")
    modifier = multires_modifier(obj)
    if modifier is not None:
        # Use Sculpt: only where the source has a Multires to start from.
        col.prop(item, "use_sculpt")
        if item.use_sculpt and item.levels < modifier.total_levels:
            row = col.row()
            row.alert = True
            row.label(text=f"Levels must be at least the sculpt's {modifier.total_levels}", icon="ERROR")
    col.prop(item, "seed")
    for prop in DETAIL_PROPS[item.detail_model]:
        col.prop(item, prop)
    # Time (section 3) moves the models, the blend and the shader, each by its rate.
    col.prop(item, "follow_frame", text="Animate With Frame")
    if item.follow_frame:
        col.prop(item, "speed")
        # Both models take them (the blend's second one has the item's settings).
        models = {item.detail_model, item.blend_model} - {"NONE"}
        if "TENTACLE" in models:
            col.prop(item, "detail_spin")
        if models - {"BERRY"}:
            col.prop(item, "detail_grow")
    if item.detail_model not in ("ROCK", "FUSE"):
        col.prop(item, "detail_seeds")
        if item.detail_seeds == "GROUP":
            col.prop_search(item, "vertex_group", obj, "vertex_groups")
    col.prop(item, "detail_at")
    col.separator()
    col.prop(item, "blend_model")
    if item.blend_model != "NONE":
        col.prop(item, "blend_seed")
        col.prop(item, "blend_gain")
        col.prop(item, "blend_alpha")
        if item.blend_alpha == "PLANE":
            col.prop(item, "blend_point")
            col.prop(item, "blend_direction")
        else:
            col.prop_search(item, "blend_group", obj, "vertex_groups")
        col.prop(item, "blend_width")
        if item.follow_frame:
            col.prop(item, "blend_sweep")
    col.separator()
    col.prop(item, "local_object")
    if item.local_object is not None:
        col.prop(item, "local_radius")
        col.prop(item, "local_gain")
        col.prop(item, "local_at")
    col.separator()
    col.prop(item, "detail_shader")
    if item.detail_shader == "PLANET":
        col.prop(item, "shader_sea")
        col.prop(item, "shader_snow")
        if item.follow_frame:
            col.prop(item, "shader_sea_rate")
            col.prop(item, "shader_snow_rate")
    col.prop(item, "confirm_above")


def _draw_no_uv_tiles(col, obj, item):
    """Without UV Map and its Tile Size: active only where the mesh has no UV map."""
    sub = col.column()
    sub.active = obj.type == "MESH" and not obj.data.uv_layers
    sub.prop(item, "no_uv_tiles")
    if item.no_uv_tiles == "WORLD":
        sub.prop(item, "tile_size")


def _draw_texture_settings(col, obj, item):
    col.prop(item, "source")
    if item.source == "FILE":
        col.prop(item, "filepath")
    elif item.source == "FIELD_NODES":
        col.prop(item, "field_nodes")
        col.prop(item, "texture_size")
    elif item.source == "FIELD_JSON":
        col.prop(item, "tree_text")
        row = col.row()
        row.active = item.tree_text is None
        row.prop(item, "tree")
        col.prop(item, "texture_size")
    else:
        col.prop(item, "pattern")
        col.prop(item, "seed")
        col.prop(item, "feature_thickness")
        col.prop(item, "texture_size")
    col.prop(item, "tiling")
    _draw_no_uv_tiles(col, obj, item)
    col.prop(item, "follow_texture")
    col.prop(item, "resolution")
    col.prop(item, "depth_steps")
    row = col.row(align=True)
    row.prop(item, "triangle_budget")
    index = next((i for i, it in enumerate(obj.thicket.items) if it.as_pointer() == item.as_pointer()), -1)
    row.operator("thicket.fit_bake_budget", text="", icon="FULLSCREEN_EXIT").index = index
    col.prop(item, "face_selection")
    _group(col, obj, item, "vertex_group", "REGION", "Region")
    col.prop(item, "combine")
    if item.combine != "NONE":
        col.prop(item, "offset")
    col.separator()
    _group(col, obj, item, "hole_group", "HOLES", "Holes")
    col.prop(item, "cutter")
    _group(col, obj, item, "move_group", "MOVE", "Move Region")
    if item.move_group or item.face_selection == "MOVE":
        col.prop(item, "move_offset")
    col.separator()
    col.prop(item, "follow_frame")
    col.prop(item, "speed" if item.follow_frame else "time")
    col.prop(item, "confirm_above")
    col.prop(item, "max_triangles")
    col.operator("thicket.export_texture", icon="EXPORT")


def draw_status(layout, obj):
    stack = obj.thicket
    done = auto_update.progress(obj)
    if done is not None:
        layout.label(text=f"Regenerating... {done:.0%}", icon="SORTTIME")
    if stack.last_error:
        box = layout.box()
        box.alert = True
        box.label(text=stack.last_error, icon="ERROR")
    if stack.last_note:
        layout.label(text=stack.last_note, icon="INFO")
        if "times the Triangle Budget" in stack.last_note:
            layout.operator("thicket.fit_bake_budget", icon="FULLSCREEN_EXIT")
    for line in filter(None, stack.last_report.split("\n")):
        _wrapped(layout.column(align=True), line, "ERROR" if "defects left" in line else "CHECKMARK")
    if stack.source_crossings:
        box = layout.box()
        _wrapped(box.column(align=True), f"{stack.source_crossings:,} faces of the source cross the source itself; the shell keeps those crossings", "ERROR")
        box.operator("thicket.select_crossings", icon="RESTRICT_SELECT_OFF")
    hint = auto_update.animation_render_hint(obj, bpy.context.scene)
    if hint:
        _wrapped(layout.column(align=True), hint, "RENDER_ANIMATION")
    if stack.result is not None:
        layout.label(text=f"Result: {stack.result.name}", icon="OUTLINER_OB_MESH")


def _group(col, obj, item, prop, selection_role, text):
    """A vertex-group field, greyed out while the selected faces play its role."""
    row = col.row()
    row.active = item.face_selection != selection_role
    row.prop_search(item, prop, obj, "vertex_groups", text=text)


def _wrapped(col, text, icon, width=70):
    """A long status line as several labels (panels do not wrap text)."""
    words, line, first = text.split(), "", True
    for word in words:
        if line and len(line) + len(word) + 1 > width:
            col.label(text=line, icon=icon if first else "BLANK1")
            line, first = word, False
        else:
            line = f"{line} {word}" if line else word
    if line:
        col.label(text=line, icon=icon if first else "BLANK1")
