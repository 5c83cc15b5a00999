//! Where things are: the orbit camera of 3D views, the planes of slice views, and the
//! transforms between co-registered volumes.
//!
//! World space is patient space: RAS+ millimetres (x towards the patient's right, y anterior,
//! z superior), as every volume loader delivers it. Shaders work in the primary volume's
//! normalized coordinates, `[0, 1]³` over its voxel grid with voxel centres at (i + 0.5) / size;
//! the runtime turns cameras and planes, which live in patient space, into those coordinates
//! through the primary volume's full grid-to-world transform (rotations, flips, shears), so an
//! oblique or flipped grid shows the same anatomy the same way up as an axis-aligned one.

use glam::{Mat4, Vec3};

/// An orbit camera around the primary volume's centre, in patient space. Superior (+z, RAS) is
/// up; azimuth 0, elevation 0 looks from the front (anterior, +y) towards -y, so the patient's
/// right is on the image's left.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitCamera {
    /// Degrees around the up axis.
    pub azimuth: f32,
    /// Degrees above the horizontal plane, clamped to ±89.
    pub elevation: f32,
    /// Distance from the centre in units of the largest side of the volume's box in patient
    /// space ([`PatientBox`]).
    pub distance: f32,
    /// Vertical field of view in degrees.
    pub fov: f32,
    /// The point orbited and looked at, relative to the volume's centre, in units of the same
    /// largest side, along the patient axes (panning moves it).
    pub target: Vec3,
}

impl Default for OrbitCamera {
    fn default() -> OrbitCamera {
        OrbitCamera { azimuth: 0.0, elevation: 0.0, distance: 2.5, fov: 30.0, target: Vec3::ZERO }
    }
}

/// The primary volume's normalized coordinates to world (RAS mm): the shaders' uniform
/// `volume_to_world`, and what cameras and planes are converted through.
pub fn volume_to_world(dims: [u32; 3], grid_to_world: Mat4) -> Mat4 {
    grid_to_world * normalized_to_index(dims)
}

/// Gradients in the primary volume's normalized coordinates (value per normalized unit) to
/// patient space (value per millimetre): the inverse transpose of `volume_to_world`'s linear
/// part (the shader's `gradient_to_world`). A gradient is a covector: where a grid is stretched
/// along an axis, its values change more slowly per millimetre along it, and a flipped axis
/// flips the gradient's component with it.
pub(crate) fn gradient_to_world(volume_to_world: Mat4) -> glam::Mat3 {
    glam::Mat3::from_mat4(volume_to_world).inverse().transpose()
}

/// The smallest box along the patient axes (RAS) that holds a volume's grid box: where slice
/// planes are placed and what the camera frames.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatientBox {
    /// The corner towards the patient's left, posterior and inferior (smallest RAS).
    pub min: Vec3,
    /// The corner towards the patient's right, anterior and superior (largest RAS).
    pub(crate) max: Vec3,
}

impl PatientBox {
    /// The box around the grid box `[0, 1]³` that `volume_to_world` maps into patient space.
    pub fn of(volume_to_world: Mat4) -> PatientBox {
        let corners = (0..8).map(|i| {
            let c = Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32);
            volume_to_world.transform_point3(c)
        });
        let (min, max) =
            corners.fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(lo, hi), p| (lo.min(p), hi.max(p)));
        PatientBox { min, max }
    }

    /// The side lengths (mm).
    pub fn size(&self) -> Vec3 {
        self.max - self.min
    }

    /// Box coordinates (`[0, 1]³` over the box, axes R, A, S) to world.
    pub(crate) fn to_world(self) -> Mat4 {
        Mat4::from_translation(self.min) * Mat4::from_scale(self.size().max(Vec3::splat(f32::MIN_POSITIVE)))
    }
}

/// The length (mm) of the longest line through a volume's grid box: its longest body diagonal.
/// Rays never take more steps than this over the step size.
pub(crate) fn longest_chord(volume_to_world: Mat4) -> f32 {
    let diagonal = |from: Vec3| {
        let to = Vec3::ONE - from;
        (volume_to_world.transform_point3(to) - volume_to_world.transform_point3(from)).length()
    };
    [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z].into_iter().map(diagonal).fold(0.0, f32::max)
}

