"""Opaque handles (issue 16): a `Mesh` read and checked once, its `Shell` kept in
Rust, and a `TexturedShell` made from them without passing the arrays again. Each
gives exactly what the array functions give for the same input."""

import numpy as np
import pytest
from conftest import add

import thicket_native as tn
from thicket import mesh_io


@pytest.fixture
def sphere(scene):
    obj = add("uv_sphere", segments=16, ring_count=8)
    return mesh_io.read_mesh(obj.data)


def test_a_mesh_is_checked_once_and_gives_its_arrays_back(sphere):
    m = tn.Mesh(sphere.vertices, sphere.face_sizes, sphere.corners, sphere.uvs)
    assert (m.vertex_count, m.face_count) == (len(sphere.vertices), len(sphere.face_sizes))
    back = m.arrays()
    np.testing.assert_array_equal(back["vertices"], sphere.vertices)
    np.testing.assert_array_equal(back["face_sizes"], sphere.face_sizes)
    np.testing.assert_array_equal(back["corners"], sphere.corners)
    np.testing.assert_array_equal(back["uvs"], sphere.uvs)
    assert "uvs" not in tn.Mesh(sphere.vertices, sphere.face_sizes, sphere.corners).arrays()
    bad = sphere.corners.copy()
    bad[5] = len(sphere.vertices)
    with pytest.raises(tn.InvalidInput, match=f"vertex {len(sphere.vertices)}"):
        tn.Mesh(sphere.vertices, sphere.face_sizes, bad)
    with pytest.raises(tn.InvalidInput, match="uvs must have shape"):
        tn.Mesh(sphere.vertices, sphere.face_sizes, sphere.corners, sphere.uvs[:-1])


def test_a_shell_handle_is_the_shell_function(sphere):
    args = (sphere.vertices, sphere.face_sizes, sphere.corners)
    mesh = tn.Mesh(*args)
    for side, output, surfaces in (("exterior", "outer", 1), ("interior", "layers", 3), ("envelope", "solid", 1)):
        want = tn.shell(*args, 0.1, side=side, relative=True, output=output, surfaces=surfaces)
        got = mesh.shell(0.1, side=side, relative=True).geometry(output, surfaces)
        assert set(got) == set(want)
        for key in ("vertices", "corners", "face_sizes", "directors", "base_offset", "source_vertex", "layer"):
            np.testing.assert_array_equal(got[key], want[key], err_msg=f"{side} {key}")
    # Given by its arrays (read back from Blender): checked against its mesh.
    shell = mesh.shell(0.1, relative=True)
    again = tn.Shell(mesh, shell.geometry()["base_offset"], shell.geometry()["directors"])
    np.testing.assert_array_equal(again.geometry()["vertices"], shell.geometry()["vertices"])
    assert again.mesh.vertex_count == mesh.vertex_count
    with pytest.raises(tn.InvalidInput, match="one row per vertex"):
        tn.Shell(mesh, np.zeros((3, 3), np.float32), np.zeros((3, 3), np.float32))
    bad = shell.geometry()["directors"].copy()
    bad[7, 1] = np.nan
    with pytest.raises(tn.InvalidInput, match="directors of vertex 7 is not finite"):
        tn.Shell(mesh, shell.geometry()["base_offset"], bad)


def test_building_a_shell_reports_progress_and_can_be_cancelled(sphere):
    mesh = tn.Mesh(sphere.vertices, sphere.face_sizes, sphere.corners)
    seen = []
    mesh.shell(0.1, relative=True, progress=seen.append)
    assert seen and seen[-1] == 1.0 and seen == sorted(seen)
    with pytest.raises(tn.Cancelled):
        mesh.shell(0.1, relative=True, progress=lambda done: False)


