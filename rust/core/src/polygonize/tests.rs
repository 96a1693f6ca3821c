//! A new scalar field meshed by writing only its sampler: analytic shapes through the
//! grid lattice, checked against their own math (distance of every vertex to the zero
//! set, normals, enclosed volume, topology) and against the closed 2-manifold contract.

use super::*;
use crate::field::ScalarField;
use glam::{Vec2, Vec3};

struct Sphere {
    center: Vec3,
    radius: f32,
}

impl ScalarField for Sphere {
    fn values(&self, points: &[Vec3], out: &mut [f32]) {
        for (o, p) in out.iter_mut().zip(points) {
            *o = (*p - self.center).length() - self.radius;
        }
    }
    fn gradients(&self, points: &[Vec3], out: &mut [Vec3]) {
        for (o, p) in out.iter_mut().zip(points) {
            *o = (*p - self.center).normalize_or_zero();
        }
    }
}

/// A torus around z: major radius `major`, tube radius `minor`.
struct Torus {
    major: f32,
    minor: f32,
}

impl ScalarField for Torus {
    fn values(&self, points: &[Vec3], out: &mut [f32]) {
        for (o, p) in out.iter_mut().zip(points) {
            *o = Vec2::new(p.truncate().length() - self.major, p.z).length() - self.minor;
        }
    }
    // No gradient given: the default central differences serve.
}

/// A hard union (min) of spheres: creases where they meet, several pieces.
struct Spheres(Vec<Sphere>);

impl ScalarField for Spheres {
    fn values(&self, points: &[Vec3], out: &mut [f32]) {
        for (o, p) in out.iter_mut().zip(points) {
            *o = self.0.iter().map(|s| (*p - s.center).length() - s.radius).fold(f32::INFINITY, f32::min);
        }
    }
    fn attribute_count(&self) -> usize {
        1
    }
    /// The index of the nearest sphere (a primitive id, carried to the vertices).
    fn attributes(&self, points: &[Vec3], out: &mut [f32]) {
        for (o, p) in out.iter_mut().zip(points) {
            let d = |s: &Sphere| (*p - s.center).length() - s.radius;
            *o = (0..self.0.len()).min_by(|&a, &b| d(&self.0[a]).total_cmp(&d(&self.0[b]))).unwrap() as f32;
        }
    }
}

fn cube(half: f32) -> (Vec3, Vec3) {
    (Vec3::splat(-half), Vec3::splat(half))
}

fn signed_volume(m: &FieldMesh) -> f64 {
    m.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| m.positions[v as usize].as_dvec3());
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

/// The largest `|f| / |∇f|` (a first-order distance to the zero set) over the vertices.
fn worst_distance<F: ScalarField>(field: &F, m: &FieldMesh) -> f32 {
    let mut values = vec![0.0; m.positions.len()];
    let mut grads = vec![Vec3::ZERO; m.positions.len()];
    field.values(&m.positions, &mut values);
    field.gradients(&m.positions, &mut grads);
    values.iter().zip(&grads).map(|(v, g)| v.abs() / g.length().max(1e-6)).fold(0.0, f32::max)
}

/// Unit normals, and every triangle faces the way its corners' normals point.
fn assert_faces_follow_normals(m: &FieldMesh) {
    assert!(m.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-4), "normals are unit vectors");
    let against = m
        .triangles
        .iter()
        .filter(|t| {
            let [a, b, c] = t.map(|v| m.positions[v as usize]);
            let n = t.iter().map(|&v| m.normals[v as usize]).sum::<Vec3>();
            (b - a).cross(c - a).dot(n) <= 0.0
        })
        .count();
    assert_eq!(against, 0, "of {} triangles", m.triangles.len());
}

fn check(m: &FieldMesh) -> SurfaceCheck {
    let c = SurfaceCheck::of(&m.positions, &m.triangles);
    assert!(c.is_closed_manifold(), "{c:?}");
    c
}

