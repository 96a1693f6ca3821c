//! Finding a shell's defects: skin triangles (the outer layer, an envelope's inner
//! layer, and the side walls over an open mesh's boundary) crossing each other or the
//! base, inverted cells, and cells enclosing another part of the base; exact
//! orientation tests in double precision.
//!
//! Together these bound the shell's volume: where two shells overlap, or a shell
//! swallows another part of the mesh, a boundary of one crosses a boundary of the
//! other, or one part lies wholly inside the other's cells (a card floating in
//! another card's shell, a pebble inside a wall's) — the enclosure test, one point
//! per connected part. Why that is enough: the cells are the images of one
//! continuous map `F(p, r) = x(p) + r d(p)` of the base times `[0, 1]` (base offsets
//! aside), whose Jacobian the inverted-cell test keeps non-negative. For such a map
//! the number of preimages of a point off the image of the boundary, and of the
//! Jacobian's zeros (the base or an
//! envelope's inner layer, the outer layer, the side walls) is its degree, the
//! winding number of that image around the point (Lipman, "Bijective mappings of
//! meshes with boundary and the degree in mesh processing", SIAM J. Imaging Sci.
//! 2014; Aigerman and Lipman, "Injective and bounded distortion mappings in 3D",
//! SIGGRAPH 2013). So two cells overlap in a volume only where that image crosses
//! itself, or where the surfaces of one connected part lie wholly inside another
//! part's cells (nested, their winding numbers add up without a crossing). The pair
//! tests keep the image from crossing itself: triangles with no base vertex in
//! common in tree joins, triangles meeting at one vertex in
//! [`Checker::find_star`], while triangles meeting along a whole edge cannot cross
//! (their planes meet in that edge's line). The enclosure test covers the nesting: a
//! part wholly inside a cell crosses nothing but has its probe point there, and a
//! part partly inside crosses a skin. `find_star` also tests two triangles of one
//! face of five or more corners meeting at a vertex, an envelope's inner and outer
//! layer triangles over faces sharing an edge (a quad's two triangles of one split
//! too), and a side wall against the walls, layer and base triangles meeting it at
//! one of its ends. Left to the inverted-cell test, as the two splits of a quad are
//! (no pair search): a wall against the triangles holding both its ends (its
//! owner's layers and base, its quad's other split), and a layer triangle against
//! the base triangle of its quad's same split where a diagonal end is pressed; for
//! these the argument above rests on the cells, untested by a search. One search
//! serves the report (every
//! element, once) and the repair pass (only the elements around directors it just
//! shortened, round after round, on a refitted BVH).
//!
//! On a base that crosses itself, a crossing of two skin triangles, or of a skin
//! triangle and a base triangle, is *inherited* (counted apart, not a defect) only
//! when the two base triangles under it cross each other: pressed flat, the shell
//! has exactly the base's crossings, so no shell can remove these. Every other
//! crossing is a defect, also one of a skin triangle over a face that crosses the
//! base somewhere else (issue 14: no new intersecting pairs beyond the base's own);
//! zero thickness removes it, so the repair always ends. Likewise a cell is spared
//! the enclosure test only for the parts that its own face crosses.

use super::geometry::{prisms, Cell};
use super::intersect::{segment_crosses_triangle, tri_box, triangles_intersect, Prepared, TriBvh};
use super::{Shell, Side};
use crate::mesh::Incidence;
use crate::Mesh;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::borrow::Cow;

/// The defects found: skin items (see [`Checker::item`]) and indices into
/// [`Checker::tris`] and [`Checker::cells`].
#[derive(Debug, Default)]
pub(crate) struct Findings {
    /// Intersecting skin items that share no base vertex (their triangles', a wall's
    /// two ends).
    pub self_pairs: Vec<(u32, u32)>,
    /// (skin triangle, base triangle) pairs that intersect, ignoring pairs of one quad
    /// split differently and pairs that share a vertex whose skin point coincides with
    /// its base point.
    pub base_pairs: Vec<(u32, u32)>,
    /// Inverted cells.
    pub inverted: Vec<u32>,
    /// Cells enclosing a point of another connected part of the base.
    pub enclosing: Vec<u32>,
    /// Intersecting pairs of either kind whose two base triangles cross each other:
    /// inherited from the input, not counted as defects.
    pub inherited: usize,
}

impl Findings {
    pub fn is_clean(&self) -> bool {
        self.self_pairs.is_empty() && self.base_pairs.is_empty() && self.inverted.is_empty() && self.enclosing.is_empty()
    }
}

/// What the search needs of a mesh, built once and used for any number of shells.
///
/// A shell's *skins* are what bounds it away from the base: the outer layer (r = 1),
/// for envelopes also the inner layer (r = 0), and over an open mesh's boundary the
/// side walls. The skin tree's items are the outer triangles (item `t` over base
/// triangle `t`), then four triangles per wall (its quad split both ways), then for
/// envelopes the inner triangles (see [`Checker::item`]).
pub(crate) struct Checker {
    /// The mesh's triangulation ([`Mesh::triangulate`]), then, for each quad, the two
    /// triangles of its other diagonal: a skin quad is not planar, and whoever shows
    /// it (Blender's viewport, an exporter) may split it either way, so both splits
    /// are checked.
    pub tris: Vec<[u32; 3]>,
    /// The mesh face of each triangle.
    pub face_of: Vec<u32>,
    /// Where the quads' other-diagonal triangles begin in `tris`.
    first_other: usize,
    pub cells: Vec<Cell>,
    pub base: Vec<[DVec3; 3]>,
    /// The base triangles with their planes, for the skin/base tests.
    base_prepared: Vec<Prepared>,
    pub base_bvh: TriBvh,
    /// Base triangles that cross another base triangle (sharing no vertex): the
    /// input intersects itself there.
    pub own: Vec<bool>,
    /// The pairs of base triangles that cross (sharing no vertex), both ways round,
    /// sorted: the crossings a shell inherits ([`inherited`](Self::inherited)).
    crossings: Vec<(u32, u32)>,
    /// The base mesh's bounding-box diagonal (the scale of "coincide").
    diag: f64,
    /// Triangles and cells around each vertex (CSR).
    tris_around: Incidence,
    cells_around: Incidence,
    /// Side walls over the boundary edges, sorted by the triangle owning them, and
    /// where each triangle's walls begin (`tris.len() + 1` entries).
    walls: Vec<Wall>,
    wall_start: Vec<u32>,
    /// The walls at each vertex (their ends; CSR).
    walls_around: Incidence,
    /// The enclosure test: the connected part of each cell, and one vertex of each
    /// part (its *probe*) with a tree over their points (empty for a mesh of one
    /// part). A part that crosses the base is probed at a vertex on none of its
    /// crossing triangles (those vertices are partly in and partly out of whatever
    /// the part crosses; its crossings are inherited, as the base's own). Not probed
    /// (`unprobed`): a part whose every vertex lies on a crossing triangle, and a
    /// loose vertex (no surface to keep out of a shell). A cell is not asked to keep
    /// out the probe of a part that its own face crosses (`face_parts`).
    part_of: Vec<u32>,
    part_of_cell: Vec<u32>,
    probes: Vec<u32>,
    probe_tree: TriBvh,
    unprobed: Vec<bool>,
    /// (face, part) for each face with a triangle that crosses a triangle of another
    /// part, sorted: a cell over the face holds some of that part, inherited as the
    /// crossings are, so it is not asked to keep that part's probe out; every other
    /// part's it is, as every other cell is.
    face_parts: Vec<(u32, u32)>,
}

/// A side wall of a shell over an open mesh: the quad between layers 0 and 1 over
/// boundary edge `ends`, owned by a base triangle holding that edge (it is checked
/// and refitted with that triangle's skin items).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Wall {
    pub ends: [u32; 2],
    pub tri: u32,
}

/// [`Checker::find`] joins whole trees, keeping the pairs of flagged triangles,
/// rather than querying the tree once per flagged skin triangle, when at least one
/// triangle in this many is flagged (the join visits each pair of overlapping nodes
/// once; a query walks from the root). On beast's second repair round (72% flagged)
/// the join took 0.8 of the queries' time; at 35-40% it was no faster.
const JOIN_SHARE: usize = 2;

/// Triangles per wall: its quad `a0 b0 b1 a1` split along both diagonals.
const WALL_TRIS: u32 = 4;

/// What a skin-tree item is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Item {
    /// The triangle of layer `r` over base triangle `tri`.
    Layer { tri: u32, r: f32 },
    /// Triangle `half` of wall `wall`.
    Wall { wall: u32, half: u32 },
}

/// Which elements to check: those flagged (mask and list); a flagged triangle is
/// checked in every skin.
pub(crate) struct Dirty {
    pub tris: Vec<bool>,
    pub cells: Vec<bool>,
    pub tri_list: Vec<u32>,
    pub cell_list: Vec<u32>,
}

impl Dirty {
    /// Flags nothing again, in time proportional to what was flagged.
    pub fn clear(&mut self) {
        self.tri_list.drain(..).for_each(|t| self.tris[t as usize] = false);
        self.cell_list.drain(..).for_each(|c| self.cells[c as usize] = false);
    }
}

