//! The dual polygonizer against independent references: the closed 2-manifold
//! contract ([`SurfaceCheck`]) and the Euler characteristic of known shapes, the
//! field's own distance `|f| / |∇f|` for vertex placement, the true corners and
//! creases of a box and a lens against the grid mesher's at the same resolution, a
//! triangle-triangle test for self-intersections, and other thread counts.

use super::*;
use crate::implicit::{FieldTree, ATTRIBUTE_COUNT, ATTRIBUTE_ID, ATTRIBUTE_TEXTURE};
use crate::polygonize::{mesh_field, GridParams, SurfaceCheck};
use crate::shell::intersect::{point_triangle_distance2, triangles_meet};
use crate::spatial::{tri_box, Bvh};
use crate::test_rng::Rng;
use glam::DVec3;

fn tree(json: &str) -> FieldTree {
    FieldTree::from_json(json).unwrap_or_else(|e| panic!("{e}: {json}"))
}

/// The tree's own bound grown by `cells` cells each side.
fn around(t: &FieldTree, resolution: u32, cells: f32) -> (Vec3, Vec3) {
    let (lo, hi) = t.bounds().expect("bounded");
    let margin = cells * (hi - lo).max_element() / resolution as f32;
    (lo - margin, hi + margin)
}

fn mesh(t: &FieldTree, bounds: (Vec3, Vec3), resolution: u32) -> DualMesh {
    mesh_dual(t, &DualParams { bounds, resolution }).unwrap()
}

fn cell(m: &DualMesh, bounds: (Vec3, Vec3)) -> f64 {
    ((bounds.1 - bounds.0) / m.cells.as_vec3()).max_element() as f64
}

/// Asserts every vertex lies within half a cell of the zero set, measured as `|f| / |∇f|`.
fn assert_near_zero_set(t: &FieldTree, m: &DualMesh, bounds: (Vec3, Vec3), what: &str) {
    let cell = cell(m, bounds);
    for p in &m.positions {
        let s = t.sample(p.as_dvec3());
        let d = s.value.abs() / s.gradient.length().max(1e-9);
        assert!(d < 0.5 * cell, "{what}: vertex {p} is {d} from the zero set (cell {cell})");
    }
}

/// Triangle pairs without a shared vertex that touch or cross.
fn self_intersections(positions: &[Vec3], triangles: &[[u32; 3]]) -> usize {
    let tris: Vec<[DVec3; 3]> = triangles.iter().map(|t| t.map(|v| positions[v as usize].as_dvec3())).collect();
    let bvh = Bvh::from_boxes(tris.iter().map(tri_box).collect());
    let pairs = bvh.overlapping_pairs(&|i, j| {
        let (a, b) = (triangles[i as usize], triangles[j as usize]);
        !a.iter().any(|v| b.contains(v)) && triangles_meet(&tris[i as usize], &tris[j as usize], 0.0)
    });
    pairs.len()
}

