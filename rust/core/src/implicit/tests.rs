//! The field tree's JSON form against its own text: every op read, written and read
//! back equal, and bad trees refused with errors that say where and what.

use super::*;
use glam::DVec3;
use serde_json::{json, Value};

fn tree(v: &Value) -> Node {
    Node::from_json(&v.to_string()).unwrap_or_else(|e| panic!("{e}: {v}"))
}

/// One tree per op (and a few combinations), as JSON.
fn catalogue() -> Vec<Value> {
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
    ]
}

#[test]
fn the_catalogue_has_every_op() {
    let ops: Vec<String> = catalogue().iter().map(|v| v["op"].as_str().unwrap().to_string()).collect();
    for name in Op::NAMES {
        assert!(ops.iter().any(|o| o == name), "{name} missing");
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
        let back = Node::from_json(&text).unwrap();
        assert_eq!(back, t, "{text}");
        assert_eq!(back.to_json(), text);
        // What was written is what was read: every given field, the defaults added.
        let written: Value = serde_json::from_str(&text).unwrap();
        assert_contains(&written, &doc);
    }
    // Exact numbers survive.
    let t = tree(&json!({"op": "sphere", "center": [0.1, 1e-300, -7.3e12], "radius": 0.30000000000000004}));
    assert_eq!(Node::from_json(&t.to_json()).unwrap(), t);
    // Defaults are filled in.
    let t = tree(&json!({"op": "segment", "a": [0, 0, 0], "b": [1, 0, 0]}));
    assert_eq!(t.op, Op::Segment { a: DVec3::ZERO, b: DVec3::X, radius: 0.0 });
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
        (json!({"op": "union_wp", "p": 0, "children": [s]}).to_string(), "p must be a finite number > 0"),
        (json!({"op": "intersection_wp", "p": -2, "children": [s]}).to_string(), "p must be a finite number > 0"),
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
        match Node::from_json(&text) {
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
        assert!(matches!(Node::new(op).validate(), Err(crate::Error::InvalidParameter(_))), "{name}");
    }
    let painted = Node::new(Op::Point { center: DVec3::ZERO, radius: 1.0 }).with_color([0.0, f64::NAN, 0.0, 1.0]);
    assert!(painted.validate().is_err());
    // Deep nesting is refused by the parser, not a stack overflow.
    let mut deep = s.to_string();
    for _ in 0..400 {
        deep = format!(r#"{{"op": "negate", "child": {deep}}}"#);
    }
    assert!(Node::from_json(&deep).is_err());
}
