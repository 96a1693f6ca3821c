//! The field tree as data: [`Node`] (an [`Op`] and an optional colour), read from and
//! written to the JSON schema of the [module docs](super), and checked
//! ([`Node::validate`]) before anything evaluates it.
//!
//! Parsing reads `serde_json::Value`s field by field (no derive), so every error names
//! the node's place in the tree (`root.children[2].shape`), its op and the field.
//! Parameters are kept as written (a normal need not be unit length, a quaternion not
//! normalized); [`super::FieldTree`] normalizes them when it compiles the tree.

use crate::{Error, Result};
use glam::DVec3;
use serde_json::{Map, Value};

/// The colour of a primitive that has none: Blender's default base colour, opaque.
pub const DEFAULT_COLOR: [f64; 4] = [0.8, 0.8, 0.8, 1.0];

/// A rotation as a quaternion `[w, x, y, z]` (Blender's order); the identity.
pub const IDENTITY: [f64; 4] = [1.0, 0.0, 0.0, 0.0];

/// The exponents `p` the `w_p` operations accept (validation says why).
pub const P_RANGE: (f64, f64) = (1e-3, 1e6);

/// The deepest nesting a tree may have, read from JSON or built in code: reading,
/// checking and compiling recurse once per level (serde_json's own parser stops at
/// 128 too).
pub const MAX_DEPTH: usize = 128;

/// How deep the node at `path` ("root.children[1].child") is: one `.` per level.
fn nesting(path: &str) -> usize {
    path.matches('.').count()
}

/// A colour ramp: stops `(position, [r, g, b, a])`, positions in `[0, 1]` and
/// increasing, at least one. It maps a texture value (section 2's `(1 + cos(omega f +
/// tau)) / 2`, in `[0, 1]`) to a colour, as the "mapped through a colour ramp"
/// asks; [`ramp_color`] evaluates it.
pub type Ramp = Vec<(f64, [f64; 4])>;

/// The colour of `ramp` at `t`: linear between the stops around `t`, the end stops'
/// colours beyond them (and at NaN, the first).
pub fn ramp_color(ramp: &[(f64, [f64; 4])], t: f64) -> [f64; 4] {
    let Some(&(first, c0)) = ramp.first() else { return DEFAULT_COLOR };
    if !(t > first) {
        return c0;
    }
    // The first stop past `t`; `t` lies after the one before it.
    let i = ramp.partition_point(|s| s.0 <= t);
    if i == ramp.len() {
        return ramp[i - 1].1;
    }
    let ((p0, a), (p1, b)) = (ramp[i - 1], ramp[i]);
    let w = (t - p0) / (p1 - p0);
    std::array::from_fn(|k| a[k] + w * (b[k] - a[k]))
}

/// One node of a field tree: what it computes and, optionally, its colour (for a
/// primitive, its diffuse colour; for an operation, a colour painted over what its
/// children blend).
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    pub op: Op,
    pub color: Option<[f64; 4]>,
}

