//! What the mouse and keys do to a view, as plain functions of the camera or plane: orbit, pan
//! and zoom of 3D views; stepping and turning of slice views.

use glam::{Vec2, Vec3};
use vrs_runtime::{OrbitCamera, SliceAxis, SlicePlane};

/// Degrees of orbit per pixel dragged.
const DEGREES_PER_PIXEL: f32 = 0.4;

/// Orbits around the target: dragging right turns the volume right, dragging up tilts it up.
pub fn orbit(camera: OrbitCamera, drag: Vec2) -> OrbitCamera {
    OrbitCamera {
        azimuth: (camera.azimuth - drag.x * DEGREES_PER_PIXEL).rem_euclid(360.0),
        elevation: (camera.elevation + drag.y * DEGREES_PER_PIXEL).clamp(-89.0, 89.0),
        ..camera
    }
}

/// Moves the target in the image plane so that the volume follows the pointer; `height` is the
/// view's height in the same pixels as `drag`.
pub fn pan(camera: OrbitCamera, drag: Vec2, height: f32) -> OrbitCamera {
    let (az, el) = (camera.azimuth.to_radians(), camera.elevation.to_radians());
    let towards_eye = Vec3::new(az.sin() * el.cos(), az.cos() * el.cos(), el.sin());
    let right = (-towards_eye).cross(Vec3::Z).normalize_or_zero();
    let up = right.cross(-towards_eye);
    // World units per pixel at the target's depth.
    let per_pixel = 2.0 * camera.distance * (camera.fov.to_radians() / 2.0).tan() / height.max(1.0);
    let target = camera.target - right * drag.x * per_pixel + up * drag.y * per_pixel;
    OrbitCamera { target, ..camera }
}

/// Zooms in for a positive scroll (in pixels), out for a negative one.
pub fn zoom(camera: OrbitCamera, scroll: f32) -> OrbitCamera {
    OrbitCamera { distance: (camera.distance * (-scroll * 0.002).exp()).clamp(0.3, 20.0), ..camera }
}

/// The index axis a slice plane is normal to.
pub fn slice_axis(plane: &SlicePlane) -> SliceAxis {
    let flat = |i: usize| plane.u[i] == 0.0 && plane.v[i] == 0.0;
    if flat(0) {
        SliceAxis::X
    } else if flat(1) {
        SliceAxis::Y
    } else {
        SliceAxis::Z
    }
}

fn axis_index(axis: SliceAxis) -> usize {
    match axis {
        SliceAxis::X => 0,
        SliceAxis::Y => 1,
        SliceAxis::Z => 2,
    }
}

/// The plane's position along its axis, in [0, 1].
pub fn slice_position(plane: &SlicePlane) -> f32 {
    plane.origin[axis_index(slice_axis(plane))]
}

/// The plane moved by `voxels` along its axis (one wheel notch is one voxel of a grid of
/// `dims`), staying on the volume's voxel centres.
pub fn step_slice(plane: SlicePlane, voxels: i32, dims: [u32; 3]) -> SlicePlane {
    let axis = axis_index(slice_axis(&plane));
    let n = dims[axis].max(1) as f32;
    let index = (plane.origin[axis] * n - 0.5).round() + voxels as f32;
    let mut origin = plane.origin;
    origin[axis] = (index.clamp(0.0, n - 1.0) + 0.5) / n;
    SlicePlane { origin, ..plane }
}

/// The plane turned to `axis`, through the volume's centre.
pub fn turn_slice(plane: SlicePlane, axis: SliceAxis) -> SlicePlane {
    if slice_axis(&plane) == axis { plane } else { SlicePlane::new(axis, 0.5) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orbiting_turns_and_tilts_within_the_poles() {
        let c = OrbitCamera::default();
        let turned = orbit(c, Vec2::new(100.0, 0.0));
        assert!((turned.azimuth - 320.0).abs() < 1e-3, "{}", turned.azimuth);
        assert_eq!(orbit(c, Vec2::new(0.0, 1e4)).elevation, 89.0);
        assert_eq!(turned.distance, c.distance);
    }

    #[test]
    fn panning_right_moves_the_target_left_in_the_image_plane() {
        let c = OrbitCamera::default(); // looks from +y towards -y; image right is -x
        let p = pan(c, Vec2::new(10.0, 0.0), 100.0);
        assert!(p.target.x > 0.0 && p.target.y.abs() < 1e-6 && p.target.z.abs() < 1e-6, "{}", p.target);
        let up = pan(c, Vec2::new(0.0, 10.0), 100.0);
        assert!(up.target.z > 0.0, "dragging down moves the volume down: {}", up.target);
    }

    #[test]
    fn zoom_is_bounded_and_symmetric() {
        let c = OrbitCamera::default();
        let back = zoom(zoom(c, 120.0), -120.0);
        assert!((back.distance - c.distance).abs() < 1e-4);
        assert!(zoom(c, 1e6).distance >= 0.3 && zoom(c, -1e6).distance <= 20.0);
    }

    #[test]
    fn slices_step_by_one_voxel_and_stop_at_the_ends() {
        let dims = [10, 20, 4];
        let plane = SlicePlane::new(SliceAxis::Z, 1.5 / 4.0); // the centre of voxel 1
        let up = step_slice(plane, 1, dims);
        assert!((slice_position(&up) - 2.5 / 4.0).abs() < 1e-6, "{}", slice_position(&up));
        let between = step_slice(SlicePlane::new(SliceAxis::Z, 0.52), 0, dims);
        assert!((slice_position(&between) - 2.5 / 4.0).abs() < 1e-6, "snaps to the nearest centre");
        let far = step_slice(plane, 100, dims);
        assert!((slice_position(&far) - 3.5 / 4.0).abs() < 1e-6);
        let low = step_slice(plane, -100, dims);
        assert!((slice_position(&low) - 0.5 / 4.0).abs() < 1e-6);
        assert_eq!(slice_axis(&turn_slice(plane, SliceAxis::X)), SliceAxis::X);
        assert_eq!(slice_axis(&SlicePlane::new(SliceAxis::Y, 0.2)), SliceAxis::Y);
    }
}
