//! What the mouse and keys do to a view, as plain functions of the camera or plane: orbit, pan
//! and zoom of 3D views; stepping and turning of slice views.

use glam::{Mat4, Vec2, Vec3};
use vrs_runtime::geometry::{PatientBox, volume_to_world};
use vrs_runtime::tf::TfCurve;
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

/// The plane moved by `voxels` voxels along its normal in patient space, on the primary grid
/// of `dims` voxels that `grid_to_world` (voxel indices to RAS mm) places. One voxel is the
/// smallest physical extent of a voxel along the normal: the distance along it after which
/// some index coordinate has moved by one (on an axis-aligned grid, the spacing of the axis
/// along the normal; on an oblique grid it never jumps a voxel of any axis). Positions snap to
/// the planes one such step apart through the centre of voxel 0 (on an axis-aligned grid, the
/// voxel centres) and stay between the grid's outermost voxel centres.
pub fn step_slice(plane: SlicePlane, voxels: i32, dims: [u32; 3], grid_to_world: Mat4) -> SlicePlane {
    let Some(grid) = SliceSteps::of(&plane, dims, grid_to_world) else { return plane };
    let index = (grid.index(&plane).round() + voxels as f32).clamp(grid.lowest, grid.highest);
    let mut origin = plane.origin;
    origin[grid.axis] = (grid.first + index * grid.step - grid.low) / grid.size;
    SlicePlane { origin, ..plane }
}

/// Where a slice view's plane is, as its header says it: the patient coordinate along its
/// normal in millimetres (RAS: x right, y anterior, z superior) and the slice's number among
/// the steps [`step_slice`] takes (1-based; on an axis-aligned grid, the voxel index + 1), e.g.
/// `z 12.5 mm · slice 76 of 189`.
pub fn slice_position_text(plane: &SlicePlane, dims: [u32; 3], grid_to_world: Mat4) -> Option<String> {
    let grid = SliceSteps::of(plane, dims, grid_to_world)?;
    let mm = grid.low + plane.origin[grid.axis] * grid.size;
    let number = grid.index(plane) - grid.lowest + 1.0;
    let count = grid.highest - grid.lowest + 1.0;
    let axis = ["x", "y", "z"][grid.axis];
    // Between two slices (a plane placed by hand, an oblique grid) the number says so.
    let number = if (number - number.round()).abs() < 0.01 { format!("{number:.0}") } else { format!("{number:.1}") };
    Some(format!("{axis} {mm:.1} mm · slice {number} of {count:.0}"))
}

/// The positions a plane steps through along its normal (see [`step_slice`]), in patient
/// millimetres: one `step` apart from the centre of voxel 0 (`first`), numbered from `lowest`
/// to `highest`; the grid's box spans `size` from `low`.
struct SliceSteps {
    axis: usize,
    step: f32,
    first: f32,
    low: f32,
    size: f32,
    lowest: f32,
    highest: f32,
}

impl SliceSteps {
    fn of(plane: &SlicePlane, dims: [u32; 3], grid_to_world: Mat4) -> Option<SliceSteps> {
        let axis = axis_index(slice_axis(plane));
        // The plane's normal in patient space is the patient axis `axis` (planes lie in box
        // coordinates, whose axes are R, A, S).
        let step = voxel_step_along(Vec3::AXES[axis], grid_to_world)?;
        let patient = PatientBox::of(volume_to_world(dims, grid_to_world));
        let (low, size) = (patient.min[axis], patient.size()[axis]);
        if !(size.is_finite() && size > 0.0) {
            return None;
        }
        // Distances along the normal from the centre of voxel 0.
        let first = grid_to_world.transform_point3(Vec3::ZERO)[axis];
        let (near, far) = voxel_centre_span(dims, grid_to_world, axis);
        let (near, far) = (near - first, far - first);
        // The tolerance keeps a centre that rounding puts a hair outside the span.
        let lowest = (near / step - 1e-3).ceil();
        let highest = (far / step + 1e-3).floor().max(lowest);
        Some(SliceSteps { axis, step, first, low, size, lowest, highest })
    }

