"""Volumetric textures from and to files (thick surfaces, ch. 3.2), with Blender as the
independent writer and reader: PNG slices saved by Blender load through
thicket_native, and the EXR and PNG files thicket_native writes open in Blender with
the same values, the same way up (texture y and Blender's pixel rows both grow upward).
"""

import pathlib
import re

import bpy
import numpy as np
import pytest

import thicket_native as tn

EIGHT_BIT = 1.0 / 255.0
SIXTEEN_BIT = 0.5 / 65535.0 + 1e-6


def blender_save(path, rgba, file_format="PNG"):
    """Saves float RGBA pixels (h, w, 4), row 0 at the bottom, through Blender itself.
    Non-Color, so Blender stores the values as given (no view transform)."""
    h, w, _ = rgba.shape
    image = bpy.data.images.new(path.name, w, h, alpha=True, float_buffer=True)
    image.colorspace_settings.name = "Non-Color"
    image.pixels.foreach_set(np.ascontiguousarray(rgba, np.float32).ravel())
    image.filepath_raw = str(path)
    image.file_format = file_format
    image.save()
    bpy.data.images.remove(image)


def gray(values, alpha=None):
    """RGBA pixels with the gray `values` and an alpha (1 when not given)."""
    rgba = np.ones(values.shape + (4,), np.float32)
    rgba[..., :3] = values[..., None]
    if alpha is not None:
        rgba[..., 3] = alpha
    return rgba


def blender_pixels(path, non_color=False):
    """The pixels Blender reads from `path`, shape (h, w, 4), row 0 at the bottom."""
    image = bpy.data.images.load(str(path))
    if non_color:
        image.colorspace_settings.name = "Non-Color"
    w, h = image.size
    px = np.empty(w * h * 4, np.float32)
    image.pixels.foreach_get(px)
    bpy.data.images.remove(image)
    return px.reshape(h, w, 4)


def test_png_slices_saved_by_blender_load_in_natural_order_and_upright(tmp_path):
    values = np.random.default_rng(1).random((12, 6, 9), dtype=np.float32)
    for z, v in enumerate(values):  # slice_2.png must come before slice_10.png
        blender_save(tmp_path / f"slice_{z}.png", gray(v))
    (tmp_path / "notes.txt").write_text("not a slice")
    t = tn.load_texture(str(tmp_path))
    assert t.shape == (12, 6, 9) and t.dtype == np.float32
    np.testing.assert_allclose(t, values, atol=EIGHT_BIT)
    # A .png picked in a file browser loads its folder's whole stack.
    np.testing.assert_array_equal(tn.load_texture(str(tmp_path / "slice_4.png")), t)


def test_alpha_channel_wins_over_luminance(tmp_path):
    alpha = np.random.default_rng(2).random((3, 5, 4), dtype=np.float32)
    for z, a in enumerate(alpha):
        blender_save(tmp_path / f"a_{z}.png", gray(np.ones_like(a), alpha=a))
    t = tn.load_texture(str(tmp_path))
    np.testing.assert_allclose(t, alpha, atol=EIGHT_BIT)


def test_exr_written_by_thicket_opens_in_blender_with_the_same_values(tmp_path):
    alpha = np.random.default_rng(3).random((3, 4, 5), dtype=np.float32)
    path = tmp_path / "volume.exr"
    assert tn.save_texture(str(path), alpha) == [str(path)]
    px = blender_pixels(path)
    # One picture nx wide and ny * nz high, slices stacked from the bottom, in channel A.
    assert px.shape == (12, 5, 4)
    np.testing.assert_array_equal(px[..., 3].reshape(3, 4, 5), alpha)
    np.testing.assert_array_equal(tn.load_texture(str(path)), alpha)


def test_png_slices_written_by_thicket_open_upright_in_blender(tmp_path):
    alpha = np.random.default_rng(4).random((3, 4, 5), dtype=np.float32)
    files = tn.save_texture(str(tmp_path / "stack"), alpha)
    assert [pathlib.Path(f).name for f in files] == ["slice_000.png", "slice_001.png", "slice_002.png"]
    for z, f in enumerate(files):
        px = blender_pixels(f, non_color=True)
        np.testing.assert_allclose(px[..., 0], alpha[z], atol=SIXTEEN_BIT)
    np.testing.assert_allclose(tn.load_texture(str(tmp_path / "stack")), alpha, atol=SIXTEEN_BIT)


def test_exr_saved_by_blender_is_one_slice_read_from_red(tmp_path):
    red = np.random.default_rng(5).random((4, 6), dtype=np.float32)
    rgba = np.zeros((4, 6, 4), np.float32)
    rgba[..., 0], rgba[..., 3] = red, 1.0  # opaque: alpha gives way to R
    blender_save(tmp_path / "blender.exr", rgba, "OPEN_EXR")
    t = tn.load_texture(str(tmp_path / "blender.exr"))
    assert t.shape == (1, 4, 6)
    np.testing.assert_allclose(t[0], red, atol=1e-3)


def raises_naming(name, *message):
    pattern = re.escape(name) + "".join(".*" + re.escape(m) for m in message)
    return pytest.raises(tn.ThicketError, match=pattern)


def test_file_errors_name_the_file(tmp_path):
    with raises_naming("nowhere", "no such file or folder"):
        tn.load_texture(str(tmp_path / "nowhere"))
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / "readme.txt").write_text("hello")
    with raises_naming("empty", "no PNG"):
        tn.load_texture(str(empty))
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "slice_0.png").write_text("a text file renamed .png")
    with raises_naming("slice_0.png", "not a readable PNG"):
        tn.load_texture(str(bad))
    sizes = tmp_path / "sizes"
    sizes.mkdir()
    blender_save(sizes / "slice_0.png", gray(np.zeros((4, 4), np.float32)))
    blender_save(sizes / "slice_1.png", gray(np.zeros((3, 4), np.float32)))
    with raises_naming("slice_1.png is 4x3 but slice_0.png is 4x4"):
        tn.load_texture(str(sizes))
    (tmp_path / "junk.exr").write_text("not an exr")
    with raises_naming("junk.exr", "not a readable OpenEXR"):
        tn.load_texture(str(tmp_path / "junk.exr"))


@pytest.mark.parametrize("name", ["zero.exr", "zero_stack"])
def test_saving_a_zero_size_texture_names_the_file(tmp_path, name):
    with raises_naming(name, "zero size"):
        tn.save_texture(str(tmp_path / name), np.zeros((0, 4, 4), np.float32))
    with raises_naming(name, "float32 array of shape (nz, ny, nx)"):
        tn.save_texture(str(tmp_path / name), np.zeros((4, 4), np.float32))
