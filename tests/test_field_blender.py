"""Field trees in Blender (issue 17): Field Mesh objects from `thicket.api` and the
Add Field Mesh operator (checked with bmesh, BVHTree and field_eval itself; bad trees
leave nothing behind; undo; save and reload), and the Solid Texture stack item
(colours and displacement against field_eval computed here, chained after a Shell)."""

import json
import math

import bmesh
import bpy
import numpy as np
import pytest
from conftest import add, positions, select_only
from mathutils.bvhtree import BVHTree

import thicket_native as tn
from thicket import api
from thicket.operators.field_mesh_add import THICKET_OT_field_mesh_add
from thicket.pure import field_tree

RED, BLUE = [1.0, 0.0, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0]
CENTER, RADIUS = (0.1, -0.05, 0.02), 0.8


def sphere(center=CENTER, radius=RADIUS, color=RED):
    return {"op": "sphere", "center": list(center), "radius": radius, "color": color}


def two_colours():
    """A soft union of a red and a blue sphere: colours vary over the surface."""
    return json.dumps({"op": "union_wp", "p": 4, "children": [sphere((-0.5, 0, 0), 0.6, RED), sphere((0.5, 0, 0), 0.6, BLUE)]})


def striped(omega=8.0):
    """A big sphere whose texture is the cosine of a plane's function through a ramp:
    texture values and colours vary at every vertex of a unit cube."""
    return json.dumps(
        {
            "op": "displace",
            "shape": sphere((0, 0, 0), 5.0),
            "texture": {"op": "plane", "point": [0, 0, 0], "normal": [1, 2, 3]},
            "amplitude": 0.0,
            "omega": omega,
            "ramp": [[0.0, RED], [1.0, BLUE]],
        }
    )


def attribute(mesh, name, domain="POINT"):
    attr = mesh.attributes[name]
    assert attr.domain == domain, (name, attr.domain)
    width = {"FLOAT_COLOR": 4, "FLOAT_VECTOR": 3}.get(attr.data_type, 1)
    key = {"FLOAT_COLOR": "color", "FLOAT_VECTOR": "vector"}.get(attr.data_type, "value")
    dtype = np.int32 if attr.data_type == "INT" else np.float32
    values = np.empty(len(attr.data) * width, dtype)
    attr.data.foreach_get(key, values)
    return values.reshape(-1, width) if width > 1 else values


def corner_vertices(mesh):
    corners = np.empty(len(mesh.loops), np.int32)
    mesh.loops.foreach_get("vertex_index", corners)
    return corners


def defects(mesh):
    """Non-manifold edges by bmesh, and crossing triangle pairs by BVHTree.overlap
    (pairs sharing a vertex dropped: neighbours touch)."""
    bm = bmesh.new()
    bm.from_mesh(mesh)
    bmesh.ops.triangulate(bm, faces=bm.faces[:])
    not_manifold = sum(not e.is_manifold for e in bm.edges)
    bm.faces.ensure_lookup_table()
    tris = np.array([[v.index for v in f.verts] for f in bm.faces], dtype=np.int64)
    bvh = BVHTree.FromBMesh(bm)
    bm.free()
    pairs = np.array(bvh.overlap(bvh), dtype=np.int64).reshape(-1, 2)
    if len(pairs):
        shared = (tris[pairs[:, 0]][:, :, None] == tris[pairs[:, 1]][:, None, :]).any(axis=(1, 2))
        pairs = pairs[~shared & (pairs[:, 0] != pairs[:, 1])]
    return not_manifold, len(pairs)


def volume(mesh):
    p = positions(mesh).astype(np.float64)
    mesh.calc_loop_triangles()
    tris = np.empty(len(mesh.loop_triangles) * 3, np.int32)
    mesh.loop_triangles.foreach_get("vertices", tris)
    a, b, c = (p[tris.reshape(-1, 3)[:, k]] for k in range(3))
    return np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0