/// The skins of a shell of `side`: layer parameters r.
pub(crate) fn skins(side: Side) -> &'static [f32] {
    if side == Side::Envelope {
        &[1.0, 0.0]
    } else {
        &[1.0]
    }
}

impl Checker {
    pub fn new(mesh: &Mesh) -> Self {
        let p = mesh.positions();
        let tri = mesh.triangulate();
        let (mut tris, mut face_of) = (tri.triangles, tri.face_of_triangle);
        let mesh_tris = tris.len();
        for (f, face) in mesh.faces().enumerate().filter(|(_, face)| face.len() == 4) {
            let first = face_of[..mesh_tris].partition_point(|&g| (g as usize) < f);
            let [a, b, c, d] = [face[0], face[1], face[2], face[3]];
            let other = if tris[first] == [a, b, c] { [[b, c, d], [b, d, a]] } else { [[a, b, c], [a, c, d]] };
            tris.extend(other);
            face_of.extend([f as u32; 2]);
        }
        let base: Vec<[DVec3; 3]> = tris.iter().map(|t| t.map(|i| p[i as usize].as_dvec3())).collect();
        let cells = prisms(mesh);
        let first_other = mesh_tris;
        let tris_around = Incidence::new(p.len(), tris.iter().copied());
        let cells_around = Incidence::new(p.len(), cells.iter().map(|c| c.base().to_vec()));
        let base_bvh = TriBvh::build(&base);
        let (walls, wall_start) = side_walls(mesh, &tris, mesh_tris, &tris_around);
        let walls_around = Incidence::new(p.len(), walls.iter().map(|w| w.ends));
        let parts = crate::mesh::vertex_parts(mesh);
        let part_of_cell: Vec<u32> = cells.iter().map(|c| parts.of[c.vertices[0] as usize]).collect();
        let probes = if parts.count > 1 { parts.first.clone() } else { Vec::new() };
        let part_of = if parts.count > 1 { parts.of } else { Vec::new() };
        let mut me = Self {
            base_prepared: base.par_iter().map(Prepared::new).collect(),
            base_bvh,
            diag: mesh.bbox_diagonal() as f64,
            own: Vec::new(),
            face_of,
            first_other,
            base,
            tris,
            cells,
            tris_around,
            cells_around,
            walls,
            wall_start,
            walls_around,
            part_of_cell,
            probes,
            probe_tree: TriBvh::from_boxes(Vec::new()),
            unprobed: Vec::new(),
            face_parts: Vec::new(),
            crossings: Vec::new(),
            part_of,
        };
        let pairs = me.base_bvh.overlapping_pairs(&|i, j| me.bases_cross(i, j));
        me.crossings = pairs.iter().flat_map(|&(i, j)| [(i, j), (j, i)]).collect();
        me.crossings.sort_unstable();
        me.own = vec![false; me.tris.len()];
        me.crossings.iter().for_each(|&(i, _)| me.own[i as usize] = true);
        me.choose_probes(p);
        me
    }

    /// Each part's probe: its first vertex on triangles of which none crosses the
    /// base; a part without one, and a loose vertex, is not probed (none probed for a
    /// mesh of one part). The probe tree and the faces that cross other parts follow.
    fn choose_probes(&mut self, p: &[Vec3]) {
        if self.probes.is_empty() {
            return;
        }
        let part = |t: u32| self.part_of[self.tris[t as usize][0] as usize];
        let mut pairs: Vec<(u32, u32)> =
            self.crossings.iter().filter(|&&(t, u)| part(t) != part(u)).map(|&(t, u)| (self.face_of[t as usize], part(u))).collect();
        pairs.sort_unstable();
        pairs.dedup();
        self.face_parts = pairs;
        let mut probe = vec![u32::MAX; self.probes.len()];
        for (v, &k) in self.part_of.iter().enumerate() {
            let around = self.tris_around.of(v);
            if probe[k as usize] == u32::MAX && !around.is_empty() && around.iter().all(|&t| !self.own[t as usize]) {
                probe[k as usize] = v as u32;
            }
        }
        self.unprobed = probe.iter().map(|&v| v == u32::MAX).collect();
        probe.iter().enumerate().filter(|(_, &v)| v != u32::MAX).for_each(|(k, &v)| self.probes[k] = v);
        let at = |v: u32| (p[v as usize].as_dvec3(), p[v as usize].as_dvec3());
        self.probe_tree = TriBvh::from_boxes(self.probes.iter().map(|&v| at(v)).collect());
    }

    /// Whether base triangles `t` and `j` cross, sharing no vertex.
    fn bases_cross(&self, t: u32, j: u32) -> bool {
        let (t, j) = (t as usize, j as usize);
        !shares(&self.tris[t], &self.tris[j]) && self.base_prepared[t].crosses_prepared(&self.base_prepared[j])
    }

    /// The base triangles that cross base triangle `t`, sharing no vertex with it.
    fn crossing_bases(&self, t: u32) -> Vec<u32> {
        let (lo, hi) = tri_box(&self.base[t as usize]);
        let mut found = Vec::new();
        self.base_bvh.query(lo, hi, |j| {
            if self.bases_cross(t, j) {
                found.push(j);
            }
        });
        found
    }

    /// Whether a crossing of skin (or base) items over base triangles `t` and `u` is
    /// inherited: `t` and `u` cross each other in the base (module docs).
    pub fn inherited(&self, t: u32, u: u32) -> bool {
        self.own[t as usize] && self.own[u as usize] && self.crossings.binary_search(&(t, u)).is_ok()
    }

    /// Pairs of base triangles that cross each other (sharing no vertex): the input's
    /// own intersections.
    pub fn base_self_pairs(&self) -> usize {
        self.crossings.len() / 2
    }

    /// The base triangles that cross another part of the mesh.
    pub fn own_tris(&self) -> Vec<u32> {
        (0..self.tris.len() as u32).filter(|&t| self.own[t as usize]).collect()
    }

    /// The mesh faces that cross another part of the mesh, sorted, each once.
    pub fn own_faces(&self) -> Vec<u32> {
        let mut f: Vec<u32> = (0..self.tris.len()).filter(|&t| self.own[t]).map(|t| self.face_of[t]).collect();
        f.sort_unstable();
        f.dedup();
        f
    }

    /// After the vertices `moved` moved (same topology and triangulation): the base
    /// triangles around them and the tree follow. Returns the base triangles whose
    /// [`own`](Self::own) flag changed.
    pub fn refit_base(&mut self, mesh: &Mesh, moved: &[u32]) -> Vec<u32> {
        let p = mesh.positions();
        let mut touched: Vec<u32> = moved.iter().flat_map(|&v| self.tris_around.of(v as usize)).copied().collect();
        touched.sort_unstable();
        touched.dedup();
        // Triangles the moved ones crossed before or cross now may change their flag.
        let mut near = touched.clone();
        let mut around = |b: (DVec3, DVec3)| self.base_bvh.query(b.0, b.1, |j| near.push(j));
        touched.iter().for_each(|&t| around(tri_box(&self.base[t as usize])));
        for &t in &touched {
            self.base[t as usize] = self.tris[t as usize].map(|i| p[i as usize].as_dvec3());
            self.base_prepared[t as usize] = Prepared::new(&self.base[t as usize]);
        }
        self.base_bvh.refit_items(touched.iter().map(|&t| (t, tri_box(&self.base[t as usize]))));
        let probe_box = |v: u32| (p[v as usize].as_dvec3(), p[v as usize].as_dvec3());
        self.probe_tree.refit_items(self.probes.iter().enumerate().filter(|(_, v)| moved.binary_search(v).is_ok()).map(|(k, &v)| (k as u32, probe_box(v))));
        let mut around = |b: (DVec3, DVec3)| self.base_bvh.query(b.0, b.1, |j| near.push(j));
        touched.iter().for_each(|&t| around(tri_box(&self.base[t as usize])));
        near.sort_unstable();
        near.dedup();
        // A pair of base triangles begins or stops crossing only if one of them moved.
        let mut moving = vec![false; self.tris.len()];
        touched.iter().for_each(|&t| moving[t as usize] = true);
        self.crossings.retain(|&(t, u)| !moving[t as usize] && !moving[u as usize]);
        let fresh: Vec<(u32, u32)> = touched.par_iter().flat_map_iter(|&t| self.crossing_bases(t).into_iter().map(move |u| (t, u))).collect();
        self.crossings.extend(fresh.iter().flat_map(|&(t, u)| [(t, u), (u, t)]));
        self.crossings.sort_unstable();
        self.crossings.dedup();
        let flags: Vec<bool> = near.iter().map(|&t| self.crossings.binary_search_by_key(&t, |c| c.0).is_ok()).collect();
        let flipped: Vec<u32> = near.iter().zip(flags).filter(|(&t, f)| self.own[t as usize] != *f).map(|(&t, _)| t).collect();
        flipped.iter().for_each(|&t| self.own[t as usize] ^= true);
        // A moved crossing triangle may cross other parts than before.
        if !flipped.is_empty() || touched.iter().any(|&t| self.own[t as usize]) {
            self.choose_probes(p);
        }
        self.diag = mesh.bbox_diagonal() as f64;
        flipped
    }