    /// The plane's (fractional) step number from the centre of voxel 0.
    fn index(&self, plane: &SlicePlane) -> f32 {
        (self.low + plane.origin[self.axis] * self.size - self.first) / self.step
    }
}

/// The smallest physical extent of a voxel along the unit patient-space direction `normal`:
/// the distance along it over which the fastest-changing voxel index changes by one. `None`
/// for a degenerate grid.
fn voxel_step_along(normal: Vec3, grid_to_world: Mat4) -> Option<f32> {
    let to_index = glam::Mat3::from_mat4(grid_to_world).inverse();
    let per_mm = (to_index * normal).abs().max_element();
    let step = 1.0 / per_mm;
    (step.is_finite() && step > 0.0).then_some(step)
}

/// The lowest and highest patient coordinate along `axis` of the grid's corner voxel centres.
fn voxel_centre_span(dims: [u32; 3], grid_to_world: Mat4, axis: usize) -> (f32, f32) {
    let last = Vec3::from(dims.map(|d| d.max(1) as f32 - 1.0));
    (0..8)
        .map(|corner| {
            let pick = |bit: usize, v: f32| if corner & (1 << bit) != 0 { v } else { 0.0 };
            let index = Vec3::new(pick(0, last.x), pick(1, last.y), pick(2, last.z));
            grid_to_world.transform_point3(index)[axis]
        })
        .fold((f32::MAX, f32::MIN), |(lo, hi), c| (lo.min(c), hi.max(c)))
}

/// The window/level change of a drag of `drag` points in a slice view of `height` points over
/// a transfer function `width` data units wide: the level's shift (down raises it; the view's
/// height is one width) and the width's scale (right widens it, doubling every 200 points).
pub fn window_level_change(drag: Vec2, height: f32, width: f32) -> (f32, f32) {
    (drag.y / height.max(1.0) * width, (drag.x / 200.0).exp2())
}

/// Radiology's CT windows (Hounsfield units), the keys 1 to 5 over a slice view and its
/// right-click menu: name, level, width.
pub const CT_WINDOWS: [(&str, f32, f32); 5] = [
    ("Brain", 40.0, 80.0),
    ("Soft tissue", 50.0, 400.0),
    ("Lung", -600.0, 1500.0),
    ("Bone", 400.0, 1800.0),
    ("Mediastinum", 50.0, 350.0),
];

/// `curve` (over the volume's `window`) with its domain moved to the window of `level` and
/// `width` data units: a CT window preset, every point kept in its place relative to the domain.
pub fn windowed_at(curve: &TfCurve, window: [f32; 2], level: f32, width: f32) -> TfCurve {
    let [lo, hi] = curve.data_domain(window);
    curve.window_levelled(window, level - 0.5 * (lo + hi), width / (hi - lo).max(f32::MIN_POSITIVE))
}

/// A window of data values `[lo, hi]` as reading software shows it: `W 80 L 40`.
pub fn window_text([lo, hi]: [f32; 2]) -> String {
    format!("W {:.0} L {:.0}", hi - lo, 0.5 * (lo + hi))
}

/// What the mouse and the keys do in the views: the keyboard help (F1 or `?`) lists them.
pub const KEYS: [(&str, &str); 16] = [
    ("3D: drag", "orbit"),
    ("3D: right or middle drag", "pan"),
    ("3D: wheel", "zoom"),
    ("slice: wheel, Up/Down, PageUp/PageDown", "step one voxel"),
    ("slice: X / Y / Z", "turn to sagittal / coronal / axial"),
    ("slice: drag a green ring", "move a mesh point (a needle's tip)"),
    ("slice: click", "move the other slices through the point (crosshair)"),
    ("slice: right drag", "this view's window (across) and level (up and down) of the primary volume"),
    ("slice: 1 to 5, or right-click", "CT window: brain, soft tissue, lung, bone, mediastinum"),
    ("slice: 0", "the volume's own window again (as the other views)"),
    ("R", "reset the view's camera or plane to the scene's"),
    ("E", "export the view as `vrsc render` writes it: SCENE-VIEW.png beside the scene"),
    ("Shift+E", "export the whole window as it is on screen: SCENE-window.png beside the scene"),
    ("L (Link 3D in the toolbar)", "link the 3D views' cameras: moving one moves them all"),
    ("F1 or ?", "show or hide these keys"),
    ("Panel (toolbar)", "parameters, transfer functions, meshes, inspector"),
];