def test_build_field_mesh_of_a_sphere_is_closed_coloured_and_of_its_volume(scene):
    obj = api.build_field_mesh(json.dumps(sphere()), name="Ball", resolution=40)
    mesh = obj.data
    assert obj.name == "Ball" and obj.name in scene.collection.all_objects
    assert len(mesh.vertices) > 1000 and len(mesh.polygons) > 1000
    assert not mesh.validate(), "Blender had to fix the mesh"
    assert defects(mesh) == (0, 0)
    # Volume within 1% of the ball's (vertices lie on the sphere, facets cut inside).
    assert volume(mesh) == pytest.approx(4 / 3 * math.pi * RADIUS**3, rel=0.01)
    distance = np.linalg.norm(positions(mesh) - np.array(CENTER, np.float32), axis=1)
    cell = (2 * RADIUS) * (1 + 4 / 40) / 40
    np.testing.assert_allclose(distance, RADIUS, atol=0.05 * cell)
    # The colour attribute: the active and rendered one, the tree's colour everywhere.
    assert mesh.color_attributes.active_color_name == "thicket_color"
    assert mesh.color_attributes[mesh.color_attributes.render_color_index].name == "thicket_color"
    assert mesh.attributes["thicket_color"].data_type == "FLOAT_COLOR"
    np.testing.assert_array_equal(attribute(mesh, "thicket_color"), np.tile(np.float32(RED), (len(mesh.vertices), 1)))
    assert (attribute(mesh, "thicket_primitive_id") == 0).all() and (attribute(mesh, "thicket_texture") == 0).all()
    # A material shows it (a Color Attribute node reading it).
    nodes = mesh.materials[0].node_tree.nodes
    assert any(n.type == "VERTEX_COLOR" and n.layer_name == "thicket_color" for n in nodes)


def test_field_mesh_colours_ids_and_texture_are_field_evals_at_its_vertices(scene):
    tree = two_colours()
    obj = api.build_field_mesh(tree, resolution=48)
    mesh = obj.data
    ref = tn.field_eval(tree, positions(mesh))
    colors = attribute(mesh, "thicket_color")
    assert colors[:, 0].max() > 0.9 and colors[:, 2].max() > 0.9, "both spheres' colours are carried"
    np.testing.assert_allclose(colors, ref["colors"], atol=2e-3)
    ids = attribute(mesh, "thicket_primitive_id")
    assert set(np.unique(ids)) == {0, 1}
    # Ids agree away from the seam between the spheres (|x| small: weights near 1/2).
    away = np.abs(positions(mesh)[:, 0]) > 0.1
    np.testing.assert_array_equal(ids[away], ref["primitive_id"][away])
    np.testing.assert_allclose(attribute(mesh, "thicket_texture"), ref["texture"], atol=2e-3)
    assert defects(mesh) == (0, 0)


@pytest.mark.parametrize(
    "tree, message",
    [
        ("{not json", "not valid JSON"),
        (json.dumps({"op": "union_wp", "p": 0, "children": [sphere()]}), "p must be"),
        (json.dumps({"op": "union_wp", "p": -2, "children": [sphere()]}), "p must be"),
        ('{"op": "sphere", "center": [0, 0, NaN], "radius": 1}', "not valid JSON"),
        ({"op": "sphere", "center": [0, 0, math.nan], "radius": 1}, "JSON compliant"),
        ({"op": "sphere", "center": [0, 0, 0], "radius": -1}, "radius"),
        ("", "empty"),
    ],
)
def test_bad_trees_raise_thicket_errors_and_make_nothing(scene, tree, message):
    before = (len(bpy.data.meshes), len(bpy.data.objects), len(bpy.data.materials))
    with pytest.raises(api.ThicketError, match=message):
        api.build_field_mesh(tree, resolution=16)
    assert (len(bpy.data.meshes), len(bpy.data.objects), len(bpy.data.materials)) == before


@pytest.mark.parametrize(
    "resolution, bounds", [(4096, None), (1, None), (32, [(0, 0, 0), (1, 1)]), (32, [(0, 0, 0), (0, 1, 1)]), (32, [(0, 0, 0), (1, 1, math.nan)])]
)
def test_bad_settings_raise_thicket_errors_and_make_nothing(scene, resolution, bounds):
    before = (len(bpy.data.meshes), len(bpy.data.objects))
    with pytest.raises(api.ThicketError):
        api.build_field_mesh(json.dumps(sphere()), resolution=resolution, bounds=bounds)
    assert (len(bpy.data.meshes), len(bpy.data.objects)) == before