    /// Nothing flagged.
    pub fn clean(&self) -> Dirty {
        Dirty { tris: vec![false; self.tris.len()], cells: vec![false; self.cells.len()], tri_list: Vec::new(), cell_list: Vec::new() }
    }

    /// Flags the triangles and cells around each of `vertices`, after clearing `dirty`
    /// (in time proportional to what it held).
    pub fn mark_anew(&self, vertices: impl Iterator<Item = u32>, dirty: &mut Dirty) {
        dirty.clear();
        vertices.for_each(|v| self.mark_around(v as usize, dirty));
    }

    /// Flags the triangles and cells around vertex `v`.
    pub fn mark_around(&self, v: usize, dirty: &mut Dirty) {
        for &t in self.tris_around.of(v) {
            if !std::mem::replace(&mut dirty.tris[t as usize], true) {
                dirty.tri_list.push(t);
            }
        }
        for &c in self.cells_around.of(v) {
            if !std::mem::replace(&mut dirty.cells[c as usize], true) {
                dirty.cell_list.push(c);
            }
        }
    }

    /// What skin item `i` is (the numbering is [`Checker`]'s).
    pub fn item(&self, i: u32) -> Item {
        let (n, w) = (self.tris.len() as u32, WALL_TRIS * self.walls.len() as u32);
        if i < n {
            Item::Layer { tri: i, r: 1.0 }
        } else if i < n + w {
            Item::Wall { wall: (i - n) / WALL_TRIS, half: (i - n) % WALL_TRIS }
        } else {
            Item::Layer { tri: i - n - w, r: 0.0 }
        }
    }

    /// The base triangle skin item `i` lies over (a wall's: the one owning it).
    pub fn item_tri(&self, i: u32) -> u32 {
        match self.item(i) {
            Item::Layer { tri, .. } => tri,
            Item::Wall { wall, .. } => self.walls[wall as usize].tri,
        }
    }

    /// The base vertices whose directors move skin item `i`.
    pub fn item_vertices(&self, i: u32) -> &[u32] {
        match self.item(i) {
            Item::Layer { tri, .. } => &self.tris[tri as usize],
            Item::Wall { wall, .. } => &self.walls[wall as usize].ends,
        }
    }

    /// How many skin items a shell of `side` has.
    pub fn items(&self, side: Side) -> usize {
        self.tris.len() * skins(side).len() + WALL_TRIS as usize * self.walls.len()
    }

    /// The corners of skin item `i` of `shell`.
    pub fn skin_tri(&self, mesh: &Mesh, shell: &Shell, i: u32) -> [DVec3; 3] {
        let at = |v: u32, r: f32| shell.point(mesh.positions(), v as usize, r).as_dvec3();
        match self.item(i) {
            Item::Layer { tri, r } => self.tris[tri as usize].map(|v| at(v, r)),
            Item::Wall { wall, half } => {
                let [a, b] = self.walls[wall as usize].ends;
                let (a0, b0, b1, a1) = (at(a, 0.0), at(b, 0.0), at(b, 1.0), at(a, 1.0));
                [[a0, b0, b1], [a0, b1, a1], [a0, b0, a1], [b0, b1, a1]][half as usize]
            }
        }
    }

    /// The skin items of base triangle `t` in a shell of `side`: its layers' and the
    /// walls it owns.
    fn items_of(&self, t: u32, side: Side) -> impl Iterator<Item = u32> {
        let (n, w) = (self.tris.len() as u32, WALL_TRIS * self.walls.len() as u32);
        let walls = self.wall_start[t as usize] * WALL_TRIS + n..self.wall_start[t as usize + 1] * WALL_TRIS + n;
        let inner = (side == Side::Envelope).then_some(n + w + t);
        std::iter::once(t).chain(walls).chain(inner)
    }

    /// Whether a skin triangle of base triangle `t` crosses another skin triangle
    /// away from it (`tree` holds the skins); after the first crossing the remaining
    /// candidates are skipped untested. Crossings inherited from the base do not count.
    pub fn outer_crosses(&self, mesh: &Mesh, shell: &Shell, t: u32, tree: &TriBvh) -> bool {
        self.items_of(t, shell.side).any(|i| {
            let mine = Prepared::new(&self.skin_tri(mesh, shell, i));
            tree.any_where(near(&mine), |j| {
                !self.inherited(t, self.item_tri(j)) && self.skins_may_cross(shell, i, j) && mine.crosses(&self.skin_tri(mesh, shell, j))
            })
        })
    }

    /// The triangles around vertex `v`.
    pub fn tris_of(&self, v: usize) -> &[u32] {
        self.tris_around.of(v)
    }

    /// Whether segment `a`-`b` of vertex `v` crosses a triangle away from `v`: of the
    /// base, or of `outer`'s skins (with their tree).
    pub fn segment_crosses(&self, mesh: &Mesh, v: u32, a: DVec3, b: DVec3, outer: Option<(&Shell, &TriBvh)>) -> bool {
        match outer {
            None => self.base_bvh.any_on_segment(a, b, |j| !self.tris[j as usize].contains(&v) && segment_crosses_triangle(a, b, &self.base[j as usize])),
            Some((shell, tree)) => {
                tree.any_on_segment(a, b, |j| !self.item_vertices(j).contains(&v) && segment_crosses_triangle(a, b, &self.skin_tri(mesh, shell, j)))
            }
        }
    }

    /// The cells around vertex `v`.
    pub fn cells_of(&self, v: usize) -> &[u32] {
        self.cells_around.of(v)
    }

