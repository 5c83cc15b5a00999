//! Vertex normals: the file's when usable, otherwise area-weighted from the faces.

use glam::Vec3;

/// The normal given to a vertex that touches no triangle of non-zero area.
const FALLBACK: Vec3 = Vec3::Z;

/// Whether a file's normals can be used: one per vertex, each finite and of non-zero length.
pub(crate) fn usable(normals: &[[f32; 3]], vertex_count: usize) -> bool {
    normals.len() == vertex_count && normals.iter().all(|&n| Vec3::from(n).try_normalize().is_some())
}

/// The normals scaled to unit length.
pub(crate) fn normalised(mut normals: Vec<[f32; 3]>) -> Vec<[f32; 3]> {
    for n in &mut normals {
        *n = unit_or_default(Vec3::from(*n)).into();
    }
    normals
}

/// `v` at unit length, or the fallback where it has none (zero, NaN or infinite).
pub(crate) fn unit_or_default(v: Vec3) -> Vec3 {
    v.try_normalize().unwrap_or(FALLBACK)
}

/// One unit normal per vertex: the sum of its triangles' normals weighted by their areas.
/// Degenerate triangles weigh nothing, so they never make a normal NaN. Indices must be in range.
pub(crate) fn area_weighted(positions: &[[f32; 3]], indices: &[u32]) -> Vec<[f32; 3]> {
    let mut sums = vec![Vec3::ZERO; positions.len()];
    for triangle in indices.chunks_exact(3) {
        let [a, b, c] = [triangle[0], triangle[1], triangle[2]].map(|i| i as usize);
        let (Some(&pa), Some(&pb), Some(&pc)) = (positions.get(a), positions.get(b), positions.get(c)) else {
            continue;
        };
        let (pa, pb, pc) = (Vec3::from(pa), Vec3::from(pb), Vec3::from(pc));
        // The cross product's length is twice the area: area weighting comes for free.
        let weighted = (pb - pa).cross(pc - pa);
        if weighted.is_finite() {
            for i in [a, b, c] {
                sums[i] += weighted;
            }
        }
    }
    sums.into_iter().map(|n| unit_or_default(n).into()).collect()
}