/// What a node computes; negative inside (`V(f) = {f <= 0}`). Section references are
/// Akleman and Chen's.
#[derive(Debug, Clone, PartialEq)]
pub enum Op {
    /// `n · (x - point)` with `n` the unit `normal` (section 2).
    Plane { point: DVec3, normal: DVec3 },
    /// `|x - center| - radius` (section 2).
    Sphere { center: DVec3, radius: f64 },
    /// `h[f1, -f1, f2, -f2, f3, -f3] - radius` over the world axes through `center`
    /// (section 3: the point skeleton at distance `radius`).
    Point { center: DVec3, radius: f64 },
    /// `h[f1 - l, -f1 - l, f2, -f2, f3, -f3] - radius`, `f1` along `b - a` from the
    /// midpoint, `l` half the length (section 3: `a2 = 0`).
    Segment { a: DVec3, b: DVec3, radius: f64 },
    /// `h[f1 - a1, -f1 - a1, f2 - a2, -f2 - a2, f3, -f3] - radius` in the frame of
    /// `rotation` at `center` (section 3's rectangle, flat in its local xy-plane).
    Rectangle { center: DVec3, half_size: [f64; 2], rotation: [f64; 4], radius: f64 },
    /// `h[f1 - a1, -f1 - a1, f2 - a2, -f2 - a2, f3 - a3, -f3 - a3] - radius` (section
    /// 3's rectangular prism `f5`, and `f5 - a5` with a radius).
    Box { center: DVec3, half_size: [f64; 3], rotation: [f64; 4], radius: f64 },
    /// `h[g - major, -g + major, f3, -f3] - minor` with `g = h[f1, -f1, f2, -f2]` the
    /// distance from the axis (section 3's `f6 - a6` with `a1 = a2 = 0`).
    Torus { center: DVec3, axis: DVec3, major: f64, minor: f64 },
    /// `f - amount`.
    Offset { child: Box<Node>, amount: f64 },
    /// `-f`.
    Negate { child: Box<Node> },
    /// The n-ary `h[f1, ..., fn]` of section 3.
    H { children: Vec<Node> },
    /// Exact union.
    Min { children: Vec<Node> },
    /// Exact intersection.
    Max { children: Vec<Node> },
    /// `w_p(f1, ..., fn) = log(Σ e^(p fi)) / p`, the approximate intersection (section 4).
    IntersectionWp { p: f64, children: Vec<Node> },
    /// `-w_p(-f1, ..., -fn)`, the approximate union.
    UnionWp { p: f64, children: Vec<Node> },
    /// `w_p(f1, -f2)`, the approximate difference.
    DifferenceWp { p: f64, children: Vec<Node> },
    /// `f0 + amplitude (cos(omega f1 + tau) + 1)` (equation 1, with section 7's phase);
    /// carries the texture value `(1 + cos(omega f1 + tau)) / 2`, and with a `ramp` the
    /// colour the ramp gives it.
    Displace { shape: Box<Node>, texture: Box<Node>, amplitude: f64, omega: f64, tau: f64, ramp: Option<Ramp> },
    /// `f0 + Σ a_j (cos(omega_j f1 + tau) + 1)` (equation 2); carries the `|a_j|`-weighted
    /// mean of the terms' texture values, and with a `ramp` the colour the ramp gives it.
    Fractal { shape: Box<Node>, texture: Box<Node>, terms: Vec<[f64; 2]>, tau: f64, ramp: Option<Ramp> },
}

impl Op {
    /// The `"op"` name of the JSON schema.
    pub fn name(&self) -> &'static str {
        match self {
            Op::Plane { .. } => "plane",
            Op::Sphere { .. } => "sphere",
            Op::Point { .. } => "point",
            Op::Segment { .. } => "segment",
            Op::Rectangle { .. } => "rectangle",
            Op::Box { .. } => "box",
            Op::Torus { .. } => "torus",
            Op::Offset { .. } => "offset",
            Op::Negate { .. } => "negate",
            Op::H { .. } => "h",
            Op::Min { .. } => "min",
            Op::Max { .. } => "max",
            Op::IntersectionWp { .. } => "intersection_wp",
            Op::UnionWp { .. } => "union_wp",
            Op::DifferenceWp { .. } => "difference_wp",
            Op::Displace { .. } => "displace",
            Op::Fractal { .. } => "fractal",
        }
    }

    /// Every op name, in the schema's order.
    pub const NAMES: [&'static str; 17] = [
        "plane",
        "sphere",
        "point",
        "segment",
        "rectangle",
        "box",
        "torus",
        "offset",
        "negate",
        "h",
        "min",
        "max",
        "intersection_wp",
        "union_wp",
        "difference_wp",
        "displace",
        "fractal",
    ];

    /// Whether this is a primitive (a leaf with its own colour and primitive id).
    pub fn is_primitive(&self) -> bool {
        matches!(self, Op::Plane { .. } | Op::Sphere { .. } | Op::Point { .. } | Op::Segment { .. } | Op::Rectangle { .. } | Op::Box { .. } | Op::Torus { .. })
    }

    /// The node's children with the field names they sit under, in evaluation order.
    pub fn children(&self) -> Vec<(String, &Node)> {
        match self {
            Op::Offset { child, .. } | Op::Negate { child } => vec![("child".into(), child)],
            Op::H { children } | Op::Min { children } | Op::Max { children } => list(children),
            Op::IntersectionWp { children, .. } | Op::UnionWp { children, .. } | Op::DifferenceWp { children, .. } => list(children),
            Op::Displace { shape, texture, .. } | Op::Fractal { shape, texture, .. } => vec![("shape".into(), shape), ("texture".into(), texture)],
            _ => Vec::new(),
        }
    }
}