    /// The corners of the cells around vertex `v` (`v` among them, others repeated).
    pub fn cell_corners_around(&self, v: usize) -> impl Iterator<Item = u32> + '_ {
        self.cells_around.of(v).iter().flat_map(|&c| self.cells[c as usize].base().iter().copied())
    }

    /// A tree over the skin triangles' boxes, refitting `reuse` when given (the
    /// shell's topology never changes).
    pub fn outer_tree(&self, mesh: &Mesh, shell: &Shell, reuse: Option<TriBvh>) -> TriBvh {
        let items = self.items(shell.side) as u32;
        let boxes = (0..items).into_par_iter().map(|i| tri_box(&self.skin_tri(mesh, shell, i)));
        match reuse {
            Some(mut tree) if tree.len() == items as usize => {
                tree.refit_boxes(boxes.collect::<Vec<_>>().into_iter());
                tree
            }
            _ => TriBvh::from_boxes(boxes.collect()),
        }
    }

    /// Moves the skin triangles of base triangles `tris` to where `shell` puts them.
    pub fn refit_outer(&self, mesh: &Mesh, shell: &Shell, tree: &mut TriBvh, tris: &[u32]) {
        tree.refit_items(tris.iter().flat_map(|&t| self.items_of(t, shell.side)).map(|i| (i, tri_box(&self.skin_tri(mesh, shell, i)))));
    }

    /// The defects of `shell` among the flagged elements (all for `None`). A pair is
    /// found when either triangle is flagged. `outer_tree` holds every skin triangle
    /// of `shell` at its current place ([`outer_tree`](Self::outer_tree), refitted
    /// after every change: a search with at least 1/`JOIN_SHARE` of the triangles
    /// flagged joins its boxes, a smaller one queries it per flagged triangle); without
    /// it the skins are not checked against each other. Everything in double precision.
    pub fn find(&self, mesh: &Mesh, shell: &Shell, dirty: Option<&Dirty>, outer_tree: Option<&TriBvh>) -> Findings {
        let p = mesh.positions();
        // Per skin triangle: (kind, item, other), kind 0 a self pair, 1 a base pair,
        // 2 an inherited pair of either kind.
        let many = dirty.is_none_or(|d| d.tri_list.len() * JOIN_SHARE >= self.tris.len());
        let timer = super::timing::Stage::start(if many { "find: pairs (tree join)" } else { "find: pairs (per triangle)" });
        super::timing::count(
            if many { "# find: tris (tree join)" } else { "# find: tris (per triangle)" },
            dirty.map_or(self.tris.len(), |d| d.tri_list.len()),
        );
        let hits: Vec<(u8, u32, u32)> = match outer_tree {
            // Everything, or much: each tree traversed against itself and against the
            // base's, which visits each pair of overlapping nodes once.
            Some(tree) if many => {
                debug_assert_eq!(tree.len(), self.items(shell.side), "the skin tree must hold every skin triangle");
                // Every skin triangle once, with its plane (each is met in dozens of
                // candidate pairs).
                let all: Vec<Prepared> = (0..self.items(shell.side) as u32).into_par_iter().map(|i| Prepared::new(&self.skin_tri(mesh, shell, i))).collect();
                let skin = |i: u32| &all[i as usize];
                let flagged = |i: u32| dirty.is_none_or(|d| d.tris[self.item_tri(i) as usize]);
                let skin_pair = |i, j| (flagged(i) || flagged(j)) && self.skins_may_cross(shell, i, j) && skin(i).crosses_prepared(skin(j));
                let base_pair = |i, j| flagged(i) && self.skin_crosses_base(mesh, shell, i, skin(i), j);
                let (skin, base) = rayon::join(|| tree.overlapping_pairs(&skin_pair), || tree.overlapping_pairs_with(&self.base_bvh, &base_pair));
                let kind = |t: u32, u: u32, k: u8| if self.inherited(t, u) { 2 } else { k };
                let skin = skin.into_iter().map(|(i, j)| (kind(self.item_tri(i), self.item_tri(j), 0), i, j));
                skin.chain(base.into_iter().map(|(i, j)| (kind(self.item_tri(i), j, 1), i, j))).collect()
            }
            _ => self.find_around(mesh, shell, dirty, outer_tree),
        };
        drop(timer);
        let timer = super::timing::Stage::start("find: star");
        let mut hits = hits;
        hits.extend(self.find_star(mesh, shell, dirty, outer_tree.is_some()));
        drop(timer);
        let _timer = super::timing::Stage::start("find: cells");
        let pairs = |k: u8| hits.iter().filter(|h| h.0 == k).map(|h| (h.1, h.2)).collect();
        let cell_list: Cow<[u32]> = match dirty {
            Some(d) => Cow::Borrowed(&d.cell_list),
            None => Cow::Owned((0..self.cells.len() as u32).collect()),
        };
        let inverted = cell_list.par_iter().copied().filter(|&c| self.cells[c as usize].is_inverted(p, shell)).collect();
        let enclosing = self.enclosing(mesh, shell, &cell_list);
        Findings { self_pairs: pairs(0), base_pairs: pairs(1), inverted, enclosing, inherited: hits.iter().filter(|h| h.0 == 2).count() }
    }

    /// [`find`](Self::find) after directors were set back to a shape in which the
    /// shell was clean, while others (`moved`, per vertex) keep a shape checked
    /// with them: `back` flags the triangles and cells around the directors set
    /// back. Only what the two may have made is looked at: a skin triangle of `back`
    /// with no moved corner against the skin triangles over a moved corner (tree
    /// pairs and [`find_star`](Self::find_star)'s), and in full (as `find` does) the
    /// triangles and cells of `back` with corners of both. Every other pair and cell
    /// of `back` is as it was in the clean shell, and every pair or cell of the
    /// moved corners without a director set back was checked with them. The
    /// restore's checks after undoing tries ([`super::restore`]) look at a fraction
    /// of what `find` on `back` would.
    pub fn find_against(&self, mesh: &Mesh, shell: &Shell, back: &Dirty, moved: &[bool], outer_tree: &TriBvh) -> Findings {
        let tri_moved = |t: u32| self.tris[t as usize].iter().any(|&v| moved[v as usize]);
        let (mixed_tris, back_only): (Vec<u32>, Vec<u32>) = back.tri_list.iter().partition(|&&t| tri_moved(t));
        let mut mixed = self.clean();
        for &t in &mixed_tris {
            mixed.tris[t as usize] = true;
        }
        mixed.tri_list = mixed_tris;
        for &c in &back.cell_list {
            if self.cells[c as usize].base().iter().any(|&v| moved[v as usize]) {
                mixed.cells[c as usize] = true;
                mixed.cell_list.push(c);
            }
        }
        let mut found = self.find(mesh, shell, Some(&mixed), Some(outer_tree));
        // The triangles around directors set back alone: against the moved ones.
        let hits: Vec<(u8, u32, u32)> = back_only
            .par_iter()
            .flat_map_iter(|&t| self.items_of(t, shell.side).map(move |i| (t, i)))
            .flat_map_iter(|(t, i)| {
                let mine = Prepared::new(&self.skin_tri(mesh, shell, i));
                // A triangle of `back` with a moved corner was checked in full above.
                self.skin_pairs(&|j| self.skin_tri(mesh, shell, j), shell, (t, i), &mine, outer_tree, |_, u| !back.tris[u as usize] && tri_moved(u))
            })
            .collect();
        let mut only = self.clean();
        for &t in &back_only {
            only.tris[t as usize] = true;
        }
        only.tri_list = back_only;
        // Star pairs with an unmoved neighbour are as they were: only those with a
        // moved one can be found.
        let star = self.find_star(mesh, shell, Some(&only), true);
        for (kind, i, j) in hits.into_iter().chain(star) {
            match kind {
                0 => found.self_pairs.push((i, j)),
                1 => found.base_pairs.push((i, j)),
                _ => found.inherited += 1,
            }
        }
        found
    }

    /// Those of `cells` that enclose the probe point of another connected part. A
    /// part wholly inside another's shell crosses none of its skins; with the
    /// crossings, this bounds the shell's volume (module docs). Only the flagged cells
    /// are asked: a part moving into a cell that did not change is found by the
    /// caller flagging the cells around its probe ([`Checker::cells_near_probes`]).
    /// A cell is not asked about the parts that its own face crosses (`face_parts`).
    fn enclosing(&self, mesh: &Mesh, shell: &Shell, cells: &[u32]) -> Vec<u32> {
        if self.probes.is_empty() {
            return Vec::new();
        }
        let p = mesh.positions();
        cells
            .par_iter()
            .copied()
            .filter(|&c| {
                let cell = &self.cells[c as usize];
                let corners = cell.corners(p, shell);
                let (lo, hi) = corners.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), q| (lo.min(q.as_dvec3()), hi.max(q.as_dvec3())));
                let part = self.part_of_cell[c as usize];
                self.probe_tree.any(lo, hi, |k| {
                    let v = self.probes[k as usize];
                    k != part
                        && !self.unprobed[k as usize]
                        && self.face_parts.binary_search(&(cell.face, k)).is_err()
                        && cell.encloses(p, shell, p[v as usize].as_dvec3())
                })
            })
            .collect()
    }

    /// The base vertices of the cells whose boxes, grown by `reach`, hold a probe of
    /// a part that has a vertex in `moved` or a triangle in `flipped` (whose crossing
    /// flag changed, which may move its part's probe), sorted: the cells a moved
    /// part or probe may have entered, for the caller to flag.
    pub fn cells_near_probes(&self, mesh: &Mesh, moved: &[u32], flipped: &[u32], reach: f64) -> Vec<u32> {
        if self.probes.is_empty() || (moved.is_empty() && flipped.is_empty()) {
            return Vec::new();
        }
        let p = mesh.positions();
        let mut hit = vec![false; self.probes.len()];
        moved.iter().for_each(|&v| hit[self.part_of[v as usize] as usize] = true);
        flipped.iter().for_each(|&t| hit[self.part_of[self.tris[t as usize][0] as usize] as usize] = true);
        let mut out = Vec::new();
        for (k, &v) in self.probes.iter().enumerate().filter(|(k, _)| hit[*k]) {
            let x = p[v as usize].as_dvec3();
            self.base_bvh.query(x - DVec3::splat(reach), x + DVec3::splat(reach), |t| {
                if self.part_of[self.tris[t as usize][0] as usize] != k as u32 {
                    out.extend(self.tris[t as usize]);
                }
            });
        }
        out.sort_unstable();
        out.dedup();
        out
    }

    /// Whether skin items `i` (at `mine()`) and `j` (at `theirs()`; both computed only
    /// once the pair is not ruled out by topology: most candidate pairs are
    /// neighbours) cross, sharing no base vertex. A flat wall counts for nothing ([`flat_wall`](Self::flat_wall)).
    fn skins_cross(&self, shell: &Shell, i: u32, mine: impl FnOnce() -> [DVec3; 3], j: u32, theirs: impl FnOnce() -> [DVec3; 3]) -> bool {
        self.skins_may_cross(shell, i, j) && triangles_intersect(&mine(), &theirs())
    }

    /// Whether [`skins_cross`](Self::skins_cross) tests skin items `i` and `j` at all
    /// (they share no base vertex, neither is a flat wall); the searches then test a
    /// [`Prepared`] query triangle against them.
    #[inline]
    fn skins_may_cross(&self, shell: &Shell, i: u32, j: u32) -> bool {
        !shares(self.item_vertices(i), self.item_vertices(j)) && !self.flat_wall(shell, i) && !self.flat_wall(shell, j)
    }

    /// Whether item `i` is a wall of no height (both ends' directors zero): it is
    /// then only the edge of the layer it stands on, whose crossings are the layer's
    /// (or, pressed onto the base, the base's own). So zero thickness stays valid.
    fn flat_wall(&self, shell: &Shell, i: u32) -> bool {
        let flat = |v: u32| shell.directors[v as usize].length() as f64 <= 1e-6 * self.diag;
        matches!(self.item(i), Item::Wall { wall, .. } if self.walls[wall as usize].ends.iter().all(|&v| flat(v)))
    }

    /// Whether skin item `i` (at `mine`) crosses base triangle `j`. The two splits of
    /// a curved quad cross each other once one is offset a little: a skin triangle is
    /// checked against its own face's base in the same split only; and not against a
    /// base triangle it shares a vertex with whose skin point coincides with the base
    /// point.
    fn skin_crosses_base(&self, mesh: &Mesh, shell: &Shell, i: u32, mine: &Prepared, j: u32) -> bool {
        let (p, tris) = (mesh.positions(), &self.tris);
        let (t, r) = match self.item(i) {
            Item::Layer { tri, r } => (tri, r),
            // A wall stands on its edge: base triangles at either end touch it.
            Item::Wall { .. } => {
                return !shares(self.item_vertices(i), &tris[j as usize]) && !self.flat_wall(shell, i) && mine.crosses_prepared(&self.base_prepared[j as usize])
            }
        };
        let (t, j) = (t as usize, j as usize);
        let coincide = |v: u32| (shell.point(p, v as usize, r).as_dvec3() - p[v as usize].as_dvec3()).length() <= 1e-6 * self.diag;
        let other_split = self.face_of[j] == self.face_of[t] && (t < self.first_other) != (j < self.first_other);
        let touching = tris[t].iter().any(|v| tris[j].contains(v) && coincide(*v));
        !other_split && !touching && mine.crosses_prepared(&self.base_prepared[j])
    }

    /// [`find`](Self::find)'s pairs the skin and base tests above leave out by
    /// topology: layer triangles of faces sharing exactly one base vertex `v` (they
    /// meet at `v`'s point of the layer), an envelope's inner and outer layer
    /// triangles of faces sharing an edge (tested whole: they meet at most where a
    /// director is zero), and a layer triangle with a base triangle
    /// sharing `v`, or an edge from `v` whose other end is not pressed, where `v`'s
    /// director is zero (the shell pressed onto the base there: they meet at the base
    /// point alone). Each such pair crossing away from the
    /// shared point is a skin pair (kind 0) or a skin/base pair (1), inherited (2)
    /// where the two base triangles themselves cross away from `v`; only the flagged
    /// triangles' pairs (by the lower triangle when both are flagged). Two triangles
    /// of one face of five or more corners (one split) are paired as triangles of
    /// different faces are; those of a quad are not (its two splits cross each
    /// other once curved, and the triangles of one split share the diagonal), short
    /// of an envelope's two layers over one split (below). With `skins_too` false,
    /// only the skin/base pairs.
    ///
    /// Why (issue 14, cells of non-adjacent faces overlapping): the cells are the
    /// images of one continuous map `F(p, r) = x(p) + r d(p)` of the base times
    /// `[0, 1]` (the texture map, chapter 3.1), whose Jacobian the fold test keeps
    /// non-negative. For a point `y` off the image of the boundary (base and outer
    /// layer; an envelope's two layers; an open mesh's side walls) and of the
    /// Jacobian's zeros, the number of preimages is the degree of `F` at `y`, the
    /// winding number of the boundary's image around `y` (Lipman, "Bijective mappings
    /// of meshes with boundary and the degree in mesh processing", SIAM J. Imaging
    /// Sci. 2014, and Aigerman and Lipman 2013, theorem 1): 0 or 1 when that image is
    /// embedded. The tree tests make it embedded except between triangles sharing a
    /// base vertex, which they skip; on the public nefertiti scan at exterior 5% the
    /// cells of faces with no vertex in common that overlapped as maps all sat at
    /// vertices with a zero director, where outer triangles sharing only that vertex
    /// (72 pairs) or an outer and a base triangle (64) crossed each other away from
    /// it. With these pairs tested too, no two cells overlap in a volume, short of the
    /// untested pairs listed below (the module docs: the enclosure test covers a part
    /// nested without crossing). Triangles
    /// sharing an edge at the same points cannot cross (their planes meet in the
    /// edge's line); a fold there is the inverted-cell test's. A crossing tested here
    /// is one of the segments opposite the shared corner crossing the other triangle
    /// properly: two triangles meeting at a corner cross elsewhere only so, short of
    /// an edge or triangle lying in the other's plane. The crossing runs from the
    /// corner to an opposite edge, and on, through the triangle beyond that edge,
    /// into a pair the trees test, unless that triangle shares a vertex with the
    /// other one too (small stars), or the edge is a boundary edge whose wall has no
    /// height: such crossings only this search finds (`tests_find_star`).
    ///
    /// Also tested here (issue 14, open meshes and envelopes): within one quad, an
    /// envelope's inner layer triangle and the outer one of the other triangle of its
    /// split (they share the diagonal's base vertices, at different points: tested
    /// whole, as over an edge of two faces); and a side wall and a triangle meeting it
    /// at one of its ends ([`wall_pairs`](Self::wall_pairs)). In `tests_find_star`'s
    /// random shells no shell had such pairs as its only defect: the other checks
    /// also caught each, which is seen, not proven, so they are searched. Not tested
    /// by any search (the module docs): a wall and the
    /// triangles holding both its ends, and a layer and a base triangle of one quad
    /// split meeting at a pressed diagonal end.
    pub(crate) fn find_star(&self, mesh: &Mesh, shell: &Shell, dirty: Option<&Dirty>, skins_too: bool) -> Vec<(u8, u32, u32)> {
        let p = mesh.positions();
        let tri_flagged = |i: usize| dirty.is_none_or(|d| d.tris[i]);
        let tri_list: Cow<[u32]> = match dirty {
            Some(d) => Cow::Borrowed(&d.tri_list),
            None => Cow::Owned((0..self.tris.len() as u32).collect()),
        };
        let (n, w) = (self.tris.len() as u32, WALL_TRIS * self.walls.len() as u32);
        let layer_item = |t: u32, r: f32| if r == 1.0 { t } else { n + w + t };
        // Triangle `t`'s corners at layer `r` (None: the base), `v` first.
        let corners = |t: u32, v: u32, r: Option<f32>| -> [DVec3; 3] {
            let tri = self.tris[t as usize];
            let k = tri.iter().position(|&x| x == v).unwrap_or(0);
            [0, 1, 2].map(|o| {
                let q = tri[(k + o) % 3] as usize;
                match r {
                    Some(r) => shell.point(p, q, r).as_dvec3(),
                    None => p[q].as_dvec3(),
                }
            })
        };
        // Each exact test behind a box test: the two triangles' boxes always meet (at
        // the shared corner), a segment's and a triangle's mostly not.
        let away = |a: &[DVec3; 3], b: &[DVec3; 3]| {
            (boxes_meet(a[1], a[2], b) && segment_crosses_triangle(a[1], a[2], b)) || (boxes_meet(b[1], b[2], a) && segment_crosses_triangle(b[1], b[2], a))
        };
        let coincide = |v: u32, r: f32| (shell.point(p, v as usize, r).as_dvec3() - p[v as usize].as_dvec3()).length() <= 1e-6 * self.diag;
        tri_list
            .par_iter()
            .flat_map_iter(|&t| {
                let mut hits = Vec::new();
                for &v in &self.tris[t as usize] {
                    for &u in self.tris_around.of(v as usize) {
                        let shared = self.tris[u as usize].iter().filter(|x| self.tris[t as usize].contains(x)).count();
                        // Triangles of one face of five or more corners (one split, no
                        // other) are paired as triangles of different faces are.
                        let face = self.face_of[t as usize];
                        let one_quad = self.face_of[u as usize] == face && mesh.face(face as usize).len() < 5;
                        // Within a quad, only an envelope's two layers over the two
                        // triangles of one split (over the diagonal, below).
                        let split_pair = shell.side == Side::Envelope && shared == 2 && (t < self.first_other as u32) == (u < self.first_other as u32);
                        if u == t || shared == 0 || shared > 2 || (one_quad && !split_pair) {
                            continue;
                        }
                        // With an edge in common, the layer triangle meets the base one at
                        // `v` alone where the edge's other end is not pressed too.
                        let other = self.tris[t as usize].iter().copied().find(|&x| x != v && self.tris[u as usize].contains(&x));
                        let inherited = || away(&corners(t, v, None), &corners(u, v, None));
                        for &r in skins(shell.side).iter().filter(|_| !one_quad) {
                            if coincide(v, r) && other.is_none_or(|a| !coincide(a, r)) && away(&corners(t, v, Some(r)), &corners(u, v, None)) {
                                hits.push((if inherited() { 2 } else { 1 }, layer_item(t, r), u));
                            }
                        }
                        if !skins_too || (u < t && tri_flagged(u as usize)) {
                            continue;
                        }
                        // An envelope's inner and outer layer triangles over an edge in
                        // common (a quad's diagonal too) meet nowhere in general: tested
                        // whole, once per pair (from the edge's lower end).
                        if let Some(a) = other {
                            if shell.side == Side::Envelope && v < a {
                                for (r, r2) in [(1.0, 0.0), (0.0, 1.0)] {
                                    if triangles_intersect(&corners(t, v, Some(r)), &corners(u, v, Some(r2))) {
                                        hits.push((if inherited() { 2 } else { 0 }, layer_item(t, r), layer_item(u, r2)));
                                    }
                                }
                            }
                            continue;
                        }
                        for &r in skins(shell.side) {
                            for &r2 in skins(shell.side) {
                                let (a, b) = (corners(t, v, Some(r)), corners(u, v, Some(r2)));
                                // Layers meeting at v are tested away from it; else whole.
                                let cross = if a[0] == b[0] { away(&a, &b) } else { triangles_intersect(&a, &b) };
                                if cross {
                                    hits.push((if inherited() { 2 } else { 0 }, layer_item(t, r), layer_item(u, r2)));
                                }
                            }
                        }
                    }
                }
                self.wall_pairs(mesh, shell, t, &tri_flagged, skins_too, &mut hits);
                hits
            })
            .collect()
    }

    /// [`find_star`](Self::find_star)'s pairs of a side wall and a triangle meeting it
    /// at one end `v` (sharing no other base vertex with the wall), for flagged
    /// triangle `t`: the walls `t` owns against the base triangles (kind 1), the
    /// layer triangles and the other walls around `v` (kind 0), and `t`'s layers
    /// against the walls around its corners owned by another triangle (each skin pair
    /// once: by the lower owner or triangle when both are flagged). Tested whole
    /// ([`triangles_intersect`]): a shared point (`v`'s at a layer, or its base point
    /// where the wall stands on the base) lies in the other's plane, so only a
    /// crossing away from it counts; a flat wall counts for nothing. Inherited (2)
    /// where the two base triangles cross.
    fn wall_pairs(&self, mesh: &Mesh, shell: &Shell, t: u32, flagged: &impl Fn(usize) -> bool, skins_too: bool, hits: &mut Vec<(u8, u32, u32)>) {
        if self.walls.is_empty() {
            return;
        }
        let n = self.tris.len() as u32;
        let halves = |w: u32| (0..WALL_TRIS).map(move |h| n + w * WALL_TRIS + h);
        let layers = |u: u32| skins(shell.side).iter().map(move |&r| if r == 1.0 { u } else { n + WALL_TRIS * self.walls.len() as u32 + u });
        let flat = |w: u32| self.flat_wall(shell, n + w * WALL_TRIS);
        let kind = |a: u32, b: u32, k: u8| if a != b && self.base_prepared[a as usize].crosses_prepared(&self.base_prepared[b as usize]) { 2 } else { k };
        let test = |hits: &mut Vec<(u8, u32, u32)>, i: u32, mine: &[DVec3; 3], j: u32, other: &[DVec3; 3], k: u8| {
            if triangles_intersect(mine, other) {
                hits.push((k, i, j));
            }
        };
        let tri = self.tris[t as usize];
        let p = mesh.positions();
        let shell_points = |v: u32| [0.0, 1.0].map(|r| shell.point(p, v as usize, r).as_dvec3());
        for w in (self.wall_start[t as usize]..self.wall_start[t as usize + 1]).filter(|&w| !flat(w)) {
            let ends = self.walls[w as usize].ends;
            for (v, o) in [(ends[0], ends[1]), (ends[1], ends[0])] {
                for i in halves(w) {
                    let mine = self.skin_tri(mesh, shell, i);
                    for &u in self.tris_around.of(v as usize).iter().filter(|&&u| !self.tris[u as usize].contains(&o)) {
                        if through_base_point(&mine, shell_points(v), p[v as usize].as_dvec3(), &self.base[u as usize]) {
                            hits.push((kind(t, u, 1), i, u));
                        }
                        if skins_too && !(flagged(u as usize) && u < t) {
                            layers(u).for_each(|j| test(hits, i, &mine, j, &self.skin_tri(mesh, shell, j), kind(t, u, 0)));
                        }
                    }
                    let others = self.walls_around.of(v as usize).iter().filter(|&&w2| w2 != w && !self.walls[w2 as usize].ends.contains(&o));
                    for &w2 in others.filter(|&&w2| skins_too && !flat(w2) && !(flagged(self.walls[w2 as usize].tri as usize) && w2 < w)) {
                        let k = kind(t, self.walls[w2 as usize].tri, 0);
                        halves(w2).for_each(|j| test(hits, i, &mine, j, &self.skin_tri(mesh, shell, j), k));
                    }
                }
            }
        }
        if !skins_too {
            return;
        }
        for &v in &tri {
            for &w in self.walls_around.of(v as usize) {
                let wall = self.walls[w as usize];
                let o = wall.ends[(wall.ends[0] == v) as usize];
                if tri.contains(&o) || flat(w) || (flagged(wall.tri as usize) && wall.tri < t) {
                    continue;
                }
                for j in layers(t) {
                    let other = self.skin_tri(mesh, shell, j);
                    halves(w).for_each(|i| test(hits, i, &self.skin_tri(mesh, shell, i), j, &other, kind(wall.tri, t, 0)));
                }
            }
        }
    }

    /// The skin items of `tree` crossing skin item `i` (of base triangle `t`, corners
    /// `mine`) that `keep(item, its base triangle)` lets through, as defect triples
    /// (2: inherited, 0: not).
    fn skin_pairs(
        &self,
        skin: &impl Fn(u32) -> [DVec3; 3],
        shell: &Shell,
        (t, i): (u32, u32),
        mine: &Prepared,
        tree: &TriBvh,
        keep: impl Fn(u32, u32) -> bool,
    ) -> Vec<(u8, u32, u32)> {
        let mut hits = Vec::new();
        tree.query_where(near(mine), |j| {
            let u = self.item_tri(j);
            if keep(j, u) && self.skins_may_cross(shell, i, j) && mine.crosses(&skin(j)) {
                hits.push((if self.inherited(t, u) { 2 } else { 0 }, i, j));
            }
        });
        hits
    }

    /// [`find`](Self::find)'s pairs, one query per flagged skin triangle.
    fn find_around(&self, mesh: &Mesh, shell: &Shell, dirty: Option<&Dirty>, outer_tree: Option<&TriBvh>) -> Vec<(u8, u32, u32)> {
        let skin = |i: u32| self.skin_tri(mesh, shell, i);
        let tri_flagged = |i: usize| dirty.is_none_or(|d| d.tris[i]);
        let tri_list: Cow<[u32]> = match dirty {
            Some(d) => Cow::Borrowed(&d.tri_list),
            None => Cow::Owned((0..self.tris.len() as u32).collect()),
        };
        tri_list
            .par_iter()
            .flat_map_iter(|&t| self.items_of(t, shell.side).map(move |i| (t, i)))
            .flat_map_iter(|(t, i)| {
                let mine = Prepared::new(&skin(i));
                let mut hits = match outer_tree {
                    // Each pair once: by the lower item, unless only the higher is flagged.
                    Some(tree) => self.skin_pairs(&skin, shell, (t, i), &mine, tree, |j, u| j > i || !tri_flagged(u as usize)),
                    None => Vec::new(),
                };
                self.base_bvh.query_where(near(&mine), |j| {
                    if self.skin_crosses_base(mesh, shell, i, &mine, j) {
                        hits.push((if self.inherited(t, j) { 2 } else { 1 }, i, j));
                    }
                });
                hits
            })
            .collect()
    }

    /// Whether the defect pair `(i, j)` still crosses in `shell`: skin items `i` and
    /// `j` for a self pair, skin item `i` and base triangle `j` otherwise (the tests
    /// [`find`](Self::find) applies away from a shared vertex; `false` for the pairs
    /// only [`find_star`](Self::find_star) tests).
    pub fn pair_crosses(&self, mesh: &Mesh, shell: &Shell, self_pair: bool, i: u32, j: u32) -> bool {
        let mine = || self.skin_tri(mesh, shell, i);
        match self_pair {
            true => self.skins_cross(shell, i, mine, j, || self.skin_tri(mesh, shell, j)),
            false => self.skin_crosses_base(mesh, shell, i, &Prepared::new(&mine()), j),
        }
    }

    /// The vertices of every defect, sorted, each once.
    pub fn defect_vertex_list(&self, f: &Findings) -> Vec<u32> {
        let mut bad = Vec::new();
        for &(i, j) in &f.self_pairs {
            bad.extend(self.item_vertices(i));
            bad.extend(self.item_vertices(j));
        }
        for &(i, _) in &f.base_pairs {
            bad.extend(self.item_vertices(i));
        }
        for &c in f.inverted.iter().chain(&f.enclosing) {
            bad.extend(self.cells[c as usize].base());
        }
        bad.sort_unstable();
        bad.dedup();
        bad
    }
}

