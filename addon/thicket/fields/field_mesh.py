"""Field Mesh objects: a field tree's zero set meshed by the core and written with
`mesh_io`, the tree and its settings stored on the object (an ID property, saved in
the .blend) so it regenerates in place."""

import bpy

from .. import mesh_io
from ..pure import native
from ..pure.field_tree import COLOR_ATTRIBUTE, check_mesh_settings, check_tree, field_mesh_arrays, field_mesh_estimate

#: The object's ID property holding the tree's JSON and the mesh settings.
SETTINGS_PROPERTY = "thicket_field"
#: The object's ID property pointing at the Text the tree was read from (optional).
TEXT_PROPERTY = "thicket_field_text"
#: The material showing the colour attribute (made once, shared by field meshes).
MATERIAL_NAME = "Thicket Field Color"


def _progress(progress, fraction):
    """Reports `fraction` done; a callback returning False cancels, except at 1.0,
    reported once the result is made (too late to undo it)."""
    if progress is not None and progress(fraction) is False and fraction < 1.0:
        raise native.get().Cancelled("cancelled")


#: The share of the progress the core's meshing covers (the rest: writing the mesh).
MESHING_SHARE = 0.9


def prepare(tree, resolution=128, bounds=None, adaptive=True):
    """The checked build settings (dict: text, resolution, bounds, adaptive); a bad
    tree or setting raises a ThicketError."""
    text = check_tree(tree)
    resolution, bounds = check_mesh_settings(resolution, bounds)
    return {"text": text, "resolution": resolution, "bounds": bounds, "adaptive": bool(adaptive)}


def estimate(prepared, max_bytes=None):
    """The core's estimate of the build (`pure.field_tree.field_mesh_estimate`)."""
    return field_mesh_estimate(prepared["text"], prepared["resolution"], prepared["bounds"], prepared["adaptive"], max_bytes)


def mesh_arrays(prepared, progress=None, max_bytes=None):
    """The mesh of a `prepare`d build, without Blender (a worker thread may run it):
    `progress` sees 0 to MESHING_SHARE; a cancel raises `Cancelled`, a build over
    `max_bytes` (default 4 GB) raises `OverLimit` (an `InvalidInput`) before it starts."""
    _progress(progress, 0.0)
    scaled = None if progress is None else (lambda f: progress(MESHING_SHARE * min(max(float(f), 0.0), 1.0)))
    p = prepared
    arrays = field_mesh_arrays(p["text"], p["resolution"], p["bounds"], p["adaptive"], progress=scaled, max_bytes=max_bytes)
    _progress(progress, MESHING_SHARE)
    return arrays


def field_settings(obj):
    """The stored settings of a Field Mesh object (dict: tree, resolution, bounds,
    adaptive), or None when `obj` is not one."""
    stored = obj.get(SETTINGS_PROPERTY) if obj is not None else None
    if stored is None:
        return None
    settings = stored.to_dict() if hasattr(stored, "to_dict") else dict(stored)
    bounds = settings.get("bounds")
    settings["bounds"] = None if bounds is None or len(bounds) == 0 else [float(v) for v in bounds]
    return settings


def _store(obj, text, resolution, bounds, adaptive, source_text=None):
    obj[SETTINGS_PROPERTY] = {
        "tree": text,
        "resolution": int(resolution),
        "adaptive": bool(adaptive),
        "bounds": [] if bounds is None else [float(v) for corner in bounds for v in corner],
    }
    if source_text is not None:
        obj[TEXT_PROPERTY] = source_text
    elif TEXT_PROPERTY in obj:
        del obj[TEXT_PROPERTY]


