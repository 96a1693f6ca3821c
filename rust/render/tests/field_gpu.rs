//! The GPU field tracer (`field_trace.wgsl`) against the CPU tracer
//! (`thicket_core::implicit::trace`), tree by tree: every op, colours, paint, ramps,
//! displacement and fractal texture functions. The shader is the only second copy of
//! the evaluator's arithmetic; these comparisons tie the two together.
//!
//! Like tests/gpu.rs, these need a GPU adapter and FAIL without one (`make test-rust`
//! installs lavapipe).

use std::sync::{Mutex, MutexGuard, OnceLock};

use thicket_core::glam::{DMat4, DVec3};
use thicket_core::implicit::samples::SOFT_CSG_20;
use thicket_core::implicit::tape::Instruction;
use thicket_core::implicit::trace::{render, Camera};
use thicket_core::implicit::FieldTree;
use thicket_render::field::program::opcode;
use thicket_render::field::{FieldTracer, Program, STACK};

fn tracer() -> MutexGuard<'static, FieldTracer> {
    static T: OnceLock<Mutex<FieldTracer>> = OnceLock::new();
    T.get_or_init(|| {
        let t = FieldTracer::new().unwrap_or_else(|e| panic!("no GPU adapter (make test-rust installs lavapipe): {e}"));
        eprintln!("GPU adapter: {}", t.adapter_name());
        Mutex::new(t)
    })
    .lock()
    .unwrap_or_else(|e| e.into_inner())
}

fn camera(size: u32) -> Camera {
    let view = DMat4::look_at_rh(DVec3::new(2.2, -2.6, 1.8), DVec3::ZERO, DVec3::Z);
    Camera { view, projection: DMat4::perspective_rh_gl(40f64.to_radians(), 1.0, 0.1, 100.0), width: size, height: size }
}

/// Agreement of the GPU image with the CPU one.
#[derive(Debug)]
struct Agreement {
    iou: f64,
    /// Mean absolute RGB difference over pixels both hit.
    color: f64,
    /// Share of pixels both hit whose RGB differs by more than 0.1 in some channel.
    color_outliers: f64,
    /// Median distance between the hit points, in pixel footprints.
    depth_median: f64,
    /// Share of pixels both hit whose normals differ by more than 5 degrees.
    normal_outliers: f64,
}

fn compare_with(name: &str, json: &str, cam: &Camera) -> Agreement {
    let tree = FieldTree::from_json(json).unwrap_or_else(|e| panic!("{name}: {e}"));
    let cam = *cam;
    let cpu = render(&tree, &cam).unwrap();
    let gpu = tracer().render(&tree, &cam).unwrap();
    let g = &gpu.render;
    let rays = cam.rays().unwrap();
    let (mut both, mut any) = (0usize, 0usize);
    let (mut color, mut outliers, mut normal_out) = (0.0, 0usize, 0usize);
    let mut depths = Vec::new();
    let w = cam.width as usize;
    assert_eq!((g.width, g.height, g.rgba.len(), g.hits.len()), (cpu.width, cpu.height, cpu.rgba.len(), cpu.hits.len()));
    for i in 0..cpu.hits.len() {
        let (a, b) = (cpu.hits[i], g.hits[i]);
        any += usize::from(a.is_some() || b.is_some());
        let (Some(a), Some(b)) = (a, b) else { continue };
        both += 1;
        let (pa, pb) = (&cpu.rgba[i * 4..i * 4 + 3], &g.rgba[i * 4..i * 4 + 3]);
        let diff: Vec<f64> = pa.iter().zip(pb).map(|(x, y)| f64::from((x - y).abs())).collect();
        color += diff.iter().sum::<f64>() / 3.0;
        outliers += usize::from(diff.iter().any(|d| *d > 0.1));
        let ray = rays.ray((i % w) as f64 + 0.5, (i / w) as f64 + 0.5).unwrap();
        let footprint = ray.near + ray.grow * (a - ray.origin).length();
        depths.push(a.distance(b) / footprint);
        let na = tree.sample(a).gradient.normalize();
        let nb = gpu.normals[i].unwrap();
        normal_out += usize::from(na.dot(nb) < 5f64.to_radians().cos());
    }
    depths.sort_by(f64::total_cmp);
    let n = both.max(1) as f64;
    let out = Agreement {
        iou: both as f64 / any.max(1) as f64,
        color: color / n,
        color_outliers: outliers as f64 / n,
        depth_median: depths.get(depths.len() / 2).copied().unwrap_or(0.0),
        normal_outliers: normal_out as f64 / n,
    };
    eprintln!("{name}: {both} pixels hit by both, {out:?}");
    assert!(both > 500, "{name}: the tree should cover the view ({both} pixels)");
    out
}