/// Whether wall triangle `half` crosses base triangle `base` around the wall's end
/// whose layer points are `ends` and base point `x`: an envelope's wall holds `x` on
/// its edge between `ends` (the base offset runs along the director), so a half with
/// that edge is split at `x` and meets `base` there only (not where rounding puts
/// the edge a hair beside `x`); any other half is tested whole.
pub(crate) fn through_base_point(half: &[DVec3; 3], ends: [DVec3; 2], x: DVec3, base: &[DVec3; 3]) -> bool {
    match ends.map(|e| half.iter().position(|&q| q == e)) {
        [Some(k0), Some(k1)] if k0 != k1 && !ends.contains(&x) => {
            let o = half[3 - k0 - k1];
            triangles_intersect(&[ends[0], o, x], base) || triangles_intersect(&[x, o, ends[1]], base)
        }
        _ => triangles_intersect(half, base),
    }
}

/// A search's test of tree boxes for query triangle `mine`: they overlap its box
/// and straddle its plane ([`Prepared::box_straddles`]); a box that fails holds no
/// triangle crossing `mine`, nor does a node above only such boxes.
fn near(mine: &Prepared) -> impl Fn(DVec3, DVec3) -> bool + '_ {
    let (lo, hi) = tri_box(mine.corners());
    move |l: DVec3, h: DVec3| !(l.cmpgt(hi).any() || h.cmplt(lo).any()) && mine.box_straddles(l, h)
}

