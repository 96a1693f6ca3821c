//! [`Checker::find_star`]'s own tests (issue 14): the pairs of triangles meeting at
//! one base vertex that the tree tests skip by topology. Hand-set directors on small
//! meshes where only `find_star` sees the crossing (and a shell a little off that
//! does not cross), and its pairs against every pair of triangles of the star
//! topology tested whole, on generated meshes with random directors; and the pairs
//! of one n-gon and of an envelope's two layers over a shared edge, found and
//! repaired.

use super::defects::{skins, Checker};
use super::intersect::triangles_intersect;
use super::report::{normal_shape, shell_report};
use super::*;
use crate::test_rng::Rng;
use crate::{hard_meshes, testmeshes as tm, Mesh};
use glam::{DVec3, Vec3};

/// A fan of `k` triangles around vertex 0 at the origin, at the bottom of a valley
/// along x: rim vertex `1 + i` at angle 2πi/k, raised `c |sin|` (facing up, into the
/// valley). Open: every rim edge is a boundary edge (walls of no height where both
/// ends are pressed).
fn valley_fan(k: u32, c: f32) -> Mesh {
    let mut p = vec![Vec3::ZERO];
    p.extend((0..k).map(|i| {
        let a = i as f32 * std::f32::consts::TAU / k as f32;
        Vec3::new(a.cos(), a.sin(), c * a.sin().abs())
    }));
    let t: Vec<[u32; 3]> = (0..k).map(|i| [0, 1 + i, 1 + (i + 1) % k]).collect();
    Mesh::from_triangles(p, &t).unwrap()
}

/// What the checks find in `shell`: `find_star`'s pairs (kind, item, other), and of
/// the whole search ([`Checker::find`], every element) the skin and skin/base pairs
/// that `find_star` did not give (the tree tests'), inverted and enclosing cells.
struct Found {
    star: Vec<(u8, u32, u32)>,
    others: Vec<(u32, u32)>,
    inverted: usize,
    enclosing: usize,
}

fn found(mesh: &Mesh, shell: &Shell) -> Found {
    let c = Checker::new(mesh);
    let tree = c.outer_tree(mesh, shell, None);
    let f = c.find(mesh, shell, None, Some(&tree));
    let mut star = c.find_star(mesh, shell, None, true);
    star.sort_unstable();
    let mut others = Vec::new();
    for (k, mut all) in [(0u8, f.self_pairs), (1, f.base_pairs)] {
        all.sort_unstable();
        let mut mine: Vec<(u32, u32)> = star.iter().filter(|h| h.0 == k).map(|h| (h.1, h.2)).collect();
        mine.sort_unstable();
        // Every pair find_star gives is among the whole search's; the rest is the trees'.
        for pair in all {
            match mine.binary_search(&pair) {
                Ok(at) => _ = mine.remove(at),
                Err(_) => others.push(pair),
            }
        }
        assert!(mine.is_empty(), "kind {k}: find_star pairs missing from find: {mine:?}");
    }
    Found { star, others, inverted: f.inverted.len(), enclosing: f.enclosing.len() }
}

/// The layer triangle of base triangle `t` at `r` and base triangle `u` (f64).
fn layer_and_base(mesh: &Mesh, shell: &Shell, t: [u32; 3], r: f32, u: [u32; 3]) -> ([DVec3; 3], [DVec3; 3]) {
    let p = mesh.positions();
    (t.map(|v| shell.point(p, v as usize, r).as_dvec3()), u.map(|v| p[v as usize].as_dvec3()))
}

/// The repair (its rounds, then its final check) leaves `shell` clean, shortening
/// the crossing's directors, and every check agrees.
fn repaired_clean(mesh: &Mesh, shell: &Shell, lifted: &[usize]) {
    let mut fixed = shell.clone();
    let check = repair::untangle(mesh, &mut fixed, ShellParams::default().repair_rounds, directors::REPAIR_FACTOR);
    let after = found(mesh, &fixed);
    let r = shell_report(mesh, &fixed);
    assert!(check.clean && after.star.iter().all(|h| h.0 == 2) && after.others.is_empty() && after.inverted == 0, "{check:?}, {:?}", after.star);
    assert_eq!((r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells), (0, 0, 0), "{r:?}");
    assert!(lifted.iter().any(|&v| fixed.achieved[v] < shell.achieved[v]), "the repair must shorten the crossing's directors: {check:?}");
}

