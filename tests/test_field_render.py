"""Sphere-traced renders of field trees (issue 17) with a real Blender camera: the
matrices Blender gives (matrix_world.inverted(), calc_matrix_camera), the image written
into bpy.data.images, and the silhouette checked against Blender's own projection of
the sphere (bpy_extras.object_utils.world_to_camera_view), perspective and orthographic."""

import json
import math
import time

import bpy
import numpy as np
import pytest
from bpy_extras.object_utils import world_to_camera_view
from mathutils import Vector

import thicket_native as tn

RED, BLUE = [1.0, 0.0, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0]


def sphere(center, radius, color):
    return {"op": "sphere", "center": list(center), "radius": radius, "color": color}


def camera(scene, location, target, w, h, ortho_scale=None):
    """A scene camera at `location` aimed at `target`, rendering w x h."""
    cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    scene.collection.objects.link(cam)
    scene.camera = cam
    cam.location = location
    cam.rotation_euler = (Vector(target) - Vector(location)).to_track_quat("-Z", "Y").to_euler()
    if ortho_scale is not None:
        cam.data.type = "ORTHO"
        cam.data.ortho_scale = ortho_scale
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = w, h, 100
    bpy.context.view_layer.update()
    return cam


def render(scene, cam, node, w, h):
    depsgraph = bpy.context.evaluated_depsgraph_get()
    view, projection = cam.matrix_world.inverted(), cam.calc_matrix_camera(depsgraph, x=w, y=h)
    return tn.field_render(json.dumps(node), view, projection, width=w, height=h)


def to_image(rgba, name="field render"):
    """The render as a Blender image (rows flipped: Image.pixels start at the bottom),
    and what Blender holds for it, read back as (h, w, 4) from the top."""
    h, w = rgba.shape[:2]
    image = bpy.data.images.new(name, w, h, alpha=True, float_buffer=True)
    image.pixels.foreach_set(np.ascontiguousarray(rgba[::-1]).ravel())
    back = np.empty(w * h * 4, np.float32)
    image.pixels.foreach_get(back)
    return image, back.reshape(h, w, 4)[::-1]


def projected_disc(scene, cam, center, radius, w, h, directions):
    """The sphere's outline in pixels (x right, y down, centres at + 0.5), by
    Blender's projection: the centre, and outline points along each `directions`
    (the silhouette's rays make asin(r / d) with the axis for a perspective camera;
    an orthographic one shows the radius itself)."""
    center = Vector(center)

    def pixel(p):
        uv = world_to_camera_view(scene, cam, p)
        return np.array([uv.x * w, (1.0 - uv.y) * h])

    c = pixel(center)
    eye = cam.matrix_world.translation
    radii = []
    for d in directions:
        if cam.data.type == "ORTHO":
            p = center + radius * d
        else:
            axis = (center - eye).normalized()
            a = math.asin(radius / (center - eye).length)
            p = eye + math.cos(a) * axis + math.sin(a) * d
        radii.append(np.linalg.norm(pixel(p) - c))
    ys, xs = np.mgrid[0:h, 0:w] + 0.5
    return c, radii, np.hypot(xs - c[0], ys - c[1])


def iou(a, b):
    return np.logical_and(a, b).sum() / np.logical_or(a, b).sum()


@pytest.mark.parametrize("ortho_scale", [None, 5.0])
def test_a_sphere_render_matches_blenders_projection_of_it(scene, ortho_scale):
    w, h = 320, 240
    center, radius = (0.3, -0.2, 0.4), 1.1
    # Perspective: aimed at the centre (the outline is a circle); orthographic: aimed
    # beside it (any sphere is a circle there).
    target = center if ortho_scale is None else (0.0, 0.0, 0.0)
    cam = camera(scene, (3.0, -4.0, 2.5), target, w, h, ortho_scale)
    rgba = render(scene, cam, sphere(center, radius, [0.2, 0.6, 0.9, 1.0]), w, h)
    assert rgba.shape == (h, w, 4) and rgba.dtype == np.float32 and np.isfinite(rgba).all()
    image, back = to_image(rgba)
    assert tuple(image.size) == (w, h) and np.array_equal(back, rgba)
    right, up = cam.matrix_world.col[0].xyz.normalized(), cam.matrix_world.col[1].xyz.normalized()
    c, radii, distance = projected_disc(scene, cam, center, radius, w, h, [right, up])
    # Square pixels: the same radius across and up.
    assert abs(radii[0] - radii[1]) < 1e-3 * radii[0] and radii[0] > 40
    hit = back[..., 3] > 0
    assert iou(hit, distance <= radii[0]) > 0.98
    # Opaque inside, transparent (all zero) outside; lit most where it faces the camera.
    assert (back[hit][:, 3] == 1.0).all() and (back[~hit] == 0.0).all()
    face = back[int(c[1]), int(c[0])]
    assert abs(face[2] - 0.9) < 0.03 and abs(face[1] - 0.6) < 0.03, face


