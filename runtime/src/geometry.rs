//! Where things are: the orbit camera of 3D views, the planes of slice views, and the
//! transforms between co-registered volumes. Shaders work in the primary volume's normalized
//! coordinates: [0,1]^3 over its voxel grid, voxel centres at (i + 0.5) / size.

use glam::{Mat4, Vec3};

/// An orbit camera around the primary volume's centre. Superior (+z of the grid) is up;
/// azimuth 0, elevation 0 looks from the front (+y side) towards -y.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitCamera {
    /// Degrees around the up axis.
    pub azimuth: f32,
    /// Degrees above the horizontal plane, clamped to ±89.
    pub elevation: f32,
    /// Distance from the centre in units of the volume's largest extent.
    pub distance: f32,
    /// Vertical field of view in degrees.
    pub fov: f32,
    /// The point orbited and looked at, relative to the volume's centre, in units of its
    /// largest extent (panning moves it).
    pub target: Vec3,
}

impl Default for OrbitCamera {
    fn default() -> OrbitCamera {
        OrbitCamera { azimuth: 0.0, elevation: 0.0, distance: 2.5, fov: 30.0, target: Vec3::ZERO }
    }
}

/// The physical extent of a grid: each index axis's length in world units.
pub fn extent(dims: [u32; 3], grid_to_world: Mat4) -> Vec3 {
    Vec3::new(
        grid_to_world.x_axis.truncate().length() * dims[0] as f32,
        grid_to_world.y_axis.truncate().length() * dims[1] as f32,
        grid_to_world.z_axis.truncate().length() * dims[2] as f32,
    )
}

impl OrbitCamera {
    /// Clip space (WebGPU, depth 0..1) to normalized volume coordinates: the shader's
    /// `inv_view_proj`. `extent` keeps the volume's proportions; its largest side spans 1.
    pub fn inv_view_proj(&self, extent: Vec3, aspect: f32) -> Mat4 {
        let scale = extent / extent.max_element().max(f32::MIN_POSITIVE);
        // Normalized coordinates to a world box centred at the origin.
        let model = Mat4::from_scale(scale) * Mat4::from_translation(Vec3::splat(-0.5));
        let (az, el) = (self.azimuth.to_radians(), self.elevation.clamp(-89.0, 89.0).to_radians());
        let distance = self.distance.max(0.01);
        let eye = self.target + distance * Vec3::new(az.sin() * el.cos(), az.cos() * el.cos(), el.sin());
        let view = glam::camera::rh::view::look_at_mat4(eye, self.target, Vec3::Z);
        // The volume lies within 1 of the centre; keep it between the planes wherever the
        // target has been panned to.
        let reach = 1.0 + self.target.length();
        let near = (distance - reach).max(distance * 0.01);
        // WebGPU clip space: depth 0..1, y up (glam's `directx` convention).
        let fov = self.fov.clamp(1.0, 170.0).to_radians();
        let proj = glam::camera::rh::proj::directx::perspective(fov, aspect.max(1e-3), near, distance + reach);
        (proj * view * model).inverse()
    }
}

/// The plane of a slice view: `origin` is the image's top-left corner, `u` and `v` its full
/// edges (left to right, top to bottom), all in normalized volume coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlicePlane {
    pub origin: Vec3,
    pub u: Vec3,
    pub v: Vec3,
}

/// The index axis a slice view is normal to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SliceAxis {
    /// Sagittal: image x along +y, image y down along -z.
    X,
    /// Coronal: image x along +x, image y down along -z.
    Y,
    /// Axial: image x along +x, image y down along -y.
    Z,
}

impl SlicePlane {
    /// The plane normal to `axis` at normalized `position`.
    pub fn new(axis: SliceAxis, position: f32) -> SlicePlane {
        let p = position;
        match axis {
            SliceAxis::X => SlicePlane { origin: Vec3::new(p, 0.0, 1.0), u: Vec3::Y, v: -Vec3::Z },
            SliceAxis::Y => SlicePlane { origin: Vec3::new(0.0, p, 1.0), u: Vec3::X, v: -Vec3::Z },
            SliceAxis::Z => SlicePlane { origin: Vec3::new(0.0, 1.0, p), u: Vec3::X, v: -Vec3::Y },
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
pub fn primary_to(primary: (&[u32; 3], Mat4), other: (&[u32; 3], Mat4)) -> Mat4 {
    let to_world = primary.1 * normalized_to_index(*primary.0);
    let from_world = (other.1 * normalized_to_index(*other.0)).inverse();
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
    fn the_default_camera_looks_at_the_centre() {
        let m = OrbitCamera::default().inv_view_proj(Vec3::ONE, 1.0);
        let near = m.project_point3(Vec3::new(0.0, 0.0, 0.0));
        let far = m.project_point3(Vec3::new(0.0, 0.0, 1.0));
        let dir = (far - near).normalize();
        assert!((dir - Vec3::NEG_Y).length() < 1e-4, "{dir}");
        let t = (0.5 - near.y) / dir.y;
        assert!((near + t * dir - Vec3::splat(0.5)).length() < 1e-4);
    }
}
