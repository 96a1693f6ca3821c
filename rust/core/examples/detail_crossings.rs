//! Crossing pairs (triangles sharing no vertex that intersect) the procedural detail's
//! models leave on the hard meshes, 2 levels, seed 0, sizes as fractions of the diagonal
//! (rock 0.03, mushroom 0.1 with length 0.04, berry 0.12, tentacle 0.012), with each
//! model's guard tally and time.
//! `cargo run -p thicket-core --release --features test-support --example detail_crossings [-- model ...]`

use std::time::Instant;
use thicket_core::hard_meshes::{all_closed, cards, self_intersections};
use thicket_core::subdivision::detail::{procedural_detail, Model};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut meshes = all_closed();
    meshes.push(("cards", cards(2000, 1)));
    for (name, base) in meshes {
        let d = base.bbox_diagonal() as f64;
        let models = [
            ("rock", Model::Rock { amplitude: 0.03 * d }),
            ("mushroom", Model::Mushroom { radius: 0.1 * d, length: 0.04 * d, seeds: vec![] }),
            ("berry", Model::Berry { radius: 0.12 * d, seeds: vec![], children: 3 }),
            ("tentacle", Model::Tentacle { length: 0.012 * d, theta: 0.0, seeds: vec![], spacing: 0.25 * d }),
        ];
        for (label, model) in models.iter().filter(|(l, _)| args.is_empty() || args.iter().any(|a| a == l)) {
            let start = Instant::now();
            let out = procedural_detail(&base, 2, model, 0).unwrap();
            let t = start.elapsed().as_secs_f64();
            let h = out.mesh.positions().iter().fold(0u64, |h, p| p.to_array().iter().fold(h, |h, x| (h ^ x.to_bits() as u64).wrapping_mul(0x100000001b3)));
            println!("{name:<15} {label:<9} crossings {:>6}  {t:6.3} s  hash {h:016x}", self_intersections(&out.mesh));
        }
    }
}
