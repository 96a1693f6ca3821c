"""Bakes fitted to their Triangle Budget (`thicket_native.fit_bake_tiles`,
`TexturedShell.fit_budget`, `api.fit_bake_tiles`, the Fit Tiles to Budget operator):
a bake over its budget gets larger tiles (a UV map's Tiling shrinks, World-Size Tiles
grow), and then bakes within 1.5 times the budget as a closed 2-manifold without
crossing pairs by Blender's own checks (bmesh `is_manifold`, `BVHTree.overlap`:
`blender_defects`); a cancelled search changes nothing."""

import bpy
import numpy as np
import pytest
from conftest import add
from test_bake_manifold import blender_defects

import thicket_native as tn
from thicket import api, mesh_io
from thicket.pure.fit_budget import FIT_SHELL_SHARE

BUDGET = 40_000
#: Small and quick, but over the budget at the starting tiles (asserted).
SETTINGS = dict(texture_size=32, triangle_budget=BUDGET, shell_thickness=0.06)
TILE = 0.06


def baked(obj):
    """The result's mesh as `blender_defects` reads a bake, and its triangle count."""
    arrays = mesh_io.read_mesh(api.result_of(obj).data)
    out = {"vertices": arrays.vertices, "face_sizes": arrays.face_sizes, "corners": arrays.corners}
    assert (arrays.face_sizes == 3).all()
    return out, arrays.face_count


def over_budget_sphere(uv_map):
    """An ico sphere (1,280 faces) whose chain mail bakes over BUDGET: with a UV map
    at Tiling 6, without one in World-Size Tiles of TILE (about half the automatic
    size, 1/32 of its diagonal)."""
    obj = add("ico_sphere", subdivisions=3, radius=1.0)
    while obj.data.uv_layers:  # the primitive's own
        obj.data.uv_layers.remove(obj.data.uv_layers[0])
    if uv_map:
        obj.data.uv_layers.new(name="UVMap")
        bpy.context.view_layer.objects.active = obj
        bpy.ops.object.mode_set(mode="EDIT")
        bpy.ops.mesh.select_all(action="SELECT")
        bpy.ops.uv.smart_project()
        bpy.ops.object.mode_set(mode="OBJECT")
        api.add_volumetric_texture(obj, "chain_mail", tiling=6.0, **SETTINGS)
    else:
        api.add_volumetric_texture(obj, "chain_mail", no_uv_tiles="WORLD", tile_size=TILE, **SETTINGS)
    return obj


@pytest.mark.parametrize("uv_map", [True, False], ids=["uv map", "world-size tiles"])
def test_an_over_budget_bake_gets_fitted_tiles_and_bakes_within_them(scene, uv_map):
    obj = over_budget_sphere(uv_map)
    _, before = baked(obj)
    assert before > 1.5 * BUDGET, f"{before} triangles: not over the budget to begin with"
    item = obj.thicket.items[-1]
    found = api.fit_bake_tiles(obj)
    assert found["fits"] and found["scale"] > 1.0 and found["triangles"] <= BUDGET * 1.05, found
    if uv_map:
        assert found["settings"] == {"tiling": pytest.approx(6.0 / found["scale"])} and item.tiling == pytest.approx(6.0 / found["scale"], rel=1e-6)
    else:
        assert item.no_uv_tiles == "WORLD" and item.tile_size == pytest.approx(TILE * found["scale"], rel=1e-5)
    # The smallest growth that fits, within 5%: the one below it did not.
    assert found["below"] is not None and found["below"] < found["scale"] <= found["below"] * 1.05 * 1.0001
    out, after = baked(obj)
    assert after <= 1.5 * BUDGET, f"{after} triangles for a budget of {BUDGET:,} (estimate {found['triangles']:,})"
    assert found["triangles"] / 1.5 <= after <= found["triangles"] * 1.5, (after, found)
    defects = {k: v for k, v in blender_defects(out).items() if v}
    assert not defects, f"{defects} in {after} triangles"
    # Within the budget now: a second fit keeps the tiles, or grows them by one
    # round at most where its quick sample starts a little over (a quarter of the cells).
    again = api.fit_bake_tiles(obj, regenerate=False)
    assert again["fits"] and again["scale"] <= 1.25 * 1.0001, again


def test_a_cancelled_fit_leaves_the_source_the_item_and_the_result_untouched(scene):
    obj = over_budget_sphere(uv_map=False)
    item = obj.thicket.items[-1]
    vertices = mesh_io.read_mesh(obj.data).vertices.copy()
    _, before = baked(obj)
    seen = []

    def stop_in_the_search(fraction):
        seen.append(fraction)
        return fraction < FIT_SHELL_SHARE  # the shell ends there: the search's first call stops it

    with pytest.raises(tn.Cancelled):
        api.fit_bake_tiles(obj, progress=stop_in_the_search)
    assert max(seen) == pytest.approx(FIT_SHELL_SHARE) and len(seen) >= 3, seen
    assert item.no_uv_tiles == "WORLD" and item.tile_size == pytest.approx(TILE) and item.tiling == 1.0
    np.testing.assert_array_equal(mesh_io.read_mesh(obj.data).vertices, vertices)
    assert baked(obj)[1] == before


def test_the_operator_fits_the_item_and_reports_it(scene):
    obj = over_budget_sphere(uv_map=False)
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.thicket.fit_bake_budget() == {"FINISHED"}
    item = obj.thicket.items[-1]
    assert item.tile_size > TILE * 1.25, "the tiles grew"


def test_native_fit_takes_uvs_or_a_tile_size_and_agrees_with_the_handle(scene):
    obj = add("ico_sphere", subdivisions=3, radius=1.0)
    base = mesh_io.read_mesh(obj.data)
    shell = tn.shell(base.vertices, base.face_sizes, base.corners, 0.06, relative=True)
    texture = tn.Texture.pattern("chain_mail", size=(32, 32, 16))
    args = (base.vertices, base.face_sizes, base.corners, shell["base_offset"], shell["directors"], [texture])
    tile = float(np.linalg.norm(np.ptp(base.vertices, axis=0))) / 32
    grown = tn.fit_bake_tiles(*args, tile_size=tile, triangle_budget=BUDGET)
    assert grown["fits"] and grown["tile_size"] == pytest.approx(tile * grown["scale"]) and grown["scale"] > 1.0, grown
    # The same through the generated UVs: their tiles grow by the same scale.
    mesh = tn.Mesh(base.vertices, base.face_sizes, base.corners)
    uvs = mesh.world_size_uvs(tile)["uvs"]
    scaled = tn.fit_bake_tiles(*args, uvs=uvs, triangle_budget=BUDGET)
    assert scaled["tile_size"] is None and scaled["scale"] == pytest.approx(grown["scale"], rel=0.06), (scaled, grown)
    handle = tn.Shell(mesh.with_world_size_uvs(tile), shell["base_offset"], shell["directors"]).textured([texture], triangle_budget=BUDGET)
    assert handle.fit_budget() == scaled
    # The estimate it returns is the bake's own estimate at those tiles.
    assert tn.estimate_bake(*args, uvs=uvs, tiling=1.0 / scaled["scale"], triangle_budget=BUDGET) == scaled["triangles"]
    for bad in ({}, {"uvs": uvs, "tile_size": tile}):
        with pytest.raises(tn.InvalidInput, match="uvs .* or tile_size"):
            tn.fit_bake_tiles(*args, triangle_budget=BUDGET, **bad)