/// A pressed vertex (zero director) at the bottom of a valley: one lifted rim vertex
/// swings its layer triangle across the valley, through a base triangle of the same
/// star that shares only the pressed vertex with it. The tree tests skip the pair
/// (they share a vertex whose layer point is its base point), the cells are not
/// inverted, and the crossing leaves the base triangle through its far edge, a
/// boundary edge with a wall of no height: only `find_star` can see it. The same
/// director a little shorter crosses nothing, and nothing is found.
#[test]
fn a_layer_triangle_through_a_base_triangle_at_a_pressed_vertex_is_found_by_the_star_alone() {
    let mesh = valley_fan(5, 2.16);
    let checker = Checker::new(&mesh);
    let (t, u) = (1u32, 4u32); // [0, 2, 3] and [0, 5, 1]: only vertex 0 in common
    assert_eq!((checker.tris[t as usize], checker.tris[u as usize]), ([0, 2, 3], [0, 5, 1]));
    let shell_with = |d: Vec3| {
        let mut directors = vec![Vec3::ZERO; 6];
        directors[2] = d;
        Shell::from_directors(vec![Vec3::ZERO; 6], directors)
    };
    let crossing = shell_with(Vec3::new(0.43, -1.96, -0.4));
    let (layer, base) = layer_and_base(&mesh, &crossing, [0, 2, 3], 1.0, [0, 5, 1]);
    assert!(triangles_intersect(&layer, &base), "the layer triangle must cross the base triangle");
    let f = found(&mesh, &crossing);
    assert!(f.star.contains(&(1, t, u)), "find_star must give (layer {t}, base {u}): {:?}", f.star);
    assert!(f.star.iter().all(|h| h.0 < 2), "nothing is inherited (the base does not cross itself): {:?}", f.star);
    assert!(f.others.is_empty() && f.inverted == 0 && f.enclosing == 0, "only find_star may see it: {:?}, {} inverted", f.others, f.inverted);
    // A little shorter, or turned a little up, the layer stays above the valley's far flank.
    for near in [Vec3::new(0.43, -1.96, -0.4) * 0.5, Vec3::new(0.43, -1.96, 0.4)] {
        let (layer, base) = layer_and_base(&mesh, &shell_with(near), [0, 2, 3], 1.0, [0, 5, 1]);
        assert!(!triangles_intersect(&layer, &base), "{near}: must not cross");
        let f = found(&mesh, &shell_with(near));
        assert!(f.star.is_empty() && f.others.is_empty() && f.inverted == 0, "{near}: nothing to find: {:?} {:?}", f.star, f.others);
    }
    repaired_clean(&mesh, &crossing, &[2]);
}

/// Two icospheres passing through each other: a base that crosses itself, so that
/// some star pairs are inherited.
fn overlapping_spheres() -> Mesh {
    let a = tm::icosphere(2);
    let n = a.vertex_count() as u32;
    let tris = a.triangulate().triangles;
    let mut p = a.positions().to_vec();
    p.extend(a.positions().iter().map(|q| *q + Vec3::new(0.7, 0.2, 0.1)));
    let all: Vec<[u32; 3]> = tris.iter().copied().chain(tris.iter().map(|t| t.map(|v| v + n))).collect();
    Mesh::from_triangles(p, &all).unwrap()
}

/// A fan around vertex 0 whose last triangle stands through its first: base
/// triangles sharing one vertex that cross each other (the star pairs over them are
/// inherited).
fn crossed_fan() -> Mesh {
    let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.5, 0.5, 1.0], [0.5, 0.5, -1.0]];
    Mesh::from_triangles(p.iter().map(|&q| Vec3::from_array(q)).collect(), &[[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]]).unwrap()
}

