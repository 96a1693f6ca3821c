//! The field core against independent references: central differences of its own
//! values for the gradients, the paper's identities (`|∇h| = 1` on orthogonal
//! unit-gradient inputs, `h[f, -f] = |f|`, `|∇w_p| <= 1`, `w_p -> max`), sampled values
//! for the bounds, the JSON text for the round trip, and the polygonizer's closed
//! 2-manifold contract for meshes of random trees.

use super::*;
use crate::polygonize::{mesh_field, GridParams, SurfaceCheck};
use crate::test_rng::Rng;
use serde_json::{json, Value};

fn v3(v: DVec3) -> Value {
    json!([v.x, v.y, v.z])
}

fn tree(v: &Value) -> FieldTree {
    FieldTree::from_json(&v.to_string()).unwrap_or_else(|e| panic!("{e}: {v}"))
}

/// One tree per op (and a few combinations), as JSON.
pub(super) fn catalogue() -> Vec<Value> {
    let plane = json!({"op": "plane", "point": [0.1, 0.2, 0.3], "normal": [1, 2, -0.5]});
    let sphere = json!({"op": "sphere", "center": [0.2, -0.1, 0.3], "radius": 0.7, "color": [1, 0, 0, 1]});
    let point = json!({"op": "point", "center": [0.1, 0, 0], "radius": 0.4, "color": [0, 1, 0, 1]});
    let segment = json!({"op": "segment", "a": [-0.5, 0.1, 0], "b": [0.6, -0.2, 0.3], "radius": 0.2, "color": [0, 0, 1, 1]});
    let rectangle = json!({"op": "rectangle", "center": [0, 0.1, 0], "half_size": [0.6, 0.3], "rotation": [0.9, 0.1, 0.3, -0.2], "radius": 0.1});
    let cuboid = json!({"op": "box", "center": [0.1, 0, -0.1], "half_size": [0.5, 0.3, 0.4], "rotation": [0.8, -0.3, 0.2, 0.4], "radius": 0.05, "color": [1, 1, 0, 0.5]});
    let torus = json!({"op": "torus", "center": [0, 0, 0.1], "axis": [0.2, 1, 0.3], "major": 0.8, "minor": 0.25, "color": [0, 1, 1, 1]});
    vec![
        plane.clone(),
        sphere.clone(),
        point.clone(),
        segment.clone(),
        rectangle.clone(),
        cuboid.clone(),
        torus.clone(),
        json!({"op": "offset", "child": cuboid, "amount": 0.2}),
        json!({"op": "negate", "child": torus}),
        json!({"op": "h", "children": [plane, sphere, segment]}),
        json!({"op": "min", "children": [sphere, cuboid, torus], "color": [0.5, 0.5, 0.5, 1]}),
        json!({"op": "max", "children": [sphere, cuboid]}),
        json!({"op": "intersection_wp", "p": 4, "children": [sphere, cuboid, segment]}),
        json!({"op": "union_wp", "p": 8, "children": [sphere, torus, point]}),
        json!({"op": "difference_wp", "p": 6, "children": [cuboid, sphere]}),
        json!({"op": "displace", "shape": segment, "texture": plane, "amplitude": 0.1, "omega": 12, "tau": 0.5}),
        json!({"op": "fractal", "shape": sphere, "texture": {"op": "union_wp", "p": 3, "children": [point, rectangle]},
               "terms": [[0.1, 5], [0.05, 11], [0.02, 23]], "tau": 0.3}),
        // Colour ramps (a single stop included), appended so the indices above stay.
        json!({"op": "displace", "shape": torus, "texture": plane, "amplitude": 0.05, "omega": 9, "tau": 1,
               "ramp": [[0, [0, 0, 0, 1]], [0.3, [1, 0, 0, 1]], [1, [1, 1, 1, 0.5]]]}),
        json!({"op": "fractal", "shape": cuboid, "texture": sphere, "terms": [[0.03, 7], [-0.01, 19]], "ramp": [[0.5, [0.1, 0.2, 0.3, 1]]]}),
    ]
}

/// Central, forward and backward differences of the tree's values at `x`.
fn differences(t: &FieldTree, x: DVec3, h: f64) -> (DVec3, DVec3, DVec3) {
    let f = |x: DVec3| t.sample(x).value;
    let f0 = f(x);
    let (mut central, mut forward, mut backward) = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO);
    for a in 0..3 {
        let mut e = DVec3::ZERO;
        e[a] = h;
        let (fp, fm) = (f(x + e), f(x - e));
        central[a] = (fp - fm) / (2.0 * h);
        forward[a] = (fp - f0) / h;
        backward[a] = (f0 - fm) / h;
    }
    (central, forward, backward)
}

#[test]
fn the_catalogue_has_every_op() {
    let ops: Vec<String> = catalogue().iter().map(|v| v["op"].as_str().unwrap().to_string()).collect();
    for name in Op::NAMES {
        assert!(ops.iter().any(|o| o == name), "{name} missing");
    }
}

#[test]
fn gradients_match_central_differences_for_every_node_type() {
    let mut rng = Rng(0x1234_5678_9abc_def1);
    for doc in catalogue() {
        let t = tree(&doc);
        let (mut checked, mut kinks) = (0, 0);
        for _ in 0..400 {
            let x = rng.vec(1.5);
            let (central, forward, backward) = differences(&t, x, 1e-6);
            // A kink within the step: the one-sided differences disagree (they do not
            // involve the analytic gradient, so this cannot hide a wrong one).
            if (forward - backward).abs().max_element() > 1e-3 {
                kinks += 1;
                continue;
            }
            let g = t.sample(x).gradient;
            assert!((g - central).length() < 1e-5 * (1.0 + central.length()), "{}: at {x} gradient {g} vs differences {central}", doc["op"]);
            checked += 1;
        }
        assert!(checked >= 360, "{}: only {checked} points away from kinks ({kinks} near)", doc["op"]);
    }
}

#[test]
fn h_of_orthogonal_unit_gradient_inputs_has_a_unit_gradient() {
    let mut rng = Rng(77);
    for _ in 0..200 {
        // Plane functions along an orthonormal frame, with offsets, some negated:
        // pairwise orthogonal gradients, as section 3's closure property asks.
        let n1 = rng.unit();
        let n2 = n1.any_orthonormal_pair().0;
        let frame = [n1, n2, n1.cross(n2)];
        let mut children: Vec<Value> = Vec::new();
        for n in frame {
            if rng.uniform() < 0.8 {
                let s = if rng.uniform() < 0.5 { 1.0 } else { -1.0 };
                children.push(json!({"op": "plane", "point": v3(rng.vec(0.5)), "normal": v3(n * s)}));
            }
        }
        if children.is_empty() {
            continue;
        }
        let t = tree(&json!({"op": "h", "children": children}));
        assert_eq!(t.lipschitz(), (children.len() as f64).sqrt(), "the generic bound");
        for _ in 0..20 {
            let g = t.sample(rng.vec(2.0)).gradient;
            assert!((g.length() - 1.0).abs() < 1e-12, "|∇h| = {}", g.length());
        }
    }
    // The skeletons are built that way: unit gradients everywhere but on the skeleton.
    for doc in &catalogue()[2..7] {
        let t = tree(doc);
        for _ in 0..500 {
            let s = t.sample(rng.vec(1.5));
            assert!((s.gradient.length() - 1.0).abs() < 1e-12, "{}: |∇f| = {}", doc["op"], s.gradient.length());
        }
    }
}

#[test]
fn h_of_f_and_minus_f_is_the_absolute_value() {
    let mut rng = Rng(5);
    for doc in catalogue() {
        let f = tree(&doc);
        let abs = tree(&json!({"op": "h", "children": [doc.clone(), {"op": "negate", "child": doc}]}));
        for _ in 0..100 {
            let x = rng.vec(1.5);
            let (a, b) = (abs.sample(x), f.sample(x));
            assert!((a.value - b.value.abs()).abs() <= 1e-12 * (1.0 + b.value.abs()), "{} vs |{}|", a.value, b.value);
            assert!((a.gradient - b.gradient * b.value.signum()).length() < 1e-9 || b.value == 0.0);
        }
    }
}

