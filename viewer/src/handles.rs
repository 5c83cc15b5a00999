//! Dragging the points meshes follow (an ablation needle's tip) in slice views: where each shows
//! (its marker), which one a press grabs, and the point under the cursor, as plain functions of
//! the plane's mapping so they are tested without a window.
//!
//! Every point a mesh follows that is a position ([`LiveScene::mesh_handles`]: a needle's tip,
//! not its direction) gets a marker in every slice view whose image it falls in, however far it
//! is from the plane: a tip usually lies a few millimetres off the slice that shows its zone,
//! and a drag keeps that distance (the point moves in a plane parallel to the slice), so the
//! point never jumps through the volume. The marker is filled when the point lies within
//! [`IN_PLANE_MM`] of the plane.

use glam::{Mat4, Vec2, Vec3};
use vrs_live::LiveScene;
use vrs_runtime::Value;
use vrs_runtime::scene::MeshHandle;

/// How close (screen points) to a marker's centre a press grabs it.
pub const GRAB_RADIUS: f32 = 8.0;

/// Within this distance (mm) from the plane a point counts as in the slice.
pub const IN_PLANE_MM: f32 = 2.0;

/// A mesh's point as a slice view shows it.
#[derive(Clone, Debug, PartialEq)]
pub struct Marker {
    /// The `[[mesh]]` whose point it is.
    pub mesh: String,
    /// The `vec3f` uniform the point follows.
    pub uniform: String,
    /// Where the point is drawn: the uniform's value placed by the mesh's placement (patient
    /// space, mm).
    pub shown: Vec3,
    /// Image coordinates of `shown` in [0, 1]^2, y down.
    pub image: Vec2,
    /// Its distance from the plane along the plane's normal (mm).
    pub depth: f32,
    /// The mesh's placement: the uniform's value to where it is drawn.
    pub model: Mat4,
}

impl Marker {
    /// Whether the point lies in the slice (within [`IN_PLANE_MM`]).
    pub fn in_plane(&self) -> bool {
        self.depth.abs() <= IN_PLANE_MM
    }
}

/// The markers of `handles` that fall in the image: `model_of` gives a mesh's placement,
/// `to_pixel` a patient-space point's image coordinates and distance from the plane (the
/// slice view's [`vrs_runtime::SliceGeometry::world_to_pixel`]).
pub fn markers(
    handles: &[MeshHandle],
    model_of: impl Fn(&str) -> Option<Mat4>,
    to_pixel: impl Fn(Vec3) -> Option<([f32; 2], f32)>,
) -> Vec<Marker> {
    handles
        .iter()
        .filter_map(|h| {
            let model = model_of(&h.mesh).unwrap_or(Mat4::IDENTITY);
            let shown = model.transform_point3(h.point);
            let (image, depth) = to_pixel(shown)?;
            let image = Vec2::from(image);
            let inside = image.cmpge(Vec2::ZERO).all() && image.cmple(Vec2::ONE).all();
            (inside && depth.is_finite()).then(|| Marker {
                mesh: h.mesh.clone(),
                uniform: h.uniform.clone(),
                shown,
                image,
                depth,
                model,
            })
        })
        .collect()
}

/// Image coordinates ([0, 1]^2, y down) of a screen position, for an image drawn at `min` with
/// `size` (screen points).
pub fn to_image(position: Vec2, min: Vec2, size: Vec2) -> Vec2 {
    (position - min) / size.max(Vec2::ONE)
}

/// The marker a press at `cursor` (image coordinates) grabs: the nearest within `radius`
/// screen points on an image of `size` points, if any.
pub fn hit(markers: &[Marker], cursor: Vec2, size: Vec2, radius: f32) -> Option<usize> {
    markers
        .iter()
        .enumerate()
        .map(|(i, m)| (i, ((m.image - cursor) * size).length()))
        .filter(|&(_, distance)| distance <= radius)
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(i, _)| i)
}

/// A marker being dragged: its uniform follows the cursor in the plane, at the distance from
/// the plane it had when grabbed.
#[derive(Clone, Debug, PartialEq)]
pub struct HandleDrag {
    /// The `[[mesh]]` whose point is dragged.
    pub mesh: String,
    /// The `vec3f` uniform the drag sets.
    pub uniform: String,
    /// The drawn point minus its foot on the plane: along the normal, the point's depth.
    offset: Vec3,
    /// A drawn position to the uniform's value (the placement's inverse).
    to_uniform: Mat4,
}