/// A prism over a regular `k`-gon: two `k`-gon caps (triangulated into triangles of
/// one face, some sharing only a vertex) and `k` quads.
fn ngon_prism(k: u32) -> Mesh {
    let mut p: Vec<Vec3> = Vec::new();
    for z in [0.0, 1.0] {
        p.extend((0..k).map(|i| {
            let a = i as f32 * std::f32::consts::TAU / k as f32;
            Vec3::new(a.cos(), a.sin(), z)
        }));
    }
    let mut corners: Vec<u32> = (0..k).rev().chain(k..2 * k).collect();
    corners.extend((0..k).flat_map(|i| [i, (i + 1) % k, k + (i + 1) % k, k + i]));
    let sizes: Vec<u32> = [k, k].into_iter().chain(std::iter::repeat_n(4, k as usize)).collect();
    Mesh::new(p, &sizes, corners, None).unwrap()
}

/// An open surface of revolution: `k` quads around, three rings flaring out and up,
/// open at the top; with `bottom`, a `k`-gon closes the bottom (a cup), else it is
/// open there too (a tube). Every rim edge has a side wall.
fn open_cup(k: u32, bottom: bool) -> Mesh {
    let p: Vec<Vec3> = (0..4)
        .flat_map(|j| {
            (0..k).map(move |i| {
                let a = i as f32 * std::f32::consts::TAU / k as f32;
                let radius = 1.0 + 0.2 * j as f32;
                Vec3::new(radius * a.cos(), radius * a.sin(), 0.5 * j as f32)
            })
        })
        .collect();
    let mut corners: Vec<u32> = if bottom { (0..k).rev().collect() } else { Vec::new() };
    corners.extend((0..3).flat_map(|j| (0..k).flat_map(move |i| [j * k + i, j * k + (i + 1) % k, (j + 1) * k + (i + 1) % k, (j + 1) * k + i])));
    let sizes: Vec<u32> = bottom.then_some(k).into_iter().chain(std::iter::repeat_n(4, 3 * k as usize)).collect();
    Mesh::new(p, &sizes, corners, None).unwrap()
}

/// Random directors: along the normal, tilted by up to `tilt`, short (1-3% of the
/// diagonal) or long (10-40%), a third of them zero.
fn random_shell(mesh: &Mesh, side: Side, tilt: f64, rng: &mut Rng) -> Shell {
    let normals = crate::mesh::vertex_normals(mesh);
    let diag = mesh.bbox_diagonal() as f64;
    let d: Vec<Vec3> = normals
        .iter()
        .map(|n| {
            if rng.uniform() < 0.33 {
                return Vec3::ZERO;
            }
            let length = if rng.uniform() < 0.5 { rng.range(0.01, 0.03) } else { rng.range(0.1, 0.4) } * diag;
            let direction = (n.as_dvec3() * side.orientation() as f64 + rng.unit() * tilt).normalize_or_zero();
            (direction * length).as_vec3()
        })
        .collect();
    // normal_shape turns an interior director inwards: given the outward one.
    let (base_offset, directors) = d.iter().map(|&d| normal_shape(side, d * side.orientation())).unzip();
    Shell { side, ..Shell::from_directors(base_offset, directors) }
}

