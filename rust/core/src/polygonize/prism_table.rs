//! Marching prisms: the iso-surface pieces inside one lattice prism, as triangles over
//! the prism's nine edges. Built once from the prism's faces: on every face the
//! crossing points are joined by segments that keep the inside on their right (seen
//! from outside the prism); the segments link into closed loops, and each loop is
//! triangulated (facing from inside to outside) so that no triangle lies in a prism
//! face, where the prism across it could make the same triangle facing the other way.
//! A side quad whose inside corners lie on a diagonal is ambiguous; it is resolved by
//! the face's mean value, which the neighbouring prism sharing that face computes
//! identically, so the surface has no cracks. Compared with splitting each prism into three tetrahedra
//! this uses no diagonal edges and makes about half as many triangles.
//!
//! Corners: `0, 1, 2` the bottom triangle (counter-clockwise seen from above), `3, 4, 5`
//! the corners above them.

use std::sync::OnceLock;

/// The nine edges as corner pairs: bottom, top, then vertical.
pub const EDGES: [[usize; 2]; 9] = [[0, 1], [1, 2], [2, 0], [3, 4], [4, 5], [5, 3], [0, 3], [1, 4], [2, 5]];

/// The side quads, counter-clockwise seen from outside.
pub const SIDES: [[usize; 4]; 3] = [[0, 1, 4, 3], [1, 2, 5, 4], [2, 0, 3, 5]];

/// Bottom and top triangles, counter-clockwise seen from outside.
const CAPS: [[usize; 3]; 2] = [[0, 2, 1], [3, 4, 5]];

/// Loops of at least this many crossings may be fanned from a centre vertex inside the
/// prism ([`Case::ring`], [`crate::polygonize::marching::march_prism_centred`]) instead
/// of being triangulated between their own vertices. Such a triangulation has its
/// triangles on the loop's far side; where the lattice is curved or sheared (a bake's
/// cells) it folds and its triangles cross the neighbouring prisms' surface (chain
/// mail, 16 x 16 x 8, 5% shells: Suzanne's head 2 crossing pairs exterior and 11
/// interior, the coil's interior 1,906; none with the fan). Loops of fewer than six
/// crossings keep the table's triangles: a triangle or quad has no better split, and
/// whether fanning five-crossing loops helps was not measured. Not from a paper.
pub const CENTRE_LOOP: usize = 6;

/// Triangles of one case, as edge indices (at most seven: nine crossings in one loop),
/// every loop triangulated between its own vertices; and the one loop of at least
/// [`CENTRE_LOOP`] crossings, if any (two would need more than nine edges), whose
/// triangles are `tris[ring_start..ring_start + ring_len - 2]`: a lattice may fan that
/// loop from a centre vertex instead, triangles `[centre, ring[i], ring[i + 1]]`
/// (cyclic), which face from inside to outside as `tris` do. `tris` are the table's
/// own triangulation whether or not a lattice asks for centres.
#[derive(Clone, Copy, Default)]
pub struct Case {
    pub count: u8,
    pub tris: [[u8; 3]; 7],
    pub ring_len: u8,
    pub ring_start: u8,
    pub ring: [u8; 9],
}

impl Case {
    /// The edges of the loop that may be fanned from a centre vertex, in winding order
    /// (empty if none).
    #[inline]
    pub fn ring(&self) -> &[u8] {
        &self.ring[..self.ring_len as usize]
    }

    /// The range of `tris` that triangulates [`Case::ring`] between its own vertices.
    #[inline]
    pub fn ring_tris(&self) -> std::ops::Range<usize> {
        let start = self.ring_start as usize;
        start..start + (self.ring_len as usize).saturating_sub(2)
    }
}

/// Case index: bit `c` set when corner `c` is inside; bit `6 + k` set when side quad
/// `k` is ambiguous and its inside corners are connected across it.
pub fn case(inside: u8, connected: u8) -> &'static Case {
    static TABLE: OnceLock<Vec<Case>> = OnceLock::new();
    &TABLE.get_or_init(build)[(inside as usize) | ((connected as usize) << 6)]
}

