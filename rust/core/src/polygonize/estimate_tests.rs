//! The estimate against the meshes it estimates, the memory limit refusing before
//! and during a build, and both meshers' progress and cancel.

use super::*;
use crate::implicit::samples::SOFT_CSG_20;
use crate::implicit::FieldTree;
use crate::polygonize::dual::{mesh_dual, mesh_dual_watched, DualParams};
use crate::polygonize::{mesh_field, mesh_field_watched, GridParams};
use crate::progress::Progress;
use std::time::Instant;

const SPHERE: &str = r#"{"op": "sphere", "center": [0.03, -0.02, 0.01], "radius": 0.7}"#;
const TORUS: &str = r#"{"op": "torus", "center": [0.01, 0.02, -0.03], "axis": [0.2, 1, 0.3], "major": 0.6, "minor": 0.22}"#;
/// A sphere with ripples of wavelength 0.16 (equation 1 along a plane): about three
/// times a smooth sphere's area.
const RIPPLED: &str = r#"{"op": "displace", "shape": {"op": "sphere", "center": [0, 0, 0], "radius": 0.6},
  "texture": {"op": "plane", "point": [0, 0, 0], "normal": [1, 0.3, 0.2]}, "amplitude": 0.05, "omega": 40}"#;

fn around(t: &FieldTree, resolution: u32) -> (Vec3, Vec3) {
    let (lo, hi) = t.bounds().unwrap();
    let margin = 2.0 * (hi - lo).max_element() / resolution as f32;
    (lo - margin, hi + margin)
}

fn within(estimated: u64, real: usize, tolerance: f64) -> bool {
    let ratio = estimated as f64 / real as f64;
    (1.0 / tolerance..=tolerance).contains(&ratio)
}

#[test]
fn the_estimate_is_within_one_and_a_half_times_the_meshes_counts() {
    for (name, json) in [("sphere", SPHERE), ("torus", TORUS), ("20-node tree", SOFT_CSG_20), ("rippled sphere", RIPPLED)] {
        let t = FieldTree::from_json(json).unwrap();
        // Resolutions past ESTIMATE_RESOLUTION are scaled; 40 is counted exactly.
        for resolution in [40, 100, 230] {
            let bounds = around(&t, resolution);
            let e = estimate(&t, bounds, resolution, Mesher::Dual).unwrap();
            let m = mesh_dual(&t, &DualParams { bounds, resolution }).unwrap();
            assert_eq!(e.cells, m.cells);
            assert!(within(e.faces, m.quads.len(), 1.5), "{name} at {resolution}: {} quads estimated, {} made", e.faces, m.quads.len());
            assert!(within(e.vertices, m.positions.len(), 1.5), "{name} at {resolution}: {} vertices estimated, {} made", e.vertices, m.positions.len());
            assert!(within(e.triangles, 2 * m.quads.len(), 1.5));
            if resolution <= ESTIMATE_RESOLUTION {
                assert_eq!(e.faces as usize, m.quads.len(), "{name}: counted on the lattice meshed, the estimate is the count");
            }
            if resolution <= 100 {
                let e = estimate(&t, bounds, resolution, Mesher::Grid).unwrap();
                let m = mesh_field(&t, &GridParams { bounds, resolution, refine: true }).unwrap();
                assert!(within(e.faces, m.triangles.len(), 1.5), "{name} at {resolution}: {} triangles estimated, {} made", e.faces, m.triangles.len());
                assert!(within(e.vertices, m.positions.len(), 1.5), "{name} at {resolution}: {} vertices estimated, {} made", e.vertices, m.positions.len());
            }
        }
    }
}

#[test]
fn memory_grows_with_the_square_of_the_resolution_and_a_huge_one_is_refused_at_once() {
    let t = FieldTree::from_json(RIPPLED).unwrap();
    let (small, big) = (estimate(&t, around(&t, 256), 256, Mesher::Dual).unwrap(), estimate(&t, around(&t, 512), 512, Mesher::Dual).unwrap());
    let growth = big.peak_bytes as f64 / small.peak_bytes as f64;
    assert!((3.5..4.5).contains(&growth), "peak grew {growth}x from 256 to 512 cells");
    let start = Instant::now();
    let huge = estimate(&t, around(&t, 2048), 2048, Mesher::Dual).unwrap();
    let err = huge.check(DEFAULT_MAX_BYTES).unwrap_err();
    let elapsed = start.elapsed().as_secs_f64();
    assert!(elapsed < 2.0, "the estimate took {elapsed} s");
    assert!(huge.peak_bytes > DEFAULT_MAX_BYTES, "{huge:?}");
    let message = err.to_string();
    for part in ["resolution 2048", "vertices", "quads", "GB at its peak", "memory limit of 4.00 GB", "cells or fewer"] {
        assert!(message.contains(part), "{part:?} not in {message:?}");
    }
    // The resolution it proposes fits.
    let fit = huge.resolution_within(DEFAULT_MAX_BYTES);
    assert!(fit < 2048 && fit > 256, "{fit}");
    estimate(&t, around(&t, fit), fit, Mesher::Dual).unwrap().check(DEFAULT_MAX_BYTES).unwrap();
    // The grid mesher's planes alone are counted: a flat sphere at 2048 cells too.
    let s = FieldTree::from_json(SPHERE).unwrap();
    assert!(estimate(&s, around(&s, 2048), 2048, Mesher::Grid).unwrap().peak_bytes > estimate(&s, around(&s, 2048), 2048, Mesher::Dual).unwrap().peak_bytes);
}