def test_a_textured_shell_from_handles_is_the_one_from_arrays(sphere):
    args = (sphere.vertices, sphere.face_sizes, sphere.corners)
    mesh = tn.Mesh(*args, sphere.uvs)
    shell = mesh.shell(0.1, relative=True)
    g = shell.geometry()
    texture = tn.texture("rivets", size=(8, 8, 4))
    settings = dict(resolution=3, depth_steps=6, tiling=2.0)
    want = tn.TexturedShell(*args, g["base_offset"], g["directors"], [texture], uvs=sphere.uvs, **settings)
    got = shell.textured([texture], **settings)
    assert got.estimate() == want.estimate() > 0
    a, b = got.bake(), want.bake()
    np.testing.assert_array_equal(a["vertices"], b["vertices"])
    np.testing.assert_array_equal(a["corners"], b["corners"])
    # The UVs are the mesh's: without them the same call tiles one per face.
    plain = tn.Mesh(*args).shell(0.1, relative=True).textured([texture], **settings)
    assert plain.estimate() != got.estimate()
    with pytest.raises(TypeError, match="pass uvs to Mesh"):
        shell.textured([texture], uvs=sphere.uvs)
    with pytest.raises(TypeError, match="unexpected keyword argument 'resolutoin'"):
        shell.textured([texture], resolutoin=3)


def test_a_texture_handle_is_the_array_it_stands_for(tmp_path):
    """`Texture.pattern`, `Texture(alpha)` and `Texture.load` hold what `texture`, the
    array and `load_texture` give; `array()` gives it back, `save_texture` takes it."""
    want = tn.texture("weave", size=(12, 10, 6), seed=3, time=0.5, thickness=1.5)
    made = tn.Texture.pattern("weave", size=(12, 10, 6), seed=3, time=0.5, thickness=1.5)
    assert made.size == (12, 10, 6)
    np.testing.assert_array_equal(made.array(), want)
    np.testing.assert_array_equal(tn.Texture.pattern("fur").array(), tn.texture("fur"))
    # From an array: checked once, clamped like the array functions clamp.
    wild = want * 3.0 - 1.0
    np.testing.assert_array_equal(tn.Texture(wild).array(), np.clip(wild, 0.0, 1.0))
    np.testing.assert_array_equal(tn.Texture(np.asfortranarray(want)).array(), want)
    # Saved from the handle and from the array alike, loaded back alike.
    written = tn.save_texture(str(tmp_path / "from_handle"), made)
    assert [p.replace("from_handle", "x") for p in written] == [p.replace("from_array", "x") for p in tn.save_texture(str(tmp_path / "from_array"), want)]
    np.testing.assert_array_equal(tn.Texture.load(written[0]).array(), tn.load_texture(written[0]))
    np.testing.assert_array_equal(tn.load_texture(str(tmp_path / "from_handle")), tn.load_texture(str(tmp_path / "from_array")))
    exr = str(tmp_path / "t.exr")
    tn.save_texture(exr, made)
    np.testing.assert_array_equal(tn.Texture.load(exr).array(), tn.load_texture(exr))
    # Refused as the array functions refuse.
    bad = want.copy()
    bad[1, 2, 3] = np.nan
    with pytest.raises(tn.InvalidInput, match="NaN"):
        tn.Texture(bad)
    with pytest.raises(tn.InvalidInput, match=r"shape \(nz, ny, nx\)"):
        tn.Texture(np.zeros((4, 4), np.float32))
    with pytest.raises(tn.InvalidInput, match="zero size"):
        tn.Texture(np.zeros((0, 4, 4), np.float32))
    with pytest.raises(tn.InvalidInput, match='unknown texture "plaid"'):
        tn.Texture.pattern("plaid")
    with pytest.raises(tn.InvalidInput, match="too large"):
        tn.Texture.pattern("weave", size=(1024, 1024, 512))
    with pytest.raises(tn.FileError):
        tn.Texture.load(str(tmp_path / "missing.exr"))