/// `find_star`'s pairs by brute force: every ordered pair of triangles of different
/// faces (or of one face of five or more corners), each pair of layers (and layer and base) tested whole with
/// [`triangles_intersect`] (two triangles meeting at a corner cross away from it
/// exactly when an opposite segment crosses the other, which is what `find_star`
/// tests; its directors are zero or far above the "coincide" tolerance here, so a
/// layer point coincides with its base point exactly when equal). Skin pairs: the
/// triangles share exactly one vertex, or an edge and the layers differ (an
/// envelope's inner and outer); skin/base pairs: they share one vertex, or an
/// edge with exactly one end, and that vertex's layer point is its base point.
/// Inherited (kind 2) where the two base triangles cross.
fn brute_star(c: &Checker, mesh: &Mesh, shell: &Shell) -> Vec<((u8, u32, u32), bool)> {
    let p = mesh.positions();
    let n = c.tris.len() as u32;
    let layers = skins(shell.side);
    let item = |t: u32, r: f32| if r == 1.0 { t } else { c.items(shell.side) as u32 - n + t };
    let at = |t: u32, r: Option<f32>| c.tris[t as usize].map(|v| r.map_or(p[v as usize], |r| shell.point(p, v as usize, r)).as_dvec3());
    let pressed = |v: u32, r: f32| {
        let (x, y) = (shell.point(p, v as usize, r), p[v as usize]);
        assert!(x == y || (x - y).length() > 1e-3 * mesh.bbox_diagonal(), "directors are zero or far from it");
        x == y
    };
    let mut hits = Vec::new();
    for t in 0..n {
        let face = c.face_of[t as usize];
        let quad = mesh.face(face as usize);
        for u in 0..n {
            let shared: Vec<u32> = c.tris[t as usize].iter().copied().filter(|v| c.tris[u as usize].contains(v)).collect();
            // Within one quad: an envelope's layers over the two triangles of one split
            // (their shared edge is the diagonal: its ends are not neighbours in the quad).
            let next = |v: u32| quad[(quad.iter().position(|&x| x == v).unwrap() + 1) % quad.len()];
            let diagonal = shared.len() == 2 && next(shared[0]) != shared[1] && next(shared[1]) != shared[0];
            let one_quad = c.face_of[u as usize] == face && quad.len() < 5;
            if shared.is_empty() || shared.len() == 3 || (one_quad && !(shell.side == Side::Envelope && diagonal)) {
                continue;
            }
            let kind = |k: u8| if triangles_intersect(&at(t, None), &at(u, None)) { 2 } else { k };
            for &r in layers {
                let one_end = shared.iter().filter(|&&v| pressed(v, r)).count() == 1;
                if !one_quad && one_end && triangles_intersect(&at(t, Some(r)), &at(u, None)) {
                    hits.push(((kind(1), item(t, r), u), false));
                }
                // Sharing an edge: an envelope's inner and outer layers.
                for &r2 in layers.iter().filter(|&&r2| t < u && (shared.len() == 1 || r2 != r)) {
                    if triangles_intersect(&at(t, Some(r)), &at(u, Some(r2))) {
                        hits.push(((kind(0), item(t, r), item(u, r2)), true));
                    }
                }
            }
        }
    }
    hits.extend(brute_walls(c, mesh, shell));
    hits
}

/// The brute force's side-wall pairs: every wall triangle (of a wall not flat)
/// against every base triangle, layer triangle and other wall's triangle sharing
/// exactly one base vertex with its wall, tested whole (a shared point lies in the
/// other's plane and cannot cross it properly). Inherited where the base triangles
/// under the two (a wall's: its owner) cross.
fn brute_walls(c: &Checker, mesh: &Mesh, shell: &Shell) -> Vec<((u8, u32, u32), bool)> {
    let p = mesh.positions();
    let n = c.tris.len() as u32;
    let items = c.items(shell.side) as u32;
    let is_wall = |i: u32| matches!(c.item(i), defects::Item::Wall { .. });
    let base = |t: u32| c.tris[t as usize].map(|v| p[v as usize].as_dvec3());
    let one = |a: &[u32], b: &[u32]| a.iter().filter(|v| b.contains(v)).count() == 1;
    let kind = |t: u32, u: u32, k: u8| if t != u && triangles_intersect(&base(t), &base(u)) { 2 } else { k };
    let mut hits = Vec::new();
    for i in (0..items).filter(|&i| is_wall(i) && c.item_vertices(i).iter().any(|&v| shell.directors[v as usize] != Vec3::ZERO)) {
        let (ends, owner, mine) = (c.item_vertices(i), c.item_tri(i), c.skin_tri(mesh, shell, i));
        // An envelope's wall holds its end's base point: split there (the two halves
        // meet a base triangle around that end at that point only).
        let split = |u: u32| {
            let v = *ends.iter().find(|v| c.tris[u as usize].contains(v)).unwrap();
            let (x, ends) = (p[v as usize].as_dvec3(), [0.0, 1.0].map(|r| shell.point(p, v as usize, r).as_dvec3()));
            defects::through_base_point(&mine, ends, x, &base(u))
        };
        for u in (0..n).filter(|&u| one(ends, &c.tris[u as usize]) && split(u)) {
            hits.push(((kind(owner, u, 1), i, u), false));
        }
        let flat = |j: u32| is_wall(j) && c.item_vertices(j).iter().all(|&v| shell.directors[v as usize] == Vec3::ZERO);
        for j in (0..items).filter(|&j| (!is_wall(j) || j > i) && !flat(j) && one(ends, c.item_vertices(j))) {
            if triangles_intersect(&mine, &c.skin_tri(mesh, shell, j)) {
                hits.push(((kind(owner, c.item_tri(j), 0), i, j), true));
            }
        }
    }
    hits
}