def test_progress_is_reported_and_a_cancel_makes_nothing(scene):
    seen = []
    api.build_field_mesh(json.dumps(sphere()), resolution=16, progress=seen.append)
    assert seen[0] == 0.0 and seen[-1] == 1.0 and seen == sorted(seen)
    before = (len(bpy.data.meshes), len(bpy.data.objects))
    with pytest.raises(tn.Cancelled):
        api.build_field_mesh(json.dumps(sphere()), resolution=16, progress=lambda f: f < 0.5)
    assert (len(bpy.data.meshes), len(bpy.data.objects)) == before
    # A cancel asked at the end, once the object is made, is too late: the object is
    # returned, not left behind by an exception.
    obj = api.build_field_mesh(json.dumps(sphere()), resolution=16, progress=lambda f: f < 1.0)
    assert obj.name in bpy.data.objects and len(bpy.data.objects) == before[1] + 1


def test_bounds_cut_an_open_tree(scene):
    plane = json.dumps({"op": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]})
    with pytest.raises(api.ThicketError, match="bound"):
        api.build_field_mesh(plane, resolution=8)
    obj = api.build_field_mesh(plane, resolution=8, bounds=[(-1, -1, -1), (1, 1, 1)])
    co = positions(obj)
    assert len(co) > 0 and co.min() >= -1 - 1e-5 and co.max() <= 1 + 1e-5


def test_the_operator_builds_from_a_text_undoes_and_reports_errors(scene):
    assert not bpy.ops.thicket.field_mesh_add.poll(), "no Text: nothing to build from"
    text = bpy.data.texts.new("ball.json")
    text.write(json.dumps(sphere()))
    assert bpy.ops.thicket.field_mesh_add.poll()
    assert {"REGISTER", "UNDO"} <= THICKET_OT_field_mesh_add.bl_options
    bpy.ops.ed.undo_push(message="before")
    assert bpy.ops.thicket.field_mesh_add(resolution=24) == {"FINISHED"}
    # The step the interface pushes after an UNDO operator (scripts push it themselves).
    bpy.ops.ed.undo_push(message="Add Field Mesh")
    obj = bpy.context.active_object
    assert obj is not None and obj.name == "ball" and len(obj.data.vertices) > 0
    assert obj["thicket_field_text"] == bpy.data.texts["ball.json"]
    bpy.ops.ed.undo()
    assert "ball" not in bpy.data.objects
    assert not any(m.users for m in bpy.data.meshes)
    # A bad tree: reported (a RuntimeError in scripts), nothing made.
    bad = bpy.data.texts.new("bad")
    bad.write('{"op": "union_wp", "p": 0, "children": []}')
    meshes = len(bpy.data.meshes)
    with pytest.raises(RuntimeError, match="p must be"):
        bpy.ops.thicket.field_mesh_add(text="bad", resolution=24)
    with pytest.raises(RuntimeError, match="no Text named"):
        bpy.ops.thicket.field_mesh_add(text="missing")
    assert len(bpy.data.meshes) == meshes


