"""Bad input never crashes Blender, never touches the source, always says what is wrong."""

import bpy
import numpy as np
import pytest
from conftest import add, mesh_object, positions, select_only

from thicket import api


def run_operator(obj, **kw):
    select_only(obj)
    return bpy.ops.thicket.add_thick_surface(**kw)


def run_failing_operator(obj, match, **kw):
    """In scripts, an operator's ERROR report arrives as RuntimeError with its text."""
    select_only(obj)
    with pytest.raises(RuntimeError, match=match):
        bpy.ops.thicket.add_thick_surface(**kw)


def test_empty_mesh_reports_and_creates_nothing(scene):
    empty = mesh_object("Empty", [], [])
    run_failing_operator(empty, "Empty: the mesh is empty")
    assert "empty" in empty.thicket.last_error
    assert "Empty_thicket" not in bpy.data.objects


def test_nan_coordinates_name_the_vertex(scene):
    obj = mesh_object("Bad", [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)], [(0, 1, 2), (0, 3, 1)])
    obj.data.vertices[3].co.z = float("nan")
    before = positions(obj).copy()
    run_failing_operator(obj, "vertex 3 has a non-finite coordinate")
    assert "vertex 3" in obj.thicket.last_error
    np.testing.assert_array_equal(positions(obj), before)


@pytest.mark.parametrize("thickness", [0.0, 1e7])
def test_absurd_thickness_is_a_clear_error(scene, thickness):
    cube = add("cube")
    run_failing_operator(cube, "thickness", thickness=thickness, thickness_mode="ABSOLUTE")
    assert "Cube_thicket" not in bpy.data.objects


def test_absurd_thickness_on_existing_stack_keeps_previous_result(scene):
    cube = add("cube")
    api.add_thick_surface(cube, thickness=0.1, thickness_mode="ABSOLUTE")
    before = positions(cube.thicket.result).copy()
    cube.thicket.items[0].thickness = 0.0  # auto-update fails: error kept, result kept
    assert "thickness" in cube.thicket.last_error
    np.testing.assert_array_equal(positions(cube.thicket.result), before)
    cube.thicket.items[0].thickness = 0.2
    assert cube.thicket.last_error == ""


def test_negative_thickness_offsets_inward(scene):
    sphere = add("uv_sphere", radius=1.0)
    api.add_thick_surface(sphere, thickness=-0.2, thickness_mode="ABSOLUTE")
    radii = np.linalg.norm(positions(sphere.thicket.result), axis=1)
    np.testing.assert_allclose(radii, 0.8, atol=1e-3)


def test_odd_but_valid_meshes_give_documented_results(scene):
    """Degenerate faces, loose vertices, non-manifold edges, n-gons and boundaries:
    a result is built; loose vertices are left out; zero-area faces stay in place."""
    verts = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0.5, 1.5, 0), (0, 0, 1), (0, 0, -1), (5, 5, 5), (2, 0, 0), (3, 0, 0), (2.5, 0, 0)]
    faces = [(0, 1, 2, 4, 3), (0, 1, 5), (0, 1, 6), (8, 9, 10)]  # ngon, non-manifold fan, zero-area
    obj = mesh_object("Odd", verts, faces)
    before = positions(obj).copy()
    assert run_operator(obj, thickness=0.1, thickness_mode="ABSOLUTE") == {"FINISHED"}
    result = positions(obj.thicket.result)
    assert len(result) == len(verts) - 1  # vertex 7 is loose
    assert np.isfinite(result).all()
    np.testing.assert_array_equal(positions(obj), before)


def test_mixed_selection_reports_skips_and_failures(scene):
    good = add("cube")
    bad = mesh_object("Empty", [], [])
    bpy.ops.object.camera_add()
    camera = bpy.context.active_object
    select_only(good, bad, camera)
    assert bpy.ops.thicket.add_thick_surface() == {"FINISHED"}  # one worked
    assert good.thicket.result is not None
    assert bad.thicket.last_error


def test_api_rejects_non_mesh_and_results(scene):
    bpy.ops.object.camera_add()
    with pytest.raises(TypeError, match="mesh"):
        api.add_thick_surface(bpy.context.active_object)
    cube = add("cube")
    result = api.add_thick_surface(cube)
    with pytest.raises(TypeError, match="result"):
        api.add_thick_surface(result)


def test_missing_vertex_group_is_reported(scene):
    cube = add("cube")
    with pytest.raises(KeyError, match="no vertex group named 'nope'"):
        api.add_thick_surface(cube, vertex_group="nope")
    assert "Cube_thicket" not in bpy.data.objects
