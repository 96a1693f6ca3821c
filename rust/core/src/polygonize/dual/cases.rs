//! The connected pieces of the surface inside one cell, by its corners' signs: the
//! marching-cubes case's edge groups that manifold dual contouring gives one vertex
//! each (Schaefer, Ju and Warren 2007, *Manifold Dual Contouring*, section 3.1).
//!
//! Corner `c` has bit 0 for `+x`, bit 1 for `+y`, bit 2 for `+z`. Edge `a * 4 + sb +
//! 2 sc` runs along axis `a` from the corner with bit `a` clear, where `sb` and `sc`
//! are the bits of the next two axes `(a + 1) % 3`, `(a + 2) % 3`. On each face the
//! crossing edges are joined in pairs; an ambiguous face (diagonal corners alike)
//! separates its inside corners, a rule of the face alone, so the two cells sharing it
//! agree and the pieces close into a 2-manifold.

use std::sync::OnceLock;

/// No piece on this edge (its ends are on one side).
pub(super) const NONE: u8 = u8::MAX;

/// The pieces of one corner configuration (bit `c` set: corner `c` inside).
#[derive(Debug, Clone, Copy)]
pub(super) struct Case {
    pub pieces: u8,
    /// The piece each edge's crossing belongs to, [`NONE`] without a crossing.
    pub piece: [u8; 12],
}

/// The edge from `(a, sb, sc)`.
pub(super) const fn edge(axis: usize, sb: usize, sc: usize) -> usize {
    axis * 4 + sb + 2 * sc
}

/// The two corners of edge `e`, the one with bit `axis` clear first.
pub(super) const fn ends(e: usize) -> (usize, usize) {
    let (a, sb, sc) = (e / 4, e % 2, (e / 2) % 2);
    let c = (sb << ((a + 1) % 3)) | (sc << ((a + 2) % 3));
    (c, c | (1 << a))
}

fn find(p: &mut [usize; 12], mut i: usize) -> usize {
    while p[i] != i {
        p[i] = p[p[i]];
        i = p[i];
    }
    i
}

fn case(config: u8) -> Case {
    let inside = |c: usize| config >> c & 1 == 1;
    let crossing = |e: usize| {
        let (a, b) = ends(e);
        inside(a) != inside(b)
    };
    let mut parent: [usize; 12] = std::array::from_fn(|i| i);
    let join = |p: &mut [usize; 12], x: usize, y: usize| {
        let (x, y) = (find(p, x), find(p, y));
        p[x] = y;
    };
    for a in 0..3 {
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        for s in 0..2 {
            let corner = |u: usize, v: usize| (s << a) | (u << b) | (v << c);
            // Along b at v (bit c), bit a = s: axis b's next axes are (c, a).
            let bottom = edge(b, 0, s);
            let top = edge(b, 1, s);
            // Along c at u (bit b), bit a = s: axis c's next axes are (a, b).
            let left = edge(c, s, 0);
            let right = edge(c, s, 1);
            let face = [bottom, top, left, right];
            let crossings: Vec<usize> = face.into_iter().filter(|&e| crossing(e)).collect();
            match crossings.len() {
                2 => join(&mut parent, crossings[0], crossings[1]),
                4 => {
                    if inside(corner(0, 0)) {
                        join(&mut parent, bottom, left);
                        join(&mut parent, top, right);
                    } else {
                        join(&mut parent, bottom, right);
                        join(&mut parent, top, left);
                    }
                }
                _ => {}
            }
        }
    }
    let mut out = Case { pieces: 0, piece: [NONE; 12] };
    let mut root_piece = [NONE; 12];
    for e in (0..12).filter(|&e| crossing(e)) {
        let r = find(&mut parent, e);
        if root_piece[r] == NONE {
            root_piece[r] = out.pieces;
            out.pieces += 1;
        }
        out.piece[e] = root_piece[r];
    }
    out
}

/// The 256 cases, built once.
pub(super) fn cases() -> &'static [Case; 256] {
    static CASES: OnceLock<[Case; 256]> = OnceLock::new();
    CASES.get_or_init(|| std::array::from_fn(|c| case(c as u8)))
}
