"""A shell's crossings and inverted cells found with Blender's own tools, independent
of the project's checker: `BVHTree.overlap` on Blender's triangulation for skin/skin
and skin/base crossings, and numpy orientation tests of every cell's tetrahedra and of
the map a texture is drawn through.
Shared by the tests and `make bench`."""

from fractions import Fraction

import numpy as np
from mathutils.bvhtree import BVHTree


def loop_triangles(mesh):
    """Blender's own triangulation (vertex triples)."""
    mesh.calc_loop_triangles()
    tris = np.empty(len(mesh.loop_triangles) * 3, np.int32)
    mesh.loop_triangles.foreach_get("vertices", tris)
    return tris.reshape(-1, 3)


# A bound on the rounding of the orientation determinant computed in float64 from
# differences, as a share of its permanent: Shewchuk's (7 + 56 eps) eps with
# eps = 2^-53, taken twice over (numpy's eps is 2^-52).
ORIENT_ERROR = 8 * np.finfo(np.float64).eps


def orient(a, b, c, d):
    """Rows of the exact sign (-1, 0, 1) of the orientation determinant of d against
    the plane of abc (float64 rows): the float64 determinant where it exceeds its
    rounding bound, else the exact one in rationals (nearly coplanar points, whose
    float64 signs are rounding noise: flat parts of a tilted base)."""
    u, v, w = b - a, c - a, d - a
    det = np.einsum("ij,ij->i", np.cross(u, v), w)
    au, av, aw = np.abs(u), np.abs(v), np.abs(w)
    permanent = (
        (au[:, 1] * av[:, 2] + au[:, 2] * av[:, 1]) * aw[:, 0]
        + (au[:, 2] * av[:, 0] + au[:, 0] * av[:, 2]) * aw[:, 1]
        + (au[:, 0] * av[:, 1] + au[:, 1] * av[:, 0]) * aw[:, 2]
    )
    sign = np.sign(det)
    # A zero permanent: every term is exactly zero, and so is the sign already.
    for i in np.flatnonzero((np.abs(det) <= ORIENT_ERROR * permanent) & (permanent > 0)):
        pa, pb, pc, pd = ([Fraction(float(x)) for x in point[i]] for point in (a, b, c, d))
        eu, ev, ew = ([q - r for q, r in zip(point, pa)] for point in (pb, pc, pd))
        cross = (eu[1] * ev[2] - eu[2] * ev[1], eu[2] * ev[0] - eu[0] * ev[2], eu[0] * ev[1] - eu[1] * ev[0])
        exact = sum(x * y for x, y in zip(cross, ew))
        sign[i] = (exact > 0) - (exact < 0)
    return sign


def segments_cross(p, q, a, b, c):
    """Whether segments p-q properly cross triangles abc (rows, float64): p and q
    strictly on either side of the plane and the line pq through the closed triangle
    (the textbook orientation test, with exact signs; a segment in the triangle's
    plane does not count)."""
    straddle = orient(a, b, c, p) * orient(a, b, c, q) < 0
    s1, s2, s3 = orient(p, q, a, b), orient(p, q, b, c), orient(p, q, c, a)
    through = ((s1 >= 0) & (s2 >= 0) & (s3 >= 0)) | ((s1 <= 0) & (s2 <= 0) & (s3 <= 0))
    return straddle & through


def triangles_cross(t, u):
    """Whether triangles t and u (m x 3 x 3, float64) intersect: an edge of one
    crosses the other."""
    hit = np.zeros(len(t), bool)
    for x, y in ((t, u), (u, t)):
        for k in range(3):
            hit |= segments_cross(x[:, k], x[:, (k + 1) % 3], y[:, 0], y[:, 1], y[:, 2])
    return hit


def bases_cross(base, pairs, tris, other_tris=None):
    """Whether the two base triangles of each pair cross each other (a float64
    orientation test, independent of Blender's overlap and of the project's checker;
    triangles sharing a vertex touch there and do not count). A pair's second triangle
    indexes `other_tris` where given (another split of the same base)."""
    if len(pairs) == 0:
        return np.zeros(0, bool)
    p = base.astype(np.float64)
    ta, tb = tris[pairs[:, 0]], (tris if other_tris is None else other_tris)[pairs[:, 1]]
    shared = (ta[:, :, None] == tb[:, None, :]).any(axis=(1, 2))
    return triangles_cross(p[ta], p[tb]) & ~shared


