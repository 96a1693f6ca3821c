//! Spatial ordering of a mesh's vertices and faces (a Morton, or Z-order, curve), so
//! that elements close in space are close in memory. Tree queries over meshes stored
//! in random order (scattered cards and debris joined from a particle system) spend
//! most of their time on cache misses; in Morton order consecutive queries touch the
//! same tree nodes and triangles.

use super::Mesh;
use glam::Vec3;
use rayon::prelude::*;

/// Spreads the low 21 bits of `x` to every third bit.
fn spread(x: u64) -> u64 {
    let mut x = x & 0x1f_ffff;
    x = (x | x << 32) & 0x1f_0000_0000_ffff;
    x = (x | x << 16) & 0x1f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    (x | x << 2) & 0x1249_2492_4924_9249
}

/// The Morton code of `p` in the box `[lo, lo + size]`, 21 bits per axis.
fn morton(p: Vec3, lo: Vec3, scale: Vec3) -> u64 {
    let q = ((p - lo) * scale).clamp(Vec3::ZERO, Vec3::splat(2_097_151.0));
    spread(q.x as u64) | spread(q.y as u64) << 1 | spread(q.z as u64) << 2
}

/// The Morton code of each point in the points' bounding box: an order along a
/// space-filling curve that does not depend on how the points are numbered.
pub fn morton_codes(points: &[Vec3]) -> Vec<u64> {
    let (lo, hi) = points.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(l, h), p| (l.min(*p), h.max(*p)));
    let scale = Vec3::splat(2_097_151.0) / (hi - lo).max(Vec3::splat(f32::MIN_POSITIVE));
    points.par_iter().map(|&p| morton(p, lo, scale)).collect()
}

impl Mesh {
    /// The mesh with its vertices in Morton order and its faces ordered by their
    /// first new vertex (corners keep their order within each face), and `order`:
    /// new vertex `i` is old vertex `order[i]`. UVs follow their corners.
    pub fn spatially_ordered(&self) -> (Mesh, Vec<u32>) {
        let codes = morton_codes(&self.positions);
        let mut order: Vec<u32> = (0..self.positions.len() as u32).collect();
        order.par_sort_by_key(|&v| (codes[v as usize], v));
        let mut new_of = vec![0u32; order.len()];
        order.iter().enumerate().for_each(|(i, &v)| new_of[v as usize] = i as u32);
        let mut faces: Vec<u32> = (0..self.face_count() as u32).collect();
        faces.par_sort_by_key(|&f| (self.face(f as usize).iter().map(|&v| new_of[v as usize]).min().unwrap_or(0), f));
        let mut offsets = Vec::with_capacity(self.offsets.len());
        offsets.push(0u32);
        let mut corners = Vec::with_capacity(self.corners.len());
        let mut uvs = self.uvs.as_ref().map(|_| Vec::with_capacity(self.corners.len()));
        for &f in &faces {
            let range = self.face_corner_range(f as usize);
            corners.extend(self.corners[range.clone()].iter().map(|&v| new_of[v as usize]));
            if let (Some(out), Some(src)) = (uvs.as_mut(), self.uvs.as_ref()) {
                out.extend_from_slice(&src[range]);
            }
            offsets.push(corners.len() as u32);
        }
        let positions = order.iter().map(|&v| self.positions[v as usize]).collect();
        (Mesh { positions, offsets, corners, uvs }, order)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_codes_interleave_the_axes() {
        let (lo, scale) = (Vec3::ZERO, Vec3::ONE);
        assert_eq!(morton(Vec3::new(1.0, 0.0, 0.0), lo, scale), 1);
        assert_eq!(morton(Vec3::new(0.0, 1.0, 0.0), lo, scale), 2);
        assert_eq!(morton(Vec3::new(0.0, 0.0, 1.0), lo, scale), 4);
        assert_eq!(morton(Vec3::new(3.0, 0.0, 0.0), lo, scale), 9);
        assert_eq!(morton(Vec3::splat(2_097_151.0), lo, scale), (1u64 << 63) - 1);
    }

    #[test]
    fn the_ordered_mesh_is_the_same_mesh_renumbered() {
        let mesh = crate::testmeshes::voxels([4, 3, 2], 2, |x, y, z| (x + y + z) % 3 != 0);
        let (sorted, order) = mesh.spatially_ordered();
        assert_eq!(sorted.vertex_count(), mesh.vertex_count());
        assert_eq!(sorted.face_count(), mesh.face_count());
        let mut seen = order.clone();
        seen.sort_unstable();
        assert!(seen.iter().enumerate().all(|(i, &v)| i as u32 == v), "order is a permutation");
        for (i, &v) in order.iter().enumerate() {
            assert_eq!(sorted.positions()[i], mesh.positions()[v as usize]);
        }
        // Every old face appears once, with its corners in the same cyclic order.
        let mut old: Vec<Vec<u32>> = mesh.faces().map(|f| f.to_vec()).collect();
        let mut new: Vec<Vec<u32>> = sorted.faces().map(|f| f.iter().map(|&v| order[v as usize]).collect()).collect();
        old.sort();
        new.sort();
        assert_eq!(old, new);
        assert!((sorted.signed_volume() - mesh.signed_volume()).abs() < 1e-4);
    }
}