/// The smallest voxel spacing of a grid (mm), from the lengths of its voxel axes.
pub(crate) fn smallest_spacing(grid_to_world: Mat4) -> f32 {
    let lengths = [grid_to_world.x_axis, grid_to_world.y_axis, grid_to_world.z_axis].map(|a| a.truncate().length());
    lengths.into_iter().filter(|l| l.is_finite() && *l > 0.0).fold(f32::INFINITY, f32::min)
}

impl OrbitCamera {
    /// Clip space (WebGPU, depth 0..1) to the primary volume's normalized coordinates: the
    /// shader's `inv_view_proj`, from the volume's `volume_to_world` ([`volume_to_world`]). The
    /// camera orbits the grid box's centre in patient space with superior up; distances are in
    /// units of the largest side of its [`PatientBox`].
    pub fn inv_view_proj(&self, volume_to_world: Mat4, aspect: f32) -> Mat4 {
        // The volume lies within 1 of the centre; keep it between the planes wherever the
        // target has been panned to.
        let reach = 1.0 + self.target.length();
        let distance = self.distance.max(0.01);
        self.inv_view_proj_between(volume_to_world, aspect, [(distance - reach).max(distance * 0.01), distance + reach])
    }

    /// [`Self::inv_view_proj`] with its planes far enough apart for meshes that reach out of
    /// the volume's sphere (a needle's handle towards the camera): the near one at 1% of the
    /// distance, the far one 100 sides beyond the centre. A mesh layer's depth is 32-bit float:
    /// at the volume that is still far finer than a voxel. The same pixels look along the same
    /// rays as through [`Self::inv_view_proj`].
    pub fn mesh_inv_view_proj(&self, volume_to_world: Mat4, aspect: f32) -> Mat4 {
        let distance = self.distance.max(0.01);
        self.inv_view_proj_between(volume_to_world, aspect, [distance * 0.01, distance + 100.0 + self.target.length()])
    }

    fn inv_view_proj_between(&self, volume_to_world: Mat4, aspect: f32, [near, far]: [f32; 2]) -> Mat4 {
        let centre = volume_to_world.transform_point3(Vec3::splat(0.5));
        let size = PatientBox::of(volume_to_world).size().max_element().max(f32::MIN_POSITIVE);
        // Normalized coordinates to a world box centred at the origin whose largest side is 1.
        let model = Mat4::from_scale(Vec3::splat(1.0 / size)) * Mat4::from_translation(-centre) * volume_to_world;
        let (az, el) = (self.azimuth.to_radians(), self.elevation.clamp(-89.0, 89.0).to_radians());
        let distance = self.distance.max(0.01);
        let eye = self.target + distance * Vec3::new(az.sin() * el.cos(), az.cos() * el.cos(), el.sin());
        let view = glam::camera::rh::view::look_at_mat4(eye, self.target, Vec3::Z);
        // WebGPU clip space: depth 0..1, y up (glam's `directx` convention).
        let fov = self.fov.clamp(1.0, 170.0).to_radians();
        let proj = glam::camera::rh::proj::directx::perspective(fov, aspect.max(1e-3), near, far);
        (proj * view * model).inverse()
    }
}

/// The plane of a slice view in patient space: `origin` is the image's top-left corner, `u` and
/// `v` its full edges (left to right, top to bottom), in box coordinates: `[0, 1]³` over the
/// primary volume's [`PatientBox`], axes R, A, S. The runtime fits the plane to the image's
/// aspect ratio (square pixels, the plane centred) and mirrors it for the display convention
/// (`SlicePlane::oriented`) when it renders.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlicePlane {
    /// The image's top-left corner.
    pub origin: Vec3,
    /// The image's top edge, left to right.
    pub u: Vec3,
    /// The image's left edge, top to bottom.
    pub v: Vec3,
}

/// The patient axis a slice view is normal to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SliceAxis {
    /// Sagittal (normal along right-left): seen from the patient's left, anterior on the
    /// image's left, superior up.
    X,
    /// Coronal (normal along anterior-posterior): seen from the front, superior up.
    Y,
    /// Axial (normal along superior-inferior): seen from the feet, anterior up.
    Z,
}

/// How slice images put the patient's sides: `Radiological` (the default, as radiologists read
/// images) shows the patient's right on the image's left, as if facing the patient (axial
/// slices seen from the feet); `Neurological` shows the patient's right on the right. Sagittal
/// images are the same in both.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Convention {
    /// The patient's right on the image's left (the default).
    #[default]
    Radiological,
    /// The patient's right on the image's right.
    Neurological,
}