/// The case of a prism with corner values `v` (inside where `>= level`). An ambiguous
/// side (inside corners on a diagonal) joins them when the face's mean is inside; the
/// sums pair the same corners in either neighbour, so both decide alike.
#[inline]
pub fn classify(v: &[f32; 6], level: f32) -> &'static Case {
    let inside = (0..6).fold(0u8, |bits, k| bits | (u8::from(v[k] >= level) << k));
    if inside == 0 || inside == 63 {
        return case(inside, 0);
    }
    let connected = SIDES.iter().enumerate().fold(0u8, |bits, (k, f)| {
        let at = |i: usize| inside & (1 << f[i]) != 0;
        let ambiguous = at(0) == at(2) && at(1) == at(3) && at(0) != at(1);
        bits | (u8::from(ambiguous && (v[f[0]] + v[f[2]]) + (v[f[1]] + v[f[3]]) >= 4.0 * level) << k)
    });
    case(inside, connected)
}

fn edge_of(a: usize, b: usize) -> usize {
    EDGES.iter().position(|e| (e[0] == a && e[1] == b) || (e[0] == b && e[1] == a)).expect("a prism edge")
}

/// `(from, to)` edge segments on one face, corners counter-clockwise from outside.
fn face_segments(face: &[usize], inside: impl Fn(usize) -> bool, connected: bool) -> Vec<(usize, usize)> {
    let k = face.len();
    // Crossings in counter-clockwise order: (edge, entering the inside?).
    let crossings: Vec<(usize, bool)> = (0..k)
        .filter_map(|i| {
            let (a, b) = (face[i], face[(i + 1) % k]);
            (inside(a) != inside(b)).then(|| (edge_of(a, b), inside(b)))
        })
        .collect();
    match crossings.len() {
        0 => vec![],
        2 => {
            let (enter, leave) = if crossings[0].1 { (crossings[0].0, crossings[1].0) } else { (crossings[1].0, crossings[0].0) };
            vec![(enter, leave)]
        }
        _ => {
            // Four crossings, alternating. Separate inside corners: each entering
            // crossing joins the next leaving one; connected: the previous one.
            let start = if crossings[0].1 { 0 } else { 1 };
            let c = |i: usize| crossings[(start + i) % 4].0;
            if connected {
                vec![(c(0), c(3)), (c(2), c(1))]
            } else {
                vec![(c(0), c(1)), (c(2), c(3))]
            }
        }
    }
}

/// Whether the edges `tri` all lie on one face of the prism: such a triangle lies in
/// that face, and the neighbouring prism across it may make the same triangle facing
/// the other way (coincident opposite faces, edges used four times).
fn in_one_face(tri: [usize; 3]) -> bool {
    let on = |face: &[usize], e: usize| face.contains(&EDGES[e][0]) && face.contains(&EDGES[e][1]);
    SIDES.iter().map(|f| &f[..]).chain(CAPS.iter().map(|f| &f[..])).any(|f| tri.iter().all(|&e| on(f, e)))
}

/// Whether a triangle edge between the crossings on prism edges `a` and `b` (not a
/// segment of the loop) is a chord across a side quad that the prism on the other
/// side could draw too: both crossings on one side quad, other than {bottom, right}
/// or {top, right} (its right edge, seen from outside, is the other prism's left, so
/// the two never draw the same chord and no edge is used four times).
fn shared_chord(a: usize, b: usize) -> bool {
    SIDES.iter().any(|f| {
        let side = |k: usize| edge_of(f[k], f[(k + 1) % 4]);
        let (bottom, right, top, left) = (side(0), side(1), side(2), side(3));
        let on = |e: usize| [bottom, right, top, left].contains(&e);
        let allowed = [(bottom, right), (top, right)].iter().any(|&(x, y)| (a, b) == (x, y) || (a, b) == (y, x));
        on(a) && on(b) && !allowed
    })
}