fn list(children: &[Node]) -> Vec<(String, &Node)> {
    children.iter().enumerate().map(|(i, c)| (format!("children[{i}]"), c)).collect()
}

impl Node {
    pub fn new(op: Op) -> Self {
        Self { op, color: None }
    }

    pub fn with_color(mut self, color: [f64; 4]) -> Self {
        self.color = Some(color);
        self
    }

    /// Reads a tree from its JSON text (the schema of the [module docs](super)) and
    /// validates it.
    pub fn from_json(text: &str) -> Result<Self> {
        let value: Value = serde_json::from_str(text).map_err(|e| Error::InvalidParameter(format!("field tree: not valid JSON: {e}")))?;
        let node = Self::from_value(&value)?;
        node.validate()?;
        Ok(node)
    }

    /// Reads a tree from a parsed JSON value (structure and types only; see
    /// [`Node::validate`] for the parameters).
    pub fn from_value(value: &Value) -> Result<Self> {
        read_node(value, "root")
    }

    /// The tree as compact JSON; [`Node::from_json`] reads it back to an equal tree
    /// (numbers are written in their shortest exact form).
    pub fn to_json(&self) -> String {
        self.to_value().to_string()
    }

    /// The tree as a JSON value: every field written, defaults included.
    pub fn to_value(&self) -> Value {
        let mut m = Map::new();
        m.insert("op".into(), Value::from(self.op.name()));
        let v3 = |v: DVec3| Value::from(v.to_array().to_vec());
        let node = |n: &Node| n.to_value();
        let nodes = |c: &[Node]| Value::Array(c.iter().map(Node::to_value).collect());
        let mut put = |k: &str, v: Value| {
            m.insert(k.into(), v);
        };
        match &self.op {
            Op::Plane { point, normal } => {
                put("point", v3(*point));
                put("normal", v3(*normal));
            }
            Op::Sphere { center, radius } | Op::Point { center, radius } => {
                put("center", v3(*center));
                put("radius", Value::from(*radius));
            }
            Op::Segment { a, b, radius } => {
                put("a", v3(*a));
                put("b", v3(*b));
                put("radius", Value::from(*radius));
            }
            Op::Rectangle { center, half_size, rotation, radius } => {
                put("center", v3(*center));
                put("half_size", Value::from(half_size.to_vec()));
                put("rotation", Value::from(rotation.to_vec()));
                put("radius", Value::from(*radius));
            }
            Op::Box { center, half_size, rotation, radius } => {
                put("center", v3(*center));
                put("half_size", Value::from(half_size.to_vec()));
                put("rotation", Value::from(rotation.to_vec()));
                put("radius", Value::from(*radius));
            }
            Op::Torus { center, axis, major, minor } => {
                put("center", v3(*center));
                put("axis", v3(*axis));
                put("major", Value::from(*major));
                put("minor", Value::from(*minor));
            }
            Op::Offset { child, amount } => {
                put("child", node(child));
                put("amount", Value::from(*amount));
            }
            Op::Negate { child } => put("child", node(child)),
            Op::H { children } | Op::Min { children } | Op::Max { children } => put("children", nodes(children)),
            Op::IntersectionWp { p, children } | Op::UnionWp { p, children } | Op::DifferenceWp { p, children } => {
                put("p", Value::from(*p));
                put("children", nodes(children));
            }
            Op::Displace { shape, texture, amplitude, omega, tau, ramp } => {
                put("shape", node(shape));
                put("texture", node(texture));
                put("amplitude", Value::from(*amplitude));
                put("omega", Value::from(*omega));
                put("tau", Value::from(*tau));
                if let Some(r) = ramp {
                    put("ramp", ramp_value(r));
                }
            }
            Op::Fractal { shape, texture, terms, tau, ramp } => {
                put("shape", node(shape));
                put("texture", node(texture));
                put("terms", Value::Array(terms.iter().map(|t| Value::from(t.to_vec())).collect()));
                put("tau", Value::from(*tau));
                if let Some(r) = ramp {
                    put("ramp", ramp_value(r));
                }
            }
        }
        if let Some(c) = self.color {
            m.insert("color".into(), Value::from(c.to_vec()));
        }
        Value::Object(m)
    }