def test_texture_handles_bake_estimate_and_render_as_their_arrays(sphere):
    """Handles in every textures list (alone and placed at an offset) give what the
    arrays give: bake_texture, estimate_bake, render_shell, TexturedShell and
    Shell.textured."""
    args = (sphere.vertices, sphere.face_sizes, sphere.corners)
    shell = tn.Mesh(*args, sphere.uvs).shell(0.1, relative=True)
    g = shell.geometry()
    arrays = [tn.texture("rivets", size=(8, 8, 4)), (tn.texture("grass", size=(8, 8, 4)), (0.25, 0.5))]
    handles = [tn.Texture.pattern("rivets", size=(8, 8, 4)), (tn.Texture.pattern("grass", size=(8, 8, 4)), (0.25, 0.5))]
    settings = dict(uvs=sphere.uvs, resolution=3, depth_steps=6, tiling=2.0)
    shell_args = (*args, g["base_offset"], g["directors"])
    want = tn.bake_texture(*shell_args, arrays, **settings)
    assert len(want["corners"]) > 0
    for got in (tn.bake_texture(*shell_args, handles, **settings), shell.textured(handles, resolution=3, depth_steps=6, tiling=2.0).bake()):
        for key in ("vertices", "corners", "texcoords", "source_face"):
            np.testing.assert_array_equal(got[key], want[key], err_msg=key)
    estimate = tn.estimate_bake(*shell_args, arrays, **settings)
    assert tn.estimate_bake(*shell_args, handles, **settings) == estimate == tn.TexturedShell(*shell_args, handles, **settings).estimate()
    # Only the first texture: a different bake, so the second one counts.
    assert tn.estimate_bake(*shell_args, handles[:1], **settings) != estimate
    view = np.array(((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, -5), (0, 0, 0, 1)), np.float32)
    projection = np.array(((2, 0, 0, 0), (0, 2, 0, 0), (0, 0, -1.02, -0.2), (0, 0, -1, 0)), np.float32)
    frame = (view, projection, 32, 24)
    drawn = tn.render_shell(*shell_args, arrays, *frame, method="reference", **settings)["rgba"]
    assert (drawn[:, :, 3] > 0.5).any()
    np.testing.assert_array_equal(tn.render_shell(*shell_args, handles, *frame, method="reference", **settings)["rgba"], drawn)
    np.testing.assert_array_equal(shell.textured(handles, resolution=3, depth_steps=6, tiling=2.0).render(*frame, method="reference")["rgba"], drawn)
    with pytest.raises(tn.InvalidInput, match="float32 array"):
        tn.estimate_bake(*shell_args, [handles[0], "weave"], **settings)


def _numpy_vertex_normals(vertices, face_sizes, corners):
    """The add-on's former numpy vertex normals (pure/field_tree.py before the core's
    were exposed), in float64: the reference `Mesh.vertex_normals` replaces."""
    p = np.asarray(vertices, dtype=np.float64)
    sizes, corners = np.asarray(face_sizes, dtype=np.int64), np.asarray(corners, dtype=np.int64)
    normals = np.zeros_like(p)
    starts = np.zeros(len(sizes), dtype=np.int64)
    np.cumsum(sizes[:-1], out=starts[1:])
    face = np.repeat(np.arange(len(sizes)), sizes)
    k = np.arange(len(corners)) - starts[face]
    nxt, prv = corners[starts[face] + (k + 1) % sizes[face]], corners[starts[face] + (k - 1) % sizes[face]]
    here = p[corners]
    face_normals = np.zeros((len(sizes), 3))
    np.add.at(face_normals, face, np.cross(here, p[nxt]))
    length = np.linalg.norm(face_normals, axis=1, keepdims=True)
    face_normals = np.divide(face_normals, length, out=np.zeros_like(face_normals), where=length > 0)
    a, b = p[nxt] - here, p[prv] - here
    la, lb = np.linalg.norm(a, axis=1), np.linalg.norm(b, axis=1)
    cos = np.einsum("ij,ij->i", a, b) / np.maximum(la * lb, 1e-300)
    angle = np.where((la > 0) & (lb > 0), np.arccos(np.clip(cos, -1.0, 1.0)), 0.0)
    np.add.at(normals, corners, face_normals[face] * angle[:, None])
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    return np.divide(normals, length, out=np.zeros_like(normals), where=length > 0)


