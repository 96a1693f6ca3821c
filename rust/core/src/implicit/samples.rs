//! Sample trees shared by the examples and tests.

/// Issue 17's benchmark tree, 20 nodes: a soft union (`w_p`, p = 8) of five spheres,
/// four boxes, four segments, a box with a sphere cut away (`difference_wp`) and a box
/// rounded by a sphere (`intersection_wp`), each primitive with its colour.
pub const SOFT_CSG_20: &str = r#"{"op": "union_wp", "p": 8, "children": [
  {"op": "sphere", "center": [0, 0, 0], "radius": 0.45, "color": [0.9, 0.2, 0.2, 1]},
  {"op": "sphere", "center": [0.6, 0.1, 0.2], "radius": 0.25, "color": [0.2, 0.9, 0.2, 1]},
  {"op": "sphere", "center": [-0.55, 0.3, -0.1], "radius": 0.3, "color": [0.2, 0.2, 0.9, 1]},
  {"op": "sphere", "center": [0.1, -0.6, 0.35], "radius": 0.2, "color": [0.9, 0.9, 0.2, 1]},
  {"op": "sphere", "center": [-0.2, 0.1, 0.7], "radius": 0.18, "color": [0.9, 0.2, 0.9, 1]},
  {"op": "box", "center": [0.5, 0.5, -0.4], "half_size": [0.2, 0.15, 0.1], "rotation": [0.92, 0.2, 0.3, 0.1], "radius": 0.02, "color": [0.2, 0.9, 0.9, 1]},
  {"op": "box", "center": [-0.5, -0.5, 0.3], "half_size": [0.15, 0.25, 0.12], "color": [0.6, 0.3, 0.1, 1]},
  {"op": "box", "center": [0.0, 0.0, -0.7], "half_size": [0.6, 0.6, 0.05], "color": [0.3, 0.3, 0.3, 1]},
  {"op": "box", "center": [0.7, -0.3, 0.0], "half_size": [0.1, 0.3, 0.2], "rotation": [0.7, 0.0, 0.7, 0.1], "color": [0.1, 0.5, 0.3, 1]},
  {"op": "segment", "a": [-0.8, -0.2, -0.6], "b": [0.8, 0.2, 0.6], "radius": 0.06, "color": [1, 0.5, 0, 1]},
  {"op": "segment", "a": [-0.7, 0.7, 0.0], "b": [0.7, -0.7, 0.1], "radius": 0.05, "color": [0, 0.5, 1, 1]},
  {"op": "segment", "a": [0.0, -0.8, -0.5], "b": [0.0, 0.8, 0.5], "radius": 0.07, "color": [0.5, 1, 0, 1]},
  {"op": "segment", "a": [-0.3, 0.0, -0.8], "b": [0.3, 0.1, 0.8], "radius": 0.04, "color": [1, 0, 0.5, 1]},
  {"op": "difference_wp", "p": 8, "children": [
    {"op": "box", "center": [-0.4, 0.5, 0.5], "half_size": [0.25, 0.2, 0.2], "color": [0.8, 0.8, 0.5, 1]},
    {"op": "sphere", "center": [-0.4, 0.5, 0.7], "radius": 0.2}]},
  {"op": "intersection_wp", "p": 8, "children": [
    {"op": "box", "center": [0.4, -0.5, -0.3], "half_size": [0.2, 0.2, 0.2], "color": [0.5, 0.8, 0.8, 1]},
    {"op": "sphere", "center": [0.4, -0.5, -0.3], "radius": 0.26}]}
]}"#;
