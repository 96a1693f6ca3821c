//! Issue 17's benchmark tree (`implicit::samples::SOFT_CSG_20`: 20 nodes, `w_p` with
//! `p = 8` over spheres, boxes and segments) meshed at 256 cells along the longest side
//! by Thicket's dual contouring (`polygonize::dual::mesh_dual`, its own evaluation and
//! interval culling) and, in the same run, by the peer the issue names: fidget's
//! manifold dual contouring (`fidget::mesh::Octree`, depth 8 = 256 cells over a cube
//! of the same side, so the same cell size) on the same function JIT-compiled from
//! fidget's math (`fidget_tree`). Prints each one's best time of `--runs`, triangles,
//! whether the mesh is a closed manifold (`polygonize::SurfaceCheck`), and how far its
//! vertices lie from the zero set (`|f| / |grad f|` of the Thicket tree, in cells).
//!
//! `cargo run --release -p thicket-peers -- [--runs N] [--depth D]`

mod fidget_tree;
#[path = "../../core/examples/common/zero_set.rs"]
mod zero_set;

use fidget_tree::Wp;
use zero_set::distance;

use fidget::jit::JitShape;
use fidget::mesh::{Octree, Settings};
use fidget::render::ThreadPool;
use std::time::Instant;
use thicket_core::glam::Vec3;
use thicket_core::implicit::samples::SOFT_CSG_20 as TREE;
use thicket_core::implicit::FieldTree;
use thicket_core::polygonize::dual::{mesh_dual, DualParams};
use thicket_core::polygonize::SurfaceCheck;

fn best<T>(runs: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut out = None;
    let mut ms = f64::INFINITY;
    for _ in 0..runs {
        let start = Instant::now();
        out = Some(f());
        ms = ms.min(start.elapsed().as_secs_f64() * 1e3);
    }
    (ms, out.expect("at least one run"))
}

fn report(name: &str, ms: f64, positions: &[Vec3], triangles: &[[u32; 3]], tree: &FieldTree, cell: f32) {
    let check = SurfaceCheck::of(positions, triangles);
    let (worst, mean) = distance(tree, positions, cell);
    println!(
        "  {name:<32} {ms:8.1} ms  {:>7} triangles  closed manifold {:<5} (boundary {}, overused {}, misoriented {}, pinched {}, degenerate {})  distance to the zero set: worst {worst:.3}, mean {mean:.4} cells",
        triangles.len(),
        check.is_closed_manifold(),
        check.boundary_edges,
        check.overused_edges,
        check.misoriented_edges,
        check.pinched_vertices,
        check.degenerate_triangles
    );
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |name: &str| args.iter().position(|a| a == name).map(|i| args.get(i + 1).expect("a value after the option").clone());
    let runs: usize = arg("--runs").map_or(2, |r| r.parse().expect("--runs takes a count")).max(1);
    let depth: u8 = arg("--depth").map_or(8, |d| d.parse().expect("--depth takes a number"));
    let resolution = 1u32 << depth;
    let tree = FieldTree::from_json(TREE).expect("the sample tree is valid");
    let (lo, hi) = tree.bounds().expect("the sample tree is bounded");
    let margin = 2.0 * (hi - lo).max_element() / resolution as f32;
    let (lo, hi) = (lo - margin, hi + margin);
    let side = (hi - lo).max_element();
    let cell = side / resolution as f32;
    println!(
        "{} threads; issue 17's soft-CSG tree (20 nodes), {resolution} cells along the longest side ({cell:.5} each), best of {runs}",
        rayon::current_num_threads()
    );

    let (ours_ms, ours) = best(runs, || mesh_dual(&tree, &DualParams { bounds: (lo, hi), resolution }).expect("meshes"));
    report("Thicket (dual contouring)", ours_ms, &ours.positions, &ours.triangles(), &tree, cell);

    let json: serde_json::Value = serde_json::from_str(TREE).expect("JSON");
    let centre = (lo + hi) / 2.0;
    // fidget's octree spans [-1, 1]³; `world_to_model` takes it onto the tree's box.
    let world_to_model = nalgebra::Matrix4::new_translation(&nalgebra::Vector3::new(centre.x, centre.y, centre.z)) * nalgebra::Matrix4::new_scaling(side / 2.0);
    let settings = Settings { depth, world_to_model, threads: Some(&ThreadPool::Global), ..Default::default() };
    let mut fastest = (f64::INFINITY, 0);
    for (form, name) in [(Wp::Plain, "fidget 0.5, w_p as ln sum exp"), (Wp::AroundMax, "fidget 0.5, w_p around its max")] {
        let shape = JitShape::from(fidget_tree::from_json(&json, form).expect("written in fidget's math"));
        let bound = shape.try_into().expect("no variables but x, y, z");
        let (ms, mesh) = best(runs, || Octree::build(&bound, &settings).expect("not cancelled").walk_dual());
        let positions: Vec<Vec3> = mesh.vertices.iter().map(|v| Vec3::new(v.x, v.y, v.z)).collect();
        let triangles: Vec<[u32; 3]> = mesh.triangles.iter().map(|t| [t.x as u32, t.y as u32, t.z as u32]).collect();
        report(name, ms, &positions, &triangles, &tree, cell);
        if ms < fastest.0 {
            fastest = (ms, triangles.len());
        }
    }
    let (fidget_ms, fidget_triangles) = fastest;
    println!(
        "  Thicket / fidget (its faster form): {:.2}x the time, {:.2}x the triangles",
        ours_ms / fidget_ms,
        ours.triangles().len() as f64 / fidget_triangles as f64
    );
}