#[test]
fn a_build_past_the_limit_stops_with_the_limit_named() {
    let t = FieldTree::from_json(RIPPLED).unwrap();
    let bounds = around(&t, 256);
    // The limit from the estimate's own model: a fifth of the mesh's need.
    let need = estimate(&t, bounds, 256, Mesher::Dual).unwrap().peak_bytes;
    for max_bytes in [need / 5, 1000] {
        let watch = Watch { progress: None, max_bytes: Some(max_bytes) };
        let start = Instant::now();
        let err = mesh_dual_watched(&t, &DualParams { bounds, resolution: 256 }, &watch).unwrap_err();
        assert!(matches!(err, crate::Error::OverLimit(_)), "{err:?}");
        assert!(err.to_string().contains("the field mesh would pass the memory limit"), "{err}");
        assert!(start.elapsed().as_secs_f64() < 1.0);
        let err = mesh_field_watched(&t, &GridParams { bounds, resolution: 256, refine: true }, &watch).unwrap_err();
        assert!(err.to_string().contains("the field mesh would pass the memory limit"), "{err}");
    }
    // Within the limit: the same mesh as without one.
    let watch = Watch { progress: None, max_bytes: Some(2 * need) };
    let (a, b) =
        (mesh_dual_watched(&t, &DualParams { bounds, resolution: 256 }, &watch).unwrap(), mesh_dual(&t, &DualParams { bounds, resolution: 256 }).unwrap());
    assert_eq!((a.positions, a.quads), (b.positions, b.quads));
}

/// Runs `build` watched by a thread that records the fraction and, with `cancel_at`,
/// cancels once it passes that; returns what `build` gave, the fractions seen and the
/// fraction where the build stopped.
fn watched<T: Send>(cancel_at: Option<f64>, build: impl FnOnce(&Progress) -> crate::Result<T> + Send) -> (crate::Result<T>, Vec<f64>, f64) {
    let progress = Progress::default();
    let finished = std::sync::atomic::AtomicBool::new(false);
    std::thread::scope(|s| {
        let watcher = s.spawn(|| {
            let mut seen = Vec::new();
            loop {
                let f = progress.fraction();
                seen.push(f);
                if cancel_at.is_some_and(|at| f > at) {
                    progress.cancel();
                    return (seen, f);
                }
                if finished.load(std::sync::atomic::Ordering::Acquire) {
                    return (seen, f);
                }
                std::thread::sleep(std::time::Duration::from_micros(200));
            }
        });
        let out = build(&progress);
        finished.store(true, std::sync::atomic::Ordering::Release);
        let (seen, _) = watcher.join().unwrap();
        (out, seen, progress.fraction())
    })
}

#[test]
fn both_meshers_report_progress_to_one_and_stop_when_cancelled() {
    let t = FieldTree::from_json(RIPPLED).unwrap();
    let bounds = around(&t, 200);
    let dual = DualParams { bounds, resolution: 200 };
    let grid = GridParams { bounds, resolution: 200, refine: true };
    let (m, seen, end) = watched(None, |p| mesh_dual_watched(&t, &dual, &Watch { progress: Some(p), max_bytes: None }));
    assert_eq!(end, 1.0);
    let plain = mesh_dual(&t, &dual).unwrap();
    assert_eq!(m.unwrap().quads, plain.quads);
    assert!(seen.windows(2).all(|w| w[0] <= w[1]), "not monotone: {seen:?}");
    assert!(seen.iter().any(|&f| f > 0.0 && f < 1.0), "no fraction between 0 and 1: {seen:?}");
    let (m, seen, end) = watched(None, |p| mesh_field_watched(&t, &grid, &Watch { progress: Some(p), max_bytes: None }));
    assert_eq!(end, 1.0);
    assert_eq!(m.unwrap().triangles, mesh_field(&t, &grid).unwrap().triangles);
    assert!(seen.windows(2).all(|w| w[0] <= w[1]), "not monotone: {seen:?}");
    // Cancelled a tenth of the way: stopped well before the end.
    for which in ["dual", "grid"] {
        let (out, _, stopped) = watched(Some(0.1), |p| {
            let watch = Watch { progress: Some(p), max_bytes: None };
            if which == "dual" {
                mesh_dual_watched(&t, &dual, &watch).map(|_| ())
            } else {
                mesh_field_watched(&t, &grid, &watch).map(|_| ())
            }
        });
        assert_eq!(out.unwrap_err(), crate::Error::Cancelled, "{which}");
        assert!(stopped < 0.5, "{which}: stopped at {stopped}");
    }
    // Cancelled before it starts: nothing is sampled.
    let progress = Progress::default();
    progress.cancel();
    let watch = Watch { progress: Some(&progress), max_bytes: None };
    assert_eq!(mesh_dual_watched(&t, &dual, &watch).unwrap_err(), crate::Error::Cancelled);
    assert_eq!(mesh_field_watched(&t, &grid, &watch).unwrap_err(), crate::Error::Cancelled);
    assert_eq!(progress.fraction(), 0.0);
}
