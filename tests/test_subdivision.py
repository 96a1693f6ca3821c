"""Catmull-Clark subdivision (`thicket_native.subdivide`, issue 18) against Blender's own
Subdivision Surface modifier on the same base mesh (Boundary Smooth "All", Use Creases
with no creases): same vertex and face counts, all quads, and every vertex of either
within 1e-5 of the bounding-box diagonal of its nearest in the other (the modifier
numbers its vertices its own way, keeping only the base vertices' indices).

Use Limit Surface: Thicket moves each vertex of the last level to the exact limit
(Catmull-Clark limit masks). Blender evaluates OpenSubdiv patches isolated to the
modifier's Quality level q (3 by default) around irregular vertices; they give the exact
limit at every level-q vertex except a boundary corner smoothed by "All" (a boundary
vertex of one face), which gets its level-q control point; between level-q vertices
(levels above q) they are approximations. So the limit surfaces are compared at
Quality = max(3, levels), with "Keep Corners" on the grid, and the two departures are
pinned as measured.
"""

import bpy
import numpy as np
import pytest
from conftest import DATA, add

import thicket_native as tn
from thicket import mesh_io


def nearest(a, b, h):
    """For each point of `b`, the index of its nearest point of `a` and the distance to it
    where that is below `h`, else a distance of at least `h` (inf where no point of `a` lies
    in the 27 cells of side `h` around it): exact for the question "is every point within
    h", vectorised by hashing `a` into cells of side `h`."""

    def cell(p):
        return np.floor(p / h).astype(np.int64) + (1 << 20)

    def key(q):
        return (q[:, 0] << 42) | (q[:, 1] << 21) | q[:, 2]

    ka = key(cell(a))
    order = np.argsort(ka)
    ka, a = ka[order], a[order]
    most = np.unique(ka, return_counts=True)[1].max()
    qb = cell(b)
    best, index = np.full(len(b), np.inf), np.zeros(len(b), np.int64)
    for off in np.stack(np.meshgrid([-1, 0, 1], [-1, 0, 1], [-1, 0, 1]), -1).reshape(-1, 3):
        kb = key(qb + off)
        first = np.searchsorted(ka, kb)
        for k in range(most):  # the k-th point of each cell
            i = np.minimum(first + k, len(ka) - 1)
            d = np.where(ka[i] == kb, np.linalg.norm(b - a[i], axis=1), np.inf)
            closer = d < best
            best, index = np.where(closer, d, best), np.where(closer, order[i], index)
    return best, index


def nearest_distances(a, b, h):
    return nearest(a, b, h)[0]


def point_set_distance(a, b, h):
    """The larger of the two directed nearest-neighbour distances between point sets `a`
    and `b`, where it is below `h`; inf otherwise."""
    return max(nearest_distances(a, b, h).max(), nearest_distances(b, a, h).max())


def blender_subdivided(obj, levels, limit, boundary_smooth="ALL", quality=3, uv_smooth="PRESERVE_BOUNDARIES"):
    """The modifier's result on `obj`: vertices, face sizes, material indices, UVs."""
    mod = obj.modifiers.new("subsurf", "SUBSURF")
    mod.levels, mod.use_limit_surface, mod.boundary_smooth, mod.quality = levels, limit, boundary_smooth, quality
    mod.uv_smooth = uv_smooth
    dg = bpy.context.evaluated_depsgraph_get()
    evaluated = obj.evaluated_get(dg)
    mesh = evaluated.to_mesh()
    arrays = mesh_io.read_mesh(mesh)
    evaluated.to_mesh_clear()
    obj.modifiers.remove(mod)
    return arrays


def bunny():
    bpy.ops.wm.obj_import(filepath=str(DATA / "bunny-3k.obj"))
    return bpy.context.selected_objects[0]


# name -> (object maker, highest level compared).
MESHES = {
    "cube": (lambda: add("cube"), 4),
    "uv_sphere": (lambda: add("uv_sphere"), 3),
    "suzanne": (lambda: add("monkey"), 3),
    "grid": (lambda: add("grid", x_subdivisions=6, y_subdivisions=4), 4),
    "cylinder_ngon_caps": (lambda: add("cylinder", vertices=12, end_fill_type="NGON"), 4),
    "torus": (lambda: add("torus", major_segments=24, minor_segments=8), 4),
    "bunny": (bunny, 2),
}
CASES = [(name, levels) for name, (_, top) in MESHES.items() for levels in range(1, top + 1)]


def compare(obj, levels, limit, boundary_smooth="ALL", quality=3):
    """(Thicket's result, Blender's, their point-set distance relative to the diagonal
    (inf beyond 1e-3), the diagonal)."""
    obj.data.polygons.foreach_set("material_index", np.arange(len(obj.data.polygons), dtype=np.int32) % 3)
    obj.data.update()
    base = mesh_io.read_mesh(obj.data)
    ours = tn.subdivide(base.vertices, base.face_sizes, base.corners, levels, limit, material_index=base.material_index, boundary_smooth=boundary_smooth)
    theirs = blender_subdivided(obj, levels, limit, boundary_smooth, quality)
    diagonal = float(np.linalg.norm(np.ptp(theirs.vertices, axis=0)))
    distance = point_set_distance(ours["vertices"], theirs.vertices, 1e-3 * diagonal) / diagonal
    return base, ours, theirs, distance, diagonal


