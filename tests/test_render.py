"""Rendering thick surfaces without baking (thick surfaces, chapters 5-6), checked
against Blender's own renderer (Cycles on the CPU) from the same cameras."""

import math

import bpy
import numpy as np
import pytest
from conftest import add

import thicket_native as tn
from thicket import api
from thicket.pure.kinds.volumetric_texture import native_settings
from thicket.render import camera, preview


def slab_sphere(tmp_path, radius=1.0):
    """A UV sphere with a shell and a slab texture (alpha 1 up to r = 0.5): its
    thick surface is a closed surface halfway through the shell."""
    nz = 21
    slab = np.zeros((nz, 4, 4), np.float32)
    slab[: nz // 2] = 1.0
    path = str(tmp_path / "slab.exr")
    tn.save_texture(path, slab)
    sphere = add("uv_sphere", segments=48, ring_count=24, radius=radius)
    api.add_volumetric_texture(sphere, "weave", shell_thickness=0.05, resolution=6, depth_steps=40, source="FILE", filepath=path)
    return sphere


def cycles_alpha(scene, path):
    """Cycles' alpha of the scene from its camera (film transparent, few samples)."""
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 4
    scene.render.film_transparent = True
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGBA"
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(path)
    w, h = image.size
    pixels = np.empty(w * h * 4, np.float32)
    image.pixels.foreach_get(pixels)
    return pixels.reshape(h, w, 4)[::-1, :, 3]  # row 0 at the top


def cycles_and_view(scene, tmp_path, obj, location, rotation, size):
    """A new camera at `location` with Euler `rotation` (radians) made the scene's,
    at `size` (width, height) pixels: Cycles' silhouette from it (alpha > 0.5), and
    the view and projection matrices of `obj`'s preview from the same camera."""
    bpy.ops.object.camera_add(location=location, rotation=rotation)
    scene.camera = bpy.context.object
    width, height = size
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = width, height, 100
    bpy.context.view_layer.update()
    baked = cycles_alpha(scene, str(tmp_path / "cycles.png")) > 0.5
    view, projection = camera.scene_camera(scene, bpy.context.evaluated_depsgraph_get(), obj, width, height)
    return baked, view, projection


def iou(a, b):
    return np.logical_and(a, b).sum() / max(1, np.logical_or(a, b).sum())


CAMERAS = {
    "perspective, shifted": dict(type="PERSP", lens=40.0, shift_x=0.08, shift_y=-0.05, sensor_fit="AUTO", size=(160, 120)),
    "perspective, vertical fit": dict(type="PERSP", lens=55.0, sensor_fit="VERTICAL", size=(96, 144)),
    "orthographic": dict(type="ORTHO", ortho_scale=4.0, size=(128, 96)),
}


@pytest.mark.parametrize("name", list(CAMERAS))
def test_silhouettes_agree_with_cycles_from_the_same_camera(scene, tmp_path, name):
    spec = dict(CAMERAS[name])
    width, height = spec.pop("size")
    sphere = slab_sphere(tmp_path)
    sphere.location = (0.3, 0.1, -0.2)
    sphere.hide_render = True  # Cycles draws the baked thick surface (the result)
    bpy.ops.object.camera_add(location=(0.5, -6.0, 1.5), rotation=(math.radians(78), 0.0, math.radians(4)))
    cam = bpy.context.object
    for key, value in spec.items():
        setattr(cam.data, key, value)
    scene.camera = cam
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = width, height, 100
    bpy.context.view_layer.update()
    reference = cycles_alpha(scene, str(tmp_path / "cycles.png")) > 0.5
    depsgraph = bpy.context.evaluated_depsgraph_get()
    view, projection = camera.scene_camera(scene, depsgraph, sphere, width, height)
    out = preview.render_arrays(sphere, view, projection, width, height, method="reference")
    ours = out["rgba"][:, :, 3] > 0.5
    assert out["rgba"].shape == (height, width, 4)
    assert 0.05 < reference.mean() < 0.9, "the sphere is in view"
    score = iou(ours, reference)
    assert score >= 0.98, f"{name}: IoU {score:.4f}"


@pytest.mark.parametrize("effect", ["holes", "region", "cutter"])
def test_the_preview_shows_holes_regions_and_cutters_as_cycles_shows_the_bake(scene, tmp_path, effect):
    # Preview = bake (issue 15): the preview used to draw the texture everywhere,
    # whatever the stack cut away or left to the base slab.
    sphere = slab_sphere(tmp_path)
    item = sphere.thicket.items[-1]
    if effect == "cutter":
        cutter = add("cube", size=2.0, location=(-1.2, 0.0, 0.0))
        cutter.hide_render = True
        item.cutter = cutter
    else:
        group = sphere.vertex_groups.new(name="upper")
        upper = [v.index for v in sphere.data.vertices if v.co.z > 0.2]
        group.add(upper, 1.0, "REPLACE")
        if effect == "holes":
            item.hole_group = "upper"
        else:
            lower = sphere.vertex_groups.new(name="lower")
            lower.add([v.index for v in sphere.data.vertices if v.co.z <= 0.2], 1.0, "REPLACE")
            item.vertex_group = "lower"  # the texture below, the base slab above
    api.regenerate(sphere)
    sphere.hide_render = True
    width, height = 128, 96
    baked, view, projection = cycles_and_view(scene, tmp_path, sphere, (0.4, -6.0, 1.2), (math.radians(80), 0.0, math.radians(4)), (width, height))
    out = preview.render_arrays(sphere, view, projection, width, height)
    ours = out["rgba"][:, :, 3] > 0.5
    # The GPU slice renderer draws every effect (a cutter too), with nothing to say.
    assert "GPU" in out["renderer"] and out["fallback"] == "", (out["renderer"], out["fallback"])
    # Without the effect the preview shows more than the bake does.
    item.cutter, item.hole_group, item.vertex_group = None, "", ""
    plain = preview.render_arrays(sphere, view, projection, width, height, method="reference")["rgba"][:, :, 3] > 0.5
    assert 0.02 < baked.mean() < 0.9
    assert iou(ours, baked) >= 0.95, f"{effect}: IoU {iou(ours, baked):.3f}"
    assert iou(plain, baked) < iou(ours, baked) - 0.03, f"{effect}: the effect must show ({iou(plain, baked):.3f})"


def test_render_preview_makes_an_image_and_files(scene, tmp_path):
    sphere = slab_sphere(tmp_path)
    bpy.ops.object.camera_add(location=(0.0, -6.0, 0.0), rotation=(math.radians(90), 0.0, 0.0))
    scene.camera = bpy.context.object
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 64, 48, 100
    exr = str(tmp_path / "preview.exr")
    image = api.render_preview(sphere, path=exr, method="reference")
    assert tuple(image.size) == (64, 48) and image.name == "Thicket Preview"
    pixels = np.empty(64 * 48 * 4, np.float32)
    image.pixels.foreach_get(pixels)
    alpha = pixels.reshape(48, 64, 4)[:, :, 3]
    assert 0.1 < (alpha > 0.5).mean() < 0.9
    # The EXR's A channel, read back by Thicket's own EXR reader (one slice, bottom row
    # first like Blender's images).
    written = tn.load_texture(exr)
    assert written.shape == (1, 48, 64)
    np.testing.assert_allclose(written[0], alpha, atol=1e-6)
    png = api.render_frames(sphere, 1, 2, str(tmp_path / "frames"), method="reference")
    assert len(png) == 2
    for path in png:
        frame = bpy.data.images.load(path)
        assert tuple(frame.size) == (64, 48)
    # The operator, as the panels run it, with its Renderer and Mipmaps settings.
    bpy.context.view_layer.objects.active = sphere
    bpy.data.images.remove(bpy.data.images["Thicket Preview"])
    for mipmaps in ("double", "linear", "off"):
        assert bpy.ops.thicket.render_preview(method="interpolating", mipmaps=mipmaps) == {"FINISHED"}
        assert tuple(bpy.data.images["Thicket Preview"].size) == (64, 48)


def test_render_errors_are_clear(scene, tmp_path):
    sphere = add("ico_sphere", subdivisions=2)
    api.add_thick_surface(sphere, kind="SHELL")
    bpy.ops.object.camera_add(location=(0.0, -6.0, 0.0), rotation=(math.radians(90), 0.0, 0.0))
    with pytest.raises(ValueError, match="no camera"):
        api.render_preview(sphere)
    scene.camera = bpy.context.object
    with pytest.raises(ValueError, match="no enabled Volumetric Texture"):
        api.render_preview(sphere, width=8, height=8)
    api.add_item(sphere, "VOLUMETRIC_TEXTURE", pattern="rivets")
    with pytest.raises(tn.ThicketError, match="0x8"):
        api.render_preview(sphere, width=0, height=8)


@pytest.fixture(autouse=True)
def no_views_left():
    """Each test leaves the live overlay's views as it found them (none): a stand-in
    view left there would be taken for a 3D view's by later tests."""
    from thicket.render import overlay

    yield
    left = dict(overlay._state["views"])
    overlay._state["views"].clear()
    assert left == {}, "a test left views in the overlay"


def _frame(overlay, handle, frame, settings, want="frame"):
    """One frame of `handle` rendered for a view as the overlay's timer renders it (on
    the worker machinery, `overlay.start_render`), waited for: the view, no longer
    among the overlay's."""
    view = overlay.View(id(handle))
    overlay._state["views"][view.session_uid] = view
    try:
        view.want = want
        overlay.start_render(view, handle, frame, settings)
        overlay.wait()
    finally:
        overlay._state["views"].pop(view.session_uid, None)
    return view


def test_live_preview_worker_renders_off_the_main_thread(scene, tmp_path):
    # The overlay's own pieces (drawing needs a window): the cached preparation and
    # the render build that calls the renderer with the GIL released.
    from thicket.render import overlay

    sphere = slab_sphere(tmp_path)
    bpy.context.view_layer.objects.active = sphere
    key, handle = overlay._prepared(sphere)
    view = np.array(((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, -6), (0, 0, 0, 1)), np.float32)  # looking along +y from y = -6
    projection = np.array(((2, 0, 0, 0), (0, 2, 0, 0), (0, 0, -1.02, -0.2), (0, 0, -1, 0)), np.float32)
    frame, settings = (view, projection, 40, 30), dict(method="reference")
    shown = _frame(overlay, handle, frame, settings, want="this render")
    assert shown.key == "this render" and shown.result.shape == (30, 40, 4)
    assert (shown.result[:, :, 3] > 0.5).mean() > 0.1
    # A render the view no longer wants (it moved on) is dropped and leaves no image.
    stale = overlay.View(-1)
    overlay._state["views"][stale.session_uid] = stale
    try:
        stale.want = "old"
        overlay.start_render(stale, handle, frame, settings)
        stale.want = "the view moved"
        overlay.wait()
    finally:
        overlay._state["views"].pop(stale.session_uid, None)
    assert stale.result is None and stale.key is None


def test_live_preview_keeps_one_native_handle_until_the_content_changes(scene, tmp_path):
    # The overlay renders every frame from one thicket_native.TexturedShell (its arrays
    # read and checked once, the renderers' scene kept), not render_shell's whole
    # setup per frame; a new handle only once the stack's content changed.
    from thicket.render import overlay

    sphere = slab_sphere(tmp_path)
    bpy.context.view_layer.objects.active = sphere
    overlay._state["prepared"] = None  # nothing kept from an earlier scene's object of the same name
    key, handle = overlay._prepared(sphere)
    assert isinstance(handle, tn.TexturedShell) and handle.vertex_count == len(sphere.data.vertices)
    view = np.array(((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, -6), (0, 0, 0, 1)), np.float32)
    projection = np.array(((2, 0, 0, 0), (0, 2, 0, 0), (0, 0, -1.02, -0.2), (0, 0, -1, 0)), np.float32)
    frames = []
    for _ in range(2):  # frame after frame, the same handle
        again, same = overlay._prepared(sphere)
        assert again == key and same is handle, "unchanged content: the same handle"
        frames.append(_frame(overlay, same, (view, projection, 40, 30), dict(method="reference")).result)
    np.testing.assert_array_equal(frames[0], frames[1])
    # What render_shell draws from the same arrays and settings, every frame anew.
    setup = render_setup_of(sphere)
    base, shell = setup.shell.base, setup.shell
    args = (base.vertices, base.face_sizes, base.corners, shell.base_offset, shell.directors, setup.textures, view, projection, 40, 30)
    np.testing.assert_array_equal(frames[0], tn.render_shell(*args, method="reference", **native_settings(setup.settings))["rgba"])
    sphere.thicket.items[-1].tiling = 2.0  # the content changed: a new handle
    changed, rebuilt = overlay._prepared(sphere)
    assert changed != key and rebuilt is not handle and isinstance(rebuilt, tn.TexturedShell)
    assert overlay._prepared(sphere)[1] is rebuilt


def render_setup_of(obj):
    """The overlay's own setup of `obj` (source read as it reads it)."""
    from thicket import mesh_io
    from thicket.pure.evaluate import render_setup
    from thicket.stack.regenerate import enabled_settings

    items = enabled_settings(obj)
    groups = sorted({g for item in items for g in item.vertex_groups()})
    return render_setup(mesh_io.read_evaluated(obj, bpy.context.evaluated_depsgraph_get(), groups), items)


def test_gpu_slices_agree_with_the_reference_in_blender(scene, tmp_path):
    # The slice renderer on whatever adapter is present (Mesa's lavapipe in CI, which
    # the Makefile installs); the reference is the ground truth.
    sphere = slab_sphere(tmp_path)
    view = np.array(((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, -6), (0, 0, 0, 1)), np.float32)
    projection = np.array(((2, 0, 0, 0), (0, 2.6667, 0, 0), (0, 0, -1.02, -0.2), (0, 0, -1, 0)), np.float32)
    reference = preview.render_arrays(sphere, view, projection, 80, 60, method="reference")
    for method in ("interpolating", "plain"):
        out = preview.render_arrays(sphere, view, projection, 80, 60, method=method, slices=16)
        assert out["renderer"].startswith("GPU slice renderer on"), out["renderer"]
        assert out["fallback"] == ""
        score = iou(out["rgba"][:, :, 3] > 0.5, reference["rgba"][:, :, 3] > 0.5)
        assert score >= 0.98, (method, score)
        both = (out["rgba"][:, :, 3] > 0.5) & (reference["rgba"][:, :, 3] > 0.5)
        assert np.abs(out["rgba"][both, :3] - reference["rgba"][both, :3]).mean() < 0.05, method
    with pytest.raises(tn.ThicketError, match="unknown render method"):
        preview.render_arrays(sphere, view, projection, 8, 8, method="raytrace")


def test_double_mipmaps_keep_far_chain_mail_from_vanishing(scene, tmp_path):
    # Chapter 6, figure 6.1, through the add-on: a chain-mail sphere seen from far
    # away (a 64-texel tile spans a few pixels). Averaged mipmaps make the rings
    # vanish; double mipmaps keep about the coverage the reference renderer finds at
    # 8x the resolution, averaged down.
    sphere = add("uv_sphere", segments=32, ring_count=16, radius=1.0)
    api.add_volumetric_texture(sphere, "chain_mail", shell_thickness=0.04, tiling=12, resolution=2, depth_steps=8)
    view = np.array(((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, -6), (0, 0, 0, 1)), np.float32)
    projection = np.array(((2, 0, 0, 0), (0, 2.6667, 0, 0), (0, 0, -1.02, -0.2), (0, 0, -1, 0)), np.float32)
    fine = preview.render_arrays(sphere, view, projection, 512, 384, method="reference")["rgba"][:, :, 3]
    truth = fine.reshape(48, 8, 64, 8).mean(axis=(1, 3)).mean()
    coverage = {}
    for mipmaps in ("off", "linear", "double"):
        out = preview.render_arrays(sphere, view, projection, 64, 48, method="interpolating", mipmaps=mipmaps)
        coverage[mipmaps] = out["rgba"][:, :, 3].mean()
    assert truth > 0.05, truth
    assert coverage["linear"] < 0.5 * truth, (coverage, truth)
    assert abs(coverage["double"] - truth) < 0.25 * truth, (coverage, truth)
    with pytest.raises(tn.ThicketError, match="unknown mipmaps"):
        preview.render_arrays(sphere, view, projection, 8, 8, method="plain", mipmaps="trilinear")


def test_previews_are_lit_by_the_scene_light(scene, tmp_path):
    # A sun from +X lights the sphere's +X side; turned to -X, the other side. Without
    # lights the default direction is used; a point light counts by its position.
    sphere = slab_sphere(tmp_path)
    view = np.array(((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, -6), (0, 0, 0, 1)), np.float32)
    projection = np.array(((2, 0, 0, 0), (0, 2.6667, 0, 0), (0, 0, -1.02, -0.2), (0, 0, -1, 0)), np.float32)

    def right_minus_left():
        out = preview.render_arrays(sphere, view, projection, 64, 48, method="reference")
        grey = out["rgba"][:, :, :3].mean(axis=2) * (out["rgba"][:, :, 3] > 0.5)
        return grey[:, 32:].sum() - grey[:, :32].sum()

    sun_data = bpy.data.lights.new("Sun", "SUN")
    sun = bpy.data.objects.new("Sun", sun_data)
    scene.collection.objects.link(sun)
    sun.rotation_euler = (0.0, math.radians(90), 0.0)  # local +Z (toward the sun) turned to +X
    assert right_minus_left() > 0
    sun.rotation_euler = (0.0, math.radians(-90), 0.0)
    assert right_minus_left() < 0
    bpy.data.objects.remove(sun)
    lamp = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", "POINT"))
    scene.collection.objects.link(lamp)
    lamp.location = (5.0, 0.0, 0.0)
    assert right_minus_left() > 0
