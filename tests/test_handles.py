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