/// Hits (kind, item, other), sorted.
type Hits = Vec<(u8, u32, u32)>;

/// `find_star`'s hits over the flagged triangles (all for `None`) split into skin
/// pairs, their two items in ascending order (which triangle's side finds a pair
/// depends on which are flagged), and skin/base pairs (those it gives without the
/// skin pairs), each sorted.
fn star_split(c: &Checker, mesh: &Mesh, shell: &Shell, dirty: Option<&defects::Dirty>) -> (Hits, Hits) {
    let mut base = c.find_star(mesh, shell, dirty, false);
    base.sort_unstable();
    let (mut skin, mut left) = (Vec::new(), base.clone());
    for h in c.find_star(mesh, shell, dirty, true) {
        match left.binary_search(&h) {
            Ok(at) => _ = left.remove(at),
            Err(_) => skin.push((h.0, h.1.min(h.2), h.1.max(h.2))),
        }
    }
    assert!(left.is_empty(), "the skin/base pairs come with the skin pairs too: {left:?}");
    skin.sort_unstable();
    (skin, base)
}

/// The brute force's hits `keep`s, split as [`star_split`]'s.
fn brute_split(hits: &[((u8, u32, u32), bool)], keep: impl Fn(u32, u32, bool) -> bool) -> (Hits, Hits) {
    let pick = |skin: bool| {
        let mut v: Vec<_> = hits
            .iter()
            .filter(|&&((_, i, j), s)| s == skin && keep(i, j, s))
            .map(|&((k, i, j), _)| if skin { (k, i.min(j), i.max(j)) } else { (k, i, j) })
            .collect();
        v.sort_unstable();
        v
    };
    (pick(true), pick(false))
}

