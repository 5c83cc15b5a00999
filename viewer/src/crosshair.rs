//! The crosshair of slice views, as 3D Slicer and OsiriX users know it: a click in one slice view
//! moves every other slice view's plane through the clicked point, and each slice view shows
//! where the other slice views cut it. Plain functions of the planes and the image's placement,
//! so they are tested without a window.

use glam::Vec3;
use vrs_runtime::SlicePlane;
use vrs_runtime::geometry::PatientBox;

/// Where another slice view cuts a slice view's image: a line across it at an image coordinate
/// in [0, 1] (x from the left, y from the top).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Cut {
    /// A vertical line at this x.
    Vertical(f32),
    /// A horizontal line at this y.
    Horizontal(f32),
}

/// `planes` (slice views' planes, in box coordinates over `patient`) moved along their normals
/// to pass through `point` (patient space, mm); a plane whose normal is not a patient axis is
/// left alone (slice planes always are axis planes here).
pub fn through(point: Vec3, planes: &[SlicePlane], patient: &PatientBox) -> Vec<SlicePlane> {
    planes
        .iter()
        .map(|plane| match normal_axis(plane) {
            Some(axis) => {
                let size = patient.size()[axis];
                let mut moved = *plane;
                if size > 0.0 && size.is_finite() {
                    moved.origin[axis] = ((point[axis] - patient.min[axis]) / size).clamp(0.0, 1.0);
                }
                moved
            }
            None => *plane,
        })
        .collect()
}

/// Where each of `others` (planes in box coordinates over `patient`) cuts an image whose
/// top-left, top-right and bottom-left corners lie at `corners` (patient space, mm): a vertical
/// line where the plane's coordinate varies along the image's x, a horizontal one where it varies
/// along y; none for a plane parallel to the image or outside it.
pub fn cuts(corners: [Vec3; 3], others: &[SlicePlane], patient: &PatientBox) -> Vec<Cut> {
    let [top_left, top_right, bottom_left] = corners;
    let (across, down) = (top_right - top_left, bottom_left - top_left);
    others
        .iter()
        .filter_map(|plane| {
            let axis = normal_axis(plane)?;
            let at = patient.min[axis] + plane.origin[axis] * patient.size()[axis];
            let along = |edge: Vec3| {
                let t = (at - top_left[axis]) / edge[axis];
                (edge[axis].abs() > 1e-6 && (0.0..=1.0).contains(&t)).then_some(t)
            };
            // The image's axes are patient axes: the plane varies along one of them.
            along(across).map(Cut::Vertical).or_else(|| along(down).map(Cut::Horizontal))
        })
        .collect()
}

/// The patient axis (0, 1, 2) a slice plane is normal to, if it is normal to one.
fn normal_axis(plane: &SlicePlane) -> Option<usize> {
    let normal = plane.u.cross(plane.v);
    (0..3).find(|&a| normal[a].abs() > 0.999 * normal.length())
}

#[cfg(test)]
mod tests {
    use super::*;
    use vrs_runtime::SliceAxis;

    /// A 200 x 100 x 50 mm box from (-100, -50, 0).
    fn patient() -> PatientBox {
        PatientBox::of(
            glam::Mat4::from_translation(Vec3::new(-100.0, -50.0, 0.0))
                * glam::Mat4::from_scale(Vec3::new(200.0, 100.0, 50.0)),
        )
    }

    #[test]
    fn a_click_moves_the_other_planes_through_the_point() {
        let planes = [SlicePlane::new(SliceAxis::X, 0.5), SlicePlane::new(SliceAxis::Y, 0.5)];
        let moved = through(Vec3::new(50.0, -25.0, 10.0), &planes, &patient());
        assert_eq!(moved[0].origin.x, 0.75, "x = 50 mm is three quarters of -100 .. 100");
        assert_eq!(moved[1].origin.y, 0.25, "y = -25 mm is a quarter of -50 .. 50");
        assert_eq!((moved[0].u, moved[0].v), (planes[0].u, planes[0].v), "only the position changes");
        let beyond = through(Vec3::new(500.0, 0.0, 0.0), &planes[..1], &patient());
        assert_eq!(beyond[0].origin.x, 1.0, "kept within the box");
    }

    #[test]
    fn the_other_planes_cut_an_axial_image_in_a_cross() {
        // An axial image (radiological: x runs from the patient's right, +x, to the left) at
        // z = 10: top-left corner (100, 50), top-right (-100, 50), bottom-left (100, -50).
        let corners = [Vec3::new(100.0, 50.0, 10.0), Vec3::new(-100.0, 50.0, 10.0), Vec3::new(100.0, -50.0, 10.0)];
        let sagittal = SlicePlane::new(SliceAxis::X, 0.75); // x = 50 mm
        let coronal = SlicePlane::new(SliceAxis::Y, 0.25); // y = -25 mm
        let axial = SlicePlane::new(SliceAxis::Z, 0.1); // parallel: no cut
        let cuts = cuts(corners, &[sagittal, coronal, axial], &patient());
        assert_eq!(cuts, [Cut::Vertical(0.25), Cut::Horizontal(0.75)]);
    }
}