#[test]
fn a_sphere_meshes_closed_on_its_zero_set_with_its_volume_and_normals() {
    let sphere = Sphere { center: Vec3::new(0.1, -0.05, 0.02), radius: 1.0 };
    for resolution in [8, 24, 64] {
        let m = mesh_field(&sphere, &GridParams { bounds: cube(1.3), resolution, refine: true }).unwrap();
        let c = check(&m);
        assert_eq!((c.components, c.euler_characteristic), (1, 2), "resolution {resolution}");
        let cell = 2.6 / resolution as f32;
        // Iso-vertices stay OFF_ISO of an edge (up to a cell's diagonal) from its ends.
        let worst = worst_distance(&sphere, &m);
        assert!(worst < 0.02 * cell, "resolution {resolution}: a vertex {worst} off the sphere ({cell} cells)");
        // Facing outward: a positive volume, converging to the ball's.
        let want = 4.0 / 3.0 * std::f64::consts::PI;
        let v = signed_volume(&m);
        assert!(v > 0.0 && (v - want).abs() < 0.6 * want * f64::from(cell * cell), "resolution {resolution}: volume {v} vs {want}");
        // Normals are the field's gradient: the radial direction.
        for (p, n) in m.positions.iter().zip(&m.normals) {
            assert!(n.dot((*p - sphere.center).normalize()) > 0.999, "normal {n} at {p}");
        }
        assert_faces_follow_normals(&m);
    }
}

#[test]
fn a_torus_meshes_as_one_closed_piece_of_genus_one_near_its_zero_set() {
    let torus = Torus { major: 0.7, minor: 0.25 };
    let bounds = (Vec3::new(-1.0, -1.0, -0.4), Vec3::new(1.0, 1.0, 0.4));
    let m = mesh_field(&torus, &GridParams { bounds, resolution: 48, refine: true }).unwrap();
    let c = check(&m);
    assert_eq!((c.components, c.euler_characteristic), (1, 0));
    let cell = 2.0 / 48.0;
    let worst = worst_distance(&torus, &m);
    assert!(worst < 0.02 * cell, "{worst} vs cell {cell}");
    let want = 2.0 * std::f64::consts::PI.powi(2) * 0.7 * 0.25f64.powi(2);
    let v = signed_volume(&m);
    assert!((v - want).abs() < 0.02 * want, "volume {v} vs {want}");
    // The cells stay near cubes on the flat box.
    assert_eq!(m.cells, glam::UVec3::new(48, 48, 20));
}

#[test]
fn refined_vertices_lie_nearer_the_zero_set_than_the_linear_guess() {
    // A thin torus on a coarse grid: the field is curved across each cell.
    let torus = Torus { major: 0.7, minor: 0.12 };
    let bounds = (Vec3::new(-1.0, -1.0, -0.3), Vec3::new(1.0, 1.0, 0.3));
    let params = |refine| GridParams { bounds, resolution: 20, refine };
    let (linear, refined) = (mesh_field(&torus, &params(false)).unwrap(), mesh_field(&torus, &params(true)).unwrap());
    check(&linear);
    check(&refined);
    let (a, b) = (worst_distance(&torus, &linear), worst_distance(&torus, &refined));
    assert!(b < 0.2 * a, "refined {b} vs linear {a}");
    assert_eq!(linear.triangles, refined.triangles, "refining moves vertices, not the connectivity");
}