/// The tolerances: silhouettes within 1% (IoU), colours within 0.01 on average with
/// under 1% of pixels off by more than 0.1 (edges, where f32 and f64 marches stop a
/// step apart), hits within a tenth of a footprint (the hit tolerance) at the
/// median, under 1% of normals off by more than 5 degrees.
fn check(name: &str, json: &str) {
    check_with(name, json, &camera(160));
}

fn check_with(name: &str, json: &str, cam: &Camera) {
    let a = compare_with(name, json, cam);
    assert!(a.iou >= 0.99, "{name}: IoU {a:?}");
    assert!(a.color < 0.01 && a.color_outliers < 0.01, "{name}: colour {a:?}");
    assert!(a.depth_median < 0.1, "{name}: depth {a:?}");
    assert!(a.normal_outliers < 0.01, "{name}: normals {a:?}");
}

#[test]
fn soft_csg_20_matches_the_cpu_tracer() {
    check("soft_csg_20", SOFT_CSG_20);
}

/// Rays made on the GPU from the camera's matrices: an off-centre perspective (the
/// window shifted as Blender's lens shift does, clip x + 0.35 w, y - 0.2 w) rolled
/// about the view axis, on a wide image, and an orthographic view on a tall one. A
/// ray generator that ignored the shift, swapped the axes, flipped y or took the
/// image for square would move the silhouette by tens of pixels.
#[test]
fn off_centre_and_non_square_cameras_match() {
    let roll = DMat4::from_axis_angle(DVec3::Z, 0.3);
    let view = roll * DMat4::look_at_rh(DVec3::new(2.0, -2.8, 1.4), DVec3::new(0.2, 0.1, 0.0), DVec3::Z);
    let (w, h) = (203, 117);
    let shift = DMat4::from_translation(DVec3::new(0.35, -0.2, 0.0));
    let perspective = Camera { view, projection: shift * DMat4::perspective_rh_gl(0.6, w as f64 / h as f64, 0.05, 500.0), width: w, height: h };
    check_with("off_centre_perspective", SOFT_CSG_20, &perspective);
    let (w, h) = (90, 171);
    let half = 1.3;
    let ortho =
        Camera { view, projection: DMat4::orthographic_rh_gl(-half * w as f64 / h as f64, half * 0.8, -half, half * 1.1, 0.1, 20.0), width: w, height: h };
    check_with("orthographic", SOFT_CSG_20, &ortho);
}

/// The colours alone (the binding's frame) are the full frame's; buffers are kept
/// between frames of one size (a warm frame allocates nothing) and a different tree
/// or size in between does not leak into the next frame.
#[test]
fn kept_buffers_and_the_colour_only_frame_agree_with_a_fresh_frame() {
    let t = tracer();
    let a = FieldTree::from_json(SOFT_CSG_20).unwrap();
    let b = FieldTree::from_json(&right_nested(3)).unwrap();
    let (cam, other) = (camera(48), Camera { width: 40, height: 56, ..camera(48) });
    let first = t.render(&a, &cam).unwrap();
    let rgba = t.render_rgba(&a, &cam).unwrap();
    assert!(!t.last_times().unwrap().allocated, "a warm frame of the same size allocates nothing");
    assert_eq!(rgba, first.render.rgba);
    assert!(first.render.hits.iter().any(Option::is_some));
    let _ = t.render(&b, &cam).unwrap();
    assert_eq!(t.render(&a, &cam).unwrap(), first, "the program of the tree in between is replaced");
    let small = t.render_rgba(&b, &other).unwrap();
    assert!(t.last_times().unwrap().allocated);
    assert_eq!(small.len(), 40 * 56 * 4);
    assert_eq!(t.render(&a, &cam).unwrap(), first, "after another size");
}

