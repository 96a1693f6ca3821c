"""World-Size Tiles: generated texture coordinates for meshes without a UV map
(`Mesh.world_size_uvs`, the core's `texture::Charts`). On a dense scan (the bunny
subdivided to about 59k faces) the bake of world-size tiles is a closed 2-manifold by
Blender's checks (bmesh `is_manifold`, `BVHTree.overlap`: `blender_defects` of
test_bake_manifold), its estimate within 1.5 times of what it makes, far smaller than
one tile per face; the Tile Size changes it; and the stack's setting reaches the bake
(and the refusal over the sample limit points at it)."""

import bpy
import numpy as np
import pytest
from conftest import DATA, mesh_object
from test_bake_manifold import blender_defects

import thicket_native as tn
from thicket import api
from thicket.pure.arrays import MeshArrays
from thicket.pure.kinds.volumetric_texture import WORLD_SIZE_HINT


def subdivided(vertices, triangles):
    """Each triangle split into four at its edge midpoints (shared midpoints welded)."""
    edges = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    unique, index = np.unique(edges, axis=0, return_inverse=True)
    mid = len(vertices) + index.reshape(3, -1).T  # midpoints of (ab, bc, ca) per triangle
    vertices = np.vstack([vertices, (vertices[unique[:, 0]] + vertices[unique[:, 1]]) / 2])
    a, b, c = triangles.T
    ab, bc, ca = mid.T
    return vertices, np.concatenate([np.stack(t, axis=1) for t in ((a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca))])


def dense_bunny(times=2):
    lines = (DATA / "bunny-3k.obj").read_text().splitlines()
    v = np.array([[float(x) for x in line.split()[1:4]] for line in lines if line.startswith("v ")], np.float64)
    f = np.array([[int(x.split("/")[0]) - 1 for x in line.split()[1:4]] for line in lines if line.startswith("f ")], np.int64)
    for _ in range(times):
        v, f = subdivided(v, f)
    return MeshArrays(v.astype(np.float32), np.full(len(f), 3, np.int32), f.astype(np.int32).ravel())


@pytest.fixture(scope="module")
def bunny():
    return dense_bunny()


def diagonal(base):
    return float(np.linalg.norm(np.ptp(base.vertices, axis=0)))


# Resolution 1: the lattice follows the texture (a step per texel a cell spans), so
# both modes are sampled as finely as their tiles need.
SETTINGS = dict(resolution=1, depth_steps=4, triangle_budget=0)


def bake_args(base, texture):
    shell = tn.shell(base.vertices, base.face_sizes, base.corners, 0.02, relative=True)
    return (base.vertices, base.face_sizes, base.corners, shell["base_offset"], shell["directors"], [texture])


def test_world_size_uvs_of_the_native_mesh(bunny):
    mesh = tn.Mesh(bunny.vertices, bunny.face_sizes, bunny.corners)
    tile = diagonal(bunny) / 32
    out = mesh.world_size_uvs(tile)
    uvs, charts = out["uvs"], out["chart_of_face"]
    assert uvs.shape == (len(bunny.corners), 2) and uvs.dtype == np.float32
    assert charts.shape == (bunny.face_count,) and 0 <= charts.min() and charts.max() == out["chart_count"] - 1
    # Far fewer charts than faces, and every triangle keeps its orientation in (s, t).
    assert 10 < out["chart_count"] < bunny.face_count / 50, out["chart_count"]
    st = uvs.reshape(-1, 3, 2).astype(np.float64)
    e, f = st[:, 1] - st[:, 0], st[:, 2] - st[:, 0]
    signed = e[:, 0] * f[:, 1] - e[:, 1] * f[:, 0]
    assert (signed > 0).all(), f"{(signed <= 0).sum()} triangles flip"
    # The area in tiles is the world area over tile² (each chart keeps its area).
    p = bunny.vertices[bunny.corners].reshape(-1, 3, 3).astype(np.float64)
    world = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum()
    assert abs(signed.sum() * tile**2 / world - 1) < 0.02
    # Deterministic; a bad tile size is refused.
    np.testing.assert_array_equal(mesh.world_size_uvs(tile)["uvs"], uvs)
    # The same UVs as a mesh of their own, the positions and faces unchanged.
    assert mesh.uvs is None
    mapped = mesh.with_world_size_uvs(tile)
    np.testing.assert_array_equal(mapped.uvs, uvs)
    np.testing.assert_array_equal(mapped.arrays()["corners"], mesh.arrays()["corners"])
    np.testing.assert_array_equal(mapped.arrays()["vertices"], bunny.vertices)
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(tn.InvalidInput, match="tile size"):
            mesh.world_size_uvs(bad)
        with pytest.raises(tn.InvalidInput, match="tile size"):
            mesh.with_world_size_uvs(bad)