#[test]
fn unions_with_creases_and_shapes_cut_by_the_box_stay_closed_manifolds() {
    // Seeded random unions of spheres, some overlapping (creases), some apart, some
    // leaving the box, at a few resolutions: the contract holds for every one.
    let mut rng = crate::test_rng::Rng(0x2545_f491);
    let mut rand = || rng.uniform() as f32;
    for seed in 0..12 {
        let spheres: Vec<Sphere> =
            (0..3 + seed % 5).map(|_| Sphere { center: Vec3::new(rand(), rand(), rand()) * 2.0 - 1.0, radius: 0.15 + 0.45 * rand() }).collect();
        let field = Spheres(spheres);
        let resolution = [9, 16, 31][seed % 3];
        let m = mesh_field(&field, &GridParams { bounds: cube(1.0), resolution, refine: true }).unwrap();
        assert!(!m.triangles.is_empty());
        check(&m);
        assert!(signed_volume(&m) > 0.0, "seed {seed}");
        // Every vertex near the zero set (creases bend the field along an edge, so the
        // crossing converges slower there), except where the box cut the surface.
        let cell = 2.0 / resolution as f32;
        let mut values = vec![0.0; m.positions.len()];
        field.values(&m.positions, &mut values);
        for (p, v) in m.positions.iter().zip(&values) {
            let near_box = p.abs().max_element() > 1.0 - 1.01 * cell;
            assert!(near_box || v.abs() < 0.1 * cell, "seed {seed}: vertex {p} at f = {v}");
        }
        // The primitive id rides along: each vertex carries its nearest sphere.
        assert_eq!((m.attribute_count, m.attributes.len()), (1, m.positions.len()));
        assert!(m.attributes.iter().all(|a| a.fract() == 0.0 && (*a as usize) < field.0.len()));
    }
}

#[test]
fn a_sphere_larger_than_the_box_is_closed_by_it_with_the_faces_normals() {
    let sphere = Sphere { center: Vec3::ZERO, radius: 1.5 };
    let m = mesh_field(&sphere, &GridParams { bounds: cube(1.0), resolution: 10, refine: true }).unwrap();
    let c = check(&m);
    assert_eq!((c.components, c.euler_characteristic), (1, 2));
    // The box cut the sphere: the cube less its corners beyond the sphere, and less
    // the chamfers along the box's edges (sampled marching keeps no sharp edge).
    let v = signed_volume(&m);
    assert!(v > 7.0 && v < 8.0, "{v}");
    assert_faces_follow_normals(&m);
    // A half-space: its cut face and the box's faces, each with its own normal.
    struct Below;
    impl ScalarField for Below {
        fn values(&self, points: &[Vec3], out: &mut [f32]) {
            for (o, p) in out.iter_mut().zip(points) {
                *o = p.z - 0.2;
            }
        }
    }
    let m = mesh_field(&Below, &GridParams { bounds: cube(1.0), resolution: 8, refine: false }).unwrap();
    check(&m);
    assert_faces_follow_normals(&m);
    // 2 x 2 x 1.2, less chamfers a cell wide along the cut's edges.
    let v = signed_volume(&m);
    assert!(v > 4.8 - 8.0 * 0.25 * 0.25 * 2.0 && v < 4.8, "{v}");
    // Away from the box the cut face is the plane z = 0.2 with normal +z.
    for (p, n) in m.positions.iter().zip(&m.normals) {
        if p.z > 0.0 && p.x.abs().max(p.y.abs()) < 0.7 {
            assert!((p.z - 0.2).abs() < 1e-5 && n.z > 0.9999, "{p} {n}");
        }
    }
    // A field inside everywhere: the box itself.
    struct Full;
    impl ScalarField for Full {
        fn values(&self, _: &[Vec3], out: &mut [f32]) {
            out.fill(-1.0);
        }
    }
    // A flat box gets at least two cells across its thin side (its faces are outside).
    let m = mesh_field(&Full, &GridParams { bounds: (Vec3::ZERO, Vec3::new(10.0, 10.0, 0.5)), resolution: 10, refine: true }).unwrap();
    assert_eq!(m.cells, glam::UVec3::new(10, 10, 2));
    let c = check(&m);
    assert_eq!((c.components, c.euler_characteristic), (1, 2));
    assert!(signed_volume(&m) > 10.0 && signed_volume(&m) < 50.0, "{}", signed_volume(&m));
    assert_faces_follow_normals(&m);
}

