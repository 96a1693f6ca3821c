//! Multiresolution analysis' memory estimate ([`budget::ANALYSIS_BYTES_PER_FACE`]) against
//! the peak heap a counting allocator measures while it runs (its own test binary: the
//! allocator is the whole process's).

use thicket_core::glam::Vec3;
use thicket_core::subdivision::budget::{self, check_analysis_fits, faces_at, ANALYSIS_BYTES_PER_FACE};
use thicket_core::subdivision::detail::{procedural_detail, Model};
use thicket_core::subdivision::multires::analyze_positions;
use thicket_core::{Error, Mesh};

#[path = "../examples/common/counting_alloc.rs"]
mod counting_alloc;

/// A torus of `major` x `minor` quads (all regular: n-gons and irregular vertices are not
/// measured here): radii 1 and 0.3.
fn torus(major: u32, minor: u32) -> Mesh {
    let mut p = Vec::new();
    for i in 0..major {
        let u = i as f32 / major as f32 * std::f32::consts::TAU;
        for j in 0..minor {
            let v = j as f32 / minor as f32 * std::f32::consts::TAU;
            let r = 1.0 + 0.3 * v.cos();
            p.push(Vec3::new(r * u.cos(), r * u.sin(), 0.3 * v.sin()));
        }
    }
    let at = |i: u32, j: u32| (i % major) * minor + j % minor;
    let corners: Vec<u32> = (0..major).flat_map(|i| (0..minor).flat_map(move |j| [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)])).collect();
    Mesh::new(p, &vec![4; (major * minor) as usize], corners, None).unwrap()
}

#[test]
fn the_analysis_estimate_covers_its_measured_peak_and_refuses_past_a_budget() {
    for (base, levels) in [(torus(24, 16), 3), (torus(60, 40), 3), (torus(40, 30), 4), (torus(8, 6), 5)] {
        let fine = procedural_detail(&base, levels, &Model::Rock { amplitude: 0.01 }, 3).unwrap().mesh.into_parts().0;
        let (m, bytes) = counting_alloc::peak_bytes(move || analyze_positions(fine, &base, levels).unwrap());
        let faces = faces_at(&m.base, levels);
        let estimate = faces * ANALYSIS_BYTES_PER_FACE;
        eprintln!("{faces} faces: {bytes} bytes measured ({:.0} per face), {estimate} estimated", bytes as f64 / faces as f64);
        assert!(estimate >= bytes as u64, "{faces} faces at {levels} levels: {bytes} bytes measured, {estimate} estimated");
        assert!(estimate < 2 * bytes as u64, "{faces} faces: the estimate {estimate} is over twice the measured {bytes}");
        assert!(check_analysis_fits(&m.base, levels, estimate).is_ok());
        let Err(Error::OverLimit(message)) = check_analysis_fits(&m.base, levels, estimate - 1) else { panic!("not refused") };
        assert!(message.starts_with("the analysis of") && message.contains(&format!("{faces} faces")), "{message}");
        // The plain subdivision's budget is not the analysis': with only what the analysis
        // measured allowed, it would still let the analysis through.
        assert!(budget::check_fits(&m.base, levels, bytes as u64).is_ok(), "{faces} faces: the plain budget would refuse");
    }
}