/// `find_star` gives exactly the brute-force pairs on generated meshes (closed,
/// quads with both splits, open with walls, a base that crosses itself; exterior,
/// interior and envelope) with random directors, short, long and zero; and with a
/// random quarter of the vertices flagged, exactly those of them whose moving
/// triangles are flagged (a skin pair with either triangle flagged, a skin/base pair
/// with its layer triangle flagged), each once.
#[test]
fn find_star_gives_the_pairs_of_a_brute_force_search() {
    let cases = [
        ("icosphere", tm::icosphere(2), Side::Exterior, 0.6),
        ("comb", tm::comb(1), Side::Interior, 0.8),
        ("saddle", tm::saddle(8), Side::Envelope, 0.8),
        ("hand", hard_meshes::hand(), Side::Exterior, 0.5),
        ("overlapping spheres", overlapping_spheres(), Side::Envelope, 0.5),
        ("crossed fan", crossed_fan(), Side::Exterior, 0.3),
        ("hexagonal prism", ngon_prism(6), Side::Envelope, 0.8),
        ("octagonal prism", ngon_prism(8), Side::Exterior, 0.8),
        ("open tube", open_cup(8, false), Side::Exterior, 0.8),
        ("open tube", open_cup(6, false), Side::Envelope, 0.8),
        ("open cup", open_cup(6, true), Side::Interior, 0.8),
        ("open cup", open_cup(7, true), Side::Envelope, 1.0),
        ("valley fan", valley_fan(5, 1.0), Side::Exterior, 0.8),
        ("plane", tm::plane(3), Side::Envelope, 1.0),
    ];
    let mut rng = Rng(0x5eed);
    let mut totals = [0usize; 3];
    let (mut edge_pairs, mut one_face, mut layers_over_edge) = (0, 0, 0);
    let (mut walls, mut diagonal) = ([0usize; 3], 0);
    let is_wall = |c: &Checker, i: u32| matches!(c.item(i), defects::Item::Wall { .. });
    for (name, mesh, side, tilt) in cases {
        let c = Checker::new(&mesh);
        let rounds = if mesh.vertex_count() < 20 { 30 } else { 3 };
        for round in 0..rounds {
            let shell = random_shell(&mesh, side, tilt, &mut rng);
            let brute = brute_star(&c, &mesh, &shell);
            let found = star_split(&c, &mesh, &shell, None);
            assert_eq!(found, brute_split(&brute, |_, _, _| true), "{name} {side:?} round {round}");
            for &((k, i, j), skin) in &brute {
                totals[k as usize] += 1;
                let other = if skin { c.item_tri(j) } else { j };
                let shared = c.tris[c.item_tri(i) as usize].iter().filter(|v| c.tris[other as usize].contains(v)).count();
                edge_pairs += (!skin && shared == 2) as usize;
                let quad = c.face_of[c.item_tri(i) as usize] == c.face_of[other as usize] && mesh.face(c.face_of[other as usize] as usize).len() == 4;
                if is_wall(&c, i) || (skin && is_wall(&c, j)) {
                    walls[if !skin {
                        0
                    } else if is_wall(&c, i) && is_wall(&c, j) {
                        2
                    } else {
                        1
                    }] += 1;
                    continue;
                }
                diagonal += quad as usize;
                one_face += (c.face_of[c.item_tri(i) as usize] == c.face_of[other as usize] && !quad) as usize;
                layers_over_edge += (skin && shared == 2 && !quad) as usize;
            }
            // Flagged: the elements around a random quarter of the vertices.
            let mut dirty = c.clean();
            c.mark_anew((0..mesh.vertex_count() as u32).filter(|_| rng.uniform() < 0.25), &mut dirty);
            let layer_flagged = |i: u32| dirty.tris[c.item_tri(i) as usize];
            let wanted = brute_split(&brute, |i, j, skin| layer_flagged(i) || (skin && layer_flagged(j)));
            assert_eq!(star_split(&c, &mesh, &shell, Some(&dirty)), wanted, "{name} {side:?} round {round}: flagged");
        }
    }
    eprintln!(
        "star pairs: skin {}, skin/base {}, inherited {}; skin/base over a shared edge {edge_pairs}; of one face {one_face}; an envelope's two layers over a shared edge {layers_over_edge}, over a quad's diagonal {diagonal}; a wall and a base triangle {}, a layer triangle {}, another wall {}",
        totals[0], totals[1], totals[2], walls[0], walls[1], walls[2]
    );
    let what = format!("every kind of pair must occur: {totals:?}, {edge_pairs}, {one_face}, {layers_over_edge}, {diagonal}, {walls:?}");
    assert!(totals[0] > 100 && totals[1] > 100 && totals[2] > 0 && edge_pairs > 10 && one_face > 10 && layers_over_edge > 10, "{what}");
    assert!(diagonal > 10 && walls.iter().all(|&k| k > 10), "{what}");
}

