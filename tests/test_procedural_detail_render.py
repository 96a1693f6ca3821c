"""The Procedural Detail item's geometry and colours as Blender's own renderer shows
them: Cycles (CPU) renders the planet preset's result, lit by nothing but its
`thicket_color` attribute (an Emission shader), from an orthographic camera above, and
the rendered shares of sea and land match those computed from the mesh's own faces
and vertex colours (projected areas of the faces seen from the camera)."""

import math
import warnings

import bpy
import numpy as np
from conftest import add

from thicket import api
from thicket.pure.field_tree import COLOR_ATTRIBUTE


def emission_of_attribute(name):
    material = bpy.data.materials.new("thicket colours")
    with warnings.catch_warnings():  # Blender 5 deprecates it; 4.2 needs it
        warnings.simplefilter("ignore", DeprecationWarning)
        material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    attribute = nodes.new("ShaderNodeAttribute")
    attribute.attribute_type, attribute.attribute_name = "GEOMETRY", name
    emission = nodes.new("ShaderNodeEmission")
    output = nodes.new("ShaderNodeOutputMaterial")
    links.new(attribute.outputs["Color"], emission.inputs["Color"])
    links.new(emission.outputs["Emission"], output.inputs["Surface"])
    return material


def render_rgba(scene, path, size):
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 4
    scene.render.film_transparent = True
    scene.view_settings.view_transform = "Standard"
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGBA"
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(path)
    pixels = np.empty(size * size * 4, np.float32)
    image.pixels.foreach_get(pixels)
    return pixels.reshape(size, size, 4)


def sea_from_above(mesh, frame, size, n=4):
    """Where the surface seen from +z is sea-like (blue over green), from the mesh alone:
    each quad split into two triangles, each triangle into n^2 smaller ones whose centres
    take the linearly interpolated vertex colour (as a renderer interpolates it), each
    weighted by its area projected on the xy plane (0 turned away). Returns the sea share
    and, per pixel of a `size`^2 image of the square `frame` wide centred on the z axis
    (row 0 at y = -frame / 2), whether most of what lands there is sea (None: nothing)."""
    co = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3).astype(np.float64)
    colors = np.empty(len(mesh.vertices) * 4, np.float32)
    mesh.attributes[COLOR_ATTRIBUTE].data.foreach_get("color", colors)
    colors = colors.reshape(-1, 4).astype(np.float64)
    corners = np.empty(len(mesh.loops), np.int32)
    mesh.loops.foreach_get("vertex_index", corners)
    quads = corners.reshape(-1, 4)  # the detail's faces are all quads
    tris = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    p, c = co[tris], colors[tris]
    area_z = np.clip(0.5 * np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])[:, 2], 0.0, None)
    # Centres of the n^2 sub-triangles in barycentric coordinates (each 1/n^2 of the area).
    centres = [((i + 1 / 3) / n, (j + 1 / 3) / n) for i in range(n) for j in range(n - i)]
    centres += [((i + 2 / 3) / n, (j + 2 / 3) / n) for i in range(n) for j in range(n - i - 1)]
    votes, weights = np.zeros(size * size), np.zeros(size * size)
    sea_area = 0.0
    for u, v in centres:
        mixed = (1 - u - v) * c[:, 0] + u * c[:, 1] + v * c[:, 2]
        at = (1 - u - v) * p[:, 0] + u * p[:, 1] + v * p[:, 2]
        sea = mixed[:, 2] > mixed[:, 1]
        sea_area += (area_z * sea).sum()
        col = np.clip(((at[:, 0] / frame + 0.5) * size).astype(int), 0, size - 1)
        row = np.clip(((at[:, 1] / frame + 0.5) * size).astype(int), 0, size - 1)
        np.add.at(votes, row * size + col, area_z * sea)
        np.add.at(weights, row * size + col, area_z)
    share = float(sea_area / (len(centres) * area_z.sum()))
    seen = weights > 0
    return share, (votes > 0.5 * weights).reshape(size, size), seen.reshape(size, size)


def test_cycles_shows_the_planet_colours_where_the_mesh_has_them(scene, tmp_path):
    planet = add("ico_sphere", subdivisions=3)
    result = api.add_procedural_detail(planet, preset="PLANET", levels=2)
    planet.hide_render = True
    result.data.materials.append(emission_of_attribute(COLOR_ATTRIBUTE))
    bpy.ops.object.camera_add(location=(0.0, 0.0, 6.0), rotation=(0.0, 0.0, 0.0))
    camera = bpy.context.object
    camera.data.type, camera.data.ortho_scale = "ORTHO", 2.6
    scene.camera = camera
    size, frame = 160, 2.6
    rgba = render_rgba(scene, str(tmp_path / "planet.png"), size)

    covered = rgba[..., 3] > 0.99
    sea_pixels = covered & (rgba[..., 2] > rgba[..., 1])
    rendered_sea = sea_pixels.sum() / covered.sum()

    expected_sea, expected_map, seen = sea_from_above(result.data, frame, size)
    assert 0.15 < expected_sea < 0.85, f"the preset has both sea and land ({expected_sea:.2f})"
    assert abs(rendered_sea - expected_sea) < 0.04, f"Cycles shows {rendered_sea:.3f} sea, the mesh {expected_sea:.3f}"
    # And in the same places: the seas Cycles draws are the mesh's, pixel for pixel
    # (away from the rim, where the filter mixes in the transparent background).
    inner = covered & seen & (rgba[..., 3] > 0.999)
    same = np.logical_and(sea_pixels, expected_map)[inner].sum() / max(1, np.logical_or(sea_pixels, expected_map)[inner].sum())
    assert same > 0.85, f"sea IoU {same:.3f}"
    # The rendered disc is the detailed sphere's: about pi r^2 of the frame.
    disc = covered.sum() * (frame / size) ** 2
    assert abs(disc - math.pi * 1.0**2) < 0.15 * math.pi, disc