#[test]
fn every_primitive_and_exact_operation_matches() {
    check(
        "primitives",
        r#"{"op": "min", "children": [
          {"op": "plane", "point": [0, 0, -0.8], "normal": [0.1, 0.05, 1], "color": [0.5, 0.5, 0.4, 1]},
          {"op": "point", "center": [0.6, 0.6, 0.2], "radius": 0.25, "color": [0.9, 0.3, 0.1, 1]},
          {"op": "segment", "a": [-0.7, 0.2, -0.3], "b": [-0.2, 0.7, 0.5], "radius": 0.12, "color": [0.1, 0.8, 0.3, 1]},
          {"op": "rectangle", "center": [0.5, -0.5, 0.0], "half_size": [0.3, 0.2], "rotation": [0.9, 0.3, 0.2, 0.1], "radius": 0.08, "color": [0.2, 0.3, 0.9, 1]},
          {"op": "torus", "center": [-0.4, -0.4, 0.1], "axis": [0.3, 0.2, 1], "major": 0.35, "minor": 0.1, "color": [0.9, 0.8, 0.1, 1]},
          {"op": "max", "color": [0.7, 0.2, 0.7, 1], "children": [
            {"op": "box", "center": [0, 0, 0.3], "half_size": [0.3, 0.3, 0.3], "rotation": [0.95, 0.1, 0.2, 0.2], "radius": 0.02},
            {"op": "negate", "child": {"op": "sphere", "center": [0, 0, 0.6], "radius": 0.3}}]},
          {"op": "offset", "amount": 0.05, "child": {"op": "h", "children": [
            {"op": "sphere", "center": [0.1, 0.9, -0.3], "radius": 0.15, "color": [1, 0, 0, 1]},
            {"op": "sphere", "center": [0.3, 0.9, -0.3], "radius": 0.15, "color": [0, 0, 1, 1]}]}}
        ]}"#,
    );
}

#[test]
fn soft_operations_blend_colours_alike() {
    check(
        "soft",
        r#"{"op": "union_wp", "p": 4, "children": [
          {"op": "sphere", "center": [-0.3, 0, 0], "radius": 0.5, "color": [1, 0, 0, 1]},
          {"op": "sphere", "center": [0.35, 0.1, 0.1], "radius": 0.45, "color": [0, 0, 1, 1]},
          {"op": "intersection_wp", "p": 12, "children": [
            {"op": "box", "center": [0, -0.6, -0.3], "half_size": [0.3, 0.3, 0.3], "color": [0, 1, 0, 1]},
            {"op": "sphere", "center": [0, -0.6, -0.3], "radius": 0.38, "color": [1, 1, 0, 1]}]},
          {"op": "difference_wp", "p": 10, "children": [
            {"op": "box", "center": [0.1, 0.6, 0.5], "half_size": [0.35, 0.2, 0.2], "color": [0, 1, 1, 1]},
            {"op": "sphere", "center": [0.1, 0.6, 0.7], "radius": 0.2, "color": [1, 0, 1, 1]}]}
        ]}"#,
    );
}