/// A random tree of unit-gradient leaves and the operations that keep `|∇f| <= 1`.
fn random_soft_tree(rng: &mut Rng, depth: u32) -> Value {
    if depth == 0 || rng.uniform() < 0.25 {
        return random_leaf(rng);
    }
    let p = rng.range(0.5, 40.0);
    let which = rng.pick(7);
    let mut kids = |n: usize| (0..n).map(|_| random_soft_tree(rng, depth - 1)).collect::<Vec<_>>();
    match which {
        0 => json!({"op": "intersection_wp", "p": p, "children": kids(2 + depth as usize % 2)}),
        1 => json!({"op": "union_wp", "p": p, "children": kids(2 + depth as usize % 3)}),
        2 => json!({"op": "difference_wp", "p": p, "children": kids(2)}),
        3 => json!({"op": "min", "children": kids(2)}),
        4 => json!({"op": "max", "children": kids(2)}),
        5 => json!({"op": "offset", "amount": 0.1, "child": kids(1)[0]}),
        _ => json!({"op": "negate", "child": kids(1)[0]}),
    }
}

fn color(rng: &mut Rng) -> Value {
    json!([rng.uniform(), rng.uniform(), rng.uniform(), 1.0])
}

/// A random bounded building block inside `[-0.9, 0.9]³`.
fn random_leaf(rng: &mut Rng) -> Value {
    let c = v3(rng.vec(0.5));
    let q = json!([rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(0.1, 1.0)]);
    let r = rng.range(0.08, 0.3);
    match rng.pick(6) {
        0 => json!({"op": "sphere", "center": c, "radius": rng.range(0.15, 0.45), "color": color(rng)}),
        1 => json!({"op": "point", "center": c, "radius": rng.range(0.15, 0.4), "color": color(rng)}),
        2 => json!({"op": "segment", "a": c, "b": v3(rng.vec(0.5)), "radius": r, "color": color(rng)}),
        3 => json!({"op": "rectangle", "center": c, "half_size": [rng.range(0.0, 0.3), rng.range(0.0, 0.3)], "rotation": q, "radius": r, "color": color(rng)}),
        4 => {
            json!({"op": "box", "center": c, "half_size": [rng.range(0.05, 0.3), rng.range(0.05, 0.3), rng.range(0.05, 0.3)], "rotation": q, "radius": rng.range(0.0, 0.1), "color": color(rng)})
        }
        _ => json!({"op": "torus", "center": c, "axis": v3(rng.unit()), "major": rng.range(0.15, 0.35), "minor": rng.range(0.05, 0.12), "color": color(rng)}),
    }
}

#[test]
fn wp_trees_have_gradients_no_longer_than_one() {
    let mut rng = Rng(99);
    for _ in 0..60 {
        let t = tree(&random_soft_tree(&mut rng, 4));
        assert!(t.lipschitz() <= 1.0);
        for _ in 0..200 {
            let g = t.sample(rng.vec(1.5)).gradient;
            assert!(g.length() <= 1.0 + 1e-12, "|∇f| = {} in {}", g.length(), t.to_json());
        }
    }
}

#[test]
fn wp_approaches_max_and_min_as_p_grows() {
    let mut rng = Rng(3);
    let spheres: Vec<Value> = (0..3).map(|_| json!({"op": "sphere", "center": v3(rng.vec(1.0)), "radius": rng.range(0.2, 0.6)})).collect();
    let f: Vec<FieldTree> = spheres.iter().map(tree).collect();
    let ln3 = 3f64.ln();
    for _ in 0..100 {
        let x = rng.vec(2.0);
        let v: Vec<f64> = f.iter().map(|t| t.sample(x).value).collect();
        let (max, min) = (v.iter().copied().fold(f64::MIN, f64::max), v.iter().copied().fold(f64::MAX, f64::min));
        let mut last = (f64::INFINITY, f64::INFINITY, f64::INFINITY);
        for p in [0.5, 2.0, 8.0, 32.0, 128.0, 512.0] {
            let i = tree(&json!({"op": "intersection_wp", "p": p, "children": spheres})).sample(x).value;
            let u = tree(&json!({"op": "union_wp", "p": p, "children": spheres})).sample(x).value;
            let d = tree(&json!({"op": "difference_wp", "p": p, "children": [spheres[0], spheres[1]]})).sample(x).value;
            let dmax = v[0].max(-v[1]);
            // max <= w_p <= max + ln(n) / p, and the gap shrinks with p.
            assert!(i >= max - 1e-12 && i <= max + ln3 / p + 1e-12, "p {p}: {i} vs max {max}");
            assert!(u <= min + 1e-12 && u >= min - ln3 / p - 1e-12, "p {p}: {u} vs min {min}");
            assert!(d >= dmax - 1e-12 && d <= dmax + 2f64.ln() / p + 1e-12, "p {p}: {d} vs {dmax}");
            let gaps = (i - max, min - u, d - dmax);
            assert!(gaps.0 <= last.0 && gaps.1 <= last.1 && gaps.2 <= last.2);
            last = gaps;
        }
        assert!(last.0 < 2e-3 && last.1 < 2e-3 && last.2 < 2e-3);
    }
}

#[test]
fn large_p_and_large_values_stay_finite() {
    // Spheres 1e3 apart, evaluated 1e3 from them: p f = 2e5, far past e^709.
    let a = json!({"op": "sphere", "center": [1000, 0, 0], "radius": 1, "color": [1, 0, 0, 1]});
    let b = json!({"op": "sphere", "center": [-1000, 0, 0], "radius": 1, "color": [0, 0, 1, 1]});
    for op in ["intersection_wp", "union_wp", "difference_wp"] {
        let t = tree(&json!({"op": op, "p": 200, "children": [a, b]}));
        for x in [DVec3::ZERO, DVec3::new(0.0, 1000.0, 0.0), DVec3::new(999.0, 0.0, 0.0), DVec3::new(-2000.0, 0.0, 5.0)] {
            let s = t.sample(x);
            assert!(s.value.is_finite() && s.gradient.is_finite() && s.color.iter().all(|c| c.is_finite()), "{op} at {x}: {s:?}");
            assert!(s.gradient.length() <= 1.0 + 1e-12);
            let (fa, fb) = ((x - DVec3::new(1000.0, 0.0, 0.0)).length() - 1.0, (x + DVec3::new(1000.0, 0.0, 0.0)).length() - 1.0);
            let want = match op {
                "intersection_wp" => fa.max(fb),
                "union_wp" => fa.min(fb),
                _ => fa.max(-fb),
            };
            assert!((s.value - want).abs() < 1e-2, "{op} at {x}: {} vs {want}", s.value);
        }
        let e = t.evaluate(&[Vec3::ZERO, Vec3::new(0.0, 1000.0, 0.0)]);
        assert!(e.values.iter().all(|v| v.is_finite()) && e.gradients.iter().all(|g| g.is_finite()));
    }
    // The ends of the accepted range stay finite too; beyond them is refused.
    for p in [crate::implicit::tree::P_RANGE.0, crate::implicit::tree::P_RANGE.1] {
        let t = tree(&json!({"op": "union_wp", "p": p, "children": [a, b]}));
        let s = t.sample(DVec3::new(0.0, 1000.0, 0.0));
        assert!(s.value.is_finite() && s.gradient.is_finite() && s.color.iter().all(|c| c.is_finite()), "p = {p}: {s:?}");
    }
    // Trees nested deeper than the limit, built in code or as a JSON value, are refused
    // before they are compiled (the recursion stays bounded).
    let mut deep = Node::new(Op::Sphere { center: DVec3::ZERO, radius: 1.0 });
    let mut value = json!({"op": "sphere", "center": [0, 0, 0], "radius": 1});
    for _ in 0..200 {
        deep = Node::new(Op::Negate { child: Box::new(deep) });
        value = json!({"op": "negate", "child": value});
    }
    assert!(FieldTree::new(deep).expect_err("refused").to_string().contains("nested deeper"));
    assert!(Node::from_value(&value).expect_err("refused").to_string().contains("nested deeper"));
    for p in [1e-310, 1e306] {
        let e = FieldTree::from_json(&json!({"op": "union_wp", "p": p, "children": [a, b]}).to_string()).expect_err("refused");
        assert!(e.to_string().contains("p must be between"), "{e}");
    }
}

/// Every field of `given` is in `written` with the same value (numbers as f64).
fn assert_contains(written: &Value, given: &Value) {
    match (written, given) {
        (Value::Object(w), Value::Object(g)) => g.iter().for_each(|(k, v)| assert_contains(w.get(k).unwrap_or_else(|| panic!("{k} not written")), v)),
        (Value::Array(w), Value::Array(g)) => {
            assert_eq!(w.len(), g.len());
            w.iter().zip(g).for_each(|(w, g)| assert_contains(w, g));
        }
        (Value::Number(w), Value::Number(g)) => assert_eq!(w.as_f64(), g.as_f64()),
        (w, g) => assert_eq!(w, g),
    }
}