def test_a_dense_scan_bakes_world_size_tiles_closed_and_estimated(scene, bunny):
    texture = tn.Texture.pattern("chain_mail", size=(8, 8, 4), thickness=3.0)
    args = bake_args(bunny, texture)
    mesh = tn.Mesh(bunny.vertices, bunny.face_sizes, bunny.corners)
    tile = diagonal(bunny) / 16
    uvs = mesh.world_size_uvs(tile)["uvs"]
    estimate = tn.estimate_bake(*args, uvs=uvs, **SETTINGS)
    out = tn.bake_texture(*args, uvs=uvs, **SETTINGS)
    count = len(out["corners"]) // 3
    assert count > 10_000
    assert count / 1.5 <= estimate <= count * 1.5, f"estimate {estimate}, baked {count}"
    assert not out["per_face_tiles"] and not out["texture_finer_than_lattice"]
    defects = {k: v for k, v in blender_defects(out).items() if v}
    assert not defects, f"{defects} in {count} triangles"
    # One tile per face, followed as finely (no sample limit), samples far more: each
    # of the 59k faces is a whole tile.
    per_face = tn.estimate_bake(*args, **SETTINGS, max_triangles=2**40)
    assert per_face > 8 * estimate, (per_face, estimate)
    # Under a sample limit the world-size bake fits in, one tile per face is coarsened
    # below its texture (told by `texture_finer_than_lattice`) and still larger.
    limit = 2 * estimate
    assert len(tn.bake_texture(*args, uvs=uvs, **SETTINGS, max_triangles=limit)["corners"]) // 3 == count
    coarse = tn.bake_texture(*args, **SETTINGS, max_triangles=limit)
    assert coarse["per_face_tiles"] and coarse["texture_finer_than_lattice"]
    # Half the tile size: four times the tiles, a larger bake.
    finer = tn.estimate_bake(*args, uvs=mesh.world_size_uvs(tile / 2)["uvs"], **SETTINGS)
    assert finer > 1.5 * estimate, (finer, estimate)


def test_the_stack_setting_reaches_the_bake_and_the_refusal_points_at_it(scene):
    base = dense_bunny(times=1)
    tris = base.corners.reshape(-1, 3)
    obj = mesh_object("bunny", base.vertices.tolist(), tris.tolist())
    assert not obj.data.uv_layers
    kw = dict(shell_thickness=0.02, resolution=1, depth_steps=4, texture_size=8, feature_thickness=3.0, triangle_budget=0)
    result = api.add_volumetric_texture(obj, "chain_mail", no_uv_tiles="WORLD", **kw)
    item = obj.thicket.items[-1]
    assert item.no_uv_tiles == "WORLD" and item.tile_size == 0.0  # automatic
    auto = len(result.data.polygons)
    assert auto > 1000 and "own texture tile" not in obj.thicket.last_note
    assert result.data.uv_layers, "the generated coordinates are the result's UV map"
    # An explicit tile size equal to the automatic one gives the same bake; half of it another.
    item.tile_size = diagonal(base) / 32
    assert len(api.regenerate(obj).data.polygons) == auto
    item.tile_size = diagonal(base) / 48
    finer = len(api.regenerate(obj).data.polygons)
    assert finer > 1.5 * auto, (finer, auto)
    # Over the sample limit even at Resolution: one tile per face is refused pointing
    # at World-Size Tiles (and its coarsened bakes are told so); World-Size Tiles is
    # refused without the hint.
    item.tile_size = 0.0
    item.resolution = 2  # at 1 step per face edge, one whole tile per face samples nothing
    item.max_triangles = 1000
    with pytest.raises(tn.OverLimit) as refused:
        api.regenerate(obj)
    assert WORLD_SIZE_HINT not in str(refused.value)
    item.no_uv_tiles = "FACE"
    before = len(obj.thicket.result.data.polygons)
    with pytest.raises(tn.OverLimit) as refused:  # an InvalidInput, told apart by kind
        api.regenerate(obj)
    assert WORLD_SIZE_HINT in str(refused.value) and isinstance(refused.value, tn.InvalidInput)
    assert len(obj.thicket.result.data.polygons) == before  # the previous result stays
    item.resolution = 1
    item.max_triangles = 2 * auto
    api.regenerate(obj)
    assert "World-Size Tiles" in obj.thicket.last_note
    bpy.data.objects.remove(obj)