def overlapping(a_points, b_points, tris, same, b_tris=None):
    """Crossing triangle pairs by Blender's BVHTree.overlap (pairs sharing a vertex
    index are dropped for a tree against itself); `b_points` are split by `b_tris`
    where given, else by `tris`."""
    b_tris = tris if b_tris is None else b_tris
    a = BVHTree.FromPolygons(a_points.tolist(), tris.tolist(), all_triangles=True)
    b = a if same else BVHTree.FromPolygons(b_points.tolist(), b_tris.tolist(), all_triangles=True)
    pairs = np.array(a.overlap(b), dtype=np.int64).reshape(-1, 2)
    if same and len(pairs):
        shared = (tris[pairs[:, 0]][:, :, None] == tris[pairs[:, 1]][:, None, :]).any(axis=(1, 2))
        pairs = pairs[~shared & (pairs[:, 0] != pairs[:, 1])]
    return pairs


def written_triangles(out, layer=1.0):
    """Blender's own triangulation of one layer of a shell result as written (`out`: a
    native shell dict; the outer layer by default, an envelope's inner one at 0 in a
    solid result), as triples of base vertices (`source_vertex`; facing either way):
    the triangles a user sees of that skin, n-gons included."""
    import bpy

    mesh = bpy.data.meshes.new("written")
    try:
        sizes, corners = out["face_sizes"], out["corners"]
        mesh.vertices.add(len(out["vertices"]))
        mesh.vertices.foreach_set("co", np.ascontiguousarray(out["vertices"], np.float32).ravel())
        mesh.loops.add(len(corners))
        mesh.loops.foreach_set("vertex_index", np.ascontiguousarray(corners, np.int32))
        mesh.polygons.add(len(sizes))
        mesh.polygons.foreach_set("loop_start", np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int32))
        mesh.update(calc_edges=True)
        tris = loop_triangles(mesh)
    finally:
        bpy.data.meshes.remove(mesh)
    mine = (out["layer"][tris] == layer).all(axis=1)
    if not mine.any():
        raise ValueError(f"the result writes no layer {layer} (an envelope's inner skin is written in a solid result)")
    return out["source_vertex"][tris[mine]].astype(np.int32)


def written_skins(out, side):
    """`written_triangles` of each skin `blender_check` tests: the outer layer, and an
    envelope's inner layer (split by Blender by its own shape, not the outer's), which
    only a solid result writes."""
    return [written_triangles(out, 1.0)] + ([written_triangles(out, 0.0)] if side == "envelope" else [])


def inverted_cells(bottom, top, tris, orientation):
    """Prisms (a b c | a' b' c') split as (a b c a') (b c a' b') (c a' b' c'): a
    tetrahedron of non-positive oriented volume inverts its cell, unless two of its
    corners coincide (a zero director: the cell is pressed flat there)."""
    a, b, c = (bottom[tris[:, k]] for k in range(3))
    a2, b2, c2 = (top[tris[:, k]] for k in range(3))
    bad = np.zeros(len(tris), bool)
    for t in ((a, b, c, a2), (b, c, a2, b2), (c, a2, b2, c2)):
        p = [x.astype(np.float64) for x in t]
        volume = np.einsum("ij,ij->i", np.cross(p[1] - p[0], p[2] - p[0]), p[3] - p[0]) * orientation
        flat = np.zeros(len(tris), bool)
        for i in range(4):
            for j in range(i + 1, 4):
                flat |= (t[i] == t[j]).all(axis=1)
        bad |= (volume <= 0) & ~flat
    area = np.linalg.norm(np.cross((b - a).astype(np.float64), (c - a).astype(np.float64)), axis=1)
    return int((bad & (area > 0)).sum())


def folding_cells(bottom, top, tris, orientation, samples=65):
    """Cells whose map P(u, v, r) = sum b_i (bottom_i + r (top_i - bottom_i)) has a
    negative Jacobian: for fixed r the map is affine in (u, v), so the Jacobian is
    checked at the corners, on `samples` values of r (sampled, not solved: the
    project's checker finds the least value exactly). Cells without area and corners
    without height (pressed flat) are not folds."""
    x = [bottom[tris[:, k]].astype(np.float64) for k in range(3)]
    d = [top[tris[:, k]].astype(np.float64) - x[k] for k in range(3)]
    area = np.linalg.norm(np.cross(x[1] - x[0], x[2] - x[0]), axis=1)
    bad = np.zeros(len(tris), bool)
    for r in np.linspace(0.0, 1.0, samples):
        normal = np.cross(x[1] + r * d[1] - x[0] - r * d[0], x[2] + r * d[2] - x[0] - r * d[0])
        for k in range(3):
            bad |= np.einsum("ij,ij->i", normal, d[k]) * orientation < -1e-12 * area * np.linalg.norm(d[k], axis=1)
    return int((bad & (area > 0)).sum())