#[test]
fn a_sphere_and_a_torus_are_closed_manifolds_of_their_genus_on_their_zero_set() {
    for (json, euler) in [
        (r#"{"op": "sphere", "center": [0.03, -0.02, 0.01], "radius": 0.7}"#, 2),
        (r#"{"op": "torus", "center": [0.01, 0.02, -0.03], "axis": [0.2, 1, 0.3], "major": 0.6, "minor": 0.22}"#, 0),
    ] {
        let t = tree(json);
        for resolution in [16, 40] {
            let bounds = around(&t, resolution, 2.0);
            let m = mesh(&t, bounds, resolution);
            let check = SurfaceCheck::of(&m.positions, &m.triangles());
            assert!(check.is_closed_manifold(), "{json} at {resolution}: {check:?}");
            assert_eq!((check.components, check.euler_characteristic), (1, euler), "{json} at {resolution}: {check:?}");
            assert_near_zero_set(&t, &m, bounds, json);
            assert_eq!(self_intersections(&m.positions, &m.triangles()), 0, "{json} at {resolution}");
            // Normals are the unit gradient: outward on the sphere.
            for (p, n) in m.positions.iter().zip(&m.normals) {
                let g = t.sample(p.as_dvec3()).gradient.normalize().as_vec3();
                assert!((*n - g).length() < 1e-4, "{n} vs {g}");
            }
        }
    }
}

/// The largest distance from `targets` to the nearest of `positions`.
fn farthest_from_vertices(targets: &[Vec3], positions: &[Vec3]) -> f32 {
    targets.iter().map(|c| positions.iter().map(|p| p.distance(*c)).fold(f32::MAX, f32::min)).fold(0.0, f32::max)
}

/// The largest distance from `targets` to the surface of the triangles.
fn farthest_from_surface(targets: &[Vec3], positions: &[Vec3], triangles: &[[u32; 3]]) -> f64 {
    let tris: Vec<[DVec3; 3]> = triangles.iter().map(|t| t.map(|v| positions[v as usize].as_dvec3())).collect();
    targets.iter().map(|c| tris.iter().map(|t| point_triangle_distance2(c.as_dvec3(), t)).fold(f64::MAX, f64::min).sqrt()).fold(0.0, f64::max)
}

#[test]
fn box_corners_and_lens_creases_stay_sharp_unlike_the_grid_mesher() {
    let resolution = 24;
    // A box off the lattice: its eight corners.
    let (c, h) = (Vec3::new(0.031, -0.017, 0.023), Vec3::new(0.53, 0.41, 0.37));
    let t = tree(&format!(r#"{{"op": "box", "center": [{}, {}, {}], "half_size": [{}, {}, {}]}}"#, c.x, c.y, c.z, h.x, h.y, h.z));
    let corners: Vec<Vec3> = (0..8).map(|k| c + h * Vec3::new([-1.0, 1.0][k & 1], [-1.0, 1.0][k >> 1 & 1], [-1.0, 1.0][k >> 2 & 1])).collect();
    let bounds = around(&t, resolution, 2.0);
    let dual = mesh(&t, bounds, resolution);
    let grid = mesh_field(&t, &GridParams { bounds, resolution, refine: true }).unwrap();
    let size = cell(&dual, bounds) as f32;
    let (d, g) = (farthest_from_vertices(&corners, &dual.positions), farthest_from_vertices(&corners, &grid.positions));
    assert!(d < 0.05 * size && d < 0.1 * g, "box corners: dual {d}, grid {g} (cell {size})");
    let check = SurfaceCheck::of(&dual.positions, &dual.triangles());
    assert!(check.is_closed_manifold() && check.euler_characteristic == 2, "{check:?}");
    assert_eq!(self_intersections(&dual.positions, &dual.triangles()), 0);
    // Two spheres intersected exactly: a lens whose rim is a circle.
    let t = tree(
        r#"{"op": "max", "children": [{"op": "sphere", "center": [-0.437, 0.01, 0.02], "radius": 0.7}, {"op": "sphere", "center": [0.463, 0.01, 0.02], "radius": 0.7}]}"#,
    );
    let r = (0.7f32 * 0.7 - 0.45 * 0.45).sqrt();
    let rim: Vec<Vec3> = (0..48).map(|k| Vec3::new(0.013, 0.01 + r * (k as f32 * 0.1309).cos(), 0.02 + r * (k as f32 * 0.1309).sin())).collect();
    // The rim's plane off the lattice's planes.
    let bounds = around(&t, resolution, 2.0);
    let bounds = (bounds.0 - Vec3::new(0.023, 0.011, 0.007), bounds.1);
    let dual = mesh(&t, bounds, resolution);
    let grid = mesh_field(&t, &GridParams { bounds, resolution, refine: true }).unwrap();
    let cell = cell(&dual, bounds);
    // The rim's distance to each mesh, mean and worst over its points: a crease that
    // crosses a cell without crossing an edge of its second sphere there is cut as
    // the grid mesher cuts it (one point in 48 here), elsewhere it is kept.
    let distances = |m: &[Vec3], t: &[[u32; 3]]| rim.iter().map(|p| farthest_from_surface(&[*p], m, t)).collect::<Vec<f64>>();
    let (d, g) = (distances(&dual.positions, &dual.triangles()), distances(&grid.positions, &grid.triangles));
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let worst = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
    assert!(mean(&d) < 0.05 * cell && mean(&d) < 0.3 * mean(&g), "lens rim, mean: dual {}, grid {} (cell {cell})", mean(&d), mean(&g));
    assert!(worst(&d) < 1.1 * worst(&g), "lens rim, worst: dual {}, grid {}", worst(&d), worst(&g));
    let check = SurfaceCheck::of(&dual.positions, &dual.triangles());
    assert!(check.is_closed_manifold() && check.euler_characteristic == 2, "{check:?}");
    assert_eq!(self_intersections(&dual.positions, &dual.triangles()), 0);
}

#[test]
fn random_trees_mesh_closed_manifold_without_self_intersections() {
    let mut rng = Rng(0xfeed_beef);
    let mut meshed = 0;
    for seed in 0..20 {
        let doc = crate::implicit::tests::random_mesh_tree(&mut rng);
        let t = tree(&doc.to_string());
        let resolution = 36;
        let bounds = around(&t, resolution, 2.5);
        let m = mesh(&t, bounds, resolution);
        let tris = m.triangles();
        let check = SurfaceCheck::of(&m.positions, &tris);
        assert!(check.is_closed_manifold(), "seed {seed}: {check:?}: {doc}");
        if m.quads.is_empty() {
            continue;
        }
        meshed += 1;
        assert_eq!(self_intersections(&m.positions, &tris), 0, "seed {seed}: {doc}");
        assert_near_zero_set(&t, &m, bounds, &format!("seed {seed}: {doc}"));
        // The attributes are the field's own at each vertex.
        assert_eq!(m.attribute_count, ATTRIBUTE_COUNT);
        let e = t.evaluate(&m.positions);
        for (i, a) in m.attributes.chunks_exact(ATTRIBUTE_COUNT).enumerate() {
            assert_eq!(&a[..4], &e.colors[i][..]);
            assert_eq!(a[ATTRIBUTE_TEXTURE], e.textures[i]);
            assert_eq!(a[ATTRIBUTE_ID] as u32, e.ids[i]);
        }
    }
    assert!(meshed >= 18, "{meshed} of 20 trees had a surface");
}

#[test]
fn a_solid_cut_by_the_box_is_closed_on_its_faces() {
    let t = tree(r#"{"op": "sphere", "center": [0, 0, 0], "radius": 1.0}"#);
    let bounds = (Vec3::new(-0.6, -0.5, -2.0), Vec3::new(0.7, 0.55, 0.2));
    let m = mesh(&t, bounds, 20);
    let check = SurfaceCheck::of(&m.positions, &m.triangles());
    assert!(check.is_closed_manifold() && check.euler_characteristic == 2, "{check:?}");
    assert_eq!(self_intersections(&m.positions, &m.triangles()), 0);
    // The box's corner inside the sphere is kept sharp.
    let corner = Vec3::new(0.7, 0.55, 0.2);
    let d = farthest_from_vertices(&[corner], &m.positions);
    assert!(d < 1e-3, "{d}");
}

#[test]
fn the_output_does_not_depend_on_the_number_of_threads() {
    let mut rng = Rng(0x5eed);
    let doc = crate::implicit::tests::random_mesh_tree(&mut rng);
    let t = tree(&doc.to_string());
    let bounds = around(&t, 48, 2.0);
    let run = |threads: usize| rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(|| mesh(&t, bounds, 48));
    let (a, b) = (run(1), run(3));
    assert!(!a.quads.is_empty());
    assert_eq!(a.quads, b.quads);
    assert!(a.positions.iter().zip(&b.positions).all(|(p, q)| p.to_array().map(f32::to_bits) == q.to_array().map(f32::to_bits)));
    assert_eq!(a.positions.len(), b.positions.len());
    assert!(a.attributes.iter().map(|v| v.to_bits()).eq(b.attributes.iter().map(|v| v.to_bits())));
}

/// A sphere that is not a number on one side.
struct Broken;
impl ScalarField for Broken {
    fn values(&self, points: &[Vec3], out: &mut [f32]) {
        for (o, p) in out.iter_mut().zip(points) {
            *o = if p.x > 0.3 { f32::NAN } else { p.length() - 0.5 };
        }
    }
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let sphere = tree(r#"{"op": "sphere", "center": [0, 0, 0], "radius": 0.5}"#);
    let ok = (Vec3::splat(-1.0), Vec3::splat(1.0));
    assert!(mesh_dual(&Broken, &DualParams { bounds: ok, resolution: 16 }).is_err());
    assert!(mesh_dual(&sphere, &DualParams { bounds: (Vec3::ONE, Vec3::ONE), resolution: 16 }).is_err());
    assert!(mesh_dual(&sphere, &DualParams { bounds: (Vec3::ONE, -Vec3::ONE), resolution: 16 }).is_err());
    assert!(mesh_dual(&sphere, &DualParams { bounds: (Vec3::splat(f32::NAN), Vec3::ONE), resolution: 16 }).is_err());
    for resolution in [0, 1, 100_000] {
        assert!(mesh_dual(&sphere, &DualParams { bounds: ok, resolution }).is_err(), "{resolution}");
    }
    // A field that cannot bound itself is meshed without culling.
    let m = mesh_dual(&crate::polygonize::grid::Unculled(&sphere), &DualParams { bounds: ok, resolution: 16 }).unwrap();
    assert!(SurfaceCheck::of(&m.positions, &m.triangles()).is_closed_manifold());
    assert_eq!(m.quads, mesh(&sphere, ok, 16).quads);
}

/// A batch's shared samples ([`block::Shared`], each lattice point evaluated once)
/// against each block sampled alone ([`block::Samples::of`]): the same points, lattice
/// coordinates and cut values, bit for bit, on every live block of issue 17's tree
/// (batches of a few blocks, all at once, and two far apart: listed on a dense grid
/// and sorted).
#[test]
fn shared_samples_match_each_block_sampled_alone() {
    let t = tree(crate::implicit::samples::SOFT_CSG_20);
    let bounds = around(&t, 48, 2.0);
    let lattice = lattice::Lattice::new(bounds, 48).unwrap();
    let live = octree::live_blocks(&t, &lattice, &crate::polygonize::estimate::Watch::default()).unwrap();
    assert!(live.len() > 50, "{} live blocks", live.len());
    let origins: Vec<UVec3> = live.iter().map(|&b| b * BLOCK).collect();
    let apart = [origins[0], origins[origins.len() - 1]];
    let mut modes = Vec::new();
    let mut proven = 0;
    for batch in [&origins[..], &origins[..7], &origins[origins.len() - 5..], &apart[..]] {
        let shared = block::Shared::of(&t, &lattice, batch).unwrap();
        modes.push(shared.is_dense());
        let mut total = 0;
        for &o in batch {
            let (a, b) = (block::Samples::of(&t, &lattice, o).unwrap(), block::Samples::from_shared(&lattice, o, &shared));
            assert_eq!((a.size, a.values.len()), (b.size, b.values.len()), "block at {o}");
            // Sampled points bit for bit; the others, decided by the Lipschitz bound,
            // on the same side.
            let n = a.size + 1;
            let at = (0..n.z).flat_map(|z| (0..n.y).flat_map(move |y| (0..n.x).map(move |x| o + UVec3::new(x, y, z))));
            for ((x, y), g) in a.values.iter().zip(&b.values).zip(at) {
                if shared.proven(g) {
                    proven += 1;
                    assert_eq!(*x <= 0.0, *y <= 0.0, "block at {o}, point {g}: {x} against {y}");
                } else {
                    assert_eq!(x.to_bits(), y.to_bits(), "block at {o}, point {g}: values differ");
                }
            }
            total += a.values.len();
        }
        // Neighbours share their faces' points: fewer evaluated than sampled alone.
        assert!(shared.evaluated() <= total && (batch.len() < 8 || shared.evaluated() < total), "{} of {total}", shared.evaluated());
    }
    // Both listings met: the small batches dense, the two far apart sorted.
    assert_eq!(&modes[1..], &[true, true, false], "{modes:?}");
    assert!(proven > 1000, "{proven} points decided without sampling");
}

/// A field tree without its Lipschitz bound (the interval bound kept).
struct NoSlope<'a>(&'a FieldTree);
impl ScalarField for NoSlope<'_> {
    fn values(&self, points: &[Vec3], out: &mut [f32]) {
        self.0.values(points, out);
    }
    fn gradients(&self, points: &[Vec3], out: &mut [Vec3]) {
        self.0.gradients(points, out);
    }
    fn attribute_count(&self) -> usize {
        self.0.attribute_count()
    }
    fn attributes(&self, points: &[Vec3], out: &mut [f32]) {
        self.0.attributes(points, out);
    }
    fn interval(&self, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
        ScalarField::interval(self.0, lo, hi)
    }
}

fn same_bits(a: &DualMesh, b: &DualMesh) -> bool {
    let bits = |m: &DualMesh| {
        m.positions.iter().chain(&m.normals).flat_map(|v| v.to_array()).chain(m.attributes.iter().copied()).map(f32::to_bits).collect::<Vec<_>>()
    };
    a.quads == b.quads && bits(a) == bits(b)
}

/// The Lipschitz bound's proofs (in the descent and the sampling) and the crossings
/// refined once per batch change no bit of the mesh: the same trees meshed by the
/// interval bound alone, and with no bound at all (every point of the lattice
/// sampled), on issue 17's tree and 12 random trees; with fewer evaluations.
#[test]
fn lipschitz_proofs_change_no_bit_of_the_mesh_and_save_samples() {
    let mut rng = Rng(0x11b5);
    let mut docs = vec![crate::implicit::samples::SOFT_CSG_20.to_string()];
    docs.extend((0..12).map(|_| crate::implicit::tests::random_mesh_tree(&mut rng).to_string()));
    let mut meshed = 0;
    for doc in &docs {
        let t = tree(doc);
        let resolution = 40;
        let bounds = around(&t, resolution, 2.5);
        let params = DualParams { bounds, resolution };
        let proven = mesh_dual(&t, &params).unwrap();
        let interval = mesh_dual(&NoSlope(&t), &params).unwrap();
        let dense = mesh_dual(&crate::polygonize::grid::Unculled(&t), &params).unwrap();
        assert!(same_bits(&proven, &interval) && same_bits(&proven, &dense), "{doc}");
        if proven.quads.is_empty() {
            continue;
        }
        meshed += 1;
        assert!(proven.profile.evaluations < interval.profile.evaluations, "{} against {}: {doc}", proven.profile.evaluations, interval.profile.evaluations);
    }
    assert!(meshed >= 10, "{meshed} of {} trees had a surface", docs.len());
}