@pytest.mark.parametrize("name,levels", CASES)
def test_matches_blender_without_limit(scene, name, levels):
    obj = MESHES[name][0]()
    base, ours, theirs, distance, _ = compare(obj, levels, False)
    assert len(ours["vertices"]) == len(theirs.vertices)
    assert len(ours["face_sizes"]) == len(theirs.face_sizes) == base.face_sizes.sum() * 4 ** (levels - 1)
    assert np.all(theirs.face_sizes == 4) and np.all(ours["face_sizes"] == 4)
    assert distance <= 1e-5, f"{name} level {levels}: {distance:.3g} of the diagonal"
    # Material indices: each base face's children, in order, carry its index.
    assert np.array_equal(ours["material_index"], np.repeat(base.material_index, base.face_sizes * 4 ** (levels - 1)))
    assert np.array_equal(np.bincount(ours["material_index"]), np.bincount(theirs.material_index))


@pytest.mark.parametrize("name,levels", CASES)
def test_matches_blender_on_the_limit_surface(scene, name, levels):
    obj = MESHES[name][0]()
    boundary = "PRESERVE_CORNERS" if name == "grid" else "ALL"
    _, ours, theirs, distance, _ = compare(obj, levels, True, boundary, quality=max(3, levels))
    assert len(ours["vertices"]) == len(theirs.vertices) and len(ours["face_sizes"]) == len(theirs.face_sizes)
    assert distance <= 1e-5, f"{name} level {levels}: {distance:.3g} of the diagonal"


@pytest.mark.parametrize("levels", [1, 2, 3])
def test_blender_smooth_corners_are_level_q_control_points(scene, levels):
    # An open grid, corners smoothed ("All"), Quality 3: Blender's four corners are the
    # corners' Catmull-Clark positions after 3 levels, 1.6e-3 from their limits (5.5e-4 of
    # the diagonal); every other vertex is on the limit.
    obj = add("grid", x_subdivisions=6, y_subdivisions=4)
    base, ours, theirs, distance, diagonal = compare(obj, levels, True)
    corners = np.flatnonzero(np.bincount(base.corners, minlength=len(base.vertices)) == 1)
    assert len(corners) == 4
    assert 5e-4 < distance < 6e-4, f"{distance:.3g} of the diagonal"
    level3 = tn.subdivide(base.vertices, base.face_sizes, base.corners, 3, False)["vertices"]
    # Blender keeps base vertex i at index i.
    assert np.abs(theirs.vertices[corners] - level3[corners]).max() <= 1e-5 * diagonal
    rest = np.setdiff1d(np.arange(len(ours["vertices"])), corners)
    others = np.setdiff1d(np.arange(len(theirs.vertices)), corners)
    assert point_set_distance(ours["vertices"][rest], theirs.vertices[others], 1e-3 * diagonal) <= 1e-5 * diagonal


def test_blender_limit_above_quality_is_approximate(scene):
    # Level 4 at Quality 3: points inside the level-3 patches at the cube's corners (valence
    # 3) come from OpenSubdiv's end-cap approximation, 1.1e-3 of the diagonal off the limit.
    _, _, _, distance, _ = compare(add("cube"), 4, True, quality=3)
    assert 1e-3 < distance < 1.2e-3, f"{distance:.3g} of the diagonal"


def test_refuses_non_manifold_and_bad_arguments(scene):
    # Three quads on one edge; a face list that is fine for Blender but not subdividable.
    vertices = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [0, -1, 0], [1, -1, 0]], np.float32)
    corners = np.array([0, 1, 2, 3, 1, 0, 4, 5, 0, 1, 7, 6], np.int32)
    sizes = np.array([4, 4, 4], np.int32)
    with pytest.raises(tn.InvalidInput, match="edge 0-1 is shared by 3 faces"):
        tn.subdivide(vertices, sizes, corners)
    # Two quads wound against each other: OpenSubdiv (so Blender) makes their edge a boundary.
    with pytest.raises(tn.InvalidInput, match="run along edge 0-1 the same way"):
        tn.subdivide(vertices, sizes[:2], np.array([0, 1, 2, 3, 0, 1, 5, 4], np.int32))
    quad = (vertices[:4], sizes[:1], corners[:4])
    for kwargs, message in [
        ({"levels": 0}, "levels must be 1 to 6"),
        ({"levels": 7}, "levels must be 1 to 6"),
        ({"material_index": np.zeros(2, np.int32)}, "2 entries for 1 faces"),
        ({"boundary_smooth": "NONE"}, "boundary_smooth"),
        ({"uvs": np.zeros((5, 2), np.float32)}, r"uvs must have shape \(4, 2\)"),
        ({"uvs": np.zeros((4, 2), np.float64)}, "uvs must be a float32 array"),
        ({"uvs": np.array([[0, 0], [1, 0], [1, np.nan], [0, 1]], np.float32)}, "UV of corner 2 is not finite"),
        ({"uvs": np.zeros((4, 2), np.float32), "uv_smooth": "SMOOTH_ALL"}, "uv_smooth must be"),
    ]:
        with pytest.raises(tn.InvalidInput, match=message):
            tn.subdivide(*quad, **kwargs)
    # One quad, corners kept: its limit is the bilinear quad itself at level 1.
    out = tn.subdivide(*quad, levels=1, limit=True, boundary_smooth="PRESERVE_CORNERS")
    assert np.allclose(np.sort(out["vertices"][:, 0]), np.sort([0, 1, 1, 0, 0.5, 1, 0.5, 0, 0.5]), atol=1e-6)