def blender_check(base, out, side, tris, written=None):
    """Crossings and inverted cells of a shell result, found with Blender's tools.

    `tris`: Blender's triangulation of the base (the user's object); `written`: that of
    each skin as the result writes it (`written_skins`: the outer skin, and an
    envelope's inner one), `tris` for every skin by default. A single array is taken
    for the outer skin only: an envelope's inner skin is split by its own shape.
    A crossing pair is inherited only where its two base triangles cross each other
    (at zero thickness the shell has exactly those pairs), the project's rule; a pair
    with one triangle over a face that crosses some other face elsewhere is not
    excused. Whether two base triangles cross is decided by a float64 test here
    (`bases_cross`), not by Blender's overlap, which misses crossings where edges pass
    near each other. Cells are checked over the base's split: Blender's split of a
    quad is one of the two the project checks, and its split of an n-gon the project's
    own; the skins over `written`, where Blender splits a quad by the skin's shape and
    draws n-gons as the triangles the result writes. `self_crossing` and
    `base_crossing` count the pairs of `self` and `base` that a float64 test finds
    crossing: Blender's float32 overlap also reports pairs that only touch."""
    offset, directors = out["base_offset"], out["directors"]
    skins = [base + offset + directors] + ([base + offset] if side == "envelope" else [])
    if written is None:
        written = [tris] * len(skins)
    elif isinstance(written, np.ndarray):
        if len(skins) > 1:
            raise ValueError("an envelope's inner skin has its own split: pass written_skins(out, side) of a solid result")
        written = [written]
    assert len(written) == len(skins)
    own = np.unique(overlapping(base, base, tris, same=True))

    flat = np.linalg.norm(directors, axis=1) + np.linalg.norm(offset, axis=1) == 0
    counts = {"self": 0, "base": 0, "self_crossing": 0, "base_crossing": 0}

    def count(kind, pairs, a_points, a_tris, b_points, b_tris):
        # Blender's pairs, and those of them the float64 test finds crossing (its overlap
        # also reports triangles that only touch, in float32).
        counts[kind] += len(pairs)
        p, q = a_points.astype(np.float64), b_points.astype(np.float64)
        counts[kind + "_crossing"] += int(triangles_cross(p[a_tris[pairs[:, 0]]], q[b_tris[pairs[:, 1]]]).sum()) if len(pairs) else 0

    for i, skin in enumerate(skins):
        wi = written[i]
        for j in range(i, len(skins)):
            wj = written[j]
            pairs = overlapping(skin, skins[j], wi, same=i == j, b_tris=wj)
            if i != j:  # inner and outer of one envelope: pairs over cells sharing a vertex are the cell's own
                shared = (wi[pairs[:, 0]][:, :, None] == wj[pairs[:, 1]][:, None, :]).any(axis=(1, 2))
                pairs = pairs[~shared]
            count("self", pairs[~bases_cross(base, pairs, wi, wj)], skin, wi, skins[j], wj)
        pairs = overlapping(skin, base, wi, same=False, b_tris=tris)
        # A skin triangle touches the base where a shared corner is pressed flat.
        touching = ((wi[pairs[:, 0]][:, :, None] == tris[pairs[:, 1]][:, None, :]) & flat[wi[pairs[:, 0]]][:, :, None]).any(axis=(1, 2))
        count("base", pairs[~touching & ~bases_cross(base, pairs, wi, tris)], skin, wi, base, tris)
    orientation = -1.0 if side == "interior" else 1.0
    inverted = inverted_cells(base + offset, base + offset + directors, tris, orientation)
    folding = folding_cells(base + offset, base + offset + directors, tris, orientation)
    return {**counts, "inverted": inverted, "folding": folding, "own": len(own)}


def quad_crossings(vertices, corners):
    """How many pairs of a quad mesh's triangles (each quad split along a diagonal)
    intersect while sharing no vertex, by Blender's own `BVHTree.overlap`: a surface
    crossing itself somewhere away from its own rings."""
    quads = np.asarray(corners, np.int64).reshape(-1, 4)
    tris = np.concatenate([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])
    tree = BVHTree.FromPolygons(np.asarray(vertices, np.float64).tolist(), tris.tolist(), all_triangles=True)
    pairs = np.array(tree.overlap(tree), np.int64).reshape(-1, 2)
    pairs = pairs[pairs[:, 0] < pairs[:, 1]]
    a, b = tris[pairs[:, 0]], tris[pairs[:, 1]]
    return int((~(a[:, :, None] == b[:, None, :]).any(axis=(1, 2))).sum())