/// All triangulations of the polygon `ring` (by the diagonal from its first and last
/// vertex's triangle), as triangle lists; loops have at most nine vertices.
fn triangulations(ring: &[usize]) -> Vec<Vec<[usize; 3]>> {
    if ring.len() < 3 {
        return vec![vec![]];
    }
    let (first, last) = (ring[0], ring[ring.len() - 1]);
    let mut out = Vec::new();
    for apex in 1..ring.len() - 1 {
        for left in triangulations(&ring[..=apex]) {
            for right in triangulations(&ring[apex..]) {
                let mut t = vec![[first, ring[apex], last]];
                t.extend(left.iter().chain(&right));
                out.push(t);
            }
        }
    }
    out
}

/// A loop's triangles with none lying in a prism face and no chord a neighbour could
/// share ([`shared_chord`]): a fan from the first vertex that allows it, else any
/// triangulation that does (one always exists: tested).
fn triangulate(ring: &[usize]) -> Vec<[usize; 3]> {
    let fan = |start: usize| -> Vec<[usize; 3]> {
        let k = ring.len();
        (1..k - 1).map(|i| [ring[start], ring[(start + i) % k], ring[(start + i + 1) % k]]).collect()
    };
    let k = ring.len();
    let on_loop = |a: usize, b: usize| (0..k).any(|i| (ring[i], ring[(i + 1) % k]) == (a, b) || (ring[i], ring[(i + 1) % k]) == (b, a));
    let clean =
        |tris: &Vec<[usize; 3]>| tris.iter().all(|t| !in_one_face(*t) && (0..3).all(|i| on_loop(t[i], t[(i + 1) % 3]) || !shared_chord(t[i], t[(i + 1) % 3])));
    (0..ring.len()).map(fan).find(clean).or_else(|| triangulations(ring).into_iter().find(clean)).unwrap_or_else(|| fan(0))
}