    /// Checks every parameter of the tree: finite numbers, `p > 0`, `omega > 0`,
    /// lengths and radii `>= 0`, non-zero normals, axes and rotations, distinct
    /// segment ends, the child counts (at least one child; exactly two for
    /// `difference_wp`; at least one fractal term) and ramps (at least one stop,
    /// positions in `[0, 1]` and increasing, finite colours).
    pub fn validate(&self) -> Result<()> {
        self.validate_at("root")
    }

    fn validate_at(&self, path: &str) -> Result<()> {
        let op = self.op.name();
        let fail = |msg: String| Err(Error::InvalidParameter(format!("field tree {path} ({op}): {msg}")));
        if nesting(path) > MAX_DEPTH {
            return fail(format!("nested deeper than {MAX_DEPTH} levels"));
        }
        let finite = |name: &str, v: f64| if v.is_finite() { Ok(()) } else { fail(format!("{name} must be a finite number, got {v}")) };
        let finite3 = |name: &str, v: DVec3| if v.is_finite() { Ok(()) } else { fail(format!("{name} must be finite, got {v}")) };
        let at_least_zero = |name: &str, v: f64| if v >= 0.0 && v.is_finite() { Ok(()) } else { fail(format!("{name} must be a finite number >= 0, got {v}")) };
        let positive = |name: &str, v: f64| if v > 0.0 && v.is_finite() { Ok(()) } else { fail(format!("{name} must be a finite number > 0, got {v}")) };
        // `w_p`'s exponent: beyond this range `p f` overflows, or `ln(n) / p` does, for
        // values a tree can have (`|f|` up to 1e300); within it `p = 200` at `|f| = 1e3`
        // and everything an artist uses (1 to a few hundred) is exact to rounding.
        let exponent =
            |p: f64| if (P_RANGE.0..=P_RANGE.1).contains(&p) { Ok(()) } else { fail(format!("p must be between {} and {}, got {p}", P_RANGE.0, P_RANGE.1)) };
        let direction = |name: &str, v: DVec3| {
            finite3(name, v)?;
            // Normalizing must give a unit vector in double precision.
            if v.length_squared() > 1e-200 && v.length().is_finite() {
                Ok(())
            } else {
                fail(format!("{name} must not be zero, got {v}"))
            }
        };
        let rotation = |q: &[f64; 4]| {
            if !q.iter().all(|c| c.is_finite()) {
                return fail(format!("rotation must be a finite quaternion [w, x, y, z], got {q:?}"));
            }
            let n2: f64 = q.iter().map(|c| c * c).sum();
            if n2 > 1e-200 && n2.is_finite() {
                Ok(())
            } else {
                fail(format!("rotation must be a non-zero quaternion [w, x, y, z], got {q:?}"))
            }
        };
        if let Some(c) = self.color {
            if !c.iter().all(|v| v.is_finite()) {
                return fail(format!("color must be four finite numbers [r, g, b, a], got {c:?}"));
            }
        }
        let check_ramp = |ramp: &Option<Ramp>| {
            let Some(ramp) = ramp else { return Ok(()) };
            if ramp.is_empty() {
                return fail("ramp needs at least one stop [position, [r, g, b, a]]".into());
            }
            for (j, (position, color)) in ramp.iter().enumerate() {
                if !(0.0..=1.0).contains(position) {
                    return fail(format!("ramp[{j}]'s position must be in [0, 1], got {position}"));
                }
                if j > 0 && !(*position > ramp[j - 1].0) {
                    return fail(format!("ramp positions must increase, ramp[{j}] is at {position} after {}", ramp[j - 1].0));
                }
                if !color.iter().all(|c| c.is_finite()) {
                    return fail(format!("ramp[{j}]'s colour must be four finite numbers [r, g, b, a], got {color:?}"));
                }
            }
            Ok(())
        };
        match &self.op {
            Op::Plane { point, normal } => {
                finite3("point", *point)?;
                direction("normal", *normal)?;
            }
            Op::Sphere { center, radius } | Op::Point { center, radius } => {
                finite3("center", *center)?;
                at_least_zero("radius", *radius)?;
            }
            Op::Segment { a, b, radius } => {
                finite3("a", *a)?;
                finite3("b", *b)?;
                at_least_zero("radius", *radius)?;
                if !((*b - *a).length_squared() > 1e-200) {
                    return fail(format!("the ends a and b must differ (a point is the op \"point\"), both are {a}"));
                }
            }
            Op::Rectangle { center, half_size, rotation: q, radius } => {
                finite3("center", *center)?;
                half_size.iter().try_for_each(|&v| at_least_zero("each half_size", v))?;
                rotation(q)?;
                at_least_zero("radius", *radius)?;
            }
            Op::Box { center, half_size, rotation: q, radius } => {
                finite3("center", *center)?;
                half_size.iter().try_for_each(|&v| at_least_zero("each half_size", v))?;
                rotation(q)?;
                at_least_zero("radius", *radius)?;
            }
            Op::Torus { center, axis, major, minor } => {
                finite3("center", *center)?;
                direction("axis", *axis)?;
                at_least_zero("major", *major)?;
                at_least_zero("minor", *minor)?;
            }
            Op::Offset { amount, .. } => finite("amount", *amount)?,
            Op::Negate { .. } => {}
            Op::H { children } | Op::Min { children } | Op::Max { children } => {
                if children.is_empty() {
                    return fail("needs at least one child".into());
                }
            }
            Op::IntersectionWp { p, children } | Op::UnionWp { p, children } => {
                exponent(*p)?;
                if children.is_empty() {
                    return fail("needs at least one child".into());
                }
            }
            Op::DifferenceWp { p, children } => {
                exponent(*p)?;
                if children.len() != 2 {
                    return fail(format!("needs exactly two children (the shape and what is cut from it), got {}", children.len()));
                }
            }
            Op::Displace { amplitude, omega, tau, ramp, .. } => {
                finite("amplitude", *amplitude)?;
                positive("omega", *omega)?;
                finite("tau", *tau)?;
                check_ramp(ramp)?;
            }
            Op::Fractal { terms, tau, ramp, .. } => {
                check_ramp(ramp)?;
                if terms.is_empty() {
                    return fail("needs at least one term [a, omega]".into());
                }
                for (j, [a, omega]) in terms.iter().enumerate() {
                    finite(&format!("terms[{j}]'s amplitude"), *a)?;
                    positive(&format!("terms[{j}]'s omega"), *omega)?;
                }
                finite("tau", *tau)?;
            }
        }
        for (field, child) in self.op.children() {
            child.validate_at(&format!("{path}.{field}"))?;
        }
        Ok(())
    }
}