#[test]
fn json_round_trips_every_node_type() {
    for doc in catalogue() {
        let t = tree(&doc);
        let text = t.to_json();
        let back = FieldTree::from_json(&text).unwrap();
        assert_eq!(back.node(), t.node(), "{text}");
        assert_eq!(back.to_json(), text);
        // What was written is what was read: every given field, the defaults added.
        let written: Value = serde_json::from_str(&text).unwrap();
        assert_contains(&written, &doc);
    }
    // Exact numbers survive.
    let t = tree(&json!({"op": "sphere", "center": [0.1, 1e-300, -7.3e12], "radius": 0.30000000000000004}));
    assert_eq!(FieldTree::from_json(&t.to_json()).unwrap().node(), t.node());
    // Defaults are filled in.
    let t = tree(&json!({"op": "segment", "a": [0, 0, 0], "b": [1, 0, 0]}));
    assert_eq!(t.node().op, Op::Segment { a: DVec3::ZERO, b: DVec3::X, radius: 0.0 });
}

#[test]
fn bad_input_gives_clear_errors() {
    let s = json!({"op": "sphere", "center": [0, 0, 0], "radius": 1});
    let cases: Vec<(String, &str)> = vec![
        ("{".into(), "not valid JSON"),
        ("[]".into(), "must be a JSON object"),
        (json!({"center": [0, 0, 0]}).to_string(), "needs an \"op\""),
        (json!({"op": "blob"}).to_string(), "unknown op \"blob\""),
        (json!({"op": 3}).to_string(), "\"op\" must be a string"),
        (json!({"op": "sphere", "center": [0, 0, 0]}).to_string(), "missing field \"radius\""),
        (json!({"op": "sphere", "center": [0, 0], "radius": 1}).to_string(), "list of 3 numbers"),
        (json!({"op": "sphere", "center": [0, 0, 0], "radius": "1"}).to_string(), "must be a number"),
        (json!({"op": "sphere", "center": [0, 0, 0], "radius": 1, "radus": 2}).to_string(), "unknown field \"radus\""),
        (json!({"op": "sphere", "center": [0, 0, 0], "radius": -1}).to_string(), "radius must be a finite number >= 0"),
        (json!({"op": "sphere", "center": [0, 0, 0], "radius": 1, "color": [1, 0, 0]}).to_string(), "\"color\" must be [r, g, b, a]"),
        (r#"{"op": "sphere", "center": [0, 0, 0], "radius": 1e999}"#.into(), "not valid JSON"),
        (json!({"op": "plane", "point": [0, 0, 0], "normal": [0, 0, 0]}).to_string(), "normal must not be zero"),
        (json!({"op": "torus", "center": [0, 0, 0], "axis": [0, 0, 0], "major": 1, "minor": 0.2}).to_string(), "axis must not be zero"),
        (json!({"op": "box", "center": [0, 0, 0], "half_size": [1, 1, 1], "rotation": [0, 0, 0, 0]}).to_string(), "non-zero quaternion"),
        (json!({"op": "box", "center": [0, 0, 0], "half_size": [1, -1, 1]}).to_string(), "half_size must be a finite number >= 0"),
        (json!({"op": "segment", "a": [1, 2, 3], "b": [1, 2, 3]}).to_string(), "must differ"),
        (json!({"op": "h", "children": []}).to_string(), "at least one child"),
        (json!({"op": "min", "children": s}).to_string(), "must be a list of nodes"),
        (json!({"op": "union_wp", "p": 0, "children": [s]}).to_string(), "p must be between"),
        (json!({"op": "intersection_wp", "p": -2, "children": [s]}).to_string(), "p must be between"),
        (json!({"op": "union_wp", "children": [s]}).to_string(), "missing field \"p\""),
        (json!({"op": "difference_wp", "p": 2, "children": [s, s, s]}).to_string(), "exactly two children"),
        (json!({"op": "difference_wp", "p": 2, "children": [s]}).to_string(), "exactly two children"),
        (json!({"op": "displace", "shape": s, "texture": s, "amplitude": 0.1, "omega": 0}).to_string(), "omega must be a finite number > 0"),
        (json!({"op": "fractal", "shape": s, "texture": s, "terms": []}).to_string(), "at least one term"),
        (json!({"op": "fractal", "shape": s, "texture": s, "terms": [[0.1]]}).to_string(), "terms[0] must be [a, omega]"),
        (
            json!({"op": "offset", "child": {"op": "max", "children": [s, {"op": "sphere"}]}, "amount": 1}).to_string(),
            "root.child.children[1] (sphere): missing field",
        ),
    ];
    for (text, want) in cases {
        match FieldTree::from_json(&text) {
            Err(crate::Error::InvalidParameter(msg)) => assert!(msg.contains(want), "{text}: {msg:?} should say {want:?}"),
            other => panic!("{text}: {other:?}"),
        }
    }
    // Trees built in code reach the same checks: NaN and infinite parameters.
    let bad = [
        Op::Sphere { center: DVec3::new(f64::NAN, 0.0, 0.0), radius: 1.0 },
        Op::Sphere { center: DVec3::ZERO, radius: f64::INFINITY },
        Op::Torus { center: DVec3::ZERO, axis: DVec3::Z, major: f64::NAN, minor: 0.1 },
        Op::Offset { child: Box::new(Node::new(Op::Point { center: DVec3::ZERO, radius: 1.0 })), amount: f64::NEG_INFINITY },
        Op::UnionWp { p: f64::NAN, children: vec![Node::new(Op::Point { center: DVec3::ZERO, radius: 1.0 })] },
        Op::Plane { point: DVec3::ZERO, normal: DVec3::splat(1e300) },
    ];
    for op in bad {
        let name = op.name();
        assert!(matches!(FieldTree::new(Node::new(op)), Err(crate::Error::InvalidParameter(_))), "{name}");
    }
    let painted = Node::new(Op::Point { center: DVec3::ZERO, radius: 1.0 }).with_color([0.0, f64::NAN, 0.0, 1.0]);
    assert!(FieldTree::new(painted).is_err());
    // Deep nesting is refused by the parser, not a stack overflow.
    let mut deep = s.to_string();
    for _ in 0..400 {
        deep = format!(r#"{{"op": "negate", "child": {deep}}}"#);
    }
    assert!(FieldTree::from_json(&deep).is_err());
}

/// A random tree of every kind of node (planes and complements included).
pub(super) fn random_any_tree(rng: &mut Rng, depth: u32) -> Value {
    if depth == 0 || rng.uniform() < 0.2 {
        return if rng.uniform() < 0.15 { json!({"op": "plane", "point": v3(rng.vec(0.5)), "normal": v3(rng.unit())}) } else { random_leaf(rng) };
    }
    let mut kid = || random_any_tree(rng, depth - 1);
    let (a, b, c) = (kid(), kid(), kid());
    match rng.pick(10) {
        0 => json!({"op": "h", "children": [a, b]}),
        1 => json!({"op": "displace", "shape": a, "texture": b, "amplitude": rng.range(-0.1, 0.2), "omega": rng.range(1.0, 20.0), "tau": rng.range(-3.0, 3.0)}),
        2 => {
            json!({"op": "fractal", "shape": a, "texture": b, "terms": [[rng.range(0.0, 0.1), rng.range(1.0, 9.0)], [rng.range(-0.05, 0.05), rng.range(5.0, 30.0)]]})
        }
        3 => json!({"op": "min", "children": [a, b, c]}),
        4 => json!({"op": "max", "children": [a, b]}),
        5 => json!({"op": "intersection_wp", "p": rng.range(0.5, 30.0), "children": [a, b, c]}),
        6 => json!({"op": "union_wp", "p": rng.range(0.5, 30.0), "children": [a, b]}),
        7 => json!({"op": "difference_wp", "p": rng.range(0.5, 30.0), "children": [a, b]}),
        8 => json!({"op": "offset", "child": a, "amount": rng.range(-0.2, 0.3)}),
        _ => json!({"op": "negate", "child": a}),
    }
}

#[test]
fn interval_and_lipschitz_bounds_hold_at_sampled_points() {
    let mut rng = Rng(2024);
    let mut docs = catalogue();
    docs.extend((0..60).map(|_| random_any_tree(&mut rng, 4)));
    for doc in docs {
        let t = tree(&doc);
        let l = t.lipschitz();
        for _ in 0..20 {
            let c = rng.vec(1.2);
            let half = DVec3::new(rng.range(0.0, 0.5), rng.range(0.0, 0.5), rng.range(0.0, 0.5));
            let (lo, hi) = (c - half, c + half);
            let (il, iu) = t.interval(lo, hi);
            let (rl, ru) = t.range(lo, hi);
            assert!(il <= iu && rl <= ru && rl >= il && ru <= iu);
            for _ in 0..50 {
                let x = lo + (hi - lo) * DVec3::new(rng.uniform(), rng.uniform(), rng.uniform());
                let v = t.sample(x).value;
                let tol = 1e-9 * (1.0 + v.abs());
                assert!(v >= rl - tol && v <= ru + tol, "{v} outside [{rl}, {ru}] (interval [{il}, {iu}]) in {lo}..{hi}: {doc}");
            }
        }
        for _ in 0..200 {
            let x = rng.vec(1.5);
            let y = x + rng.vec(0.3);
            let (fx, fy) = (t.sample(x).value, t.sample(y).value);
            assert!((fx - fy).abs() <= l * (x - y).length() * (1.0 + 1e-9) + 1e-12, "Lipschitz {l}: {fx} vs {fy} over {}: {doc}", (x - y).length());
        }
    }
}

#[test]
fn intervals_are_tight_for_planes_and_spheres() {
    let t = tree(&json!({"op": "sphere", "center": [0, 0, 0], "radius": 1}));
    assert_eq!(t.interval(DVec3::new(2.0, -1.0, -1.0), DVec3::new(3.0, 1.0, 1.0)), (1.0, 11f64.sqrt() - 1.0));
    // A point is the distance to its centre: as tight as the sphere's.
    let t = tree(&json!({"op": "point", "center": [0, 0, 0], "radius": 1}));
    assert_eq!(t.interval(DVec3::new(2.0, -1.0, -1.0), DVec3::new(3.0, 1.0, 1.0)), (1.0, 11f64.sqrt() - 1.0));
    let t = tree(&json!({"op": "plane", "point": [0, 0, 0], "normal": [0, 0, 2]}));
    assert_eq!(t.interval(DVec3::splat(-1.0), DVec3::new(1.0, 1.0, 3.0)), (-1.0, 3.0));
    // A culled box: no surface where the interval keeps one sign.
    let t = tree(&catalogue()[13]);
    let (l, _) = t.interval(DVec3::splat(3.0), DVec3::splat(3.5));
    assert!(l > 0.0);
}

#[test]
fn the_solid_lies_inside_its_box() {
    let mut rng = Rng(31337);
    let mut bounded = 0;
    for _ in 0..120 {
        let doc = random_any_tree(&mut rng, 3);
        let t = tree(&doc);
        let Some(b) = t.solid_box() else { continue };
        bounded += 1;
        let (lo, hi) = t.bounds().unwrap();
        assert!(lo.as_dvec3().cmple(b.lo).all() && hi.as_dvec3().cmpge(b.hi).all());
        for _ in 0..400 {
            let x = rng.vec(2.5);
            let inside_box = x.cmpge(b.lo).all() && x.cmple(b.hi).all();
            assert!(inside_box || t.sample(x).value > 0.0, "{x} is in the solid, outside {b:?}: {doc}");
        }
    }
    assert!(bounded > 40, "{bounded}");
    // What cannot be bounded says so.
    for doc in [&catalogue()[0], &catalogue()[8]] {
        assert_eq!(tree(doc).solid_box(), None);
    }
    // The rules on known shapes.
    let b = tree(&json!({"op": "offset", "amount": 0.5, "child": {"op": "sphere", "center": [1, 2, 3], "radius": 1}})).solid_box().unwrap();
    assert_eq!((b.lo, b.hi), (DVec3::new(-0.5, 0.5, 1.5), DVec3::new(2.5, 3.5, 4.5)));
    let b = tree(&catalogue()[6]).solid_box().unwrap();
    let axis = DVec3::new(0.2, 1.0, 0.3).normalize();
    let want = (DVec3::ONE - axis * axis).powf(0.5) * 0.8 + 0.25;
    assert!((b.hi - DVec3::new(0.0, 0.0, 0.1) - want).abs().max_element() < 1e-12);
}

/// Points just outside a box and in a shell around it: on a grid of every face at
/// offsets from a hair to 0.3, and at random in the box grown by 0.6.
fn points_outside(b: Aabb, rng: &mut Rng) -> Vec<DVec3> {
    let mut out = Vec::new();
    let size = b.hi - b.lo;
    for a in 0..3 {
        let (u, v) = ((a + 1) % 3, (a + 2) % 3);
        for side in [-1.0, 1.0] {
            for offset in [1e-9, 1e-3, 0.01, 0.04, 0.1, 0.3] {
                for i in 0..=16 {
                    for j in 0..=16 {
                        let mut x = b.lo;
                        x[a] = if side > 0.0 { b.hi[a] + offset } else { b.lo[a] - offset };
                        x[u] += size[u] * f64::from(i) / 16.0;
                        x[v] += size[v] * f64::from(j) / 16.0;
                        out.push(x);
                    }
                }
            }
        }
    }
    let g = b.grown(0.6);
    while out.len() < 6 * 6 * 289 + 2000 {
        let x = g.lo + (g.hi - g.lo) * DVec3::new(rng.uniform(), rng.uniform(), rng.uniform());
        if !(x.cmpge(b.lo).all() && x.cmple(b.hi).all()) {
            out.push(x);
        }
    }
    out
}

/// A soft union of 2 to 12 random leaves (some cut, intersected or in a nested soft
/// union), with small `p` too: the unions whose blend reaches furthest past their
/// children (up to `ln(n) / p`).
fn random_soft_union(rng: &mut Rng) -> Value {
    let n = 2 + rng.pick(11);
    let kids: Vec<Value> = (0..n)
        .map(|_| match rng.pick(6) {
            0 => json!({"op": "difference_wp", "p": rng.range(1.0, 20.0), "children": [random_leaf(rng), random_leaf(rng)]}),
            1 => json!({"op": "intersection_wp", "p": rng.range(1.0, 20.0), "children": [random_leaf(rng), random_leaf(rng)]}),
            2 => json!({"op": "union_wp", "p": rng.range(1.0, 20.0), "children": [random_leaf(rng), random_leaf(rng), random_leaf(rng)]}),
            3 => json!({"op": "offset", "amount": rng.range(-0.05, 0.1), "child": random_leaf(rng)}),
            _ => random_leaf(rng),
        })
        .collect();
    json!({"op": "union_wp", "p": if rng.uniform() < 0.3 { rng.range(0.5, 3.0) } else { rng.range(3.0, 30.0) }, "children": kids})
}

#[test]
fn soft_unions_have_no_surface_outside_their_box() {
    let mut rng = Rng(0x50f7_b0dd);
    let (mut bulging, mut trees) = (0, 0);
    for _ in 0..60 {
        let doc = if rng.uniform() < 0.7 { random_soft_union(&mut rng) } else { random_soft_tree(&mut rng, 3) };
        let t = tree(&doc);
        let Some(b) = t.solid_box() else { continue };
        trees += 1;
        let points = points_outside(b, &mut rng);
        let e = t.evaluate(&points.iter().map(|p| p.as_vec3()).collect::<Vec<_>>());
        for (x, v) in points.iter().zip(&e.values) {
            // The batch's single precision first, then the exact value where it is near 0.
            assert!(*v > 1e-4 || t.sample(*x).value > 0.0, "{x} is in the solid, outside {b:?}: {doc}");
        }
        // The blend reaches past the farthest child: a box without it (each face at
        // the farthest child's reach) would miss surface. Counted so the test shows
        // the bound is not met by luck.
        if doc["op"] == "union_wp" {
            let p = doc["p"].as_f64().unwrap();
            let kids: Vec<FieldTree> = doc["children"].as_array().unwrap().iter().map(tree).collect();
            let reach = kids.iter().map(|k| k.solid_box().unwrap()).reduce(Aabb::union).unwrap();
            let pushed = (0..3).any(|a| {
                b.hi[a] > reach.hi[a] + 0.01 / p && {
                    let mut x = (b.lo + b.hi) * 0.5;
                    (0..200).any(|_| {
                        x = b.lo + (b.hi - b.lo) * DVec3::new(rng.uniform(), rng.uniform(), rng.uniform());
                        x[a] = reach.hi[a] + 1e-3;
                        t.sample(x).value <= 0.0
                    })
                }
            });
            bulging += usize::from(pushed);
        }
    }
    assert!(trees >= 50, "{trees}");
    assert!(bulging >= 5, "only {bulging} unions had surface beyond their children's boxes");
}

#[test]
fn a_soft_union_box_is_exact_for_concentric_spheres_and_reaches_each_child() {
    // Two equal concentric spheres: g = |x| - r - ln(2)/p exactly, the box's faces at
    // w_p(r, r) = r + ln(2)/p, the true extent.
    let (r, p) = (0.5, 4.0);
    let s = json!({"op": "sphere", "center": [0, 0, 0], "radius": r});
    let b = tree(&json!({"op": "union_wp", "p": p, "children": [s, s]})).solid_box().unwrap();
    let want = r + 2f64.ln() / p;
    assert!((b.hi - DVec3::splat(want)).abs().max_element() < 1e-9 && (b.lo + DVec3::splat(want)).abs().max_element() < 1e-9, "{b:?}");
    // A small sphere far from a large one: the large one's faces move out by
    // ln(1 + e^(-p δ))/p, far less than the old rule's largest radius plus ln(2)/p.
    let big = json!({"op": "sphere", "center": [0, 0, 0], "radius": 1});
    let small = json!({"op": "sphere", "center": [3, 0, 0], "radius": 0.1});
    let b = tree(&json!({"op": "union_wp", "p": 8, "children": [big, small]})).solid_box().unwrap();
    let near = |got: f64, want: f64| (got - want).abs() < 1e-9;
    // y and z: the big sphere reaches 1, the small one 0.1: δ = 0.9.
    assert!(near(b.hi.y, 1.0 + (1.0 + (-8.0 * 0.9f64).exp()).ln() / 8.0), "{b:?}");
    assert!(near(b.lo.y, -b.hi.y) && near(b.hi.z, b.hi.y));
    // x: the small sphere reaches 3.1 on the high side (2.1 past the big one), the big
    // one -1 on the low side (3.9 past the small one).
    assert!(near(b.hi.x, 3.1 + (1.0 + (-8.0 * 2.1f64).exp()).ln() / 8.0), "{b:?}");
    assert!(near(b.lo.x, -1.0 - (1.0 + (-8.0 * 3.9f64).exp()).ln() / 8.0), "{b:?}");
    // The old rule: both children's boxes grown by the larger radius, 1, and ln(2)/8.
    assert!(b.hi.y < 1.0 + 2f64.ln() / 8.0 - 0.08 && b.hi.x < 4.0, "{b:?}");
}

#[test]
fn the_benchmark_trees_box_is_near_its_surface() {
    let t = FieldTree::from_json(samples::SOFT_CSG_20).unwrap();
    let b = t.solid_box().unwrap();
    // The solid's points on a lattice of 97³ over its box grown by 0.2: all inside the
    // box, and their box (at most the solid's) at least 0.8x the bound along each axis.
    let g = b.grown(0.2);
    let n = 97;
    let points: Vec<Vec3> = (0..n * n * n)
        .map(|i| (g.lo + (g.hi - g.lo) * DVec3::new((i % n) as f64, (i / n % n) as f64, (i / n / n) as f64) / (n - 1) as f64).as_vec3())
        .collect();
    let values = t.evaluate(&points).values;
    let inside: Vec<DVec3> = points.iter().zip(&values).filter(|(_, v)| **v <= 0.0).map(|(p, _)| p.as_dvec3()).collect();
    let (lo, hi) = inside.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    assert!(lo.cmpge(b.lo).all() && hi.cmple(b.hi).all(), "{lo} {hi} outside {b:?}");
    let ratio = (b.hi - b.lo) / (hi - lo);
    assert!(ratio.max_element() <= 1.25, "the bound {b:?} is {ratio} the solid's [{lo}, {hi}]");
}

#[test]
fn colours_ids_and_textures_follow_the_weights() {
    let red = json!({"op": "sphere", "center": [-1, 0, 0], "radius": 0.5, "color": [1, 0, 0, 1]});
    let blue = json!({"op": "sphere", "center": [1, 0, 0], "radius": 0.5, "color": [0, 0, 1, 1]});
    let u = tree(&json!({"op": "union_wp", "p": 4, "children": [red, blue]}));
    // Midway the weights are equal; near one sphere its colour dominates, with the
    // softmax's weight e^(-p f) / Σ.
    let mid = u.sample(DVec3::ZERO);
    assert!((mid.color[0] - 0.5).abs() < 1e-12 && (mid.color[2] - 0.5).abs() < 1e-12 && mid.color[3] == 1.0);
    let near = u.sample(DVec3::new(-1.5, 0.0, 0.0));
    let (fr, fb) = (0.0f64, 2.0f64);
    let wr = (-4.0 * fr).exp() / ((-4.0 * fr).exp() + (-4.0 * fb).exp());
    assert!((near.color[0] - wr).abs() < 1e-12 && near.id == 0);
    assert_eq!(u.sample(DVec3::new(1.2, 0.0, 0.0)).id, 1);
    // min takes the nearer's colour and id; a colour on an operation paints it all.
    let m = tree(&json!({"op": "min", "children": [red, blue]}));
    assert_eq!((m.sample(DVec3::new(0.9, 0.0, 0.0)).color, m.sample(DVec3::new(0.9, 0.0, 0.0)).id), ([0.0, 0.0, 1.0, 1.0], 1));
    let painted = tree(&json!({"op": "min", "children": [red, blue], "color": [0, 1, 0, 1]}));
    assert_eq!(painted.sample(DVec3::new(0.9, 0.0, 0.0)).color, [0.0, 1.0, 0.0, 1.0]);
    // h blends by its positive parts fi / Σ fj where both are outside.
    let hb = tree(&json!({"op": "h", "children": [
        {"op": "plane", "point": [0, 0, 0], "normal": [1, 0, 0], "color": [1, 0, 0, 1]},
        {"op": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "color": [0, 0, 1, 1]}]}));
    let s = hb.sample(DVec3::new(3.0, 1.0, 0.0));
    assert!((s.value - 10f64.sqrt()).abs() < 1e-12 && (s.color[0] - 0.75).abs() < 1e-12 && (s.color[2] - 0.25).abs() < 1e-12 && s.id == 0);
    let s = hb.sample(DVec3::new(-3.0, -1.0, 0.0));
    assert_eq!((s.value, s.color, s.id), (-1.0, [0.0, 0.0, 1.0, 1.0], 1));
    // The texture function of the texture child, (1 + cos(omega f1 + tau)) / 2,
    // carried without displacing at amplitude 0.
    let plane = json!({"op": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]});
    let d = tree(&json!({"op": "displace", "shape": red, "texture": plane, "amplitude": 0, "omega": 3, "tau": 0.25}));
    for z in [-0.4, 0.1, 0.7] {
        let s = d.sample(DVec3::new(-1.0, 0.2, z));
        assert!((s.texture - 0.5 * (1.0 + (3.0 * z + 0.25).cos())).abs() < 1e-12);
        assert!((s.value - ((DVec3::new(0.0, 0.2, z)).length() - 0.5)).abs() < 1e-12);
        assert_eq!((s.color, s.id), ([1.0, 0.0, 0.0, 1.0], 0));
    }
    // Primitives count in JSON order, a displace's texture included.
    assert_eq!(d.primitive_count(), 2);
}

/// A ramp evaluated by hand: linear between the stops around `t`, clamped at the ends.
fn ramp_by_hand(stops: &[(f64, [f64; 4])], t: f64) -> [f64; 4] {
    if t <= stops[0].0 {
        return stops[0].1;
    }
    for w in stops.windows(2) {
        let ((p0, c0), (p1, c1)) = (w[0], w[1]);
        if t <= p1 {
            let s = (t - p0) / (p1 - p0);
            return [0, 1, 2, 3].map(|k| (1.0 - s) * c0[k] + s * c1[k]);
        }
    }
    stops[stops.len() - 1].1
}

#[test]
fn ramp_colours_follow_the_texture_function() {
    let stops = [(0.1, [0.0, 0.0, 1.0, 1.0]), (0.4, [1.0, 0.0, 0.0, 1.0]), (0.9, [1.0, 1.0, 0.0, 0.5])];
    let ramp: Vec<Value> = stops.iter().map(|(p, c)| json!([p, c])).collect();
    let sphere = json!({"op": "sphere", "center": [0, 0, 0], "radius": 0.5, "color": [0, 1, 0, 1]});
    let plane = json!({"op": "plane", "point": [0, 0, 0.1], "normal": [0, 0, 2]});
    let (omega, tau) = (7.0, 0.3);
    let d = tree(&json!({"op": "displace", "shape": sphere, "texture": plane, "amplitude": 0.02, "omega": omega, "tau": tau, "ramp": ramp}));
    let mut rng = Rng(17);
    let points: Vec<DVec3> = (0..400).map(|_| rng.vec(1.0)).collect();
    let e = d.evaluate(&points.iter().map(|p| p.as_vec3()).collect::<Vec<_>>());
    let (mut low, mut high) = (0, 0);
    for (i, x) in points.iter().enumerate() {
        // Section 2's texture function of the plane, computed here from the formula.
        let t = 0.5 * (1.0 + (omega * (x.z - 0.1) + tau).cos());
        low += usize::from(t < 0.1);
        high += usize::from(t > 0.9);
        let want = ramp_by_hand(&stops, t);
        let s = d.sample(*x);
        assert!((s.texture - t).abs() < 1e-12);
        for k in 0..4 {
            assert!((s.color[k] - want[k]).abs() < 1e-12, "{x}: {:?} vs {want:?} at t = {t}", s.color);
            assert!((f64::from(e.colors[i][k]) - want[k]).abs() < 1e-6);
        }
    }
    assert!(low > 5 && high > 5, "both clamped ends sampled: {low} {high}");
    // The colour then blends through the parent like any colour: a union far from the
    // displaced sphere takes the other child's, next to it the ramp's.
    let blue_box = json!({"op": "box", "center": [3, 0, 0], "half_size": [0.5, 0.5, 0.5], "color": [0, 0, 1, 1]});
    let displaced = d.node().to_value();
    let u = tree(&json!({"op": "union_wp", "p": 40, "children": [displaced, blue_box]}));
    let x = DVec3::new(-0.6, 0.0, 0.25);
    let t = 0.5 * (1.0 + (omega * 0.15 + tau).cos());
    let (got, want) = (u.sample(x).color, ramp_by_hand(&stops, t));
    assert!(got.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-9), "{got:?} vs {want:?}");
    let far = u.sample(DVec3::new(3.6, 0.0, 0.0)).color;
    assert!(far.iter().zip([0.0, 0.0, 1.0, 1.0]).all(|(a, b)| (a - b).abs() < 1e-12), "{far:?}");
    // A colour on the node itself still replaces what it carries.
    let mut painted = displaced.clone();
    painted["color"] = json!([0.2, 0.2, 0.2, 1]);
    assert_eq!(tree(&painted).sample(x).color, [0.2, 0.2, 0.2, 1.0]);
    // A fractal's ramp reads its weighted mean texture value.
    let f = tree(&json!({"op": "fractal", "shape": sphere, "texture": plane, "terms": [[0.02, 3], [-0.01, 11]], "tau": tau, "ramp": ramp}));
    for x in &points[..50] {
        let tex = |w: f64| 0.5 * (1.0 + (w * (x.z - 0.1) + tau).cos());
        let t = (0.02 * tex(3.0) + 0.01 * tex(11.0)) / 0.03;
        let want = ramp_by_hand(&stops, t);
        let s = f.sample(*x);
        assert!((s.texture - t).abs() < 1e-12 && s.color.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-12));
    }
    // Round trip: the ramp is written and read back equal.
    for t in [&d, &f] {
        let text = t.to_json();
        assert!(text.contains("\"ramp\":[[0.1,[0.0,0.0,1.0,1.0]]"), "{text}");
        assert_eq!(FieldTree::from_json(&text).unwrap().node(), t.node());
    }
}