def test_a_field_mesh_saves_reloads_and_regenerates(scene, tmp_path):
    text = bpy.data.texts.new("tree")
    text.write(two_colours())
    obj = api.build_field_mesh(text, name="Blob", resolution=32, bounds=[(-1.5, -1, -1), (1.5, 1, 1)], adaptive=False)
    count = len(obj.data.vertices)
    path = str(tmp_path / "field.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    obj = bpy.data.objects["Blob"]
    assert len(obj.data.vertices) == count
    settings = api.regenerate_field_mesh(obj) and __import__("thicket.fields", fromlist=["x"]).field_settings(obj)
    assert settings["resolution"] == 32 and settings["adaptive"] is False and settings["bounds"] == [-1.5, -1, -1, 1.5, 1, 1]
    assert len(obj.data.vertices) == count
    assert obj.data.color_attributes.active_color_name == "thicket_color"
    # Regenerating reads the Text: a smaller tree gives fewer vertices; a bad one
    # raises and keeps the mesh.
    obj["thicket_field_text"].from_string(json.dumps(sphere((0, 0, 0), 0.4)))
    api.regenerate_field_mesh(obj)
    assert 0 < len(obj.data.vertices) < count
    smaller = len(obj.data.vertices)
    obj["thicket_field_text"].from_string('{"op": "sphere"}')
    with pytest.raises(api.ThicketError):
        api.regenerate_field_mesh(obj)
    assert len(obj.data.vertices) == smaller
    with pytest.raises(TypeError, match="not a Thicket Field Mesh"):
        api.regenerate_field_mesh(add("cube"))


def subdivided_cube(cuts=4):
    cube = add("cube", size=1.0)
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.subdivide(number_cuts=cuts)
    bpy.ops.object.mode_set(mode="OBJECT")
    return cube


def test_solid_texture_colour_is_field_evals_colour_at_each_vertex_and_corner(scene):
    cube = subdivided_cube()
    source = positions(cube).copy()
    tree = striped()
    result = api.add_solid_texture(cube, tree, mode="COLOR")
    mesh = result.data
    ref = tn.field_eval(tree, positions(mesh))
    colors = attribute(mesh, "thicket_color")
    assert np.ptp(colors[:, 0]) > 0.5, "the stripes vary over the cube"
    np.testing.assert_allclose(colors, ref["colors"], atol=1e-6)
    np.testing.assert_allclose(attribute(mesh, "thicket_texture"), ref["texture"], atol=1e-6)
    assert mesh.color_attributes.active_color_name == "thicket_color"
    np.testing.assert_array_equal(positions(mesh), source)
    # Per face corner: each corner has its vertex's colour.
    item = cube.thicket.items[0]
    item.domain = "CORNER"
    api.regenerate(cube)
    mesh = result.data
    corner_colors = attribute(mesh, "thicket_color", "CORNER")
    np.testing.assert_allclose(corner_colors, ref["colors"][corner_vertices(mesh)], atol=1e-6)
    # The source is untouched.
    np.testing.assert_array_equal(positions(cube), source)
    assert "thicket_color" not in cube.data.attributes


def test_solid_texture_displaces_along_normals_by_amplitude_times_texture(scene):
    cube = subdivided_cube()
    source = positions(cube).copy()
    normals = np.empty(len(cube.data.vertices) * 3, np.float32)
    cube.data.vertices.foreach_get("normal", normals)
    normals = normals.reshape(-1, 3)
    tree = striped()
    texture = tn.field_eval(tree, source)["texture"]
    assert np.ptp(texture) > 0.5
    result = api.add_solid_texture(cube, tree, mode="DISPLACE", amplitude=0.05)
    moved = positions(result)
    np.testing.assert_allclose(moved, source + 0.05 * texture[:, None] * normals, atol=1e-5)
    assert len(result.data.polygons) == len(cube.data.polygons)
    np.testing.assert_array_equal(positions(cube), source)
    # The same tree's colours after the displacement: chained in one stack.
    api.add_item(cube, "SOLID_TEXTURE", tree=tree)
    api.regenerate(cube)
    np.testing.assert_allclose(attribute(result.data, "thicket_color"), tn.field_eval(tree, positions(result))["colors"], atol=1e-6)


def test_solid_texture_after_a_shell_colours_the_shell(scene):
    cube = subdivided_cube(2)
    select_only(cube)
    shell = api.add_thick_surface(cube, thickness=0.1, thickness_mode="ABSOLUTE", output="SOLID")
    shell_vertices = positions(shell).copy()
    tree = striped()
    result = api.add_solid_texture(cube, tree)
    assert result == shell and [i.kind for i in cube.thicket.items] == ["OFFSET_SHELL", "SOLID_TEXTURE"]
    np.testing.assert_array_equal(positions(result), shell_vertices)
    np.testing.assert_allclose(attribute(result.data, "thicket_color"), tn.field_eval(tree, shell_vertices)["colors"], atol=1e-6)
    assert "thicket_director" in result.data.attributes, "the shell's attributes are kept"


def test_solid_texture_errors_add_nothing_and_reach_the_stack(scene):
    cube = subdivided_cube(1)
    with pytest.raises(api.ThicketError, match="p must be"):
        api.add_solid_texture(cube, json.dumps({"op": "union_wp", "p": -1, "children": [sphere()]}))
    assert len(cube.thicket.items) == 0
    # A tree broken later (in a Text) is the stack's error, shown on the panel.
    text = bpy.data.texts.new("tex")
    text.write(striped())
    api.add_solid_texture(cube, text)
    text.from_string("{")
    with pytest.raises(api.ThicketError, match="JSON"):
        api.regenerate(cube)
    cube.thicket.items[0].tree_text = None  # the item's own (empty) tree: refused, named
    assert "no field tree" in cube.thicket.last_error


def test_editing_a_tree_text_regenerates_the_stacks_that_read_it(scene):
    """Texts are not in the depsgraph, so typing in one sends no update: the watcher
    (a timer in the interface; called here as the timer calls it) regenerates the
    stacks reading an edited Text, and only those. A tree broken halfway through
    typing is the stack's error, the last result kept."""
    from thicket.stack import text_watch

    assert text_watch.is_watching()
    cube, other = subdivided_cube(2), subdivided_cube(1)
    text = bpy.data.texts.new("tree")
    text.write(striped())
    result = api.add_solid_texture(cube, text)
    api.add_solid_texture(other, striped())  # its own JSON: not a reader of the Text
    text_watch.poll()  # the first look only remembers
    assert text_watch.poll() == [], "nothing edited"
    before = attribute(result.data, "thicket_color").copy()
    text.from_string(striped(omega=3.0))
    assert text_watch.poll() == [cube]
    after = attribute(result.data, "thicket_color")
    np.testing.assert_allclose(after, tn.field_eval(striped(omega=3.0), positions(result))["colors"], atol=1e-6)
    assert np.abs(after - before).max() > 0.1
    # A Text no stack reads (a script) is never compared; the read one is found by
    # its users, with or without a fake user of its own.
    script = bpy.data.texts.new("script")
    script.write("print('hello')")
    text_watch.poll()
    script.from_string("print('edited')")
    assert text_watch.poll() == [] and script.as_pointer() not in text_watch._seen
    text.use_fake_user = False
    text.from_string(striped(omega=2.0))
    assert text_watch.poll() == [cube]
    text.from_string("{")
    assert text_watch.poll() == [cube]
    assert "JSON" in cube.thicket.last_error
    np.testing.assert_allclose(attribute(result.data, "thicket_color"), tn.field_eval(striped(omega=2.0), positions(result))["colors"], atol=1e-6)


def test_solid_texture_refuses_a_colour_attribute_named_like_a_uv_map_or_a_reserved_one(scene):
    cube = subdivided_cube(1)
    uv = cube.data.uv_layers[0].name
    for name in (uv, "position", "thicket_texture", ".hidden"):
        with pytest.raises(api.ThicketError, match="cannot be called"):
            api.add_solid_texture(cube, json.dumps(sphere()), domain="CORNER", color_attribute=name)
        cube.thicket.items.clear()
    assert [layer.name for layer in cube.data.uv_layers] == [uv]


def test_the_item_add_operator_adds_a_solid_texture(scene):
    cube = subdivided_cube(1)
    select_only(cube)
    bpy.ops.thicket.item_add(kind="SOLID_TEXTURE")
    assert [i.kind for i in cube.thicket.items] == ["SOLID_TEXTURE"] and cube.thicket.items[0].name == "Solid Texture"
    assert "no field tree" in cube.thicket.last_error
    cube.thicket.items[0].tree = striped()  # regenerates live (at once, headless)
    assert cube.thicket.last_error == ""
    assert "thicket_color" in cube.thicket.result.data.attributes


def test_vertex_normals_match_blenders():
    """field_tree.vertex_normals (numpy) against Blender's on a mesh with quads, triangles and uneven faces."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    obj = add("monkey")
    mesh = obj.data
    from thicket import mesh_io

    arrays = mesh_io.read_mesh(mesh)
    ours = field_tree.vertex_normals(arrays)
    theirs = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("normal", theirs)
    np.testing.assert_allclose(ours, theirs.reshape(-1, 3), atol=1e-4)


class Layout:
    """Records what a draw function shows; every property drawn must exist."""

    def __init__(self, drawn):
        self.drawn = drawn

    def __getattr__(self, name):
        if name in ("column", "row", "box"):
            return lambda **kw: self
        if name in ("separator", "label", "operator", "prop_search"):
            return lambda *a, **kw: type("Any", (), {"__setattr__": lambda *a: None})()
        raise AttributeError(name)

    def prop(self, data, name, **kw):
        assert name in data.bl_rna.properties, name
        self.drawn.append(name)


def test_the_panel_draws_the_solid_texture_settings(scene):
    from thicket.ui.item_settings import draw_item_settings

    cube = subdivided_cube(1)
    api.add_item(cube, "SOLID_TEXTURE", tree=striped())
    item = cube.thicket.items[0]
    drawn = []
    draw_item_settings(Layout(drawn), cube, item)
    assert drawn == ["tree_text", "tree", "mode", "domain", "color_attribute"]
    item.mode = "DISPLACE"
    drawn.clear()
    draw_item_settings(Layout(drawn), cube, item)
    assert drawn == ["tree_text", "tree", "mode", "amplitude"]


def image_rgba(image):
    width, height = image.size
    pixels = np.empty(width * height * 4, np.float32)
    image.pixels.foreach_get(pixels)
    return pixels.reshape(height, width, 4)[::-1]  # row 0 at the top, as rendered


def test_render_field_frames_the_tree_without_a_camera(scene):
    tree = json.dumps(sphere())
    image = api.render_field(tree, width=64, height=48, image="Ball")
    assert image.name == "Ball" and tuple(image.size) == (64, 48) and image.is_float
    rgba = image_rgba(image)
    # The ball is framed: covered in the middle, empty at the corners, red where hit.
    assert rgba[24, 32, 3] > 0.99 and rgba[0, 0, 3] == 0 and rgba[-1, -1, 3] == 0
    hit = rgba[..., 3] > 0.99
    assert 0.1 < hit.mean() < 0.9
    assert (rgba[hit][:, 0] > rgba[hit][:, 2]).all(), "shaded red, not blue"
    # The same image again: resized in place, not a second image.
    images = len(bpy.data.images)
    api.render_field(tree, width=32, height=32, image="Ball")
    assert len(bpy.data.images) == images and tuple(bpy.data.images["Ball"].size) == (32, 32)


def test_render_field_from_a_camera_is_field_render_with_its_matrices(scene):
    tree = two_colours()
    bpy.ops.object.camera_add(location=(0, -6, 0), rotation=(math.pi / 2, 0, 0))
    camera = bpy.context.active_object
    image = api.render_field(tree, camera=camera, width=40, height=30)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    view = np.array(camera.matrix_world.inverted(), np.float32)
    projection = np.array(camera.calc_matrix_camera(depsgraph, x=40, y=30), np.float32)
    expected = tn.field_render(tree, view, projection, width=40, height=30)
    np.testing.assert_allclose(image_rgba(image), expected, atol=1e-6)
    rgba = image_rgba(image)
    # Looking along +y: the red sphere (x < 0) on the left, the blue one on the right.
    assert rgba[15, 13, 3] == 1 and rgba[15, 13, 0] > 2 * rgba[15, 13, 2]
    assert rgba[15, 27, 3] == 1 and rgba[15, 27, 2] > 2 * rgba[15, 27, 0]
    assert rgba[15, 2, 3] == 0 and rgba[2, 20, 3] == 0


def test_render_field_refuses_bad_input_and_makes_no_image(scene):
    images = len(bpy.data.images)
    with pytest.raises(api.ThicketError, match="p must be"):
        api.render_field(json.dumps({"op": "union_wp", "p": 0, "children": [sphere()]}))
    with pytest.raises(api.ThicketError):
        api.render_field(json.dumps({"op": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]}))  # nothing bounds it: no default view
    with pytest.raises(api.ThicketError, match="width and height"):
        api.render_field(json.dumps(sphere()), width=0)
    with pytest.raises(TypeError, match="camera"):
        api.render_field(json.dumps(sphere()), camera=add("cube"))
    assert len(bpy.data.images) == images


def test_render_field_never_overwrites_a_users_image(scene):
    """An image of the requested name that Thicket did not make (here a texture a
    material uses) is left as it was; the render goes to a new image."""
    albedo = bpy.data.images.new("Albedo", 4, 4)
    material = bpy.data.materials.new("M")
    material.use_nodes = True
    node = material.node_tree.nodes.new("ShaderNodeTexImage")
    node.image = albedo
    tree = json.dumps(sphere())
    image = api.render_field(tree, width=16, height=16, image="Albedo")
    assert image != albedo and node.image == albedo and tuple(albedo.size) == (4, 4)
    # Its own image it reuses.
    assert api.render_field(tree, width=16, height=16, image=image.name) == image
