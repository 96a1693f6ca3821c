//! A Thicket field tree (its JSON, `implicit::tree`) written in fidget's math: the
//! same functions, so both meshers draw the same zero set. The primitives are the
//! exact distances Thicket's `h` skeletons reduce to (section 3 of Akleman and Chen:
//! `h` over the positive parts is the Euclidean length), and `w_p` is written as
//! the plain `ln Σ e^(p s_i f_i) / p` a fidget user would write (Thicket evaluates
//! the same value as a log-sum-exp around its largest term).

use fidget::context::Tree;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use serde_json::Value;

fn vector(node: &Value, key: &str) -> Result<Vector3<f64>, String> {
    let v: Vec<f64> = node[key].as_array().ok_or(format!("{key}: not an array"))?.iter().filter_map(Value::as_f64).collect();
    (v.len() == 3).then(|| Vector3::new(v[0], v[1], v[2])).ok_or(format!("{key}: not three numbers"))
}

fn number(node: &Value, key: &str, default: f64) -> f64 {
    node.get(key).and_then(Value::as_f64).unwrap_or(default)
}

/// The coordinates of the point against `axes` through `center`.
fn local(center: Vector3<f64>, axes: [Vector3<f64>; 3]) -> [Tree; 3] {
    let c = center.cast::<f32>();
    let (x, y, z) = (Tree::x() - c.x, Tree::y() - c.y, Tree::z() - c.z);
    axes.map(|a| {
        let a = a.cast::<f32>();
        x.clone() * a.x + y.clone() * a.y + z.clone() * a.z
    })
}

/// How `w_p` is written in fidget's math.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wp {
    /// `outer · ln(Σ e^(p s_i f_i)) / p`, as the paper writes it.
    Plain,
    /// Around the largest term, `m + ln(Σ e^(p s_i f_i - p m)) / p` with
    /// `m = max s_i f_i`: the same value, with `max`'s tight interval in front.
    AroundMax,
}

/// `w_p` of the children with their signs `s_i`, times `outer`.
fn soft(p: f64, signed: Vec<(f64, Tree)>, outer: f64, form: Wp) -> Tree {
    let terms: Vec<Tree> = signed.into_iter().map(|(s, f)| f * s as f32).collect();
    let top = match form {
        Wp::Plain => None,
        Wp::AroundMax => terms.iter().cloned().reduce(|a, b| a.max(b)),
    };
    let sum = terms
        .into_iter()
        .map(|t| match &top {
            Some(m) => ((t - m.clone()) * p as f32).exp(),
            None => (t * p as f32).exp(),
        })
        .reduce(|a, b| a + b)
        .expect("w_p has children");
    let value = sum.ln() * (1.0 / p) as f32;
    let value = match top {
        Some(m) => m + value,
        None => value,
    };
    value * outer as f32
}

/// The fidget tree of a Thicket tree's JSON node (the ops the benchmark's tree uses).
pub fn from_json(node: &Value, form: Wp) -> Result<Tree, String> {
    let op = node["op"].as_str().ok_or("a node without op")?;
    let children =
        || -> Result<Vec<Tree>, String> { node["children"].as_array().ok_or(format!("{op}: no children"))?.iter().map(|c| from_json(c, form)).collect() };
    Ok(match op {
        "sphere" => {
            let c = vector(node, "center")?;
            let [x, y, z] = local(c, [Vector3::x(), Vector3::y(), Vector3::z()]);
            (x.square() + y.square() + z.square()).sqrt() - number(node, "radius", 0.0) as f32
        }
        "box" => {
            let q: Vec<f64> = node.get("rotation").and_then(Value::as_array).map_or(vec![1.0, 0.0, 0.0, 0.0], |q| q.iter().filter_map(Value::as_f64).collect());
            let r = UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3])).to_rotation_matrix();
            let m = r.matrix();
            let axes = [m.column(0).into_owned(), m.column(1).into_owned(), m.column(2).into_owned()];
            let half = vector(node, "half_size")?;
            let q: Vec<Tree> = local(vector(node, "center")?, axes).into_iter().zip(half.iter()).map(|(f, h)| f.abs() - *h as f32).collect();
            let outside = (q[0].max(0.0f32).square() + q[1].max(0.0f32).square() + q[2].max(0.0f32).square()).sqrt();
            let inside = q[0].max(q[1].clone()).max(q[2].clone()).min(0.0f32);
            outside + inside - number(node, "radius", 0.0) as f32
        }
        "segment" => {
            let (a, b) = (vector(node, "a")?, vector(node, "b")?);
            let half = (b - a).norm() / 2.0;
            let u = (b - a) / (2.0 * half);
            let (v, w) = (u.cross(&Vector3::x()), u.cross(&Vector3::y()));
            let v = if v.norm() > w.norm() { v.normalize() } else { w.normalize() };
            let [f1, f2, f3] = local((a + b) / 2.0, [u, v, u.cross(&v)]);
            ((f1.abs() - half as f32).max(0.0f32).square() + f2.square() + f3.square()).sqrt() - number(node, "radius", 0.0) as f32
        }
        "union_wp" => soft(number(node, "p", 1.0), children()?.into_iter().map(|f| (-1.0, f)).collect(), -1.0, form),
        "intersection_wp" => soft(number(node, "p", 1.0), children()?.into_iter().map(|f| (1.0, f)).collect(), 1.0, form),
        "difference_wp" => {
            let mut c = children()?.into_iter();
            let (a, b) = (c.next().ok_or("difference_wp: no children")?, c.next().ok_or("difference_wp: one child")?);
            soft(number(node, "p", 1.0), vec![(1.0, a), (-1.0, b)], 1.0, form)
        }
        other => return Err(format!("{other}: not written in fidget's math here")),
    })
}