#[test]
fn texture_functions_and_ramps_match() {
    check(
        "displace",
        r#"{"op": "displace", "amplitude": 0.04, "omega": 18, "tau": 0.3,
          "ramp": [[0, [0.1, 0.2, 0.8, 1]], [0.5, [0.9, 0.9, 0.9, 1]], [1, [0.8, 0.3, 0.1, 1]]],
          "shape": {"op": "sphere", "center": [0, 0, 0], "radius": 0.7},
          "texture": {"op": "plane", "point": [0, 0, 0], "normal": [0.2, 0.3, 1]}}"#,
    );
    check(
        "fractal",
        r#"{"op": "fractal", "terms": [[0.05, 8], [0.025, 16], [0.0125, 32]], "tau": 0.5,
          "ramp": [[0.2, [0.2, 0.6, 0.2, 1]], [0.8, [0.9, 0.8, 0.3, 1]]],
          "shape": {"op": "box", "center": [0, 0, 0], "half_size": [0.5, 0.5, 0.4], "radius": 0.05},
          "texture": {"op": "sphere", "center": [0.3, 0.2, 0.1], "radius": 0}}"#,
    );
    check(
        "painted_displace",
        r#"{"op": "displace", "amplitude": 0.03, "omega": 12, "tau": 0, "color": [0.3, 0.7, 0.9, 1],
          "shape": {"op": "torus", "center": [0, 0, 0], "axis": [0, 0, 1], "major": 0.6, "minor": 0.25},
          "texture": {"op": "segment", "a": [0, 0, -1], "b": [0, 0, 1], "radius": 0}}"#,
    );
}

