"""The one module that reads and writes Blender mesh data.

Everything goes through `foreach_get` / `foreach_set` and numpy arrays (float32
positions, int32 indices): no per-vertex Python loops. Positions, corner vertices and
material indices go through the generic attribute API (`position`, `.corner_vert`,
`material_index`), a plain copy in Blender 4.2 and later, where the older
`vertices`/`loops`/`polygons` properties convert item by item (5-10 ms each on a
44k-face result: most of an incremental shell edit's I/O).
"""

import bpy
import numpy as np

from .pure.arrays import SELECTED_FACES, SELECTED_VERTICES, MeshArrays, weight_attribute


def _transfer(method, mesh, attribute, key, array, collection, prop):
    """`foreach_get` or `foreach_set` (`method`) of `array` through the attribute's
    `key`, or through `collection`'s `prop` where the mesh has no such attribute."""
    attr = mesh.attributes.get(attribute)
    if attr is not None:
        getattr(attr.data, method)(key, array)
    else:
        getattr(collection, method)(prop, array)


def read_mesh(mesh: bpy.types.Mesh, float_attributes=()) -> MeshArrays:
    """Positions, faces and the named float point attributes of `mesh`."""
    n, f, c = len(mesh.vertices), len(mesh.polygons), len(mesh.loops)
    vertices = np.empty(n * 3, dtype=np.float32)
    _transfer("foreach_get", mesh, "position", "vector", vertices, mesh.vertices, "co")
    face_sizes = np.empty(f, dtype=np.int32)
    mesh.polygons.foreach_get("loop_total", face_sizes)
    corners = np.empty(c, dtype=np.int32)
    _transfer("foreach_get", mesh, ".corner_vert", "value", corners, mesh.loops, "vertex_index")
    attrs = {}
    for name in float_attributes:
        attr = mesh.attributes.get(name)
        if attr is not None and attr.domain == "POINT" and attr.data_type == "FLOAT":
            values = np.empty(n, dtype=np.float32)
            attr.data.foreach_get("value", values)
            attrs[name] = values
    uv_maps = {}
    for layer in mesh.uv_layers if c > 0 else ():
        uv = np.empty(c * 2, dtype=np.float32)
        layer.data.foreach_get("uv", uv)
        uv_maps[layer.name] = uv.reshape(c, 2)
    active = mesh.uv_layers.active
    uvs = uv_maps.get(active.name) if active is not None else None
    material_index = np.zeros(f, dtype=np.int32)
    attr = mesh.attributes.get("material_index")
    if attr is not None and attr.domain == "FACE" and attr.data_type == "INT":
        attr.data.foreach_get("value", material_index)
    arrays = MeshArrays(vertices.reshape(n, 3), face_sizes, corners, attrs, uvs)
    arrays.uv_maps = uv_maps
    arrays.material_index = material_index
    if active is not None:
        arrays.uv_name = active.name
    return arrays


def write_mesh(mesh: bpy.types.Mesh, arrays: MeshArrays) -> None:
    """Replaces the geometry of `mesh` with `arrays` (and its point attributes)."""
    mesh.clear_geometry()
    n, f, c = arrays.vertex_count, arrays.face_count, len(arrays.corners)
    mesh.vertices.add(n)
    _transfer("foreach_set", mesh, "position", "vector", np.ascontiguousarray(arrays.vertices, dtype=np.float32).ravel(), mesh.vertices, "co")
    mesh.loops.add(c)
    _transfer("foreach_set", mesh, ".corner_vert", "value", np.ascontiguousarray(arrays.corners, dtype=np.int32), mesh.loops, "vertex_index")
    mesh.polygons.add(f)
    starts = np.zeros(f, dtype=np.int32)
    np.cumsum(arrays.face_sizes[:-1], out=starts[1:])
    mesh.polygons.foreach_set("loop_start", starts)
    mesh.update(calc_edges=True)
    if arrays.normals is not None and n > 0:
        # Custom normals (Blender 4.1+ needs no auto smooth for them to show).
        mesh.polygons.foreach_set("use_smooth", np.ones(f, dtype=bool))
        mesh.normals_split_custom_set_from_vertices(np.ascontiguousarray(arrays.normals, dtype=np.float32))
    for name, uv in arrays.uv_maps.items():
        layer = mesh.uv_layers.new(name=name, do_init=False)
        layer.data.foreach_set("uv", np.ascontiguousarray(uv, dtype=np.float32).ravel())
    if arrays.uv_name in mesh.uv_layers:
        mesh.uv_layers.active = mesh.uv_layers[arrays.uv_name]
    if arrays.material_index is not None and f > 0:
        attr = mesh.attributes.get("material_index") or mesh.attributes.new("material_index", "INT", "FACE")
        attr.data.foreach_set("value", np.ascontiguousarray(arrays.material_index, dtype=np.int32))
    for name, values in arrays.point_attributes.items():
        values = np.ascontiguousarray(values, dtype=np.float32)
        vector = values.ndim == 2
        attr = mesh.attributes.new(name, "FLOAT_VECTOR" if vector else "FLOAT", "POINT")
        attr.data.foreach_set("vector" if vector else "value", values.ravel())
    write_attributes(mesh, arrays.attributes, arrays.active_color)