def test_a_coloured_union_shows_each_colour_where_blender_projects_it(scene):
    w, h = 200, 120
    left, right = (-1.0, 0.0, 0.0), (1.0, 0.0, 0.0)
    cam = camera(scene, (0.0, -7.0, 0.0), (0.0, 0.0, 0.0), w, h)
    node = {"op": "union_wp", "p": 16, "children": [sphere(left, 0.8, RED), sphere(right, 0.8, BLUE)]}
    _, back = to_image(render(scene, cam, node, w, h))
    for center, ours, other in [(left, 0, 2), (right, 2, 0)]:
        uv = world_to_camera_view(scene, cam, Vector(center))
        px = back[int((1.0 - uv.y) * h), int(uv.x * w)]
        assert px[ours] > 0.8 and px[other] < 0.01 and px[3] == 1.0, px
    hit = back[..., 3] > 0
    assert hit[:, : w // 2].sum() > 1000 and hit[:, w // 2 :].sum() > 1000
    red = hit & (back[..., 0] > 5 * back[..., 2])
    blue = hit & (back[..., 2] > 5 * back[..., 0])
    assert not red[:, w // 2 + 5 :].any() and not blue[:, : w // 2 - 5].any()


def test_a_texture_ramp_colours_the_render(scene):
    w, h = 96, 96
    cam = camera(scene, (0.0, -5.0, 0.0), (0.0, 0.0, 0.0), w, h)
    plane = {"op": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]}
    ramp = [[0.0, RED], [0.45, RED], [0.55, BLUE], [1.0, BLUE]]
    node = {"op": "displace", "shape": sphere((0, 0, 0), 1.0, [1, 1, 1, 1]), "texture": plane, "amplitude": 0, "omega": 4, "ramp": ramp}
    _, back = to_image(render(scene, cam, node, w, h))
    # At z = 0 the texture value is 1 (blue); at z = +-pi/4 it is 0 (red).
    for z, ours in [(0.0, 2), (math.pi / 4, 0), (-math.pi / 4, 0)]:
        uv = world_to_camera_view(scene, cam, Vector((0.0, -math.sqrt(1.0 - z * z), z)))
        px = back[int((1.0 - uv.y) * h), int(uv.x * w)]
        assert px[ours] > 0.5 and px[2 - ours] == 0.0, (z, px)


def test_defaults_render_512_square_quickly(scene):
    cam = camera(scene, (2.2, -2.6, 1.8), (0.0, 0.0, 0.0), 512, 512)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    node = {"op": "union_wp", "p": 8, "children": [sphere((0, 0, 0), 0.45, RED), sphere((0.6, 0.1, 0.2), 0.25, BLUE)]}
    start = time.perf_counter()
    rgba = tn.field_render(json.dumps(node), cam.matrix_world.inverted(), cam.calc_matrix_camera(depsgraph, x=512, y=512))
    elapsed = time.perf_counter() - start
    assert rgba.shape == (512, 512, 4) and (rgba[..., 3] > 0).any()
    # The issue asks for under a second (a shared CI machine gets slack).
    assert elapsed < 5.0, elapsed


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"width": 0}, "1 to 16384 pixels on each side, got 0 x 16"),
        ({"height": -3}, "height must be 1 to 16384"),
        ({"width": 20000}, "1 to 16384 pixels"),
        ({"view": np.zeros((4, 4))}, "not invertible"),
        ({"projection": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}, "projection must be a 4x4 matrix"),
        ({"view": "not a matrix"}, "view must be a 4x4 matrix"),
        ({"projection": np.full((4, 4), np.nan)}, "must be finite"),
        ({"tree": {"op": "sphere", "center": [0, 0, 0]}}, "missing field"),
    ],
)
def test_bad_cameras_and_trees_raise_invalid_input(scene, change, message):
    cam = camera(scene, (0.0, -5.0, 0.0), (0.0, 0.0, 0.0), 16, 16)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    args = {
        "tree": sphere((0, 0, 0), 1.0, RED),
        "view": cam.matrix_world.inverted(),
        "projection": cam.calc_matrix_camera(depsgraph, x=16, y=16),
        "width": 16,
        "height": 16,
    }
    args.update(change)
    with pytest.raises(tn.InvalidInput, match=message):
        tn.field_render(json.dumps(args.pop("tree")), **args)


def test_gpu_and_cpu_paths_agree_through_the_binding(scene):
    """device="gpu" (the wgpu tracer; lavapipe in CI) against device="cpu": the same
    silhouette and colours; "auto" renders too, and a bad device name is refused."""
    w, h = 128, 96
    cam = camera(scene, (2.2, -2.6, 1.8), (0.0, 0.0, 0.0), w, h)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    view, projection = cam.matrix_world.inverted(), cam.calc_matrix_camera(depsgraph, x=w, y=h)
    plane = {"op": "plane", "point": [0, 0, 0], "normal": [0.2, 0.3, 1]}
    ramp = [[0.0, RED], [1.0, BLUE]]
    node = {
        "op": "union_wp",
        "p": 8,
        "children": [
            {"op": "displace", "shape": sphere((0, 0, 0), 0.6, [1, 1, 1, 1]), "texture": plane, "amplitude": 0.03, "omega": 12, "tau": 0.0, "ramp": ramp},
            {"op": "torus", "center": [0.5, 0.3, 0.2], "axis": [0, 0.3, 1], "major": 0.4, "minor": 0.1, "color": [0.2, 0.9, 0.3, 1]},
        ],
    }
    text = json.dumps(node)
    cpu = tn.field_render(text, view, projection, width=w, height=h, device="cpu")
    gpu = tn.field_render(text, view, projection, width=w, height=h, device="gpu")
    auto = tn.field_render(text, view, projection, width=w, height=h, device="auto")
    assert gpu.shape == cpu.shape == auto.shape == (h, w, 4) and gpu.dtype == np.float32
    hit_cpu, hit_gpu = cpu[..., 3] > 0, gpu[..., 3] > 0
    assert hit_cpu.sum() > 1000
    assert iou(hit_cpu, hit_gpu) >= 0.99
    both = hit_cpu & hit_gpu
    assert np.abs(cpu[both][:, :3] - gpu[both][:, :3]).mean() < 0.01
    assert iou(hit_cpu, auto[..., 3] > 0) >= 0.99
    with pytest.raises(tn.InvalidInput, match="device must be"):
        tn.field_render(text, view, projection, width=w, height=h, device="tpu")