#[test]
fn bad_ramps_are_refused_naming_the_node_and_field() {
    let s = json!({"op": "sphere", "center": [0, 0, 0], "radius": 1});
    let displace =
        |ramp: Value| json!({"op": "min", "children": [s, {"op": "displace", "shape": s, "texture": s, "amplitude": 0.1, "omega": 2, "ramp": ramp}]});
    let cases = [
        (json!([]), "root.children[1] (displace): ramp needs at least one stop"),
        (json!([[0.5, [1, 0, 0]]]), "root.children[1] (displace): ramp[0] must be [position, [r, g, b, a]]"),
        (json!([[0.5]]), "ramp[0] must be [position, [r, g, b, a]]"),
        (json!({"a": 1}), "\"ramp\" must be a list of stops"),
        (json!([[0, [1, 0, 0, 1]], [1.5, [1, 0, 0, 1]]]), "ramp[1]'s position must be in [0, 1], got 1.5"),
        (json!([[-0.1, [1, 0, 0, 1]]]), "ramp[0]'s position must be in [0, 1]"),
        (json!([[0.5, [1, 0, 0, 1]], [0.5, [0, 1, 0, 1]]]), "ramp positions must increase, ramp[1] is at 0.5 after 0.5"),
        (json!([[0.6, [1, 0, 0, 1]], [0.2, [0, 1, 0, 1]]]), "ramp positions must increase"),
    ];
    for (ramp, want) in cases {
        let text = displace(ramp).to_string();
        match FieldTree::from_json(&text) {
            Err(crate::Error::InvalidParameter(msg)) => assert!(msg.contains(want), "{text}: {msg:?} should say {want:?}"),
            other => panic!("{text}: expected an error saying {want:?}, got {other:?}"),
        }
    }
    // Non-finite colours, from a tree built in code.
    let sphere = Node::new(Op::Sphere { center: DVec3::ZERO, radius: 1.0 });
    let op = Op::Fractal {
        shape: Box::new(sphere.clone()),
        texture: Box::new(sphere),
        terms: vec![[0.1, 2.0]],
        tau: 0.0,
        ramp: Some(vec![(0.0, [f64::NAN, 0.0, 0.0, 1.0])]),
    };
    let msg = FieldTree::new(Node::new(op)).unwrap_err().to_string();
    assert!(msg.contains("root (fractal): ramp[0]'s colour must be four finite numbers"), "{msg}");
    // A ramp where the op has none is an unknown field.
    let text = json!({"op": "offset", "child": s, "amount": 0.1, "ramp": [[0, [1, 1, 1, 1]]]}).to_string();
    assert!(FieldTree::from_json(&text).unwrap_err().to_string().contains("unknown field \"ramp\""));
}