#[test]
fn the_contract_holds_for_extreme_values_infinities_and_zeros() {
    // A huge value outside a thin layer, meshed without refinement: vertices stay off
    // the lattice points (no degenerate triangles).
    struct Cliff;
    impl ScalarField for Cliff {
        fn values(&self, points: &[Vec3], out: &mut [f32]) {
            for (o, p) in out.iter_mut().zip(points) {
                let d = p.length() - 0.7;
                *o = if d > 0.5 {
                    f32::MAX
                } else if d > 0.05 {
                    1e6
                } else {
                    d
                };
            }
        }
    }
    for refine in [false, true] {
        check(&mesh_field(&Cliff, &GridParams { bounds: cube(1.0), resolution: 16, refine }).unwrap());
    }
    // Minus infinity is inside: a solid ball, not a hollow shell.
    struct Core;
    impl ScalarField for Core {
        fn values(&self, points: &[Vec3], out: &mut [f32]) {
            for (o, p) in out.iter_mut().zip(points) {
                *o = if p.length() < 0.4 { f32::NEG_INFINITY } else { p.length() - 0.8 };
            }
        }
    }
    let c = check(&mesh_field(&Core, &GridParams { bounds: cube(1.0), resolution: 16, refine: true }).unwrap());
    assert_eq!((c.components, c.euler_characteristic), (1, 2));
    // Zero is inside (V(f) = {f <= 0}): a ball where the field is 0.
    struct Flat;
    impl ScalarField for Flat {
        fn values(&self, points: &[Vec3], out: &mut [f32]) {
            for (o, p) in out.iter_mut().zip(points) {
                *o = (p.length() - 0.6).max(0.0);
            }
        }
    }
    let m = mesh_field(&Flat, &GridParams { bounds: cube(1.0), resolution: 16, refine: true }).unwrap();
    let c = check(&m);
    assert_eq!((c.components, c.euler_characteristic), (1, 2));
    // Every vertex on the zero set (where the field is 0 throughout, anywhere in it).
    assert!(m.positions.iter().all(|p| p.length() < 0.6 + 2.0 / 16.0), "the ball of radius 0.6, within a cell");
}

#[test]
fn the_mesh_does_not_depend_on_the_number_of_threads() {
    let torus = Torus { major: 0.7, minor: 0.25 };
    let params = GridParams { bounds: (Vec3::new(-1.0, -1.0, -0.4), Vec3::new(1.0, 1.0, 0.4)), resolution: 40, refine: true };
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| mesh_field(&torus, &params).unwrap())
    };
    let (one, three) = (run(1), run(3));
    assert_eq!(one.positions, three.positions);
    assert_eq!(one.triangles, three.triangles);
}

#[test]
fn an_empty_box_makes_nothing_and_bad_settings_are_refused() {
    let far = Sphere { center: Vec3::splat(10.0), radius: 1.0 };
    let m = mesh_field(&far, &GridParams { bounds: cube(1.0), resolution: 8, refine: true }).unwrap();
    assert!(m.triangles.is_empty() && m.positions.is_empty());
    let sphere = Sphere { center: Vec3::ZERO, radius: 1.0 };
    for bad in [
        GridParams { bounds: cube(1.0), resolution: 1, refine: true },
        GridParams { bounds: cube(1.0), resolution: grid::MAX_RESOLUTION + 1, refine: true },
        GridParams { bounds: (Vec3::ONE, Vec3::ZERO), resolution: 8, refine: true },
        GridParams { bounds: (Vec3::ZERO, Vec3::new(1.0, f32::NAN, 1.0)), resolution: 8, refine: true },
        // Cells too small to keep vertices apart in single precision so far out.
        GridParams { bounds: (Vec3::splat(1e6), Vec3::splat(1e6 + 1.0)), resolution: 16, refine: true },
    ] {
        assert!(matches!(mesh_field(&sphere, &bad), Err(crate::Error::InvalidParameter(_))), "{bad:?}");
    }
    // A field that is NaN somewhere counts as outside there and still closes, with
    // unit normals (the faces' own where the field's gradient is not a number).
    struct Holey;
    impl ScalarField for Holey {
        fn values(&self, points: &[Vec3], out: &mut [f32]) {
            for (o, p) in out.iter_mut().zip(points) {
                *o = if p.x > 0.3 { f32::NAN } else { p.length() - 0.8 };
            }
        }
    }
    let m = mesh_field(&Holey, &GridParams { bounds: cube(1.0), resolution: 16, refine: true }).unwrap();
    check(&m);
    assert!(m.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-4));
}