/// Which of the pair kinds that `find_star` tests since issue 14's follow-up a defect
/// pair of `find` is: 1 two triangles of one face of five or more corners meeting at
/// a vertex (a skin pair or a layer and base pair), 2 an envelope's inner and outer
/// layer triangles over faces sharing an edge; 0 any other.
fn new_kind(c: &Checker, shell: &Shell, self_pair: bool, i: u32, j: u32) -> u8 {
    let (t, u) = (c.item_tri(i), if self_pair { c.item_tri(j) } else { j });
    let shared = c.tris[t as usize].iter().filter(|v| c.tris[u as usize].contains(v)).count();
    let layer = |k: u32| match c.item(k) {
        defects::Item::Layer { r, .. } => Some(r),
        defects::Item::Wall { .. } => None,
    };
    if c.face_of[t as usize] == c.face_of[u as usize] && t != u {
        1
    } else if self_pair && shell.side == Side::Envelope && shared == 2 && layer(i).is_some() && layer(j).is_some() && layer(i) != layer(j) {
        2
    } else {
        0
    }
}

/// Issue 14's hole: the pairs of the two kinds `find_star` now tests (the checker
/// before it never tested them). On random shells (seeded) of a hexagonal prism (its
/// caps' triangles, some meeting at a vertex only) and of an envelope over an
/// icosphere, `find` reports such pairs; they really cross (whole triangles, exact),
/// and the repair removes them, shortening directors, with every check clean after.
/// No shell of these searches crossed in such pairs alone: each also had inverted
/// cells (counted, printed), so the crossings here are also found otherwise.
#[test]
fn pairs_of_one_ngon_and_of_an_envelopes_two_layers_are_found_and_repaired() {
    let cases = [
        ("hexagonal prism", ngon_prism(6), Side::Exterior, 1u8),
        ("hexagonal prism", ngon_prism(6), Side::Envelope, 1),
        ("icosphere", tm::icosphere(1), Side::Envelope, 2),
    ];
    let mut rng = Rng(0x14);
    for (name, mesh, side, kind) in cases {
        let c = Checker::new(&mesh);
        let (mut with, mut alone, mut tried) = (0, 0, 0);
        while with < 3 && tried < 300 {
            tried += 1;
            let shell = random_shell(&mesh, side, [0.3, 0.8, 1.5][tried % 3], &mut rng);
            let what = format!("{name} {side:?}");
            let Some((only, moved)) = pairs_of_kind(&c, &mesh, &shell, |s, i, j| new_kind(&c, &shell, s, i, j) == kind, &what) else { continue };
            with += 1;
            alone += only as usize;
            repaired_clean(&mesh, &shell, &moved);
        }
        eprintln!("{name} {side:?}: {with} shells of {tried} with pairs of kind {kind}, {alone} with no other defect");
        assert!(with == 3, "{name} {side:?}: {with} shells of {tried} with pairs of kind {kind}");
    }
}

/// The defect pairs `find` reports in `shell` that `is_kind` (self pair, i, j)
/// picks, each asserted to cross (whole triangles, exact): None where there are none;
/// else whether they were the shell's only defects, and the vertices of each pair's
/// first skin item.
fn pairs_of_kind(c: &Checker, mesh: &Mesh, shell: &Shell, is_kind: impl Fn(bool, u32, u32) -> bool, what: &str) -> Option<(bool, Vec<usize>)> {
    let p = mesh.positions();
    let tree = c.outer_tree(mesh, shell, None);
    let f = c.find(mesh, shell, None, Some(&tree));
    let pairs: Vec<(bool, u32, u32)> = f.self_pairs.iter().map(|&(i, j)| (true, i, j)).chain(f.base_pairs.iter().map(|&(i, j)| (false, i, j))).collect();
    let mine: Vec<(bool, u32, u32)> = pairs.iter().copied().filter(|&(s, i, j)| is_kind(s, i, j)).collect();
    if mine.is_empty() {
        return None;
    }
    for &(s, i, j) in &mine {
        let other = if s { c.skin_tri(mesh, shell, j) } else { c.tris[j as usize].map(|v| p[v as usize].as_dvec3()) };
        assert!(triangles_intersect(&c.skin_tri(mesh, shell, i), &other), "{what}: ({i}, {j}) must cross");
    }
    let alone = mine.len() == pairs.len() && f.inverted.is_empty() && f.enclosing.is_empty();
    Some((alone, mine.iter().flat_map(|&(_, i, _)| c.item_vertices(i).iter().map(|&v| v as usize)).collect()))
}