/// Reads one node at `path` (structure and types; values are checked by validate).
fn read_node(value: &Value, path: &str) -> Result<Node> {
    let err = |msg: String| Error::InvalidParameter(format!("field tree {path}: {msg}"));
    if nesting(path) > MAX_DEPTH {
        return Err(err(format!("nested deeper than {MAX_DEPTH} levels")));
    }
    let Value::Object(map) = value else {
        return Err(err(format!("a node must be a JSON object with an \"op\", got {}", kind_of(value))));
    };
    let op_name = match map.get("op") {
        Some(Value::String(s)) => s.as_str(),
        Some(v) => return Err(err(format!("\"op\" must be a string, got {}", kind_of(v)))),
        None => return Err(err(format!("a node needs an \"op\", one of {}", Op::NAMES.join(", ")))),
    };
    let r = Reader { map, path, op: op_name };
    let op = match op_name {
        "plane" => {
            r.only(&["point", "normal"])?;
            Op::Plane { point: r.vec3("point")?, normal: r.vec3("normal")? }
        }
        "sphere" => {
            r.only(&["center", "radius"])?;
            Op::Sphere { center: r.vec3("center")?, radius: r.number("radius")? }
        }
        "point" => {
            r.only(&["center", "radius"])?;
            Op::Point { center: r.vec3("center")?, radius: r.number_or("radius", 0.0)? }
        }
        "segment" => {
            r.only(&["a", "b", "radius"])?;
            Op::Segment { a: r.vec3("a")?, b: r.vec3("b")?, radius: r.number_or("radius", 0.0)? }
        }
        "rectangle" => {
            r.only(&["center", "half_size", "rotation", "radius"])?;
            Op::Rectangle {
                center: r.vec3("center")?,
                half_size: r.numbers("half_size")?,
                rotation: r.numbers_or("rotation", IDENTITY)?,
                radius: r.number_or("radius", 0.0)?,
            }
        }
        "box" => {
            r.only(&["center", "half_size", "rotation", "radius"])?;
            Op::Box {
                center: r.vec3("center")?,
                half_size: r.numbers("half_size")?,
                rotation: r.numbers_or("rotation", IDENTITY)?,
                radius: r.number_or("radius", 0.0)?,
            }
        }
        "torus" => {
            r.only(&["center", "axis", "major", "minor"])?;
            Op::Torus { center: r.vec3("center")?, axis: r.vec3("axis")?, major: r.number("major")?, minor: r.number("minor")? }
        }
        "offset" => {
            r.only(&["child", "amount"])?;
            Op::Offset { child: Box::new(r.node("child")?), amount: r.number("amount")? }
        }
        "negate" => {
            r.only(&["child"])?;
            Op::Negate { child: Box::new(r.node("child")?) }
        }
        "h" | "min" | "max" => {
            r.only(&["children"])?;
            let children = r.nodes("children")?;
            match op_name {
                "h" => Op::H { children },
                "min" => Op::Min { children },
                _ => Op::Max { children },
            }
        }
        "intersection_wp" | "union_wp" | "difference_wp" => {
            r.only(&["p", "children"])?;
            let (p, children) = (r.number("p")?, r.nodes("children")?);
            match op_name {
                "intersection_wp" => Op::IntersectionWp { p, children },
                "union_wp" => Op::UnionWp { p, children },
                _ => Op::DifferenceWp { p, children },
            }
        }
        "displace" => {
            r.only(&["shape", "texture", "amplitude", "omega", "tau", "ramp"])?;
            Op::Displace {
                shape: Box::new(r.node("shape")?),
                texture: Box::new(r.node("texture")?),
                amplitude: r.number("amplitude")?,
                omega: r.number("omega")?,
                tau: r.number_or("tau", 0.0)?,
                ramp: r.ramp()?,
            }
        }
        "fractal" => {
            r.only(&["shape", "texture", "terms", "tau", "ramp"])?;
            let terms = match r.get("terms")? {
                Value::Array(items) => items
                    .iter()
                    .enumerate()
                    .map(|(j, t)| numbers_of::<2>(t).ok_or_else(|| r.err(&format!("terms[{j}] must be [a, omega], got {t}"))))
                    .collect::<Result<Vec<_>>>()?,
                v => return Err(r.err(&format!("\"terms\" must be a list of [a, omega], got {}", kind_of(v)))),
            };
            Op::Fractal { shape: Box::new(r.node("shape")?), texture: Box::new(r.node("texture")?), terms, tau: r.number_or("tau", 0.0)?, ramp: r.ramp()? }
        }
        other => return Err(err(format!("unknown op {other:?}; one of {}", Op::NAMES.join(", ")))),
    };
    let color = match map.get("color") {
        None => None,
        Some(v) => Some(numbers_of::<4>(v).ok_or_else(|| r.err(&format!("\"color\" must be [r, g, b, a], got {v}")))?),
    };
    Ok(Node { op, color })
}