/// The keyboard help: a window listing [`KEYS`], shown while `open`.
pub fn keys_window(ctx: &egui::Context, open: &mut bool) {
    egui::Window::new("Keys").open(open).collapsible(false).resizable(false).show(ctx, |ui| {
        egui::Grid::new("keys").striped(true).show(ui, |ui| {
            for (input, action) in KEYS {
                ui.label(egui::RichText::new(input).monospace());
                ui.label(action);
                ui.end_row();
            }
        });
    });
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
    fn the_slice_position_reads_in_millimetres_and_slice_numbers() {
        // 4 slices of 2.5 mm along z, voxel 0's centre at z = -10 mm: centres at -10, -7.5, -5,
        // -2.5; the box from -11.25 to -1.25.
        let g = Mat4::from_translation(Vec3::new(0.0, 0.0, -10.0)) * Mat4::from_scale(Vec3::new(1.0, 1.0, 2.5));
        let dims = [10, 20, 4];
        let second = SlicePlane::new(SliceAxis::Z, 1.5 / 4.0);
        assert_eq!(slice_position_text(&second, dims, g).as_deref(), Some("z -7.5 mm · slice 2 of 4"));
        let last = step_slice(second, 10, dims, g);
        assert_eq!(slice_position_text(&last, dims, g).as_deref(), Some("z -2.5 mm · slice 4 of 4"));
        let sagittal = SlicePlane::new(SliceAxis::X, 0.5);
        assert_eq!(slice_position_text(&sagittal, dims, g).as_deref(), Some("x 4.5 mm · slice 5.5 of 10"));
    }

    #[test]
    fn slices_step_by_one_voxel_and_stop_at_the_ends() {
        let dims = [10, 20, 4];
        let g = Mat4::IDENTITY;
        let plane = SlicePlane::new(SliceAxis::Z, 1.5 / 4.0); // the centre of voxel 1
        let up = step_slice(plane, 1, dims, g);
        assert!((slice_position(&up) - 2.5 / 4.0).abs() < 1e-6, "{}", slice_position(&up));
        let between = step_slice(SlicePlane::new(SliceAxis::Z, 0.52), 0, dims, g);
        assert!((slice_position(&between) - 2.5 / 4.0).abs() < 1e-6, "snaps to the nearest centre");
        let far = step_slice(plane, 100, dims, g);
        assert!((slice_position(&far) - 3.5 / 4.0).abs() < 1e-6);
        let low = step_slice(plane, -100, dims, g);
        assert!((slice_position(&low) - 0.5 / 4.0).abs() < 1e-6);
        assert_eq!(slice_axis(&turn_slice(plane, SliceAxis::X)), SliceAxis::X);
        assert_eq!(slice_axis(&SlicePlane::new(SliceAxis::Y, 0.2)), SliceAxis::Y);
    }

    /// The patient-space distance (mm) between two planes normal to `axis`.
    fn moved_mm(a: &SlicePlane, b: &SlicePlane, dims: [u32; 3], g: Mat4) -> f32 {
        let size = PatientBox::of(volume_to_world(dims, g)).size();
        let axis = axis_index(slice_axis(a));
        (b.origin[axis] - a.origin[axis]) * size[axis]
    }

    #[test]
    fn a_permuted_grid_steps_by_the_spacing_along_the_normal() {
        // Index axes: i -> superior (2 mm), j -> right (0.5 mm), k -> posterior (3 mm).
        let g = Mat4::from_cols(
            glam::Vec4::new(0.0, 0.0, 2.0, 0.0),
            glam::Vec4::new(0.5, 0.0, 0.0, 0.0),
            glam::Vec4::new(0.0, -3.0, 0.0, 0.0),
            glam::Vec4::new(10.0, 20.0, -30.0, 1.0),
        );
        let dims = [8, 40, 6];
        for (axis, spacing, count) in [(SliceAxis::Z, 2.0, 8), (SliceAxis::X, 0.5, 40), (SliceAxis::Y, 3.0, 6)] {
            let start = step_slice(SlicePlane::new(axis, 0.5), 0, dims, g);
            let next = step_slice(start, 1, dims, g);
            let moved = moved_mm(&start, &next, dims, g);
            assert!((moved - spacing).abs() < 1e-3, "{axis:?}: moved {moved} mm, spacing {spacing}");
            // From one end to the other: every voxel centre once.
            let bottom = step_slice(start, -1000, dims, g);
            let top = step_slice(start, 1000, dims, g);
            let span = moved_mm(&bottom, &top, dims, g);
            assert!((span - spacing * (count - 1) as f32).abs() < 1e-3, "{axis:?}: span {span}");
            // The ends are half a voxel inside the box.
            assert!(
                (slice_position(&bottom) - 0.5 / count as f32).abs() < 1e-4,
                "{axis:?}: {}",
                slice_position(&bottom)
            );
        }
    }

    #[test]
    fn an_oblique_grid_steps_by_the_smallest_extent_of_a_voxel_along_the_normal() {
        // 1 x 1 x 4 mm voxels turned by 30 degrees about the patient's x axis: along superior,
        // index j changes by sin(30)/1 per mm and k by cos(30)/4 per mm, so j is the fastest and
        // one step is 1 / sin(30) = 2 mm (not the 4 mm slice spacing, nor the 1 mm pixel size).
        let turn = Mat4::from_rotation_x(30f32.to_radians());
        let g = turn * Mat4::from_scale(Vec3::new(1.0, 1.0, 4.0));
        let dims = [32, 32, 16];
        let start = step_slice(SlicePlane::new(SliceAxis::Z, 0.5), 0, dims, g);
        let next = step_slice(start, 1, dims, g);
        let moved = moved_mm(&start, &next, dims, g);
        assert!((moved - 2.0).abs() < 1e-3, "moved {moved} mm");
        let back = step_slice(next, -1, dims, g);
        assert!(moved_mm(&start, &back, dims, g).abs() < 1e-3, "steps are reversible");
        // A slight tilt (1 degree) of an axis-aligned grid keeps about its slice spacing.
        let tilted = Mat4::from_rotation_x(1f32.to_radians()) * Mat4::from_scale(Vec3::new(1.0, 1.0, 4.0));
        let s = step_slice(SlicePlane::new(SliceAxis::Z, 0.5), 0, dims, tilted);
        let moved = moved_mm(&s, &step_slice(s, 1, dims, tilted), dims, tilted);
        assert!((moved - 4.0).abs() < 0.3, "moved {moved} mm");
    }

    #[test]
    fn a_right_drag_across_scales_the_width_and_down_moves_the_level() {
        let (shift, scale) = window_level_change(Vec2::new(200.0, 0.0), 400.0, 1000.0);
        assert_eq!((shift, scale), (0.0, 2.0), "200 points right double the width");
        let (shift, scale) = window_level_change(Vec2::new(-200.0, 100.0), 400.0, 1000.0);
        assert_eq!((shift, scale), (250.0, 0.5), "a quarter of the height down: a quarter width up");
    }

    #[test]
    fn a_ct_window_preset_puts_the_curve_on_its_window() {
        let grey = vrs_runtime::tf::preset_curve("grayscale").unwrap();
        let volume_window = [-1000.0, 2000.0];
        let (_, level, width) = CT_WINDOWS[0];
        let brain = windowed_at(&grey, volume_window, level, width);
        assert_eq!(brain.data_domain(volume_window), [0.0, 80.0]);
        assert_eq!(window_text(brain.data_domain(volume_window)), "W 80 L 40");
        // The ramp keeps its shape over the new window: its first and last points at its ends.
        assert_eq!(brain.color.first().map(|c| c.0), Some(0.0));
        assert_eq!(brain.color.last().map(|c| c.0), Some(80.0));
        assert_eq!(window_text(grey.data_domain(volume_window)), "W 3000 L 500");
    }
}