fn build() -> Vec<Case> {
    (0..512usize)
        .map(|index| {
            let inside = |c: usize| index & (1 << c) != 0;
            let mut next = [usize::MAX; 9];
            for (k, side) in SIDES.iter().enumerate() {
                for (from, to) in face_segments(side, inside, index & (1 << (6 + k)) != 0) {
                    next[from] = to;
                }
            }
            for cap in &CAPS {
                for (from, to) in face_segments(cap, inside, false) {
                    next[from] = to;
                }
            }
            let mut case = Case::default();
            let mut seen = [false; 9];
            for start in 0..9 {
                if next[start] == usize::MAX || seen[start] {
                    continue;
                }
                let mut ring = vec![start];
                seen[start] = true;
                let mut e = next[start];
                while e != start {
                    seen[e] = true;
                    ring.push(e);
                    e = next[e];
                }
                let tris = triangulate(&ring);
                if ring.len() >= CENTRE_LOOP {
                    debug_assert_eq!(case.ring_len, 0, "one long loop per prism");
                    debug_assert_eq!(tris.len(), ring.len() - 2);
                    case.ring_len = ring.len() as u8;
                    case.ring_start = case.count;
                    ring.iter().enumerate().for_each(|(k, &e)| case.ring[k] = e as u8);
                }
                for t in tris {
                    case.tris[case.count as usize] = t.map(|e| e as u8);
                    case.count += 1;
                }
            }
            case
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every crossing edge is used, every triangle edge is shared by exactly two
    /// triangles or lies on a prism face, and triangles face the outside corners: for
    /// the table's own triangulation, and with its long loop ([`Case::ring`]) fanned
    /// from a centre vertex (9, at its crossings' mean) instead.
    #[test]
    fn every_case_is_a_closed_surface_inside_the_prism() {
        // Corner positions of a right prism; an iso-point at each edge's midpoint.
        let corner = |c: usize| {
            let base = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]][c % 3];
            glam::Vec3::new(base[0], base[1], (c / 3) as f32)
        };
        let edge_mid = |e: u8| (corner(EDGES[e as usize][0]) + corner(EDGES[e as usize][1])) / 2.0;
        let mut long_loops = 0;
        for inside in 0u8..64 {
            for connected in 0u8..8 {
                let t = case(inside, connected);
                let ring = t.ring();
                assert!(ring.is_empty() || ring.len() >= CENTRE_LOOP, "case {inside:06b}/{connected:03b}");
                long_loops += usize::from(!ring.is_empty());
                let own: Vec<[u8; 3]> = t.tris[..t.count as usize].to_vec();
                let centred: Vec<[u8; 3]> = (0..t.count as usize)
                    .filter(|k| !t.ring_tris().contains(k))
                    .map(|k| t.tris[k])
                    .chain((0..ring.len()).map(|k| [9, ring[k], ring[(k + 1) % ring.len()]]))
                    .collect();
                // The loop's own triangles are exactly those over its edges, bounded
                // by the loop walked in its winding order.
                let over_ring: Vec<&[u8; 3]> = own.iter().filter(|tri| tri.iter().any(|e| ring.contains(e))).collect();
                assert!(over_ring.iter().all(|tri| tri.iter().all(|e| ring.contains(e))));
                assert_eq!(over_ring.len(), ring.len().saturating_sub(2));
                assert!(t.ring_tris().all(|k| ring.contains(&t.tris[k][0])));
                let mid = |e: u8| if e == 9 { ring.iter().map(|&e| edge_mid(e)).sum::<glam::Vec3>() / ring.len() as f32 } else { edge_mid(e) };
                for (what, tris) in [("own", &own), ("centred", &centred)] {
                    let ins = |c: usize| inside & (1 << c) != 0;
                    let crossing: Vec<u8> = (0..9u8).filter(|&e| ins(EDGES[e as usize][0]) != ins(EDGES[e as usize][1])).collect();
                    let mut used: Vec<u8> = tris.iter().flatten().copied().filter(|&e| e != 9).collect();
                    used.sort();
                    used.dedup();
                    assert_eq!(used, crossing, "{what} case {inside:06b}/{connected:03b}");
                    // Interior edges (both ends on one loop, not on one face) pair up
                    // with opposite directions: consistent orientation.
                    let mut directed = std::collections::HashMap::new();
                    for tri in tris {
                        for k in 0..3 {
                            *directed.entry((tri[k], tri[(k + 1) % 3])).or_insert(0) += 1;
                        }
                    }
                    for (&(a, b), &n) in &directed {
                        assert_eq!(n, 1, "{what}: edge {a}-{b} twice in one direction, case {inside:06b}");
                        // An edge used once is a segment of a loop on a prism face.
                        assert!(directed.contains_key(&(b, a)) || (a != 9 && b != 9 && in_one_face([a as usize, b as usize, b as usize])), "{what}: {a}-{b}");
                    }
                    // No triangle lies in a prism face (the prism across it could make
                    // the same triangle facing the other way).
                    for tri in tris.iter().filter(|t| !t.contains(&9)) {
                        assert!(!in_one_face(tri.map(|e| e as usize)), "{what} case {inside:06b}/{connected:03b}: {tri:?} lies in a face");
                    }
                    // Edges inside the loop's triangulation (used by two of its
                    // triangles) are no chords the neighbouring prism could draw as well.
                    for (&(a, b), _) in directed.iter().filter(|(&(a, b), _)| a != 9 && b != 9 && directed.contains_key(&(b, a))) {
                        assert!(!shared_chord(a as usize, b as usize), "{what} case {inside:06b}/{connected:03b}: chord {a}-{b}");
                    }
                    // Orientation: every triangle's normal points away from the inside
                    // corners' centroid of its own loop, checked on single-loop cases.
                    if !tris.is_empty() && (connected == 0) && inside.count_ones() == 1 {
                        let c = (0..6).find(|&c| ins(c)).unwrap();
                        for tri in tris {
                            let [a, b, d] = tri.map(mid);
                            let nrm = (b - a).cross(d - a);
                            assert!(nrm.dot((a + b + d) / 3.0 - corner(c)) > 0.0, "{what} case {inside:06b} faces inward");
                        }
                    }
                }
            }
        }
        assert!(long_loops > 0, "some cases have loops of six or more crossings");
    }
}