def _color_material():
    """A material whose base colour is the rendered colour attribute (a Color
    Attribute node with no name reads the mesh's default colour attribute)."""
    material = bpy.data.materials.get(MATERIAL_NAME)
    if material is not None:
        return material
    material = bpy.data.materials.new(MATERIAL_NAME)
    if bpy.app.version < (5, 0, 0):  # always on in Blender 5 (the property is deprecated there)
        material.use_nodes = True
    nodes = material.node_tree.nodes
    shader = next((n for n in nodes if n.type == "BSDF_PRINCIPLED"), None)
    if shader is not None:
        color = nodes.new("ShaderNodeVertexColor")
        color.layer_name = COLOR_ATTRIBUTE
        color.location = (shader.location.x - 300, shader.location.y)
        material.node_tree.links.new(color.outputs["Color"], shader.inputs["Base Color"])
    return material


def write_new(prepared, arrays, name="Field Mesh", collection=None, source_text=None):
    """A new Field Mesh object of `arrays` (from `mesh_arrays(prepared)`), linked to
    `collection` (default the active one), its settings stored."""
    if collection is None:
        collection = bpy.context.collection or bpy.context.scene.collection
    mesh = bpy.data.meshes.new(name)
    try:
        mesh_io.write_mesh(mesh, arrays)
        mesh.materials.append(_color_material())
        obj = bpy.data.objects.new(name, mesh)
    except BaseException:
        bpy.data.meshes.remove(mesh)
        raise
    collection.objects.link(obj)
    p = prepared
    _store(obj, p["text"], p["resolution"], p["bounds"], p["adaptive"], source_text)
    return obj


def write_existing(obj, prepared, arrays, source_text=None):
    """Replaces the Field Mesh `obj`'s mesh by `arrays` and stores the settings."""
    mesh_io.write_mesh(obj.data, arrays)
    p = prepared
    _store(obj, p["text"], p["resolution"], p["bounds"], p["adaptive"], source_text)
    return obj


def build_field_mesh(
    tree_json, name="Field Mesh", resolution=128, bounds=None, adaptive=True, collection=None, progress=None, source_text=None, max_bytes=None
):
    """A new mesh object of the tree's zero set (see `thicket.api.build_field_mesh`).
    Everything is checked and meshed before any datablock is made, so a bad tree or
    setting (a ThicketError), a build over `max_bytes` or a cancel leaves the file as
    it was."""
    prepared = prepare(tree_json, resolution, bounds, adaptive)
    if collection is not None and not isinstance(collection, bpy.types.Collection):
        raise TypeError(f"collection must be a Blender collection, got {type(collection).__name__}")
    arrays = mesh_arrays(prepared, progress, max_bytes)
    obj = write_new(prepared, arrays, name, collection, source_text)
    _progress(progress, 1.0)
    return obj


def prepare_regeneration(obj, tree=None, resolution=None, adaptive=None):
    """The `prepare`d rebuild of a Field Mesh object and the Text it reads (or None):
    its stored tree and settings (its Text's current content when it was built from
    one that still exists), `tree`, `resolution` and `adaptive` replacing them when
    given."""
    settings = field_settings(obj)
    if settings is None:
        raise TypeError(f"'{getattr(obj, 'name', obj)}' is not a Thicket Field Mesh (it has no stored field tree)")
    source_text = obj.get(TEXT_PROPERTY)
    source_text = source_text if isinstance(source_text, bpy.types.Text) else None
    if tree is None:
        tree = source_text.as_string() if source_text is not None else settings["tree"]
    resolution = settings["resolution"] if resolution is None else resolution
    adaptive = settings["adaptive"] if adaptive is None else adaptive
    return prepare(tree, resolution, settings["bounds"], adaptive), source_text


def regenerate_field_mesh(obj, progress=None, tree=None, resolution=None, adaptive=None, max_bytes=None):
    """Rebuilds a Field Mesh object's mesh in place from its stored tree and settings
    (from its Text's current content when it was built from one that still exists).
    `tree`, `resolution` and `adaptive`, when given, replace the stored ones (a node
    tree's regeneration passes its own). On error, over `max_bytes` or on a cancel
    the mesh stays as it was."""
    prepared, source_text = prepare_regeneration(obj, tree, resolution, adaptive)
    arrays = mesh_arrays(prepared, progress, max_bytes)
    write_existing(obj, prepared, arrays, source_text)
    _progress(progress, 1.0)
    return obj