/// Field access for one node's object, with errors that name the node.
struct Reader<'a> {
    map: &'a Map<String, Value>,
    path: &'a str,
    op: &'a str,
}

impl Reader<'_> {
    fn err(&self, msg: &str) -> Error {
        Error::InvalidParameter(format!("field tree {} ({}): {msg}", self.path, self.op))
    }
    /// Refuses fields the op does not have (a misspelt optional field would otherwise
    /// fall back to its default unnoticed).
    fn only(&self, fields: &[&str]) -> Result<()> {
        for key in self.map.keys() {
            if key != "op" && key != "color" && !fields.contains(&key.as_str()) {
                return Err(self.err(&format!("unknown field {key:?}; {} has {}, and color", self.op, fields.join(", "))));
            }
        }
        Ok(())
    }
    fn get(&self, name: &str) -> Result<&Value> {
        self.map.get(name).ok_or_else(|| self.err(&format!("missing field {name:?}")))
    }
    fn number(&self, name: &str) -> Result<f64> {
        let v = self.get(name)?;
        v.as_f64().ok_or_else(|| self.err(&format!("{name:?} must be a number, got {}", kind_of(v))))
    }
    fn number_or(&self, name: &str, default: f64) -> Result<f64> {
        if self.map.contains_key(name) {
            self.number(name)
        } else {
            Ok(default)
        }
    }
    fn numbers<const N: usize>(&self, name: &str) -> Result<[f64; N]> {
        let v = self.get(name)?;
        numbers_of::<N>(v).ok_or_else(|| self.err(&format!("{name:?} must be a list of {N} numbers, got {v}")))
    }
    fn numbers_or<const N: usize>(&self, name: &str, default: [f64; N]) -> Result<[f64; N]> {
        if self.map.contains_key(name) {
            self.numbers(name)
        } else {
            Ok(default)
        }
    }
    /// The optional `"ramp"`: `[[position, [r, g, b, a]], ...]` (values are checked by
    /// validate).
    fn ramp(&self) -> Result<Option<Ramp>> {
        let Some(v) = self.map.get("ramp") else { return Ok(None) };
        let shape = "[[position, [r, g, b, a]], ...]";
        let Value::Array(items) = v else {
            return Err(self.err(&format!("\"ramp\" must be a list of stops {shape}, got {}", kind_of(v))));
        };
        let stop = |item: &Value| match item.as_array().map(Vec::as_slice) {
            Some([p, c]) => Some((p.as_f64()?, numbers_of::<4>(c)?)),
            _ => None,
        };
        let stops =
            items.iter().enumerate().map(|(j, item)| stop(item).ok_or_else(|| self.err(&format!("ramp[{j}] must be [position, [r, g, b, a]], got {item}"))));
        stops.collect::<Result<Vec<_>>>().map(Some)
    }
    fn vec3(&self, name: &str) -> Result<DVec3> {
        self.numbers::<3>(name).map(DVec3::from_array)
    }
    fn node(&self, name: &str) -> Result<Node> {
        read_node(self.get(name)?, &format!("{}.{name}", self.path))
    }
    fn nodes(&self, name: &str) -> Result<Vec<Node>> {
        match self.get(name)? {
            Value::Array(items) => items.iter().enumerate().map(|(i, v)| read_node(v, &format!("{}.{name}[{i}]", self.path))).collect(),
            v => Err(self.err(&format!("{name:?} must be a list of nodes, got {}", kind_of(v)))),
        }
    }
}

fn ramp_value(ramp: &[(f64, [f64; 4])]) -> Value {
    Value::Array(ramp.iter().map(|(p, c)| Value::Array(vec![Value::from(*p), Value::from(c.to_vec())])).collect())
}

fn numbers_of<const N: usize>(v: &Value) -> Option<[f64; N]> {
    let items = v.as_array()?;
    if items.len() != N {
        return None;
    }
    let mut out = [0.0; N];
    for (o, item) in out.iter_mut().zip(items) {
        *o = item.as_f64()?;
    }
    Some(out)
}

fn kind_of(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "a list",
        Value::Object(_) => "an object",
    }
}
