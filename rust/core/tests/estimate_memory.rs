//! The field mesh estimate's peak bytes against the peak a counting allocator measures
//! while each mesher runs (its own test binary: the allocator is the whole process's).

use thicket_core::implicit::FieldTree;
use thicket_core::polygonize::dual::{mesh_dual, DualParams};
use thicket_core::polygonize::{estimate, mesh_field, GridParams, Mesher};

#[path = "../examples/common/counting_alloc.rs"]
mod counting_alloc;

/// Peak live heap bytes above the start while `f` runs.
fn peak<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let (out, bytes) = counting_alloc::peak_bytes(f);
    (out, bytes as f64)
}

#[test]
fn the_estimated_peak_is_within_0_8_to_2_times_the_measured_one() {
    let trees = [
        r#"{"op": "sphere", "center": [0.03, -0.02, 0.01], "radius": 0.7}"#,
        r#"{"op": "torus", "center": [0, 0, 0], "axis": [0.2, 1, 0.3], "major": 0.6, "minor": 0.22}"#,
        thicket_core::implicit::samples::SOFT_CSG_20,
        r#"{"op": "displace", "shape": {"op": "sphere", "center": [0, 0, 0], "radius": 0.6},
            "texture": {"op": "plane", "point": [0, 0, 0], "normal": [1, 0.3, 0.2]}, "amplitude": 0.05, "omega": 40}"#,
    ];
    for json in trees {
        let t = FieldTree::from_json(json).unwrap();
        let (lo, hi) = t.bounds().unwrap();
        for resolution in [96, 200] {
            let margin = 2.0 * (hi - lo).max_element() / resolution as f32;
            let bounds = (lo - margin, hi + margin);
            let e = estimate(&t, bounds, resolution, Mesher::Dual).unwrap();
            let (_, real) = peak(|| mesh_dual(&t, &DualParams { bounds, resolution }).unwrap());
            let ratio = e.peak_bytes as f64 / real;
            assert!((0.8..2.0).contains(&ratio), "dual at {resolution}: {} estimated, {real} measured: {json}", e.peak_bytes);
            let e = estimate(&t, bounds, resolution, Mesher::Grid).unwrap();
            let (_, real) = peak(|| mesh_field(&t, &GridParams { bounds, resolution, refine: true }).unwrap());
            let ratio = e.peak_bytes as f64 / real;
            assert!((0.8..2.0).contains(&ratio), "grid at {resolution}: {} estimated, {real} measured: {json}", e.peak_bytes);
        }
    }
}