impl SlicePlane {
    /// The plane normal to `axis` at `position` (0 at the patient's left, posterior or inferior
    /// end of the volume's box, 1 at the right, anterior or superior end), oriented for the
    /// radiological convention.
    pub fn new(axis: SliceAxis, position: f32) -> SlicePlane {
        let p = position;
        match axis {
            SliceAxis::X => SlicePlane { origin: Vec3::new(p, 1.0, 1.0), u: -Vec3::Y, v: -Vec3::Z },
            SliceAxis::Y => SlicePlane { origin: Vec3::new(1.0, p, 1.0), u: -Vec3::X, v: -Vec3::Z },
            SliceAxis::Z => SlicePlane { origin: Vec3::new(1.0, 1.0, p), u: -Vec3::X, v: -Vec3::Y },
        }
    }

    /// The plane as `convention` shows it: the neurological convention mirrors an image whose
    /// horizontal runs along the patient's right-left axis; every other plane is unchanged.
    pub(crate) fn oriented(self, convention: Convention) -> SlicePlane {
        let runs_right_left = self.u.x.abs() >= self.u.y.abs().max(self.u.z.abs());
        if convention == Convention::Neurological && runs_right_left {
            SlicePlane { origin: self.origin + self.u, u: -self.u, ..self }
        } else {
            self
        }
    }

    /// The patient directions at the image's edges, `[left, right, top, bottom]`, one letter
    /// each (R, L, A, P, S, I: the direction of the dominant patient axis across that edge), for
    /// a viewer to draw. An axial plane in the radiological convention gives `["R", "L", "A", "P"]`.
    pub(crate) fn edge_labels(&self) -> [&'static str; 4] {
        [direction_letter(-self.u), direction_letter(self.u), direction_letter(-self.v), direction_letter(self.v)]
    }
}

/// The edge labels `[left, right, top, bottom]` of a slice view normal to `axis` shown in
/// `convention` (see `SlicePlane::edge_labels`).
pub fn slice_edge_labels(axis: SliceAxis, convention: Convention) -> [&'static str; 4] {
    SlicePlane::new(axis, 0.5).oriented(convention).edge_labels()
}

/// The letter of the patient direction closest to `d` (RAS): R, L, A, P, S or I.
fn direction_letter(d: Vec3) -> &'static str {
    let a = d.abs();
    if a.x >= a.y && a.x >= a.z {
        if d.x >= 0.0 { "R" } else { "L" }
    } else if a.y >= a.z {
        if d.y >= 0.0 { "A" } else { "P" }
    } else if d.z >= 0.0 {
        "S"
    } else {
        "I"
    }
}

/// A slice plane where the shader needs it: in the primary volume's normalized coordinates
/// (`slice_origin`, `slice_u`, `slice_v`) with `normal`, the displacement of 1 mm along the
/// plane's normal in patient space (`slice_normal`: its direction is where rays go, its length
/// how far 1 mm is).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ShaderPlane {
    pub origin: Vec3,
    pub u: Vec3,
    pub v: Vec3,
    pub normal: Vec3,
}

impl ShaderPlane {
    /// `plane` (box coordinates of the volume with `volume_to_world`) fitted to an image of
    /// `aspect` = width / height with square pixels, in normalized volume coordinates.
    pub(crate) fn new(plane: SlicePlane, volume_to_world: Mat4, aspect: f32) -> ShaderPlane {
        let to_world = PatientBox::of(volume_to_world).to_world();
        let (mut origin, mut u, mut v) = (
            to_world.transform_point3(plane.origin),
            to_world.transform_vector3(plane.u),
            to_world.transform_vector3(plane.v),
        );
        // Widen the shorter edge around the centre until the plane has the image's proportions.
        let (lu, lv) = (u.length().max(f32::MIN_POSITIVE), v.length().max(f32::MIN_POSITIVE));
        let aspect = aspect.max(1e-6);
        if lu / lv < aspect {
            let k = aspect * lv / lu;
            origin -= 0.5 * (k - 1.0) * u;
            u *= k;
        } else {
            let k = lu / (aspect * lv);
            origin -= 0.5 * (k - 1.0) * v;
            v *= k;
        }
        let from_world = volume_to_world.inverse();
        ShaderPlane {
            origin: from_world.transform_point3(origin),
            u: from_world.transform_vector3(u),
            v: from_world.transform_vector3(v),
            normal: from_world.transform_vector3(u.cross(v).normalize_or_zero()),
        }
    }
}