/// Whether the boxes of segment `p q` and of triangle `t` meet, as closed intervals
/// ([`Checker::find_star`]'s prefilter). Exact: min and max do not round, and a point
/// where the segment crosses the triangle lies in both boxes, so no crossing is
/// skipped, also where the boxes only touch (at a shared corner).
#[inline]
fn boxes_meet(p: DVec3, q: DVec3, t: &[DVec3; 3]) -> bool {
    let (lo, hi) = tri_box(t);
    p.min(q).cmple(hi).all() && p.max(q).cmpge(lo).all()
}

fn shares(a: &[u32], b: &[u32]) -> bool {
    a.iter().any(|v| b.contains(v))
}

/// The side walls over `mesh`'s boundary edges, each owned by the triangle of the
/// mesh's triangulation (the first `mesh_tris` of `tris`) holding its edge, sorted by
/// owner, and where each of `tris` has its walls begin.
fn side_walls(mesh: &Mesh, tris: &[[u32; 3]], mesh_tris: usize, tris_around: &Incidence) -> (Vec<Wall>, Vec<u32>) {
    let mut walls: Vec<Wall> = crate::mesh::boundary_edges(mesh)
        .into_iter()
        .filter_map(|(a, b)| {
            let tri = tris_around.of(a as usize).iter().copied().find(|&t| (t as usize) < mesh_tris && tris[t as usize].contains(&b))?;
            Some(Wall { ends: [a, b], tri })
        })
        .collect();
    walls.sort_by_key(|w| (w.tri, w.ends));
    let mut start = vec![0u32; tris.len() + 1];
    walls.iter().for_each(|w| start[w.tri as usize + 1] += 1);
    (0..tris.len()).for_each(|t| start[t + 1] += start[t]);
    (walls, start)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hard_meshes;
    use crate::shell::{build_shell, ShellParams, Thickness};
    use crate::testmeshes;
    use glam::Vec3;

    /// An envelope wall's half holding its end's base point `x` on its edge between
    /// the end's layer points meets a base triangle through `x` at `x` only, also
    /// where rounding puts the edge a hair beside `x` (the whole half would cross
    /// it there); a base triangle the wall really passes through is found, and a
    /// half without that edge is tested whole.
    #[test]
    fn through_base_point_meets_the_base_at_its_point_only() {
        use crate::shell::intersect::triangles_intersect;
        let d = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
        let x = d(0.0, 0.0, 0.0);
        // The wall lies in the plane y = 0; its edge from z = -1 to z = 1 passes
        // 5e-10 to the side of x, into the base triangle below, which has x as a
        // corner and otherwise lies at x < 0 in the plane z = 0.
        let ends = [d(0.0, 0.0, -1.0), d(-1e-9, 0.0, 1.0)];
        let half = [ends[0], d(1.0, 0.0, 0.0), ends[1]];
        let touching = [x, d(-1.0, -1.0, 0.0), d(-1.0, 1.0, 0.0)];
        assert!(triangles_intersect(&half, &touching), "the whole half crosses the base a hair beside x");
        assert!(!through_base_point(&half, ends, x, &touching));
        // A base triangle the wall passes through, away from x (at z = 0.5).
        let through = [d(0.9, -1.0, 0.5), d(0.9, 1.0, 0.5), d(-0.5, 0.0, 0.5)];
        assert!(through_base_point(&half, ends, x, &through));
        // A half without the edge between the ends is tested whole: it crosses
        // `through` (at z = 0.5, x from 0.375 to 0.75) and misses `touching`.
        let other = [ends[0], d(1.0, 0.0, 0.0), d(0.5, 0.0, 1.0)];
        assert!(through_base_point(&other, ends, x, &through) && !through_base_point(&other, ends, x, &touching));
    }

    /// Two icospheres that pass through each other: a base that crosses itself.
    fn overlapping_spheres() -> Mesh {
        let a = testmeshes::icosphere(3);
        let n = a.vertex_count() as u32;
        let mut positions = a.positions().to_vec();
        positions.extend(a.positions().iter().map(|p| *p + glam::Vec3::new(0.7, 0.2, 0.1)));
        let mut corners = a.corners().to_vec();
        corners.extend(a.corners().iter().map(|c| c + n));
        let sizes = [a.face_sizes(), a.face_sizes()].concat();
        Mesh::new(positions, &sizes, corners, None).unwrap()
    }

    /// The whole-shell search (two tree joins), and the joins keeping the pairs of
    /// flagged triangles, find exactly the pairs that one query per (flagged) skin
    /// triangle finds, on traced shells left folded (no repair), on quads
    /// (both splits), on a base that crosses itself (inherited pairs) and on both
    /// skins of an envelope; the base's own crossings agree with one query per
    /// triangle.
    #[test]
    fn joined_search_matches_one_query_per_triangle() {
        let unrepaired = ShellParams { repair_rounds: 0, ..ShellParams::default() };
        let cases = [
            ("comb", testmeshes::comb(2), Side::Exterior, 0.2),
            ("torus knot", hard_meshes::torus_knot(), Side::Exterior, 0.2),
            ("crossing cards", hard_meshes::cards(300, 3), Side::Envelope, 0.05),
            ("overlapping spheres", overlapping_spheres(), Side::Exterior, 0.1),
            ("hand", hard_meshes::hand(), Side::Interior, 0.1),
        ];
        let (mut self_pairs, mut inherited) = (0, 0);
        for (name, mesh, side, fraction) in cases {
            let t = Thickness::relative(fraction).per_vertex(&mesh, None).unwrap();
            let shell = build_shell(&mesh, &t, side, &unrepaired).unwrap();
            let checker = Checker::new(&mesh);
            let own: Vec<bool> = (0..checker.tris.len() as u32).map(|t| !checker.crossing_bases(t).is_empty()).collect();
            assert_eq!(checker.own, own, "{name}: base crossings");
            let mut crossings: Vec<(u32, u32)> =
                (0..checker.tris.len() as u32).flat_map(|t| checker.crossing_bases(t).into_iter().map(move |u| (t, u))).collect();
            crossings.sort_unstable();
            assert_eq!(checker.crossings, crossings, "{name}: crossing pairs");
            let tree = checker.outer_tree(&mesh, &shell, None);
            let ordered = |(i, j): (u32, u32)| (i.min(j), i.max(j));
            let sorted = |f: Findings| {
                let mut f = f;
                f.self_pairs = f.self_pairs.into_iter().map(ordered).collect();
                f.self_pairs.sort_unstable();
                f.base_pairs.sort_unstable();
                (f.self_pairs, f.base_pairs, f.inverted, f.inherited)
            };
            // Everything, most triangles flagged (a join keeping the flagged pairs),
            // and few (one query each): against one query per flagged triangle.
            let n = mesh.vertex_count();
            let flagged = |every: usize| {
                let mut d = checker.clean();
                checker.mark_anew((0..n as u32).filter(|v| (*v as usize).is_multiple_of(every)), &mut d);
                d
            };
            let (most, few) = (flagged(3), flagged(40));
            assert!(most.tri_list.len() * JOIN_SHARE >= checker.tris.len() && few.tri_list.len() * JOIN_SHARE < checker.tris.len(), "{name}");
            for dirty in [None, Some(&most), Some(&few)] {
                let what = format!("{name}, {:?} flagged", dirty.map(|d| d.tri_list.len()));
                let joined = sorted(checker.find(&mesh, &shell, dirty, Some(&tree)));
                // The pairs meeting at one vertex are found apart ([`Checker::find_star`]).
                let mut hits = checker.find_around(&mesh, &shell, dirty, Some(&tree));
                hits.extend(checker.find_star(&mesh, &shell, dirty, true));
                let pairs = |k: u8| {
                    let mut p: Vec<(u32, u32)> = hits.iter().filter(|h| h.0 == k).map(|h| if k == 0 { ordered((h.1, h.2)) } else { (h.1, h.2) }).collect();
                    p.sort_unstable();
                    p
                };
                assert_eq!(joined.0, pairs(0), "{what}: skin pairs");
                assert_eq!(joined.1, pairs(1), "{what}: skin/base pairs");
                assert_eq!(joined.3, hits.iter().filter(|h| h.0 == 2).count(), "{what}: inherited pairs");
                if dirty.is_none() {
                    self_pairs += joined.0.len() + joined.1.len();
                    inherited += joined.3;
                }
            }
            // The whole-shell join's pairs with a flagged skin triangle (either one of
            // a skin pair): for the few flagged (queried one by one) a reference on the
            // other path; for the most (the same join, filtered) a check of the filter.
            // Skin and base pairs only: `find` counts inherited pairs, unflagged.
            let all = sorted(checker.find(&mesh, &shell, None, Some(&tree)));
            for dirty in [&few, &most] {
                let flagged = |i: u32| dirty.tris[checker.item_tri(i) as usize];
                let keep_skin: Vec<(u32, u32)> = all.0.iter().copied().filter(|&(i, j)| flagged(i) || flagged(j)).collect();
                let keep_base: Vec<(u32, u32)> = all.1.iter().copied().filter(|&(i, _)| flagged(i)).collect();
                let (skin, base, _, _) = sorted(checker.find(&mesh, &shell, Some(dirty), Some(&tree)));
                let what = format!("{name}, {} flagged, against the whole join", dirty.tri_list.len());
                assert_eq!(skin, keep_skin, "{what}: skin pairs");
                assert_eq!(base, keep_base, "{what}: skin/base pairs");
            }
        }
        assert!(self_pairs > 100 && inherited > 0, "the shells must fold and the cards cross: {self_pairs}, {inherited}");
    }
    /// Two tubes (long ellipsoids) crossing like a plus sign: a base that crosses
    /// itself along two loops, with room around them for thick shells.
    fn crossing_tubes() -> Mesh {
        let s = testmeshes::icosphere(3);
        let n = s.vertex_count() as u32;
        let mut p: Vec<Vec3> = s.positions().iter().map(|q| *q * Vec3::new(1.0, 0.25, 0.25)).collect();
        p.extend(s.positions().iter().map(|q| *q * Vec3::new(0.25, 1.0, 0.25) + Vec3::new(0.1, 0.0, 0.05)));
        let tris = s.triangulate().triangles;
        let all: Vec<[u32; 3]> = tris.iter().copied().chain(tris.iter().map(|t| t.map(|v| v + n))).collect();
        Mesh::from_triangles(p, &all).unwrap()
    }

    /// Crossings of a shell's skins with each other and with the base whose two base
    /// triangles do not cross each other, found by testing every pair of triangles
    /// of a triangle mesh that share no vertex (independent of the checker's trees
    /// and of its rule), and how far the base triangle of such a pair farthest from
    /// the base's crossings is from the nearest one (a share of the diagonal).
    fn new_crossings(mesh: &Mesh, shell: &Shell) -> (usize, f64) {
        let p = mesh.positions();
        let tris = mesh.triangulate().triangles;
        let layers = skins(shell.side);
        let at = |t: &[u32; 3], r: Option<f32>| t.map(|v| r.map_or(p[v as usize], |r| shell.point(p, v as usize, r)).as_dvec3());
        let boxes: Vec<(DVec3, DVec3)> = tris
            .iter()
            .map(|t| {
                let all = layers.iter().map(|&r| at(t, Some(r))).chain([at(t, None)]).flatten();
                all.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), q| (lo.min(q), hi.max(q)))
            })
            .collect();
        let crossing = |t: usize, u: usize| !shares(&tris[t], &tris[u]) && triangles_intersect(&at(&tris[t], None), &at(&tris[u], None));
        let own: Vec<usize> = (0..tris.len()).filter(|&t| (0..tris.len()).any(|u| crossing(t, u))).collect();
        let centre = |t: usize| at(&tris[t], None).iter().sum::<DVec3>() / 3.0;
        let (mut count, mut farthest) = (0, 0.0f64);
        for t in 0..tris.len() {
            for u in t + 1..tris.len() {
                let ((lo, hi), (lo2, hi2)) = (boxes[t], boxes[u]);
                if shares(&tris[t], &tris[u]) || lo.cmpgt(hi2).any() || lo2.cmpgt(hi).any() || crossing(t, u) {
                    continue;
                }
                let mut skin_pairs = layers.iter().flat_map(|&r| layers.iter().map(move |&s| (Some(r), Some(s))));
                let with_base = layers.iter().flat_map(|&r| [(Some(r), None), (None, Some(r))]);
                if skin_pairs.any(|(r, s)| triangles_intersect(&at(&tris[t], r), &at(&tris[u], s)))
                    || with_base.clone().any(|(r, s)| triangles_intersect(&at(&tris[t], r), &at(&tris[u], s)))
                {
                    count += 1;
                    let away = |a: usize| own.iter().map(|&o| centre(o).distance(centre(a))).fold(f64::INFINITY, f64::min);
                    farthest = farthest.max(away(t).max(away(u)));
                }
            }
        }
        (count, farthest / mesh.bbox_diagonal() as f64)
    }

    /// Reviewer's M1: beside a base's own crossings the repair presses bands of
    /// vertices flat, and the restore tried only the whole target (or 96% of it),
    /// which no vertex on a crossing face reaches there (its lifted skin crosses the
    /// base's neighbouring triangles, a new crossing under the strict rule). The
    /// restore now also tries shares of the target, down to 3%: at most a tenth of
    /// the vertices left below 3% could be lifted to it alone, along their own
    /// direction (the normal where flat), without a defect. Before, on the crossing
    /// tubes at exterior 10%, 92 of 193 could (now 5 of 108). Envelopes are left
    /// out: 22 of 160 still could.
    #[test]
    fn few_vertices_beside_a_base_crossing_stay_flat_where_a_share_of_their_target_fits() {
        let mesh = crossing_tubes();
        let checker = Checker::new(&mesh);
        let normals = crate::mesh::vertex_normals(&mesh);
        let share = crate::shell::restore::PARTIAL[0];
        for (fraction, side) in crate::shell::tests::HARD_CASES.into_iter().filter(|c| c.1 != Side::Envelope) {
            let t = Thickness::relative(fraction).per_vertex(&mesh, None).unwrap();
            let shell = build_shell(&mesh, &t, side, &ShellParams::default()).unwrap();
            let tree = checker.outer_tree(&mesh, &shell, None);
            let short: Vec<usize> = (0..mesh.vertex_count()).filter(|&v| shell.achieved[v] < share * shell.target[v] && normals[v] != Vec3::ZERO).collect();
            let fits = |v: usize| {
                let mut lifted = shell.clone();
                let length = share * shell.target[v];
                (lifted.base_offset[v], lifted.directors[v]) = match shell.achieved[v] > 0.0 {
                    true => (shell.base_offset[v] * (length / shell.achieved[v]), shell.directors[v] * (length / shell.achieved[v])),
                    false => crate::shell::report::normal_shape(side, normals[v] * length),
                };
                lifted.achieved[v] = lifted.directors[v].length();
                let (mut tree, mut dirty) = (tree.clone(), checker.clean());
                checker.mark_around(v, &mut dirty);
                checker.refit_outer(&mesh, &lifted, &mut tree, &dirty.tri_list);
                checker.find(&mesh, &lifted, Some(&dirty), Some(&tree)).is_clean()
            };
            let liftable: Vec<usize> = short.iter().copied().filter(|&v| fits(v)).collect();
            let what =
                format!("{side:?} {fraction}: {} of {} vertices below {share} of their target fit there alone: {liftable:?}", liftable.len(), short.len());
            eprintln!("{what}");
            assert!(shell.check.clean && !short.is_empty(), "{what}");
            assert!(liftable.len() * 10 <= short.len(), "{what}");
        }
    }

    /// Issue 14: a base that crosses itself gets no new crossings. Pressed flat, a
    /// shell has exactly the base's crossing pairs; every other crossing is new, even
    /// one of a skin triangle over a face that crosses the base elsewhere (the rule
    /// that let any pair with such a face pass left crossings a few percent of the
    /// diagonal away from the base's). Counted by brute force over every pair of
    /// triangles, on every side and thickness.
    #[test]
    fn a_self_crossing_base_gets_no_crossing_pair_its_base_triangles_lack() {
        let mesh = crossing_tubes();
        let checker = Checker::new(&mesh);
        assert!(checker.base_self_pairs() > 0, "the tubes must cross");
        for (fraction, side) in crate::shell::tests::HARD_CASES {
            let t = Thickness::relative(fraction).per_vertex(&mesh, None).unwrap();
            let shell = build_shell(&mesh, &t, side, &ShellParams::default()).unwrap();
            let r = crate::shell::report::shell_report(&mesh, &shell);
            let (new, away) = new_crossings(&mesh, &shell);
            let what = format!("{side:?} {fraction}: {new} new crossing pairs, up to {away:.4} of the diagonal from the base's; {r:?}");
            eprintln!("{what}");
            assert_eq!(new, 0, "{what}");
            assert!(shell.check.clean && r.inherited_intersections > 0, "{what}");
            assert_eq!((r.outer_self_intersections, r.outer_base_intersections, r.inverted_cells), (0, 0, 0), "{what}");
        }
    }
}
