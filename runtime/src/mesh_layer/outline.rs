//! Where meshes cross a slice plane: each triangle that straddles the plane gives a segment,
//! drawn as a quad a few pixels wide in the slice image. Computed on the CPU (linear in the
//! triangle count) because a rasterizer cannot draw it: a surface perpendicular to the plane,
//! such as a needle's shaft crossing an axial slice, projects onto the plane as zero-area
//! triangles.

use crate::mesh::Mesh;
use glam::{Mat4, Vec2, Vec3};

/// The plane of a slice image: image coordinates `(x, y)` in [0, 1]^2 (y down) and `s`, mm
/// along the plane's normal, to patient space; and back.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SliceFrame {
    pub image_to_world: Mat4,
    pub world_to_image: Mat4,
}

/// Vertices (position, normal) of the outline quads of `mesh` placed by `model` in `frame`,
/// in clip space at depth `depth`, `width` pixels wide in an image of `size` pixels.
pub(crate) fn outline_quads(
    mesh: &Mesh,
    model: Mat4,
    frame: &SliceFrame,
    size: [u32; 2],
    width: f32,
    depth: f32,
) -> Vec<f32> {
    let to_image = frame.world_to_image * model;
    let image: Vec<Vec3> = mesh.positions.iter().map(|&p| to_image.transform_point3(Vec3::from(p))).collect();
    let half = Vec2::new(width / size[0].max(1) as f32, width / size[1].max(1) as f32);
    let mut out = Vec::new();
    for tri in mesh.indices.chunks_exact(3) {
        let corners = [tri[0], tri[1], tri[2]].map(|i| image.get(i as usize).copied().unwrap_or(Vec3::ZERO));
        if let Some((a, b)) = crossing(corners) {
            push_quad(&mut out, ndc(a), ndc(b), half, depth);
        }
    }
    out
}

/// Image coordinates (y down) to clip space (y up).
fn ndc(p: Vec2) -> Vec2 {
    Vec2::new(p.x * 2.0 - 1.0, 1.0 - p.y * 2.0)
}

/// The segment where a triangle (image coordinates, `z` = mm from the plane) crosses `z = 0`.
fn crossing(t: [Vec3; 3]) -> Option<(Vec2, Vec2)> {
    let mut points = Vec::with_capacity(2);
    for (p, q) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
        // Half-open on the upper side, so a vertex on the plane counts once.
        if (p.z < 0.0) != (q.z < 0.0) {
            let k = p.z / (p.z - q.z);
            points.push(p.truncate().lerp(q.truncate(), k));
        }
    }
    match points[..] {
        [a, b] if a.is_finite() && b.is_finite() => Some((a, b)),
        _ => None,
    }
}

/// Two triangles covering the segment `a`-`b` widened by `half` (clip units per axis) on each
/// side and at its ends, so consecutive segments join without gaps.
fn push_quad(out: &mut Vec<f32>, a: Vec2, b: Vec2, half: Vec2, depth: f32) {
    let pixels = |v: Vec2| v / half;
    let along = pixels(b - a).try_normalize().unwrap_or(Vec2::X);
    let across = Vec2::new(-along.y, along.x);
    let (along, across) = (along * half, across * half);
    let corners = [a - along - across, a - along + across, b + along + across, b + along - across];
    for i in [0, 1, 2, 0, 2, 3] {
        let c = corners[i];
        out.extend_from_slice(&[c.x, c.y, depth, 0.0, 0.0, 1.0]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_triangle_across_the_plane_gives_one_segment_on_it() {
        let t = [Vec3::new(0.0, 0.0, -1.0), Vec3::new(1.0, 0.0, 1.0), Vec3::new(0.0, 1.0, 1.0)];
        let (a, b) = crossing(t).unwrap();
        assert!((a - Vec2::new(0.5, 0.0)).length() < 1e-6, "{a}");
        assert!((b - Vec2::new(0.0, 0.5)).length() < 1e-6, "{b}");
    }

    #[test]
    fn triangles_on_one_side_give_none() {
        let t = [Vec3::new(0.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 2.0), Vec3::new(0.0, 1.0, 0.5)];
        assert!(crossing(t).is_none());
        let flat = [Vec3::ZERO, Vec3::X, Vec3::Y];
        assert!(crossing(flat).is_none(), "a triangle in the plane has no crossing segment");
    }

    #[test]
    fn a_vertical_cylinder_crossing_an_axial_plane_outlines_a_circle() {
        let mesh = crate::mesh::shapes::cylinder(Vec3::new(0.0, 0.0, -10.0), Vec3::new(0.0, 0.0, 10.0), 5.0, 32)
            .expect("a cylinder");
        // Image x, y over [-20, 20] mm in x and y; s = z.
        let image_to_world = Mat4::from_cols_array(&[
            40.0, 0.0, 0.0, 0.0, //
            0.0, -40.0, 0.0, 0.0, //
            0.0, 0.0, 1.0, 0.0, //
            -20.0, 20.0, 0.0, 1.0,
        ]);
        let frame = SliceFrame { image_to_world, world_to_image: image_to_world.inverse() };
        let quads = outline_quads(&mesh, Mat4::IDENTITY, &frame, [400, 400], 1.0, 0.5);
        assert_eq!(quads.len() % 36, 0);
        assert!(quads.len() / 36 >= 32, "one segment per side face crossing: {}", quads.len() / 36);
        // Every vertex lies within a pixel or two of the circle of radius 5 mm (0.25 in clip units).
        for v in quads.chunks_exact(6) {
            let r = Vec2::new(v[0], v[1]).length();
            assert!((r - 0.25).abs() < 0.02, "{r}");
            assert_eq!(v[2], 0.5);
        }
    }
}