/// Every node type: the block loops (values, gradients and attributes in blocks of
/// 64 and parallel chunks) against one point at a time, at many random points.
#[test]
fn batches_equal_single_samples_across_blocks_and_chunks() {
    let mut rng = Rng(8);
    for doc in catalogue() {
        batch_equals_single_samples(&tree(&doc), &mut rng);
    }
    batch_equals_single_samples(&FieldTree::from_json(super::samples::SOFT_CSG_20).unwrap(), &mut rng);
}

fn batch_equals_single_samples(t: &FieldTree, rng: &mut Rng) {
    let points: Vec<Vec3> = (0..2500).map(|_| rng.vec(1.5).as_vec3()).collect();
    let e = t.evaluate(&points);
    let mut values = vec![0.0; points.len()];
    let mut grads = vec![Vec3::ZERO; points.len()];
    let mut attrs = vec![0.0; points.len() * ATTRIBUTE_COUNT];
    t.values(&points, &mut values);
    t.gradients(&points, &mut grads);
    t.attributes(&points, &mut attrs);
    for (i, p) in points.iter().enumerate() {
        let s = t.sample(p.as_dvec3());
        assert_eq!((e.values[i], values[i]), (s.value as f32, s.value as f32));
        assert_eq!((e.gradients[i], grads[i]), (s.gradient.as_vec3(), s.gradient.as_vec3()));
        assert_eq!(e.colors[i], s.color.map(|c| c as f32));
        assert_eq!(&attrs[i * ATTRIBUTE_COUNT..i * ATTRIBUTE_COUNT + 4], &e.colors[i][..]);
        assert_eq!((attrs[i * ATTRIBUTE_COUNT + ATTRIBUTE_TEXTURE], e.textures[i]), (s.texture as f32, s.texture as f32));
        assert_eq!((attrs[i * ATTRIBUTE_COUNT + ATTRIBUTE_ID], e.ids[i]), (s.id as f32, s.id));
    }
}