def test_preview_bake_and_estimate_take_the_same_generated_uvs(scene):
    """World-Size Tiles reaches every consumer of UVs through one handle: the preview
    renders, the stack's bake and its estimate are those of the arrays functions given
    the generated UVs."""
    from conftest import add

    from thicket import mesh_io
    from thicket.pure import evaluate as E
    from thicket.pure import settings as S
    from thicket.pure.kinds.volumetric_texture import auto_tile_size

    full = mesh_io.read_mesh(add("ico_sphere", subdivisions=3).data)
    sphere = MeshArrays(full.vertices, full.face_sizes, full.corners)
    shell_item = S.OffsetShell(thickness=0.1, relative=True)
    texture = S.VolumetricTexture(pattern="rivets", texture_size=8, resolution=3, depth_steps=6, no_uv_tiles="world", tile_size=0.3)
    uvs = tn.Mesh(sphere.vertices, sphere.face_sizes, sphere.corners).world_size_uvs(0.3)["uvs"]
    setup = E.render_setup(sphere, [shell_item, texture])
    np.testing.assert_array_equal(setup.settings["uvs"], uvs)
    shell = setup.shell
    args = (sphere.vertices, sphere.face_sizes, sphere.corners, shell.base_offset, shell.directors, [tn.texture("rivets", size=(8, 8, 4))])
    settings = dict(uvs=uvs, resolution=3, depth_steps=6)
    view = np.array(((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, -5), (0, 0, 0, 1)), np.float32)
    projection = np.array(((2, 0, 0, 0), (0, 2, 0, 0), (0, 0, -1.02, -0.2), (0, 0, -1, 0)), np.float32)
    frame = (view, projection, 32, 24)
    drawn = setup.handle().render(*frame, method="reference")
    assert (drawn["rgba"][:, :, 3] > 0.5).any() and not drawn["per_face_tiles"]
    np.testing.assert_array_equal(drawn["rgba"], tn.render_shell(*args[:5], args[5], *frame, method="reference", **settings)["rgba"])
    baked = E.evaluate_stack(sphere, [shell_item, texture])
    want = tn.bake_texture(*args, **settings)
    assert len(want["corners"]) > 0 and not want["per_face_tiles"]
    np.testing.assert_array_equal(baked.corners, want["corners"])
    np.testing.assert_array_equal(baked.vertices, want["vertices"])
    # The result's UV map is the generated UVs carried to the bake (Tiling 1).
    np.testing.assert_allclose(baked.uv_maps[sphere.uv_name], want["corner_texcoords"][:, :2])
    estimate = tn.estimate_bake(*args, **settings)
    with pytest.raises(Exception, match=f"about {estimate:,} triangles"):
        E.evaluate_stack(sphere, [shell_item, S.VolumetricTexture(**{**texture.__dict__, "confirm_above": 0})], ask=True)
    # Tile size 0: the automatic one, 1/32 of the bounding-box diagonal.
    assert auto_tile_size(sphere) == pytest.approx(np.linalg.norm(np.ptp(sphere.vertices, axis=0)) / 32)
    auto = E.render_setup(sphere, [shell_item, S.VolumetricTexture(**{**texture.__dict__, "tile_size": 0.0})])
    assert auto.settings["world_tile_size"] == pytest.approx(auto_tile_size(sphere))


def test_cycles_renders_the_world_size_bake_as_the_preview_shows_it(scene, tmp_path):
    # Preview = bake for generated coordinates too: Cycles' silhouette of the baked
    # chain mail (the add-on's defaults but the tile size, World-Size Tiles on a
    # sphere without a UV map) against the reference ray marcher from the same
    # camera, close enough that the rings are pixels wide (issue 15: IoU >= 0.95). Drawn with one tile per face instead, the preview
    # would show other rings.
    import math

    from test_render import cycles_and_view, iou

    from thicket.render import preview

    sphere = mesh_object("ball", *ico_sphere())
    assert not sphere.data.uv_layers
    # Tiles of 1/16 of the diagonal (twice the automatic size, a quarter of its bake).
    api.add_volumetric_texture(sphere, "chain_mail", shell_thickness=0.06, no_uv_tiles="WORLD", tile_size=2 * math.sqrt(3) / 16)
    sphere.hide_render = True  # Cycles draws the bake (the result)
    # Rings a few pixels wide: at 160 x 120 with the automatic tiles, anti-aliased
    # Cycles and the point-sampled preview disagree on pixels the wires half cover
    # (IoU 0.925 there, 0.962 at 480 x 360).
    width, height = 320, 240
    baked, view, projection = cycles_and_view(scene, tmp_path, sphere, (0.0, -2.4, 0.5), (math.radians(80), 0.0, 0.0), (width, height))

    def drawn():
        return preview.render_arrays(sphere, view, projection, width, height, method="reference")["rgba"][:, :, 3] > 0.5

    world = drawn()
    sphere.thicket.items[-1].no_uv_tiles = "FACE"
    per_face = drawn()
    assert 0.05 < baked.mean() < 0.95, "the shell fills part of the view"
    score = iou(world, baked)
    print(f"world-size IoU {score:.3f}, per-face preview against the same bake {iou(per_face, baked):.3f}")
    assert score >= 0.95, f"IoU {score:.3f}"
    assert iou(per_face, baked) < score - 0.05, "the preview follows the world-size coordinates"


def ico_sphere(subdivisions=3):
    """An icosphere's vertices and triangles (no UV map: `mesh_object` makes none)."""
    import bmesh

    bm = bmesh.new()
    bmesh.ops.create_icosphere(bm, subdivisions=subdivisions, radius=1.0)
    vertices = [tuple(v.co) for v in bm.verts]
    triangles = [[v.index for v in f.verts] for f in bm.faces]
    bm.free()
    return vertices, triangles