/// Normalized coordinates of a grid to voxel indices.
fn normalized_to_index(dims: [u32; 3]) -> Mat4 {
    let d = Vec3::new(dims[0] as f32, dims[1] as f32, dims[2] as f32);
    Mat4::from_translation(Vec3::splat(-0.5)) * Mat4::from_scale(d)
}

/// The primary volume's normalized coordinates to another volume's (`primary_to_NAME`),
/// through both grids' grid-to-world transforms: co-registered volumes line up whatever their
/// grids.
pub(crate) fn primary_to(primary: (&[u32; 3], Mat4), other: (&[u32; 3], Mat4)) -> Mat4 {
    let to_world = volume_to_world(*primary.0, primary.1);
    let from_world = volume_to_world(*other.0, other.1).inverse();
    from_world * to_world
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_grid_maps_to_identity_and_a_half_size_grid_lines_up() {
        let g = Mat4::from_scale(Vec3::splat(2.0));
        assert!(primary_to((&[10, 10, 10], g), (&[10, 10, 10], g)).abs_diff_eq(Mat4::IDENTITY, 1e-6));
        // The same box sampled at twice the spacing: the voxel-centre convention moves the origin.
        let coarse = Mat4::from_translation(Vec3::splat(1.0)) * Mat4::from_scale(Vec3::splat(4.0));
        let m = primary_to((&[10, 10, 10], g), (&[5, 5, 5], coarse));
        let p = m.transform_point3(Vec3::splat(0.5));
        assert!((p - Vec3::splat(0.5)).length() < 1e-5, "{p}");
    }

    #[test]
    fn the_default_camera_looks_at_the_centre_from_the_front() {
        let m = OrbitCamera::default().inv_view_proj(Mat4::IDENTITY, 1.0);
        let near = m.project_point3(Vec3::new(0.0, 0.0, 0.0));
        let far = m.project_point3(Vec3::new(0.0, 0.0, 1.0));
        let dir = (far - near).normalize();
        assert!((dir - Vec3::NEG_Y).length() < 1e-4, "{dir}");
        let t = (0.5 - near.y) / dir.y;
        assert!((near + t * dir - Vec3::splat(0.5)).length() < 1e-4);
        // The image's right is the patient's left (-x) and its top superior (+z).
        let right = m.project_point3(Vec3::new(0.5, 0.0, 0.0)) - near;
        let up = m.project_point3(Vec3::new(0.0, 0.5, 0.0)) - near;
        assert!(right.x < 0.0 && right.x.abs() > right.z.abs(), "{right}");
        assert!(up.z > 0.0 && up.z.abs() > up.x.abs(), "{up}");
    }

    /// A grid stored with its index axes permuted and flipped (i -> posterior, j -> superior,
    /// k -> left, anisotropic voxels): the camera sees the same patient-space box.
    fn oblique_grid() -> ([u32; 3], Mat4) {
        let g = Mat4::from_cols(
            glam::Vec4::new(0.0, -0.5, 0.0, 0.0),
            glam::Vec4::new(0.0, 0.0, 2.0, 0.0),
            glam::Vec4::new(-1.0, 0.0, 0.0, 0.0),
            glam::Vec4::new(30.0, 40.0, -50.0, 1.0),
        );
        ([80, 20, 60], g)
    }

    #[test]
    fn the_camera_orbits_in_patient_space_whatever_the_grid() {
        let (dims, g) = oblique_grid();
        let to_world = volume_to_world(dims, g);
        let m = to_world * OrbitCamera::default().inv_view_proj(to_world, 1.0);
        // Through world space, the default camera still looks posterior with superior up.
        let near = m.project_point3(Vec3::ZERO);
        let dir = (m.project_point3(Vec3::Z) - near).normalize();
        assert!((dir - Vec3::NEG_Y).length() < 1e-4, "{dir}");
        let up = m.project_point3(Vec3::new(0.0, 0.5, 0.0)) - near;
        assert!(up.z > 0.0 && up.z.abs() > 10.0 * up.x.abs().max(up.y.abs()), "{up}");
        let b = PatientBox::of(to_world);
        assert!((b.size() - Vec3::new(60.0, 40.0, 40.0)).length() < 1e-3, "{:?}", b.size());
    }

    #[test]
    fn an_axial_plane_is_axial_in_patient_space_on_an_oblique_grid() {
        let (dims, g) = oblique_grid();
        let to_world = volume_to_world(dims, g);
        let p = ShaderPlane::new(SlicePlane::new(SliceAxis::Z, 0.5), to_world, 60.0 / 40.0);
        let (u, v, n) =
            (to_world.transform_vector3(p.u), to_world.transform_vector3(p.v), to_world.transform_vector3(p.normal));
        assert!((u - Vec3::new(-60.0, 0.0, 0.0)).length() < 1e-3, "u {u}");
        assert!((v - Vec3::new(0.0, -40.0, 0.0)).length() < 1e-3, "v {v}");
        assert!((n - Vec3::Z).length() < 1e-5, "1 mm superior: {n}");
        let centre = to_world.transform_point3(p.origin + 0.5 * p.u + 0.5 * p.v);
        assert!((centre - to_world.transform_point3(Vec3::splat(0.5))).length() < 1e-3);
    }

    #[test]
    fn a_plane_fits_the_image_with_square_pixels() {
        let to_world = Mat4::from_scale(Vec3::new(100.0, 50.0, 10.0));
        let p = ShaderPlane::new(SlicePlane::new(SliceAxis::Z, 0.5), to_world, 1.0);
        let (u, v) = (to_world.transform_vector3(p.u), to_world.transform_vector3(p.v));
        assert!((u.length() - 100.0).abs() < 1e-3 && (v.length() - 100.0).abs() < 1e-3, "{u} {v}");
        // The 50 mm of anterior-posterior extent sit in the middle of the 100 mm tall image.
        assert!((to_world.transform_point3(p.origin).y - 75.0).abs() < 1e-3);
    }

    #[test]
    fn edge_labels_of_the_standard_planes() {
        use Convention::*;
        assert_eq!(slice_edge_labels(SliceAxis::Z, Radiological), ["R", "L", "A", "P"]);
        assert_eq!(slice_edge_labels(SliceAxis::Z, Neurological), ["L", "R", "A", "P"]);
        assert_eq!(slice_edge_labels(SliceAxis::Y, Radiological), ["R", "L", "S", "I"]);
        assert_eq!(slice_edge_labels(SliceAxis::Y, Neurological), ["L", "R", "S", "I"]);
        assert_eq!(slice_edge_labels(SliceAxis::X, Radiological), ["A", "P", "S", "I"]);
        assert_eq!(slice_edge_labels(SliceAxis::X, Neurological), ["A", "P", "S", "I"]);
    }

    #[test]
    fn the_neurological_mirror_keeps_the_plane_in_place() {
        let plane = SlicePlane::new(SliceAxis::Z, 0.3);
        let mirrored = plane.oriented(Convention::Neurological);
        assert_eq!(mirrored.origin + mirrored.u, plane.origin);
        assert_eq!(mirrored.oriented(Convention::Neurological), plane);
        assert_eq!(plane.oriented(Convention::Radiological), plane);
    }

    #[test]
    fn chords_and_spacings() {
        let g = Mat4::from_scale(Vec3::new(0.5, 1.0, 2.0));
        let to_world = volume_to_world([10, 10, 10], g);
        assert!((longest_chord(to_world) - Vec3::new(5.0, 10.0, 20.0).length()).abs() < 1e-4);
        assert_eq!(smallest_spacing(g), 0.5);
    }

    #[test]
    fn gradients_go_to_patient_space_as_covectors() {
        // f(w) = a . w in patient space has the gradient a there; in the oblique grid's
        // normalized coordinates (w = M p + o) it is f(p) = (M^T a) . p + const.
        let (dims, g) = oblique_grid();
        let to_world = volume_to_world(dims, g);
        let a = Vec3::new(0.3, -1.0, 2.0);
        let normalized = glam::Mat3::from_mat4(to_world).transpose() * a;
        let back = gradient_to_world(to_world) * normalized;
        assert!((back - a).length() < 1e-4 * a.length(), "{back}");
    }
}