def smart_projected_sphere():
    obj = add("uv_sphere", segments=16, ring_count=8)
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.uv.smart_project()
    bpy.ops.object.mode_set(mode="OBJECT")
    return obj


# UV maps: the primitives' own (the cube's cross, where every vertex lies on a seam; the
# grid's, all smooth inside a boundary; Suzanne's islands; the cylinder's n-gon caps) and a
# Smart UV Project.
UV_MESHES = {
    "cube": lambda: add("cube"),
    "grid": lambda: add("grid", x_subdivisions=6, y_subdivisions=4),
    "suzanne": lambda: add("monkey"),
    "cylinder_ngon_caps": lambda: add("cylinder", vertices=12, end_fill_type="NGON"),
    "smart_projected_sphere": smart_projected_sphere,
}


def corner_uv_difference(ours, theirs, diagonal):
    """The largest difference between the UVs of matching corners: faces matched by their
    centroids (one-to-one), corners within a face by their vertices."""
    mine = ours["vertices"][ours["corners"]].reshape(-1, 4, 3)
    other = theirs.vertices[theirs.corners].reshape(-1, 4, 3)
    distance, face = nearest(other.mean(axis=1), mine.mean(axis=1), 1e-3 * diagonal)
    assert distance.max() <= 1e-3 * diagonal and len(np.unique(face)) == len(face), "faces do not match one to one"
    gaps = np.linalg.norm(mine[:, :, None, :] - other[face][:, None, :, :], axis=3)
    corner = gaps.argmin(axis=2)
    assert np.all(np.sort(corner, axis=1) == np.arange(4)), "corners do not match one to one"
    matched = np.take_along_axis(theirs.uvs.reshape(-1, 4, 2)[face], corner[:, :, None], axis=1)
    return np.abs(ours["uvs"].reshape(-1, 4, 2) - matched).max()


@pytest.mark.parametrize("uv_smooth", ["PRESERVE_BOUNDARIES", "NONE"])
@pytest.mark.parametrize("limit", [False, True])
@pytest.mark.parametrize("levels", [1, 2, 3])
@pytest.mark.parametrize("name", list(UV_MESHES))
def test_uvs_match_blender(scene, name, levels, limit, uv_smooth):
    # Per-corner UVs against the modifier's UV map, within 1e-5 (UV units: the maps span
    # [0, 1]); the two differ by float32 rounding, at most 3.0e-7. The limit surface at
    # Quality max(3, levels), as for the positions.
    obj = UV_MESHES[name]()
    boundary = "PRESERVE_CORNERS" if limit and name == "grid" else "ALL"
    base = mesh_io.read_mesh(obj.data)
    assert base.uvs is not None
    ours = tn.subdivide(base.vertices, base.face_sizes, base.corners, levels, limit, uvs=base.uvs, boundary_smooth=boundary, uv_smooth=uv_smooth)
    theirs = blender_subdivided(obj, levels, limit, boundary, max(3, levels), uv_smooth)
    assert ours["uvs"].shape == theirs.uvs.shape == (len(ours["corners"]), 2) and ours["uvs"].dtype == np.float32
    diagonal = float(np.linalg.norm(np.ptp(theirs.vertices, axis=0)))
    difference = corner_uv_difference(ours, theirs, diagonal)
    assert difference <= 1e-5, f"{name} level {levels} limit {limit} {uv_smooth}: {difference:.3g}"
    # The positions are those subdivide gives without UVs.
    plain = tn.subdivide(base.vertices, base.face_sizes, base.corners, levels, limit, boundary_smooth=boundary)
    assert np.array_equal(ours["vertices"], plain["vertices"]) and np.array_equal(ours["corners"], plain["corners"])


def test_uv_smooth_rules_differ_where_uvs_are_smooth(scene):
    # On Suzanne's islands the default rule smooths inner UVs; 'NONE' keeps them bilinear:
    # the two must differ there (or the test above could not tell the rules apart).
    obj = add("monkey")
    base = mesh_io.read_mesh(obj.data)
    smooth, linear = (
        tn.subdivide(base.vertices, base.face_sizes, base.corners, 2, uvs=base.uvs, uv_smooth=rule)["uvs"] for rule in ("PRESERVE_BOUNDARIES", "NONE")
    )
    assert np.abs(smooth - linear).max() > 1e-2
