//! Meshes scalar fields through `polygonize::mesh_field` (marching prisms on a grid of
//! cubes, iso-vertices refined on the field) beside fast-surface-nets on the same
//! samples, in one run: time (sampling included for both), triangles, and how far the
//! vertices lie from the zero set (`|f| / |grad f|`, in cells; ours of the field cut
//! by the box, since it closes the surface there, theirs of the field: their surface
//! stays open), for an analytic torus and the chain mail pattern's field over one tile.
//!
//! `cargo run --release -p thicket-core --example field_mesh_bench`

use fast_surface_nets::ndshape::{RuntimeShape, Shape};
use fast_surface_nets::{surface_nets, SurfaceNetsBuffer};
use rayon::prelude::*;
use std::time::Instant;
use thicket_core::field::ScalarField;
use thicket_core::glam::{Vec2, Vec3};
use thicket_core::polygonize::{mesh_field, GridParams, SurfaceCheck};
use thicket_core::texture::{Generator, Pattern};

#[path = "common/zero_set.rs"]
mod zero_set;
use zero_set::distance;

struct Torus;

impl ScalarField for Torus {
    fn values(&self, points: &[Vec3], out: &mut [f32]) {
        for (o, p) in out.iter_mut().zip(points) {
            *o = Vec2::new(p.truncate().length() - 0.6, p.z).length() - 0.25;
        }
    }
}

/// The field cut by the box (what `mesh_field` meshes: the surface closes on the box).
struct Cut<'a, F> {
    field: &'a F,
    bounds: (Vec3, Vec3),
}

impl<F: ScalarField> ScalarField for Cut<'_, F> {
    fn values(&self, points: &[Vec3], out: &mut [f32]) {
        self.field.values(points, out);
        for (o, p) in out.iter_mut().zip(points) {
            *o = o.max((self.bounds.0 - *p).max(*p - self.bounds.1).max_element());
        }
    }
    fn difference_step(&self) -> f32 {
        1e-4
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn bench<F: ScalarField>(name: &str, field: &F, bounds: (Vec3, Vec3), cells: u32) {
    let params = GridParams { bounds, resolution: cells, refine: true };
    let mut ours = Vec::new();
    let mut mesh = None;
    for _ in 0..3 {
        let start = Instant::now();
        mesh = Some(mesh_field(field, &params).unwrap());
        ours.push(start.elapsed().as_secs_f64());
    }
    let mesh = mesh.unwrap();
    let cell = (bounds.1 - bounds.0).max_element() / cells as f32;
    let check = SurfaceCheck::of(&mesh.positions, &mesh.triangles);
    let (worst, mean) = distance(&Cut { field, bounds }, &mesh.positions, cell);

    // fast-surface-nets on the same grid of samples (padded by one sample each side,
    // as it needs), sampled in parallel like ours; it polygonizes on one thread.
    let step = (bounds.1 - bounds.0) / mesh.cells.as_vec3();
    let dims = (mesh.cells + 3).to_array();
    let shape = RuntimeShape::<u32, 3>::new(dims);
    let origin = bounds.0 - step;
    let mut buffer = SurfaceNetsBuffer::default();
    let mut theirs = Vec::new();
    for _ in 0..3 {
        let start = Instant::now();
        let points: Vec<Vec3> = (0..shape.size())
            .map(|i| {
                let [x, y, z] = shape.delinearize(i);
                origin + Vec3::new(x as f32, y as f32, z as f32) * step
            })
            .collect();
        let mut sdf = vec![0.0f32; points.len()];
        sdf.par_chunks_mut(4096).zip(points.par_chunks(4096)).for_each(|(out, p)| field.values(p, out));
        surface_nets(&sdf, &shape, [0; 3], dims.map(|d| d - 1), &mut buffer);
        theirs.push(start.elapsed().as_secs_f64());
    }
    let nets: Vec<Vec3> = buffer.positions.iter().map(|p| origin + Vec3::from(*p) * step).collect();
    let (nets_worst, nets_mean) = distance(field, &nets, cell);
    let (ours, theirs) = (median(ours), median(theirs));
    println!("{name}, {cells} cells along the longest side:");
    println!(
        "  Thicket mesh_field:  {:7.1} ms, {:>8} triangles, vertex distance to the zero set worst {worst:.3} / mean {mean:.4} cells, closed manifold: {}",
        ours * 1e3,
        mesh.triangles.len(),
        check.is_closed_manifold()
    );
    println!(
        "  fast-surface-nets:   {:7.1} ms, {:>8} triangles, vertex distance to the zero set worst {nets_worst:.3} / mean {nets_mean:.4} cells",
        theirs * 1e3,
        buffer.indices.len() / 3
    );
    println!(
        "  ratio (Thicket / fast-surface-nets): time {:.2}x, triangles {:.2}x",
        ours / theirs,
        mesh.triangles.len() as f64 / (buffer.indices.len() / 3).max(1) as f64
    );
}

fn main() {
    println!("{} threads", rayon::current_num_threads());
    bench("torus (analytic distance)", &Torus, (Vec3::new(-1.0, -1.0, -0.4), Vec3::new(1.0, 1.0, 0.4)), 128);
    let chain_mail = Generator::new(Pattern::ChainMail).field().unwrap();
    bench("chain mail pattern field, one tile", &chain_mail, (Vec3::ZERO, Vec3::ONE), 128);
}