#: foreach_set key and numpy type of each attribute data type `write_attributes` takes.
_ATTRIBUTE_KEYS = {
    "FLOAT": ("value", np.float32),
    "INT": ("value", np.int32),
    "FLOAT_VECTOR": ("vector", np.float32),
    "FLOAT_COLOR": ("color", np.float32),
    "BOOLEAN": ("value", bool),
}


def write_attributes(mesh: bpy.types.Mesh, attributes: dict, active_color: str = "") -> None:
    """Writes `attributes` (name -> (domain, data type, values)) into `mesh`, replacing
    attributes of the same name; `active_color` (a FLOAT_COLOR among them) becomes the
    active and the rendered colour attribute (what a Color Attribute node reads by default)."""
    for name, (domain, data_type, values) in attributes.items():
        key, dtype = _ATTRIBUTE_KEYS[data_type]
        old = mesh.attributes.get(name)
        if old is not None:
            mesh.attributes.remove(old)
        attr = mesh.attributes.new(name, data_type, domain)
        attr.data.foreach_set(key, np.ascontiguousarray(values, dtype=dtype).ravel())
    if active_color:
        mesh.color_attributes.active_color_name = active_color
        mesh.color_attributes.default_color_name = active_color


def _weight_capture_group(group_names) -> bpy.types.NodeTree:
    """A throw-away geometry-nodes group storing each vertex group as a float point
    attribute (see `arrays.weight_attribute`), so weights can be read with foreach_get."""
    tree = bpy.data.node_groups.new(".thicket weight capture", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = tree.nodes, tree.links
    socket = nodes.new("NodeGroupInput").outputs[0]
    for group_name in group_names:
        named = nodes.new("GeometryNodeInputNamedAttribute")
        named.data_type = "FLOAT"
        named.inputs["Name"].default_value = group_name
        store = nodes.new("GeometryNodeStoreNamedAttribute")
        store.data_type = "FLOAT"
        store.domain = "POINT"
        store.inputs["Name"].default_value = weight_attribute(group_name)
        links.new(socket, store.inputs["Geometry"])
        links.new(named.outputs["Attribute"], store.inputs["Value"])
        socket = store.outputs["Geometry"]
    links.new(socket, nodes.new("NodeGroupOutput").inputs[0])
    return tree


def read_evaluated(obj: bpy.types.Object, depsgraph, vertex_groups=(), modifiers=True) -> MeshArrays:
    """The object's mesh after its own modifiers (`modifiers` True; else its own mesh,
    the modifiers' cage), in object space.

    Each named vertex group comes back as point attribute `weight_attribute(name)`
    (0 where a vertex is not in the group). Blender exposes vertex-group weights to
    Python only per vertex, so they are read through a temporary copy of the object
    with a geometry-nodes capture appended; the user's object is not modified.
    Call it with auto-update suspended (`stack.guard.suspended`), as
    `stack.regenerate` does: the probe's own depsgraph updates must not schedule work.
    """
    selections = {SELECTED_FACES: _selected_face_weights, SELECTED_VERTICES: _selected_vertex_weights}
    for pseudo, weights in selections.items():
        if pseudo in vertex_groups:
            arrays = read_evaluated(obj, depsgraph, [g for g in vertex_groups if g != pseudo], modifiers)
            arrays.point_attributes[weight_attribute(pseudo)] = weights(obj, arrays)
            return arrays
    if not vertex_groups:
        return _evaluated_arrays(obj, depsgraph) if modifiers else read_own_mesh(obj)

    missing = [g for g in vertex_groups if obj.vertex_groups.get(g) is None]
    if missing:
        raise KeyError(f"Object '{obj.name}' has no vertex group named '{missing[0]}'")
    tree = _weight_capture_group(vertex_groups)
    probe = obj.copy()
    probe.name = f".thicket probe {obj.name}"
    collection = bpy.context.scene.collection
    collection.objects.link(probe)
    try:
        probe.parent = None
        probe.thicket.items.clear()
        probe.thicket.result = None
        if not modifiers:
            # Off, not removed: removing a Multires deletes the shared mesh's displacements.
            for m in probe.modifiers:
                m.show_viewport = False
        modifier = probe.modifiers.new("thicket weights", "NODES")
        modifier.node_group = tree
        depsgraph = bpy.context.evaluated_depsgraph_get()
        depsgraph.update()
        evaluated = probe.evaluated_get(depsgraph)
        mesh = evaluated.to_mesh()
        try:
            return read_mesh(mesh, [weight_attribute(g) for g in vertex_groups])
        finally:
            evaluated.to_mesh_clear()
    finally:
        collection.objects.unlink(probe)
        bpy.data.objects.remove(probe, do_unlink=True)
        bpy.data.node_groups.remove(tree)
        # Evaluate now, so the depsgraph updates that name the removed probe are sent
        # (callers suspend Thicket's handler) instead of reaching the next handler call
        # as dangling IDs, which crashed Blender when read.
        bpy.context.view_layer.update()


def read_own_mesh(obj: bpy.types.Object) -> MeshArrays:
    """`obj`'s own mesh (no modifiers). In Edit Mode the edits are flushed first and a
    copy is read: an edited mesh's UV maps have no data until the mode is left."""
    if obj.mode != "EDIT":
        return read_mesh(obj.data)
    obj.update_from_editmode()
    copy = obj.data.copy()
    try:
        return read_mesh(copy)
    finally:
        bpy.data.meshes.remove(copy)


def _evaluated_arrays(obj, depsgraph) -> MeshArrays:
    """`obj`'s mesh as `depsgraph` evaluates it (its modifiers applied)."""
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        return read_mesh(mesh)
    finally:
        evaluated.to_mesh_clear()


def multires_modifier(obj: bpy.types.Object):
    """The object's first Multires modifier (the one Blender sculpts), or None."""
    return next((m for m in obj.modifiers if m.type == "MULTIRES"), None)


def _checked_multires(obj: bpy.types.Object):
    """`obj`'s Multires modifier and its total levels, once it can be read: refused
    without one, with no levels or in Sculpt Mode; Edit Mode is flushed first."""
    modifier = multires_modifier(obj)
    if modifier is None:
        raise ValueError(f"'{obj.name}' has no Multires modifier")
    levels = modifier.total_levels
    if levels < 1:
        raise ValueError(f"the Multires modifier of '{obj.name}' has no levels: subdivide it first")
    if obj.mode == "SCULPT":
        raise ValueError(f"'{obj.name}' is in Sculpt Mode: leave it (its latest strokes are kept in the sculpt) before reading the Multires")
    if obj.mode == "EDIT":
        obj.update_from_editmode()
    return modifier, levels


def _probes_removed(probes):
    collection = bpy.context.scene.collection
    for probe in probes:
        if probe.name in collection.objects:
            collection.objects.unlink(probe)
        bpy.data.objects.remove(probe, do_unlink=True)
    bpy.context.view_layer.update()


def read_sculpt(obj: bpy.types.Object, depsgraph=None) -> MeshArrays:
    """`obj`'s Multires sculpt at the modifier's total levels, in Blender's numbering: the
    modifier alone, before any other. The object's own evaluated mesh when that is it
    (Object Mode, the Multires its only modifier shown, at its total levels); else a
    copy of the object with its Multires at all its levels and every other modifier
    off (none is removed: removing a Multires deletes the mesh's displacements). Call
    it with auto-update suspended, after `_checked_multires`."""
    modifier = multires_modifier(obj)
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    # A render depsgraph evaluates the modifiers shown in renders, at their render levels.
    render = depsgraph.mode == "RENDER"
    shown = [m for m in obj.modifiers if (m.show_render if render else m.show_viewport)]
    levels = modifier.render_levels if render else modifier.levels
    if obj.mode == "OBJECT" and shown == [modifier] and levels == modifier.total_levels:
        return _evaluated_arrays(obj, depsgraph)
    sculpt = obj.copy()
    if obj.mode == "EDIT":
        # An edited mesh evaluates as its edit cage, without the Multires: a copy of the
        # flushed mesh (its displacements with it) is read instead.
        sculpt.data = obj.data.copy()
    try:
        sculpt.hide_viewport = False
        sculpt.name = f".thicket sculpt {obj.name}"
        sculpt.parent = None
        sculpt.thicket.items.clear()
        sculpt.thicket.result = None
        first = True
        for m in sculpt.modifiers:
            if m.type == "MULTIRES" and first:
                m.levels = m.total_levels
                m.show_viewport = True
                first = False
            else:
                m.show_viewport = False
        bpy.context.scene.collection.objects.link(sculpt)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        depsgraph.update()
        return _evaluated_arrays(sculpt, depsgraph)
    finally:
        copied = sculpt.data if sculpt.data != obj.data else None
        _probes_removed([sculpt])
        if copied is not None:
            bpy.data.meshes.remove(copied)


def multires_order(obj: bpy.types.Object, base: MeshArrays, levels: int, sculpted: MeshArrays):
    """The permutation from Blender's Multires numbering of `base` at `levels` (the
    sculpt `sculpted`, from `read_sculpt`) to Thicket's: Thicket's vertex i is the
    Multires mesh's vertex `order[i]` (int32). Blender's numbering read here
    (`multires_numbering`), matched by `procedural_detail_sculpt.match_numbering`."""
    from .pure.kinds.procedural_detail_sculpt import match_numbering

    return match_numbering(base, levels, sculpted, multires_numbering(obj, levels), obj.name)


def multires_numbering(obj: bpy.types.Object, levels: int) -> np.ndarray:
    """Blender's Subdivision Surface (Use Limit Surface) of `obj`'s base at `levels`:
    its positions (float32 (m, 3)) in the numbering Blender gives Multires.

    Blender numbers the subdivided vertices its own way (OpenSubdiv's). Its Subdivision
    Surface modifier (Use Limit Surface, same levels and boundary smoothing) on
    the same base numbers them as Multires does, and Thicket's limit positions match its
    positions, so `thicket_native.match_subdivision` finds the permutation by nearest
    position. It is evaluated on a temporary object sharing `obj`'s mesh."""
    modifier = multires_modifier(obj)
    mesh = obj.data.copy() if obj.mode == "EDIT" else obj.data  # as in `read_sculpt`
    plain = bpy.data.objects.new(f".thicket numbering {obj.name}", mesh)
    try:
        surface = plain.modifiers.new("thicket numbering", "SUBSURF")
        surface.levels = levels
        surface.use_limit_surface = True
        # Thicket's limit positions: every boundary smoothed, no creases (the numbering
        # does not depend on either).
        surface.boundary_smooth = "ALL"
        surface.use_creases = False
        # Quality below the levels approximates the patches (1e-3 of the size off the
        # limit); the numbering does not depend on it.
        surface.quality = max(modifier.quality, levels)
        bpy.context.scene.collection.objects.link(plain)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        depsgraph.update()
        return _evaluated_arrays(plain, depsgraph).vertices
    finally:
        _probes_removed([plain])
        if mesh != obj.data:
            bpy.data.meshes.remove(mesh)


def read_multires(obj: bpy.types.Object):
    """An object's Multires sculpt and its numbering: `(base, levels, sculpted, order)`,
    `base` the object's own mesh (MeshArrays), `levels` the modifier's total levels,
    `sculpted` (MeshArrays) the modifier's evaluated mesh at those levels (the modifier
    alone, before any other) in Blender's numbering, and `order` (int32) the
    permutation to the numbering `thicket_native.analyze` takes: Thicket's vertex i is
    the Multires mesh's vertex `order[i]` (`read_sculpt`, `multires_order`;
    `procedural_detail_sculpt.analyse` checks it and analyses). Both are evaluated on temporary objects; the
    user's object, its modifiers and its sculpt are not modified. Call it with
    auto-update suspended."""
    _, levels = _checked_multires(obj)
    base = read_own_mesh(obj)
    sculpted = read_sculpt(obj)
    return base, levels, sculpted, multires_order(obj, base, levels, sculpted)


def _original_selection(obj, arrays: MeshArrays, what):
    """The source's own mesh, whose selection is read: modifiers must keep its faces
    and vertices (checked), so its indices are the evaluated mesh's."""
    mesh = obj.data
    if obj.mode == "EDIT":
        obj.update_from_editmode()
    if len(mesh.polygons) != arrays.face_count or len(mesh.loops) != len(arrays.corners) or len(mesh.vertices) != arrays.vertex_count:
        raise ValueError(f"'{obj.name}': selected {what} can only be used when its modifiers keep its faces; use a vertex group")
    return mesh


def _selected_vertex_weights(obj, arrays: MeshArrays):
    """1 on the source's selected vertices, 0 elsewhere (see `_original_selection`)."""
    mesh = _original_selection(obj, arrays, "vertices")
    selected = np.empty(len(mesh.vertices), dtype=bool)
    mesh.vertices.foreach_get("select", selected)
    return selected.astype(np.float32)


def _selected_face_weights(obj, arrays: MeshArrays):
    """1 on the vertices of the source's selected faces, 0 elsewhere (see
    `_original_selection`)."""
    mesh = _original_selection(obj, arrays, "faces")
    selected = np.empty(len(mesh.polygons), dtype=bool)
    mesh.polygons.foreach_get("select", selected)
    weights = np.zeros(arrays.vertex_count, dtype=np.float32)
    weights[arrays.corners[np.repeat(selected, arrays.face_sizes)]] = 1.0
    return weights


def read_solid(obj: bpy.types.Object, space: bpy.types.Object, depsgraph):
    """`obj`'s evaluated mesh as (vertices float32 (n,3), triangles int32 (t,3)) in
    `space`'s object coordinates (a cutter, in its source's space)."""
    if obj.name not in bpy.data.objects:
        raise KeyError(f"the cutter object '{obj.name}' no longer exists")
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        mesh.calc_loop_triangles()
        vertices = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
        mesh.vertices.foreach_get("co", vertices)
        triangles = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int32)
        mesh.loop_triangles.foreach_get("vertices", triangles)
    finally:
        evaluated.to_mesh_clear()
    matrix = np.array(space.matrix_world.inverted() @ obj.matrix_world, dtype=np.float64)
    vertices = vertices.reshape(-1, 3).astype(np.float64) @ matrix[:3, :3].T + matrix[:3, 3]
    return np.ascontiguousarray(vertices, dtype=np.float32), triangles.reshape(-1, 3)


def select_faces(mesh: bpy.types.Mesh, faces) -> None:
    """Selects exactly `faces` (indices) of `mesh`, with their edges and vertices."""
    face_flags = np.zeros(len(mesh.polygons), dtype=bool)
    face_flags[np.asarray(faces, dtype=np.int64)] = True
    mesh.polygons.foreach_set("select", face_flags)
    corner_flags = np.repeat(face_flags, _face_sizes(mesh))
    corners = np.empty(len(mesh.loops), dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", corners)
    vertex_flags = np.zeros(len(mesh.vertices), dtype=bool)
    vertex_flags[corners[corner_flags]] = True
    mesh.vertices.foreach_set("select", vertex_flags)
    edge_vertices = np.empty(len(mesh.edges) * 2, dtype=np.int32)
    mesh.edges.foreach_get("vertices", edge_vertices)
    mesh.edges.foreach_set("select", vertex_flags[edge_vertices].reshape(-1, 2).all(axis=1))
    mesh.update()


def _face_sizes(mesh: bpy.types.Mesh):
    sizes = np.empty(len(mesh.polygons), dtype=np.int32)
    mesh.polygons.foreach_get("loop_total", sizes)
    return sizes