@pytest.mark.parametrize("shape", ["monkey", "cone", "torus", "grid"])
def test_mesh_vertex_normals_are_the_former_numpy_ones(scene, shape):
    """`Mesh.vertex_normals()` (the core's) equals the add-on's former numpy normals
    on quads, triangles, an n-gon (the cone's base) and open meshes, and gives zero
    for a loose vertex and for the vertices of a degenerate face only."""
    a = mesh_io.read_mesh(add(shape).data)
    loose = np.array([[9.0, 9.0, 9.0], [7.0, 7.0, 7.0], [7.0, 7.0, 7.0], [7.0, 7.0, 7.0]], np.float32)
    vertices = np.concatenate([a.vertices, loose])
    n = len(a.vertices)
    sizes = np.append(a.face_sizes, 3).astype(np.int32)
    corners = np.append(a.corners, [n + 1, n + 2, n + 3]).astype(np.int32)  # a zero-area triangle
    got = tn.Mesh(vertices, sizes, corners).vertex_normals()
    assert got.dtype == np.float32 and got.shape == (n + 4, 3)
    want = _numpy_vertex_normals(vertices, sizes, corners)
    np.testing.assert_allclose(got, want, atol=2e-6)
    np.testing.assert_array_equal(got[n:], 0.0)
    np.testing.assert_allclose(np.linalg.norm(got[:n], axis=1), 1.0, atol=1e-6)


@pytest.mark.parametrize("shell_kind", ["offset", "field"])
def test_the_stack_passes_handles_from_the_shell_to_the_texture(sphere, shell_kind):
    """The Shell kinds hand the Volumetric Texture a `Shell` handle (its mesh the base
    with its UVs) and the texture places `Texture` handles; the bake, the estimate and
    the preview made from them are what the array functions make from the shell's
    arrays and the patterns' arrays, as the stack made them before the handles."""
    from thicket.pure import evaluate as E
    from thicket.pure import settings as S

    shell_item = S.OffsetShell(thickness=0.1, relative=True) if shell_kind == "offset" else S.FieldShell(thickness=0.1, relative=True)
    texture = S.VolumetricTexture(pattern="rivets", combine="grass", offset=(0.25, 0.5), texture_size=8, tiling=2.0, resolution=3, depth_steps=6)
    setup = E.render_setup(sphere, [shell_item, texture])
    shell = setup.shell
    assert isinstance(shell.handle, tn.Shell) and shell.handle.mesh.vertex_count == sphere.vertex_count
    np.testing.assert_array_equal(shell.handle.geometry()["directors"], shell.directors)
    np.testing.assert_array_equal(shell.handle.geometry()["base_offset"], shell.base_offset)
    np.testing.assert_array_equal(shell.handle.mesh.arrays()["uvs"], sphere.uvs)
    first, (second, offset) = setup.textures
    assert isinstance(first, tn.Texture) and isinstance(second, tn.Texture) and offset == (0.25, 0.5)
    arrays = [tn.texture("rivets", size=(8, 8, 4)), (tn.texture("grass", size=(8, 8, 4)), (0.25, 0.5))]
    np.testing.assert_array_equal(first.array(), arrays[0])
    np.testing.assert_array_equal(second.array(), arrays[1][0])
    shell_args = (sphere.vertices, sphere.face_sizes, sphere.corners, shell.base_offset, shell.directors, arrays)
    settings = dict(uvs=sphere.uvs, tiling=2.0, resolution=3, depth_steps=6)
    assert setup.settings["uvs"] is sphere.uvs  # what render_shell takes; the handle's mesh has them
    view = np.array(((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, -5), (0, 0, 0, 1)), np.float32)
    projection = np.array(((2, 0, 0, 0), (0, 2, 0, 0), (0, 0, -1.02, -0.2), (0, 0, -1, 0)), np.float32)
    frame = (view, projection, 32, 24)
    drawn = setup.handle().render(*frame, method="reference")["rgba"]
    assert (drawn[:, :, 3] > 0.5).any()
    np.testing.assert_array_equal(drawn, tn.render_shell(*shell_args[:5], arrays, *frame, method="reference", **settings)["rgba"])
    # Baked through the stack: the bake of the same arrays, and its estimate the same.
    baked = E.evaluate_stack(sphere, [shell_item, texture])
    want = tn.bake_texture(*shell_args, **settings)
    assert len(want["corners"]) > 0
    np.testing.assert_array_equal(baked.vertices, want["vertices"])
    np.testing.assert_array_equal(baked.corners, want["corners"])
    estimate = tn.estimate_bake(*shell_args, **settings)
    with pytest.raises(Exception, match=f"about {estimate:,} triangles"):
        E.evaluate_stack(sphere, [shell_item, S.VolumetricTexture(**{**texture.__dict__, "confirm_above": 0})], ask=True)