/// A random closed, bounded tree for meshing: soft unions of shapes, some cut,
/// intersected, grown or displaced.
pub(crate) fn random_mesh_tree(rng: &mut Rng) -> Value {
    let part = |rng: &mut Rng| -> Value {
        let a = random_leaf(rng);
        match rng.pick(6) {
            0 => json!({"op": "difference_wp", "p": rng.range(4.0, 30.0), "children": [a, random_leaf(rng)]}),
            1 => json!({"op": "intersection_wp", "p": rng.range(4.0, 30.0), "children": [a, {"op": "sphere", "center": v3(rng.vec(0.3)), "radius": 0.6}]}),
            2 => {
                json!({"op": "displace", "shape": a, "texture": random_leaf(rng), "amplitude": rng.range(0.0, 0.04), "omega": rng.range(5.0, 15.0), "tau": rng.range(0.0, 6.0)})
            }
            3 => json!({"op": "offset", "child": a, "amount": rng.range(-0.03, 0.05)}),
            4 => json!({"op": "h", "children": [a, random_leaf(rng)]}),
            _ => a,
        }
    };
    let parts: Vec<Value> = (0..2 + rng.pick(3)).map(|_| part(rng)).collect();
    if rng.uniform() < 0.5 {
        json!({"op": "union_wp", "p": rng.range(3.0, 30.0), "children": parts})
    } else {
        json!({"op": "min", "children": parts})
    }
}

