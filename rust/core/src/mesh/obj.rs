//! Minimal Wavefront OBJ reader: `v` and `f` records (any arity; `v/vt/vn` corner
//! syntax and negative indices accepted), everything else ignored.

use super::Mesh;
use crate::{Error, Result};
use glam::Vec3;

/// Parses OBJ text into a mesh (positions and faces only).
pub fn parse_obj(text: &str) -> Result<Mesh> {
    let mut positions = Vec::new();
    let (mut sizes, mut corners) = (Vec::new(), Vec::new());
    for (ln, line) in text.lines().enumerate() {
        let mut it = line.split_whitespace();
        let bad = |what: &str| Error::InvalidMesh(format!("OBJ line {}: {what}", ln + 1));
        match it.next() {
            Some("v") => {
                let c: Vec<f32> = it.take(3).map(|s| s.parse::<f32>()).collect::<std::result::Result<_, _>>().map_err(|_| bad("bad coordinate"))?;
                if c.len() != 3 {
                    return Err(bad("a vertex needs 3 coordinates"));
                }
                positions.push(Vec3::new(c[0], c[1], c[2]));
            }
            Some("f") => {
                let mut n = 0;
                for tok in it {
                    let i: i64 = tok.split('/').next().unwrap_or("").parse().map_err(|_| bad("bad face index"))?;
                    let idx = if i > 0 { i - 1 } else { positions.len() as i64 + i };
                    if idx < 0 {
                        return Err(bad("face index out of range"));
                    }
                    corners.push(idx as u32);
                    n += 1;
                }
                sizes.push(n);
            }
            _ => {}
        }
    }
    Mesh::new(positions, &sizes, corners, None)
}
