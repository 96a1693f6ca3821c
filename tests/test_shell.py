"""The L_p-field shell through thicket_native and the stack (thick surfaces, ch. 4)."""

import bpy
import numpy as np
import pytest
import thicket_native as tn
from conftest import add, positions

from thicket import api, mesh_io


def triangles_of(obj):
    mesh = obj.data
    mesh.calc_loop_triangles()
    tris = np.empty(len(mesh.loop_triangles) * 3, np.int32)
    mesh.loop_triangles.foreach_get("vertices", tris)
    return tris.reshape(-1, 3)


def test_build_shell_on_sphere_follows_normals(scene):
    sphere = add("ico_sphere", subdivisions=4, radius=1.0)
    v = positions(sphere)
    directors = tn.build_shell(v, triangles_of(sphere), 0.1, "exterior")
    assert directors.shape == v.shape and directors.dtype == np.float32
    normals = v / np.linalg.norm(v, axis=1, keepdims=True)
    lengths = np.linalg.norm(directors, axis=1)
    np.testing.assert_allclose(lengths, 0.1, rtol=0.02)
    cosine = np.sum(directors / lengths[:, None] * normals, axis=1)
    assert cosine.min() > 0.999
    inward = tn.build_shell(v, triangles_of(sphere), np.full(len(v), 0.1, np.float32), "interior")
    assert np.sum(inward * normals, axis=1).max() < -0.09


def test_field_shell_folds_far_less_than_offset_on_a_concave_head(scene):
    """Suzanne (subdivided) at 5% exterior: normal displacement folds in thousands of
    face pairs; the field shell must do an order of magnitude better and invert no prism."""
    head = add("monkey")
    head.modifiers.new("subdivide", "SUBSURF").levels = 1
    bpy.ops.object.modifier_apply(modifier="subdivide")
    a = mesh_io.read_mesh(head.data)
    diag = float(np.linalg.norm(np.ptp(a.vertices, axis=0)))
    field = tn.shell(a.vertices, a.face_sizes, a.corners, 0.05, relative=True)
    offset = tn.offset_shell(a.vertices, a.face_sizes, a.corners, 0.05, relative=True)
    target = np.full(len(a.vertices), 0.05 * diag, np.float32)
    ours = tn.shell_report(a.vertices, a.face_sizes, a.corners, field["directors"], field["target"])
    baseline = tn.shell_report(a.vertices, a.face_sizes, a.corners, offset["directors"], target)
    assert baseline["outer_self_intersections"] > 1000
    assert ours["outer_self_intersections"] * 10 < baseline["outer_self_intersections"]
    assert ours["inverted_cells"] == 0 and baseline["inverted_cells"] > 0
    assert 0 < ours["mean_ratio"] <= 1.0001


def test_shell_stack_item_in_blender(scene):
    sphere = add("uv_sphere", radius=1.0)
    result = api.add_thick_surface(sphere, kind="SHELL", side="ENVELOPE", thickness=0.2, thickness_mode="ABSOLUTE", output="SOLID")
    radii = np.linalg.norm(positions(result), axis=1)
    n = len(sphere.data.vertices)
    np.testing.assert_allclose(radii[:n], 1.1, atol=0.01)  # outer layer
    np.testing.assert_allclose(radii[n:], 0.9, atol=0.01)  # inner layer of the envelope
    achieved = np.empty(len(result.data.vertices), np.float32)
    result.data.attributes["thicket_thickness"].data.foreach_get("value", achieved)
    np.testing.assert_allclose(achieved, 0.2, rtol=0.03)
    sphere.thicket.items[0].side = "INTERIOR"
    assert np.linalg.norm(positions(sphere.thicket.result), axis=1).max() < 1.0 + 1e-4


@pytest.mark.parametrize("side", ["sideways", ""])
def test_bad_side_is_a_clear_error(side):
    v = np.eye(3, dtype=np.float32)
    with pytest.raises(tn.ThicketError, match="side"):
        tn.build_shell(v, np.array([[0, 1, 2]], np.int32), 0.1, side)