impl HandleDrag {
    /// Grabs `marker`; `to_world` is the view's image coordinates to the point on the plane
    /// ([`vrs_runtime::SliceGeometry::pixel_to_world`]). `None` when the plane or the
    /// mesh's placement is degenerate.
    pub fn start(marker: &Marker, to_world: impl Fn(Vec2) -> Option<Vec3>) -> Option<HandleDrag> {
        let foot = to_world(marker.image)?;
        let determinant = marker.model.determinant();
        let to_uniform = marker.model.inverse();
        let offset = marker.shown - foot;
        let invertible = determinant != 0.0 && to_uniform.is_finite();
        (invertible && offset.is_finite()).then(|| HandleDrag {
            mesh: marker.mesh.clone(),
            uniform: marker.uniform.clone(),
            offset,
            to_uniform,
        })
    }

    /// The uniform's value that draws the point under `cursor` (image coordinates) at its
    /// depth.
    pub fn value_at(&self, cursor: Vec2, to_world: impl Fn(Vec2) -> Option<Vec3>) -> Option<Vec3> {
        let on_plane = to_world(cursor)?;
        let value = self.to_uniform.transform_point3(on_plane + self.offset);
        value.is_finite().then_some(value)
    }
}

/// The markers of slice view `index` of `live` (none for a raycast view).
pub fn slice_markers(live: &LiveScene, index: usize) -> Vec<Marker> {
    let renderer = live.renderer();
    if live.slice(index).is_none() {
        return Vec::new();
    }
    let model_of = |mesh: &str| renderer.meshes().iter().find(|m| m.name == mesh).map(|m| m.model);
    let geometry = renderer.slice_geometry(index);
    markers(&live.mesh_handles(), model_of, |p| Some(geometry?.world_to_pixel(p)))
}

/// Grabs the marker of slice view `index` under `cursor` (image coordinates) on an image of
/// `size` screen points, if a marker is within [`GRAB_RADIUS`].
pub fn grab(live: &LiveScene, index: usize, cursor: Vec2, size: Vec2) -> Option<HandleDrag> {
    let markers = slice_markers(live, index);
    let i = hit(&markers, cursor, size, GRAB_RADIUS)?;
    let geometry = live.renderer().slice_geometry(index);
    HandleDrag::start(&markers[i], |p| Some(geometry?.pixel_to_world(p.to_array())))
}