/// A sphere that bounds itself over boxes (the exact range of `|x - c| - r`), and
/// counts the points it is asked for.
struct BoundedSphere {
    sphere: Sphere,
    asked: std::sync::atomic::AtomicUsize,
}

impl BoundedSphere {
    fn new(center: Vec3, radius: f32) -> Self {
        Self { sphere: Sphere { center, radius }, asked: Default::default() }
    }
    fn asked(&self) -> usize {
        self.asked.swap(0, std::sync::atomic::Ordering::Relaxed)
    }
}

impl ScalarField for BoundedSphere {
    fn values(&self, points: &[Vec3], out: &mut [f32]) {
        self.asked.fetch_add(points.len(), std::sync::atomic::Ordering::Relaxed);
        self.sphere.values(points, out);
    }
    fn gradients(&self, points: &[Vec3], out: &mut [Vec3]) {
        self.sphere.gradients(points, out);
    }
    fn attribute_count(&self) -> usize {
        1
    }
    fn attributes(&self, points: &[Vec3], out: &mut [f32]) {
        for (o, p) in out.iter_mut().zip(points) {
            *o = p.x + 2.0 * p.y;
        }
    }
    fn interval(&self, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
        let c = self.sphere.center;
        let near = (c.clamp(lo, hi) - c).length();
        let far = (c - lo).abs().max((hi - c).abs()).length();
        // Rounded outward by a little: the sampled values are rounded too.
        let slack = 1e-5 * (1.0 + far);
        Some((near - self.sphere.radius - slack, far - self.sphere.radius + slack))
    }
}

#[test]
fn interval_culling_samples_less_and_meshes_the_same_bit_for_bit() {
    let same = |a: &FieldMesh, b: &FieldMesh| {
        a.positions == b.positions
            && a.triangles == b.triangles
            && a.normals == b.normals
            && a.attributes.iter().map(|v| v.to_bits()).eq(b.attributes.iter().map(|v| v.to_bits()))
    };
    // A small sphere in a large box (most of it culled outside), one through the
    // box's faces (the cut closes there), one containing the box (all inside: only
    // the cells on the faces are kept), one outside it; ragged grids (slabs and
    // culling blocks that do not divide the cells), with and without refinement.
    let cases = [
        (Vec3::new(0.1, -0.2, 0.05), 0.45, (Vec3::new(-1.0, -1.1, -0.9), Vec3::new(1.2, 1.0, 1.05)), 37, true),
        (Vec3::new(0.6, 0.0, 0.0), 0.7, cube(1.0), 29, true),
        (Vec3::new(0.6, 0.0, 0.0), 0.7, cube(1.0), 29, false),
        (Vec3::new(0.2, 0.1, 0.0), 5.0, (Vec3::splat(-1.0), Vec3::new(1.0, 0.7, 0.45)), 43, true),
        (Vec3::splat(10.0), 1.0, cube(1.0), 20, true),
    ];
    for (center, radius, bounds, resolution, refine) in cases {
        let field = BoundedSphere::new(center, radius);
        let params = GridParams { bounds, resolution, refine };
        let dense = mesh_field(&grid::Unculled(&field), &params).unwrap();
        let dense_asked = field.asked();
        let culled = mesh_field(&field, &params).unwrap();
        let culled_asked = field.asked();
        assert!(same(&dense, &culled), "{center} {radius} {bounds:?} {resolution}: {} vs {} triangles", dense.triangles.len(), culled.triangles.len());
        check(&culled);
        // Refinement and normals ask the same points either way: the lattice's
        // samples are what culling saves, at least half of them here.
        let lattice = (dense.cells + 1).element_product() as usize;
        assert!(dense_asked - culled_asked > lattice / 2, "{center} {radius}: {culled_asked} of {dense_asked} points asked, {lattice} lattice points");
    }
    // The culled share grows with the resolution: the surface's cells are fewer.
    let field = BoundedSphere::new(Vec3::ZERO, 0.5);
    let params = GridParams { bounds: cube(1.0), resolution: 96, refine: true };
    let culled = mesh_field(&field, &params).unwrap();
    let asked = field.asked();
    assert!(asked * 5 < 97usize.pow(3), "{asked} samples of {}", 97usize.pow(3));
    check(&culled);
}

