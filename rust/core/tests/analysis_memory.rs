//! Multiresolution analysis' memory estimate ([`budget::ANALYSIS_BYTES_PER_FACE`]) against
//! the peak heap a counting allocator measures while it runs (its own test binary: the
//! allocator is the whole process's).

use thicket_core::subdivision::budget::{self, check_analysis_fits, faces_at, ANALYSIS_BYTES_PER_FACE};
use thicket_core::subdivision::detail::{procedural_detail, Model};
use thicket_core::subdivision::multires::analyze_positions;
use thicket_core::Error;

#[path = "../examples/common/counting_alloc.rs"]
mod counting_alloc;
#[path = "../examples/common/torus.rs"]
mod torus;
use torus::torus;

#[test]
fn the_analysis_estimate_covers_its_measured_peak_and_refuses_past_a_budget() {
    for (base, levels) in [(torus(24, 16, 0.3), 3), (torus(60, 40, 0.3), 3), (torus(40, 30, 0.3), 4), (torus(8, 6, 0.3), 5)] {
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
