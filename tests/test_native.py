"""thicket_native called directly with numpy arrays (as scripts and the add-on do)."""

import numpy as np
import pytest

import thicket_native as tn

CUBE_V = np.array([[x, y, z] for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)], np.float32)
CUBE_F = np.array([[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [1, 3, 7, 5], [3, 2, 6, 7], [2, 0, 4, 6]], np.int32)


def test_offset_moves_cube_corners_along_diagonals():
    out = tn.offset_shell(CUBE_V, np.full(6, 4, np.int32), CUBE_F.ravel(), 0.5)
    moved = out["vertices"] - CUBE_V[out["source_vertex"]]
    expected = CUBE_V[out["source_vertex"]] / np.sqrt(3) * 0.5
    np.testing.assert_allclose(moved, expected, atol=1e-6)
    assert out["vertices"].dtype == np.float32 and out["corners"].dtype == np.int32
    assert out["directors"].shape == (8, 3)


def test_relative_thickness_and_factors():
    factors = np.linspace(0, 1, 8, dtype=np.float32)
    out = tn.offset_shell(CUBE_V, np.full(6, 4, np.uint32), CUBE_F.astype(np.uint32).ravel(), 0.1, relative=True, factors=factors)
    lengths = np.linalg.norm(out["directors"], axis=1)
    np.testing.assert_allclose(lengths, factors * 0.1 * np.sqrt(12), rtol=1e-5, atol=1e-7)


def test_solid_output_is_closed():
    out = tn.offset_shell(CUBE_V, np.full(6, 4, np.int32), CUBE_F.ravel(), 0.2, output="solid")
    report = tn.mesh_report(out["vertices"], out["face_sizes"], out["corners"])
    assert report["closed_manifold"] and report["faces"] == 12


@pytest.mark.parametrize(
    "vertices, sizes, corners, message",
    [
        (CUBE_V, np.full(6, 4, np.int32), np.arange(24, dtype=np.int32), "refers to vertex"),
        (CUBE_V, np.full(6, 4, np.int32), -np.ones(24, np.int32), "negative index"),
        (CUBE_V, np.array([2], np.int32), np.array([0, 1], np.int32), "at least 3"),
        (CUBE_V[:, :2].copy(), np.array([3], np.int32), np.array([0, 1, 2], np.int32), "shape"),
        (np.zeros((0, 3), np.float32), np.zeros(0, np.int32), np.zeros(0, np.int32), "empty"),
    ],
)
def test_structural_errors_are_thicket_errors(vertices, sizes, corners, message):
    with pytest.raises(tn.ThicketError, match=message):
        tn.offset_shell(vertices, sizes, corners, 0.1)


def test_nan_coordinates_named():
    v = CUBE_V.copy()
    v[3, 1] = np.nan
    with pytest.raises(tn.ThicketError, match="vertex 3 has a non-finite"):
        tn.offset_shell(v, np.full(6, 4, np.int32), CUBE_F.ravel(), 0.1)


@pytest.mark.parametrize("thickness", [0.0, float("nan"), float("inf"), 1e9])
def test_absurd_thickness_refused(thickness):
    with pytest.raises(tn.ThicketError, match="thickness"):
        tn.offset_shell(CUBE_V, np.full(6, 4, np.int32), CUBE_F.ravel(), thickness)


def test_non_contiguous_input_refused_not_crashing():
    strided = np.zeros((8, 6), np.float32)[:, ::2]
    with pytest.raises(tn.ThicketError, match="contiguous"):
        tn.offset_shell(strided, np.full(6, 4, np.int32), CUBE_F.ravel(), 0.1)


def test_thicket_error_is_a_value_error():
    assert issubclass(tn.ThicketError, ValueError)