#[test]
fn a_box_whose_extent_overflows_is_refused_by_both_meshers() {
    // Finite corners, infinite extent: refused with the box's message, not meshed into NaN.
    let huge = (Vec3::splat(-3e38), Vec3::splat(3e38));
    let e = super::grid::cells_for(huge, 8).unwrap_err();
    assert!(e.to_string().contains("finite and not empty"), "{e}");
    let field = Sphere { center: Vec3::ZERO, radius: 1.0 };
    assert!(mesh_field(&field, &GridParams { bounds: huge, resolution: 8, refine: true }).unwrap_err().to_string().contains("finite and not empty"));
    let dual = super::dual::mesh_dual(&field, &super::dual::DualParams { bounds: huge, resolution: 8 });
    assert!(dual.is_err());
}

#[test]
fn a_six_crossing_loop_is_fanned_from_a_centre_inside_the_prism_when_asked() {
    // Corners 0 and 4 inside, joined across their side quad (its mean is above the
    // level): one loop through the six edges at them. A triangulation between its own
    // vertices folded where the bake's lattice is sheared (Suzanne's head, chain mail:
    // 2 crossing pairs exterior, 11 interior); the bake asks for a centre vertex.
    let values = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let mut rings = Vec::new();
    let mut tris = Vec::new();
    marching::march_prism_centred(
        &values,
        0.4,
        false,
        &mut 0u32,
        |made, _, _| {
            *made += 1;
            *made - 1
        },
        |_, ring| {
            rings.push(ring.to_vec());
            100
        },
        &mut tris,
    );
    assert_eq!(rings.len(), 1, "one centre vertex");
    let ring = &rings[0];
    assert_eq!(ring.len(), 6);
    assert_eq!(tris.len(), 6, "{tris:?}");
    assert!(tris.iter().all(|t| t.contains(&100)), "every triangle at the centre: {tris:?}");
    // A closed fan: the spokes pair up in opposite directions, and the rim is the loop,
    // walked once in its own order.
    let mut directed = std::collections::HashSet::new();
    for t in &tris {
        for k in 0..3 {
            assert!(directed.insert((t[k], t[(k + 1) % 3])), "{tris:?}");
        }
    }
    for k in 0..6 {
        let (a, b) = (ring[k].2, ring[(k + 1) % 6].2);
        assert!(directed.contains(&(a, b)) && !directed.contains(&(b, a)));
        assert!(directed.contains(&(100, a)) && directed.contains(&(a, 100)));
    }
    // Without a centre (the field polygonizer), the table's own four triangles over
    // the same six vertices, with the same rim.
    let (mut plain, mut asked) = (Vec::new(), Vec::new());
    marching::march_prism(
        &values,
        0.4,
        false,
        |a, b| {
            asked.push((a, b));
            asked.len() as u32 - 1
        },
        &mut plain,
    );
    assert_eq!(plain.len(), 4, "{plain:?}");
    let edge = |k: usize| (ring[k].0, ring[k].1);
    for t in &plain {
        for k in 0..3 {
            let (a, b) = (asked[t[k] as usize], asked[t[(k + 1) % 3] as usize]);
            let (i, j) = ((0..6).find(|&i| edge(i) == a).unwrap(), (0..6).find(|&j| edge(j) == b).unwrap());
            // A rim edge keeps the loop's direction; a chord is walked back by another.
            assert!(j == (i + 1) % 6 || i != (j + 1) % 6, "{plain:?}");
        }
    }
    // The centre: inside the prism, moved from the loop's mean (crossings at the
    // midpoints here) onto the level of the values' interpolation.
    let w = marching::centre_weights(&values, 0.4, ring.iter().map(|&(a, b, _)| (a, b, 0.5)), 0.05);
    assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-5 && w.iter().all(|&x| x > 0.0), "{w:?}");
    let value = w.iter().zip(&values).map(|(w, v)| w * v).sum::<f32>();
    assert!((value - 0.4).abs() < 0.02, "{value} {w:?}");
}

