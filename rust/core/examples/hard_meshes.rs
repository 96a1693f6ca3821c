//! Writes the generated hard test meshes (`thicket_core::hard_meshes`: every closed
//! one but the bunny, plus 2000 cards) as OBJ files to `tests/data/hard/`, and prints
//! their sizes, narrowest gaps and thinnest parts (from vertex-normal rays, in % of
//! the bounding-box diagonal) and self-intersection counts.
//!
//! `cargo run -p thicket-core --release --features test-support --example hard_meshes`

use thicket_core::hard_meshes::{all_closed, cards, ray_gaps, self_intersections, to_obj};

fn main() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/hard");
    std::fs::create_dir_all(&dir).unwrap();
    let mut meshes: Vec<_> = all_closed().into_iter().filter(|(name, _)| *name != "bunny").collect();
    meshes.push(("cards", cards(2000, 1)));
    println!("{:<15} {:>6} {:>6} {:>6} {:>7} {:>7} {:>7} {:>6} {:>8}", "mesh", "verts", "faces", "tris", "diag", "gap%", "thick%", "cross", "bytes");
    for (name, m) in meshes {
        let text = to_obj(&m);
        std::fs::write(dir.join(format!("{name}.obj")), &text).unwrap();
        let (d, r) = (m.bbox_diagonal(), m.report());
        let (gap, thick) = if name == "cards" { (f32::NAN, f32::NAN) } else { ray_gaps(&m) };
        println!(
            "{name:<15} {:>6} {:>6} {:>6} {d:>7.3} {:>7.2} {:>7.2} {:>6} {:>8}",
            r.vertices,
            r.faces,
            r.triangles,
            100.0 * gap / d,
            100.0 * thick / d,
            self_intersections(&m),
            text.len()
        );
    }
}