/// Moves the dragged point under `cursor` (image coordinates of slice view `index`): sets its
/// uniform, which moves the mesh and whatever else reads it. Returns the new value.
pub fn drag_to(live: &mut LiveScene, index: usize, drag: &HandleDrag, cursor: Vec2) -> Result<Vec3, String> {
    let geometry = live.renderer().slice_geometry(index);
    let to_world = |p: Vec2| Some(geometry?.pixel_to_world(p.to_array()));
    let value = drag.value_at(cursor, to_world).ok_or_else(|| format!("view {index} is not a slice"))?;
    live.set_uniform(&drag.uniform, Value::Float(value.to_array().to_vec())).map_err(|e| e.to_string())?;
    Ok(value)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An axial plane at z = `z` mm: image x to patient -x (radiological), image y to patient
    /// -y, over 200 mm centred on the origin.
    fn plane(z: f32) -> (impl Fn(Vec2) -> Option<Vec3>, impl Fn(Vec3) -> Option<Projected>) {
        let to_world = move |p: Vec2| Some(Vec3::new(100.0 - 200.0 * p.x, 100.0 - 200.0 * p.y, z));
        let to_pixel = move |w: Vec3| Some(([(100.0 - w.x) / 200.0, (100.0 - w.y) / 200.0], w.z - z));
        (to_world, to_pixel)
    }

    /// Image coordinates and the distance from the plane.
    type Projected = ([f32; 2], f32);

    fn handle(mesh: &str, uniform: &str, point: Vec3) -> MeshHandle {
        MeshHandle { mesh: mesh.into(), uniform: uniform.into(), point }
    }

    #[test]
    fn markers_show_where_the_points_fall_and_how_far_they_are() {
        let (_, to_pixel) = plane(10.0);
        let handles = [
            handle("a", "tip_a", Vec3::new(0.0, 0.0, 13.0)),
            handle("b", "tip_b", Vec3::new(50.0, -50.0, 10.5)),
            // Outside the image: no marker.
            handle("c", "tip_c", Vec3::new(500.0, 0.0, 10.0)),
        ];
        let shift = Mat4::from_translation(Vec3::new(-20.0, 0.0, 0.0));
        let model_of = |mesh: &str| (mesh == "b").then_some(shift);
        let m = markers(&handles, model_of, to_pixel);
        assert_eq!(m.len(), 2);
        assert_eq!(m[0].image, Vec2::new(0.5, 0.5));
        assert!((m[0].depth - 3.0).abs() < 1e-5 && !m[0].in_plane());
        // b is drawn 20 mm to the patient's right of its uniform (image left in this plane).
        assert!((m[1].image - Vec2::new(0.35, 0.75)).length() < 1e-5, "{}", m[1].image);
        assert!(m[1].in_plane());
    }

    #[test]
    fn a_press_grabs_the_nearest_marker_within_the_radius() {
        let (_, to_pixel) = plane(0.0);
        let handles = [handle("a", "tip_a", Vec3::new(0.0, 0.0, 0.0)), handle("b", "tip_b", Vec3::new(-4.0, 0.0, 0.0))];
        let m = markers(&handles, |_| None, to_pixel);
        let size = Vec2::splat(400.0); // 2 points per mm
        let centre = Vec2::splat(0.5);
        assert_eq!(hit(&m, centre, size, GRAB_RADIUS), Some(0));
        // 7 points right of a, 1 point left of b (b is 8 points right of a).
        assert_eq!(hit(&m, centre + Vec2::new(7.0, 0.0) / size, size, GRAB_RADIUS), Some(1));
        // 9 points above a: nothing.
        assert_eq!(hit(&m, centre - Vec2::new(0.0, 9.0) / size, size, GRAB_RADIUS), None);
        assert_eq!(hit(&[], centre, size, GRAB_RADIUS), None);
        assert_eq!(to_image(Vec2::new(300.0, 250.0), Vec2::new(100.0, 50.0), size), centre);
    }

    #[test]
    fn a_drag_moves_the_point_in_the_plane_at_its_depth() {
        let (to_world, to_pixel) = plane(10.0);
        let handles = [handle("a", "tip_a", Vec3::new(4.0, 6.0, 13.5))];
        let m = markers(&handles, |_| None, &to_pixel);
        let drag = HandleDrag::start(&m[0], &to_world).unwrap();
        assert_eq!(drag.uniform, "tip_a");
        // Where it was grabbed: the same point.
        let same = drag.value_at(m[0].image, &to_world).unwrap();
        assert!((same - handles[0].point).length() < 1e-4, "{same}");
        // 0.1 of the image right and down: 20 mm to the patient's left (-x) and posterior (-y).
        let moved = drag.value_at(m[0].image + Vec2::splat(0.1), &to_world).unwrap();
        assert!((moved - Vec3::new(-16.0, -14.0, 13.5)).length() < 1e-4, "{moved}");
    }

    #[test]
    fn a_placed_mesh_is_dragged_where_it_is_drawn() {
        let (to_world, to_pixel) = plane(0.0);
        let placement = Mat4::from_translation(Vec3::new(10.0, 0.0, 2.0));
        let handles = [handle("a", "tip_a", Vec3::new(0.0, 0.0, 0.0))];
        let m = markers(&handles, |_| Some(placement), &to_pixel);
        assert!((m[0].image - Vec2::new(0.45, 0.5)).length() < 1e-5, "drawn 10 mm right: {}", m[0].image);
        assert!((m[0].depth - 2.0).abs() < 1e-5);
        let drag = HandleDrag::start(&m[0], &to_world).unwrap();
        // The drawn tip under the image centre is at (0, 0, 2); the uniform is 10 mm left of it.
        let value = drag.value_at(Vec2::splat(0.5), &to_world).unwrap();
        assert!((value - Vec3::new(-10.0, 0.0, 0.0)).length() < 1e-4, "{value}");
        // A placement that flattens the mesh cannot be undone: no drag.
        let flat = Marker { model: Mat4::from_scale(Vec3::new(1.0, 1.0, 0.0)), ..m[0].clone() };
        assert!(HandleDrag::start(&flat, &to_world).is_none());
        // Nor without a plane.
        assert!(HandleDrag::start(&m[0], |_| None).is_none());
    }
}