#[test]
fn prisms_without_a_long_loop_march_alike_with_or_without_centres() {
    // Every inside set, ambiguous sides joined or not: march_prism_centred makes
    // march_prism's triangles (same vertices asked in the same order) where no loop has
    // six crossings, and otherwise those of the other loops plus one fan.
    let mut long = 0;
    for inside in 0u8..64 {
        for connected in 0u8..8 {
            // Values giving the case: inside corners 1 (or 0.6), outside 0; an
            // ambiguous side joined when its mean reaches the level (0.5).
            let mut values: [f32; 6] = std::array::from_fn(|c| f32::from(u8::from(inside & (1 << c) != 0)));
            for (k, side) in prism_table::SIDES.iter().enumerate() {
                if connected & (1 << k) == 0 {
                    for &c in side {
                        values[c] = values[c].min(0.6);
                    }
                }
            }
            let case = prism_table::classify(&values, 0.5);
            let (mut plain, mut centred) = (Vec::new(), Vec::new());
            let (mut asked, mut asked_centred) = (Vec::new(), Vec::new());
            marching::march_prism(
                &values,
                0.5,
                true,
                |a, b| {
                    asked.push((a, b));
                    asked.len() as u32 - 1
                },
                &mut plain,
            );
            marching::march_prism_centred(
                &values,
                0.5,
                true,
                &mut asked_centred,
                |asked, a, b| {
                    asked.push((a, b));
                    asked.len() as u32 - 1
                },
                |_, _| 99,
                &mut centred,
            );
            // The table read directly: its triangles in order, flipped, each edge's
            // vertex asked the first time a triangle uses it.
            let mut edge_ids = [u32::MAX; 9];
            let mut reference_asked = Vec::new();
            let reference: Vec<[u32; 3]> = case.tris[..case.count as usize]
                .iter()
                .map(|tri| {
                    let t = tri.map(|e| {
                        let e = e as usize;
                        if edge_ids[e] == u32::MAX {
                            reference_asked.push((prism_table::EDGES[e][0], prism_table::EDGES[e][1]));
                            edge_ids[e] = reference_asked.len() as u32 - 1;
                        }
                        edge_ids[e]
                    });
                    [t[0], t[2], t[1]]
                })
                .collect();
            assert_eq!((&plain, &asked), (&reference, &reference_asked), "case {inside:06b}/{connected:03b}");
            if case.ring().is_empty() {
                assert_eq!((&plain, &asked), (&centred, &asked_centred), "case {inside:06b}/{connected:03b}");
            } else {
                long += 1;
                // The other loops' triangles as the table has them, then a fan from
                // the centre over consecutive vertices of the long loop.
                let vertex = |asked: &[(usize, usize)], id: u32| asked[id as usize];
                let (fan, rest): (Vec<[u32; 3]>, Vec<[u32; 3]>) = centred.iter().copied().partition(|t| t.contains(&99));
                let kept: Vec<_> =
                    reference.iter().enumerate().filter(|(k, _)| !case.ring_tris().contains(k)).map(|(_, t)| t.map(|i| vertex(&reference_asked, i))).collect();
                assert_eq!(rest.iter().map(|t| t.map(|i| vertex(&asked_centred, i))).collect::<Vec<_>>(), kept);
                let ring: Vec<(usize, usize)> = case.ring().iter().map(|&e| (prism_table::EDGES[e as usize][0], prism_table::EDGES[e as usize][1])).collect();
                assert_eq!(fan.len(), ring.len());
                for (k, t) in fan.iter().enumerate() {
                    // Flipped: [centre, next, this].
                    assert_eq!((t[0], vertex(&asked_centred, t[2]), vertex(&asked_centred, t[1])), (99, ring[k], ring[(k + 1) % ring.len()]));
                }
            }
        }
    }
    assert!(long > 0);
}