#[test]
fn random_trees_mesh_closed_manifold_on_their_zero_set() {
    let mut rng = Rng(0xfeed_beef);
    let mut meshed = 0;
    for seed in 0..20 {
        let doc = random_mesh_tree(&mut rng);
        let t = tree(&doc);
        let (lo, hi) = t.bounds().expect("bounded");
        let resolution = 36;
        let margin = 2.5 * (hi - lo).max_element() / resolution as f32;
        let bounds = (lo - margin, hi + margin);
        let m = mesh_field(&t, &GridParams { bounds, resolution, refine: true }).unwrap();
        let check = SurfaceCheck::of(&m.positions, &m.triangles);
        assert!(check.is_closed_manifold(), "seed {seed}: {check:?}: {doc}");
        if m.triangles.is_empty() {
            continue;
        }
        meshed += 1;
        let cell = ((bounds.1 - bounds.0) / m.cells.as_vec3()).max_element() as f64;
        for p in &m.positions {
            let s = t.sample(p.as_dvec3());
            let d = s.value.abs() / s.gradient.length().max(1e-9);
            assert!(d < 0.5 * cell, "seed {seed}: vertex {p} is {d} from the zero set (cell {cell}): {doc}");
        }
        // The carried attributes ride along: colour, texture, a primitive's id.
        assert_eq!(m.attribute_count, ATTRIBUTE_COUNT);
        for a in m.attributes.chunks_exact(ATTRIBUTE_COUNT) {
            assert!(a[..4].iter().all(|c| (-1e-6..=1.0 + 1e-6).contains(c)), "{a:?}");
            assert!((0.0..=1.0).contains(&a[ATTRIBUTE_TEXTURE]));
            assert!(a[ATTRIBUTE_ID].fract() == 0.0 && (a[ATTRIBUTE_ID] as u32) < t.primitive_count());
        }
    }
    assert!(meshed >= 18, "{meshed} of 20 trees had a surface");
}

#[test]
fn interval_culled_meshes_equal_the_unculled_bit_for_bit() {
    use crate::polygonize::grid::Unculled;
    let mut rng = Rng(0x5eed_cafe);
    let same = |a: &crate::polygonize::FieldMesh, b: &crate::polygonize::FieldMesh| {
        a.positions == b.positions
            && a.triangles == b.triangles
            && a.normals == b.normals
            && a.attributes.iter().map(|v| v.to_bits()).eq(b.attributes.iter().map(|v| v.to_bits()))
    };
    let mut meshed = 0;
    // Closed trees in their own bounds, and trees of every node (planes and
    // complements: solids the box cuts, culled inside too) in a fixed box; grids whose
    // cells the slabs and culling blocks do not divide.
    for n in 0..16 {
        let (doc, bounds, resolution) = if n % 2 == 0 {
            let doc = random_mesh_tree(&mut rng);
            let (lo, hi) = tree(&doc).bounds().expect("bounded");
            let margin = 0.05 * (hi - lo).max_element();
            (doc, (lo - margin, hi + margin), 29 + n)
        } else {
            (random_any_tree(&mut rng, 3), (Vec3::new(-1.2, -1.0, -1.1), Vec3::new(1.1, 1.2, 0.9)), 23 + n)
        };
        let t = tree(&doc);
        let params = GridParams { bounds, resolution, refine: true };
        let (dense, culled) = (mesh_field(&Unculled(&t), &params).unwrap(), mesh_field(&t, &params).unwrap());
        assert!(same(&dense, &culled), "tree {n}: {} vs {} triangles: {doc}", dense.triangles.len(), culled.triangles.len());
        assert!(SurfaceCheck::of(&culled.positions, &culled.triangles).is_closed_manifold(), "tree {n}: {doc}");
        meshed += usize::from(!culled.triangles.is_empty());
    }
    assert!(meshed >= 12, "{meshed} of 16 trees had a surface");
}

#[test]
fn the_scalar_field_interval_encloses_the_single_precision_values() {
    let mut rng = Rng(77);
    for _ in 0..40 {
        let doc = random_any_tree(&mut rng, 3);
        let t = tree(&doc);
        let c = rng.vec(1.0).as_vec3();
        let half = rng.vec(0.3).abs().as_vec3();
        let (lo, hi) = ScalarField::interval(&t, c - half, c + half).expect("trees bound themselves");
        let points: Vec<Vec3> = (0..200).map(|_| c - half + 2.0 * half * DVec3::new(rng.uniform(), rng.uniform(), rng.uniform()).as_vec3()).collect();
        let mut values = vec![0.0; points.len()];
        t.values(&points, &mut values);
        assert!(values.iter().all(|v| (lo..=hi).contains(v)), "[{lo}, {hi}]: {doc}");
        let (l, u) = t.range((c - half).as_dvec3(), (c + half).as_dvec3());
        assert!(f64::from(lo) <= l && f64::from(hi) >= u);
    }
}

/// The layer `{x : t(x) >= 1/2}` of a texture value `t` around `seed` (a point inside
/// it), measured along the line through `seed` in `direction`: the distance between
/// its two boundary crossings, each found by stepping out by `step` and bisecting on
/// `t` alone (no gradient used).
fn layer_thickness(t: &dyn Fn(DVec3) -> f64, seed: DVec3, direction: DVec3, step: f64) -> f64 {
    assert!(t(seed) > 0.5, "seed {seed} is not inside a layer: {}", t(seed));
    let boundary = |sign: f64| {
        let (mut inside, mut outside) = (0.0, step);
        while t(seed + direction * sign * outside) >= 0.5 {
            inside = outside;
            outside += step;
            assert!(outside < 100.0 * step, "no layer boundary along {direction}");
        }
        for _ in 0..60 {
            let mid = 0.5 * (inside + outside);
            if t(seed + direction * sign * mid) >= 0.5 {
                inside = mid;
            } else {
                outside = mid;
            }
        }
        0.5 * (inside + outside)
    };
    boundary(1.0) + boundary(-1.0)
}