/// A tree nested to the right: each `min` holds its first child while the next
/// `min` below it is evaluated, `levels + 1` results alive at once.
fn right_nested(levels: usize) -> String {
    let mut json = r#"{"op": "sphere", "center": [0, 0, 0], "radius": 0.3}"#.to_string();
    for k in 0..levels {
        json = format!(r#"{{"op": "min", "children": [{{"op": "sphere", "center": [{}, 0, 0], "radius": 0.05}}, {json}]}}"#, 0.1 * k as f64);
    }
    json
}

#[test]
fn a_tree_too_deep_for_the_stack_is_an_error() {
    // Just fits: the same image as the CPU's.
    let fits = FieldTree::from_json(&right_nested(STACK - 1)).unwrap();
    let cam = camera(64);
    let gpu = tracer().render(&fits, &cam).unwrap();
    let cpu = render(&fits, &cam).unwrap();
    let agree = gpu.render.hits.iter().zip(&cpu.hits).filter(|(a, b)| a.is_some() == b.is_some()).count();
    assert!(agree as f64 > 0.99 * cpu.hits.len() as f64);
    let deep = FieldTree::from_json(&right_nested(STACK)).unwrap();
    let err = tracer().render(&deep, &cam).unwrap_err().to_string();
    assert!(err.contains("results alive at once") && err.contains("cpu"), "{err}");
}

/// The shared tracer refuses a software rasterizer unless asked for one ("auto" then
/// falls back to the CPU tracer, about 27x faster than lavapipe), and renders on it
/// when asked ("gpu").
#[test]
fn the_shared_tracer_takes_a_software_adapter_only_when_asked() {
    let tree = FieldTree::from_json(SOFT_CSG_20).unwrap();
    let software = tracer().is_software();
    let cam = camera(32);
    assert!(thicket_render::field::render_on_shared_gpu(&tree, &cam, true).is_ok());
    let refused = thicket_render::field::render_on_shared_gpu(&tree, &cam, false);
    assert_eq!(refused.is_err(), software, "{:?}", refused.err());
}

/// Words of the instruction at `words[0]`, by the shader's layout (its header), read
/// from the words alone.
fn shader_length(words: &[f32]) -> usize {
    let count = |i: usize| words[i] as usize;
    match words[0] {
        opcode::PRIM => 22,
        opcode::OFFSET | opcode::H | opcode::MIN | opcode::MAX => 2,
        opcode::NEGATE => 1,
        opcode::WP | opcode::DISPLACE => 4,
        opcode::FRACTAL => 4 + 2 * count(1),
        opcode::PAINT => 5,
        opcode::RAMP => 2 + 5 * count(1),
        other => panic!("unknown opcode {other}"),
    }
}

/// The GPU program is the core's tape translated instruction by instruction (not a
/// second walk of the tree): as many instructions as the tape, each the opcode of the
/// tape's instruction at its place with its parameters, laid out as the shader reads
/// them, and the tape's stack depth.
#[test]
fn the_gpu_program_is_the_tape_translated() {
    let mut trees = vec![SOFT_CSG_20.to_string(), right_nested(5)];
    trees.push(
        r#"{"op": "max", "color": [0.1, 0.2, 0.3, 1], "children": [
          {"op": "fractal", "terms": [[0.05, 8], [0.02, 16]], "tau": 0.5, "ramp": [[0.2, [0.2, 0.6, 0.2, 1]], [0.8, [0.9, 0.8, 0.3, 1]]],
           "shape": {"op": "torus", "center": [0, 0, 0], "axis": [0.3, 0, 1], "major": 0.6, "minor": 0.2},
           "texture": {"op": "negate", "child": {"op": "point", "center": [0.3, 0.2, 0.1]}}},
          {"op": "displace", "amplitude": 0.03, "omega": 12, "color": [0.3, 0.7, 0.9, 1],
           "shape": {"op": "offset", "amount": 0.1, "child": {"op": "h", "children": [
             {"op": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]}, {"op": "rectangle", "center": [0, 0, 0], "half_size": [0.3, 0.2]}]}},
           "texture": {"op": "difference_wp", "p": 6, "children": [
             {"op": "segment", "a": [0, 0, -1], "b": [0, 0, 1]}, {"op": "box", "center": [0, 0, 0], "half_size": [0.2, 0.2, 0.2]}]}}]}"#
            .to_string(),
    );
    for json in &trees {
        let tree = FieldTree::from_json(json).unwrap();
        let program = Program::compile(&tree).unwrap();
        let tape = tree.instructions();
        assert_eq!(program.starts.len(), tape.len(), "{json}");
        assert_eq!(program.depth, tree.stack_depth());
        let mut at = 0;
        let mut primitives = 0;
        for (inst, &start) in tape.iter().zip(&program.starts) {
            assert_eq!(start, at, "instructions follow each other");
            let w = &program.words[start..];
            let expected = match inst {
                Instruction::Prim { prim: p, id, color } => {
                    // Parameters: the tape's compiled frame, id order and colour.
                    assert_eq!(*id, primitives);
                    primitives += 1;
                    assert_eq!(w[2..5], p.center.to_array().map(|v| v as f32));
                    assert_eq!(w[5..8], p.axes[0].to_array().map(|v| v as f32));
                    assert_eq!(w[18..22], color.map(|v| v as f32));
                    opcode::PRIM
                }
                Instruction::Offset(a) => {
                    assert_eq!(w[1], *a as f32);
                    opcode::OFFSET
                }
                Instruction::Negate => opcode::NEGATE,
                Instruction::H(n) | Instruction::Min(n) | Instruction::Max(n) => {
                    assert_eq!(w[1], *n as f32);
                    match inst {
                        Instruction::H(_) => opcode::H,
                        Instruction::Min(_) => opcode::MIN,
                        _ => opcode::MAX,
                    }
                }
                Instruction::Wp { p, n, .. } => {
                    assert_eq!(w[1..3], [*n as f32, *p as f32]);
                    opcode::WP
                }
                Instruction::Displace { amplitude, .. } => {
                    assert_eq!(w[1], *amplitude as f32);
                    opcode::DISPLACE
                }
                Instruction::Fractal { terms, .. } => {
                    assert_eq!(w[1], terms.len() as f32);
                    opcode::FRACTAL
                }
                Instruction::Paint(c) => {
                    assert_eq!(w[1..5], c.map(|v| v as f32));
                    opcode::PAINT
                }
                Instruction::Ramp(r) => {
                    assert_eq!(w[1], r.len() as f32);
                    opcode::RAMP
                }
            };
            assert_eq!(w[0], expected, "{inst:?}");
            at += shader_length(w);
        }
        assert_eq!(at, program.words.len(), "the words are exactly the tape's instructions");
        assert_eq!(primitives, tree.primitive_count());
    }
    // The depth check reads the tape's: one level more than the stack is refused.
    let deep = FieldTree::from_json(&right_nested(STACK)).unwrap();
    assert_eq!(deep.stack_depth(), STACK + 1);
    let err = Program::compile(&deep).unwrap_err().to_string();
    assert!(err.contains("results alive at once") && err.contains("cpu"), "{err}");
}