/// Which of the pair kinds added for issue 14's open meshes a defect pair of `find`
/// is: 1 a side wall and a triangle meeting it at one end (a wall, a layer or a base
/// triangle sharing one base vertex with the wall), 2 an envelope's inner and outer
/// layer triangles over the two triangles of one split of a quad; 0 any other.
fn wall_or_diagonal(c: &Checker, mesh: &Mesh, self_pair: bool, i: u32, j: u32) -> u8 {
    let wall = |k: u32| matches!(c.item(k), defects::Item::Wall { .. });
    let other: &[u32] = if self_pair { c.item_vertices(j) } else { &c.tris[j as usize] };
    let shared = c.item_vertices(i).iter().filter(|v| other.contains(v)).count();
    let (t, u) = (c.item_tri(i), if self_pair { c.item_tri(j) } else { j });
    let layer = |k: u32| matches!(c.item(k), defects::Item::Layer { r, .. } if r == 1.0);
    if (wall(i) || (self_pair && wall(j))) && shared == 1 {
        1
    } else if self_pair
        && !wall(i)
        && !wall(j)
        && t != u
        && c.face_of[t as usize] == c.face_of[u as usize]
        && mesh.face(c.face_of[t as usize] as usize).len() == 4
        && layer(i) != layer(j)
    {
        2
    } else {
        0
    }
}

/// Issue 14's last untested pairs, now in `find_star`: a side wall and a triangle
/// at one of its ends (open tube, cup and fan; exterior, interior, envelope), and an
/// envelope's two layers over one split of a quad (open tube, hexagonal prism). On
/// 200 random shells (seeded) per case, `find` reports such pairs; they really cross
/// (whole triangles, exact), and the repair removes them from the first three,
/// shortening directors, every check clean after. Counted and printed: the shells
/// in which such pairs were the only defect (no other pair, inverted or enclosing
/// cell), which the checker before this would have missed: none (below).
#[test]
fn pairs_of_a_side_wall_at_one_end_and_of_a_quads_split_are_found_and_repaired() {
    let cases = [
        ("open tube", open_cup(8, false), Side::Exterior, 1u8),
        ("open cup", open_cup(6, true), Side::Interior, 1),
        ("open cup", open_cup(6, true), Side::Envelope, 1),
        ("valley fan", valley_fan(5, 1.0), Side::Exterior, 1),
        ("open tube", open_cup(6, false), Side::Envelope, 2),
        ("hexagonal prism", ngon_prism(6), Side::Envelope, 2),
    ];
    let mut rng = Rng(0x514e);
    let mut alone_total = [0usize; 3];
    for (name, mesh, side, kind) in cases {
        let c = Checker::new(&mesh);
        let (mut with, mut alone) = (0, 0);
        for tried in 0..200 {
            let shell = random_shell(&mesh, side, [0.3, 0.8, 1.5][tried % 3], &mut rng);
            let what = format!("{name} {side:?}");
            let Some((only, moved)) = pairs_of_kind(&c, &mesh, &shell, |s, i, j| wall_or_diagonal(&c, &mesh, s, i, j) == kind, &what) else { continue };
            with += 1;
            alone += only as usize;
            if with <= 3 {
                repaired_clean(&mesh, &shell, &moved);
            }
        }
        eprintln!("{name} {side:?}: {with} of 200 shells with pairs of kind {kind}, {alone} with no other defect");
        alone_total[kind as usize] += alone;
        assert!(with >= 3, "{name} {side:?}: {with} shells of 200 with pairs of kind {kind}");
    }
    // Seen (seed 0x514e): no shell with wall pairs nor with pairs over a quad's split
    // had them alone (each also had other defects; the counts are printed). Tested whole,
    // without the split at an envelope's base point, 18 envelope cups did: rounding
    // put the wall's edge a hair beside the base point, a crossing of no width.
    eprintln!("shells whose only defects were such pairs: walls {}, a quad's split {}", alone_total[1], alone_total[2]);
}