/// The texture layers of section 2 (`(1 + cos(omega f + tau)) / 2 >= 1/2`, a band of
/// `pi / omega` in `f`) keep their thickness where `|grad f| = 1`: on a sphere and on a
/// torus built from `h` as the paper builds it (section 3: `g = h[f1, -f1, f2, -f2]`,
/// then `h[g - a, -g + a, f3, -f3] - r`), every layer measured along the shape's
/// normal at 240 random places, five layers deep from inside the solid to outside it,
/// is `pi / omega` (0.05) within 1e-9 (measured: 5e-16, double precision's
/// rounding). A scaled sphere (`|S x| - r`, `S = diag(1, 1, 2)`: gradient length 1 to 2)
/// fails the same tolerance by orders of magnitude: its layers measure from half to
/// 1.7 times `pi / omega`.
#[test]
fn texture_layers_have_a_uniform_thickness_on_unit_gradient_shapes_and_not_on_a_scaled_one() {
    const TOLERANCE: f64 = 1e-9;
    let (omega, tau) = (20.0 * std::f64::consts::PI, 0.3);
    let thickness = std::f64::consts::PI / omega;
    // Layer centres in f: omega f + tau = 2 pi k.
    let centres: Vec<f64> = (-2..=2).map(|k| (2.0 * std::f64::consts::PI * f64::from(k) - tau) / omega).collect();
    // The texture value as the tree carries it (`displace` with no amplitude).
    let textured = |shape: &Value| tree(&json!({"op": "displace", "shape": shape, "texture": shape, "amplitude": 0.0, "omega": omega, "tau": tau}));
    let mut rng = Rng(17);
    let center = DVec3::new(0.1, -0.2, 0.05);
    let (n1, n2) = (DVec3::new(1.0, 1.0, 0.0).normalize(), DVec3::new(-1.0, 1.0, 1.0).normalize());
    let n3 = n1.cross(n2);
    let (major, minor) = (0.7, 0.3);
    let plane = |n: DVec3| json!({"op": "plane", "point": v3(center), "normal": v3(n)});
    let both = |f: Value| vec![f.clone(), json!({"op": "negate", "child": f})];
    let g = json!({"op": "h", "children": ([both(plane(n1)), both(plane(n2))].concat())});
    let ring = json!({"op": "offset", "child": g, "amount": major});
    let torus_from_h = json!({"op": "offset", "amount": minor, "child": {"op": "h", "children": ([both(ring), both(plane(n3))].concat())}});
    let sphere = json!({"op": "sphere", "center": v3(center), "radius": 0.6});
    for (name, shape) in [("sphere", sphere), ("torus from h", torus_from_h)] {
        let (shape_tree, texture_tree) = (tree(&shape), textured(&shape));
        let t = |x: DVec3| texture_tree.sample(x).texture;
        let mut worst: f64 = 0.0;
        for _ in 0..48 {
            // A point on the zero set: a random point pulled along the gradient (one
            // step is exact for a distance).
            let mut x = center + rng.vec(1.0);
            for _ in 0..3 {
                let s = shape_tree.sample(x);
                x -= s.gradient.normalize() * s.value;
            }
            let normal = shape_tree.sample(x).gradient.normalize();
            assert!(shape_tree.sample(x).value.abs() < 1e-9, "{name}: {x} is not on the zero set: {:?}", shape_tree.sample(x));
            for &c in &centres {
                let d = layer_thickness(&t, x + normal * c, normal, thickness / 8.0);
                worst = worst.max((d - thickness).abs());
            }
        }
        eprintln!("{name}: the worst of 240 layers is {worst:e} off {thickness}");
        assert!(worst < TOLERANCE, "{name}: a layer is {worst} off its thickness {thickness}");
    }
    // The contrast: a sphere scaled along z, its own texture layers measured the same way.
    let scale = DVec3::new(1.0, 1.0, 2.0);
    let f = |x: DVec3| ((x - center) * scale).length() - 0.6;
    let t = |x: DVec3| (1.0 + (omega * f(x) + tau).cos()) / 2.0;
    let (mut lo, mut hi) = (f64::MAX, 0.0f64);
    for _ in 0..48 {
        let u = rng.unit();
        let x = center + u * 0.6 / (u * scale).length();
        let normal = ((x - center) * scale * scale).normalize();
        for &c in &centres {
            // The layer's centre on the normal line: where f = c (Newton along the line).
            let mut s = 0.0;
            for _ in 0..20 {
                let p = x + normal * s;
                let slope = ((p - center) * scale * scale / ((p - center) * scale).length()).dot(normal);
                s += (c - f(p)) / slope;
            }
            let d = layer_thickness(&t, x + normal * s, normal, thickness / 16.0);
            (lo, hi) = (lo.min(d), hi.max(d));
        }
    }
    let worst = (hi - thickness).max(thickness - lo);
    eprintln!("scaled sphere: layers {lo} to {hi}, {worst} off {thickness}");
    assert!(worst > 0.3 * thickness && worst > 1e4 * TOLERANCE, "scaled sphere: layers from {lo} to {hi}, not {thickness}");
}

/// The tape's public face ([`tape`]) is the evaluator's tape: post order, ids in JSON
/// order, paints after their operation and ramps after their texture op, the
/// primitives' compiled frames (evaluated here by hand), and the stack depth.
#[test]
fn the_public_tape_is_the_evaluators_post_order() {
    use tape::{Instruction as I, PrimitiveKind};
    let t = tree(&json!({"op": "min", "color": [0.5, 0.5, 0.5, 1], "children": [
        {"op": "sphere", "center": [0.1, 0.2, 0.3], "radius": 0.4},
        {"op": "offset", "amount": 0.1, "child": {"op": "negate", "child": {"op": "plane", "point": [0, 0, 0], "normal": [0, 0, 2]}}},
        {"op": "displace", "amplitude": 0.1, "omega": 3, "ramp": [[0, [1, 0, 0, 1]]],
         "shape": {"op": "box", "center": [0, 0, 0], "half_size": [0.2, 0.3, 0.4]},
         "texture": {"op": "segment", "a": [0, 0, 0], "b": [1, 0, 0]}}]}));
    let insts = t.instructions();
    let names: Vec<String> = insts
        .iter()
        .map(|i| match i {
            I::Prim { prim: p, id, .. } => format!("{:?}#{}", p.kind, id),
            other => format!("{other:?}").split(['(', ' ']).next().unwrap().to_string(),
        })
        .collect();
    assert_eq!(names, ["Sphere#0", "Plane#1", "Negate", "Offset", "Cuboid#2", "Cuboid#3", "Displace", "Ramp", "Min", "Paint"]);
    assert!(matches!(insts[8], I::Min(3)));
    assert_eq!(t.stack_depth(), 4);
    assert_eq!(t.primitive_count(), 4);
    // The primitives' parameters evaluate to the tree's own values (the plane's normal
    // normalized, the box's frame the identity).
    let x = DVec3::new(0.35, -0.2, 0.15);
    for inst in insts {
        if let I::Prim { prim: p, id, .. } = inst {
            let d = x - p.center;
            let v = match p.kind {
                PrimitiveKind::Sphere => d.length() - p.radius,
                PrimitiveKind::Plane => p.axes[0].dot(d),
                _ => continue,
            };
            let alone = match id {
                0 => json!({"op": "sphere", "center": [0.1, 0.2, 0.3], "radius": 0.4}),
                _ => json!({"op": "plane", "point": [0, 0, 0], "normal": [0, 0, 2]}),
            };
            assert!((v - tree(&alone).sample(x).value).abs() < 1e-12, "{p:?}");
        }
    }
}

/// The tape compiled for AVX2 against the baseline build, bit for bit (values,
/// gradients, colours, textures, ids; values alone too), for every node type and the
/// benchmark tree, in blocks of every length. Where the CPU has no AVX2 there is one
/// path and nothing to compare: the test says so on its output.
#[test]
fn the_avx2_tape_equals_the_baseline_bit_for_bit() {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        use super::eval::{Need, Scratch, BLOCK};
        let mut rng = Rng(0xa5c2);
        let mut trees: Vec<FieldTree> = catalogue().iter().map(tree).collect();
        trees.push(FieldTree::from_json(super::samples::SOFT_CSG_20).unwrap());
        let mut compared = 0;
        for t in &trees {
            for len in [1, 7, 33, BLOCK] {
                let points: Vec<DVec3> = (0..len).map(|_| rng.vec(1.5)).collect();
                for need in [Need::ALL, Need::VALUE, Need::GRADIENT] {
                    let (mut a, mut b) = (Scratch::new(&t.tape), Scratch::new(&t.tape));
                    let portable = t.tape.run_portable(&points, need, &mut a);
                    // SAFETY: the CPU has AVX2, checked above.
                    let wide = unsafe { t.tape.run_avx2(&points, need, &mut b) };
                    for j in 0..len {
                        let bits = |s: &super::eval::Slot| {
                            let mut v = vec![s.f[j].to_bits(), u64::from(s.id[j])];
                            if need.gradient {
                                v.extend(s.g.iter().map(|g| g[j].to_bits()));
                            }
                            if need.attributes {
                                v.extend(s.c.iter().map(|c| c[j].to_bits()));
                                v.push(s.t[j].to_bits());
                            }
                            v
                        };
                        assert_eq!(bits(portable), bits(wide), "{} at {}", t.to_json(), points[j]);
                        compared += 1;
                    }
                }
            }
        }
        assert!(compared > 1000, "{compared}");
        return;
    }
    println!("no AVX2 on this CPU: one path only");
}
