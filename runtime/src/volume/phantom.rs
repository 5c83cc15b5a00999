//! Synthetic volumes for demos and tests, so the renderer can be shown without a data set.
//!
//! A phantom is a list of shapes painted in order over the box [-1, 1]^3 (x fastest, y down the
//! image, z up), each with its own value: a later shape replaces what it covers. Edges are
//! band-limited: a shape covers a voxel by the fraction a Gaussian of `EDGE_SIGMA` voxels
//! around the voxel's centre has inside the surface (of the approximate signed distance), as a
//! scanner's point-spread function blurs a real edge. One-voxel edges (a smoothstep over one
//! voxel, before) left the gradient, hence the shading normal, jumping at every voxel: lit
//! surfaces showed concentric terraces. Values are Hounsfield units, as in a CT: air -1000 around the
//! body, soft tissue a few tens, bone several hundred, so the CT presets show them as they show
//! a patient's CT.

use std::fmt;

use glam::{Mat4, Quat, Vec2, Vec3};

use super::Volume;

/// Air around the body, in Hounsfield units.
pub(crate) const AIR: f32 = -1000.0;

/// The phantoms [`phantom`] knows.
pub(crate) const PHANTOMS: &[&str] = &["head", "abdomen"];

/// Each axis of a generated phantom is clamped to this many voxels (2^30 voxels in all, 4 GiB as
/// `f32`), so a typo in a size cannot exhaust memory.
pub(crate) const MAX_PHANTOM_DIM: u32 = 1024;

/// A phantom name that is not one of `PHANTOMS`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnknownPhantom {
    pub(crate) name: String,
}

impl fmt::Display for UnknownPhantom {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "unknown phantom `{}`", self.name)?;
        if let Some(close) = crate::tf::did_you_mean(&self.name, PHANTOMS) {
            write!(f, " (did you mean `{close}`?)")?;
        }
        write!(f, "; the phantoms are: {}", PHANTOMS.join(", "))
    }
}

impl std::error::Error for UnknownPhantom {}

/// Generates the phantom `name` (one of `PHANTOMS`) with `dims` voxels of 1 mm, centred at the
/// world origin. Each axis is clamped to 1..=`MAX_PHANTOM_DIM`. Deterministic.
///
/// - `head`: the 3D Shepp-Logan phantom (Kak & Slaney's ellipsoids) with CT values: skull
///   1000 HU, brain 35, ventricles 5, a few hyperdense small lesions (75-90).
/// - `abdomen`: a body cross-section after contrast: skin 30 HU, fat -100, muscle 55, soft
///   tissue 40, liver 65 (image left, the patient's right) with hepatic vessels 250 and a
///   tumour 45 with an enhancing rim 150, kidneys 160, aorta 250, spine and ribs 700.
pub fn phantom(name: &str, dims: [u32; 3]) -> Result<Volume, UnknownPhantom> {
    let shapes = match name {
        "head" => head(),
        "abdomen" => abdomen(),
        _ => return Err(UnknownPhantom { name: name.to_string() }),
    };
    let dims = dims.map(|d| d.clamp(1, MAX_PHANTOM_DIM));
    let grid = Grid::new(dims);
    let mut data = vec![AIR; grid.len()];
    for shape in &shapes {
        grid.paint(&mut data, shape);
    }
    if name == "abdomen" {
        // Its shapes are laid out as on a radiological image (patient's right on the left,
        // back at the bottom); the grid is RAS like NIfTI: +x right, +y anterior.
        mirror_xy(&mut data, dims);
    }
    let centre = Vec3::from_array(dims.map(|d| (d as f32 - 1.0) / 2.0));
    let mut volume = Volume::new(dims, Mat4::from_translation(-centre), data);
    // Every value is meant: the automatic window is the whole range (the percentiles' window
    // clipped the head's skull at 820 of its 986 HU, and the lit skull showed rings where the
    // texture saturated).
    volume.own_window = Some(volume.range);
    Ok(volume)
}

/// Reverses the x and y axes of a grid (a half turn about z).
fn mirror_xy(data: &mut [f32], dims: [u32; 3]) {
    let (nx, ny) = (dims[0] as usize, dims[1] as usize);
    for slice in data.chunks_exact_mut(nx * ny) {
        slice.reverse();
    }
}

/// A region of the phantom box, in the box's normalized coordinates [-1, 1]^3.
#[derive(Clone, Debug)]
enum Region {
    /// An ellipsoid with semi-axes `radii`, rotated about z by the angle whose (cosine, sine) is
    /// `rotation` (precomputed: the distance is evaluated for millions of voxels).
    Ellipsoid { centre: Vec3, radii: Vec3, rotation: Vec2 },
    /// An elliptic cylinder along z: the ellipse `radii` (x, y) around `centre`, for
    /// |z - centre.z| <= `half_length`.
    Cylinder { centre: Vec3, radii: Vec2, half_length: f32 },
    /// A tube: the points within `radius` of the segment from `a` to `b`; `radius` is in units
    /// of the box's shortest half-axis, so tubes stay round in voxels.
    Capsule { a: Vec3, b: Vec3, radius: f32 },
}

/// A region painted with a value, optionally only inside the union of `within` (so vessels stay
/// inside their organ).
struct Shape {
    region: Region,
    value: f32,
    within: Vec<Region>,
}

impl Shape {
    fn new(region: Region, value: f32) -> Shape {
        Shape { region, value, within: Vec::new() }
    }

    fn within(mut self, regions: &[Region]) -> Shape {
        self.within = regions.to_vec();
        self
    }
}

fn ellipsoid(centre: [f32; 3], radii: [f32; 3], angle_degrees: f32) -> Region {
    let (sin, cos) = angle_degrees.to_radians().sin_cos();
    Region::Ellipsoid { centre: centre.into(), radii: radii.into(), rotation: Vec2::new(cos, sin) }
}

fn cylinder(centre: [f32; 3], radii: [f32; 2], half_length: f32) -> Region {
    Region::Cylinder { centre: centre.into(), radii: radii.into(), half_length }
}

/// The voxel grid: converts between voxel indices and normalized coordinates and measures
/// distances in voxels.
struct Grid {
    dims: [u32; 3],
    /// Voxels per normalized unit along each axis (half the dimension).
    scale: Vec3,
}

impl Grid {
    fn new(dims: [u32; 3]) -> Grid {
        Grid { dims, scale: Vec3::from_array(dims.map(|d| d as f32 / 2.0)) }
    }

    fn len(&self) -> usize {
        self.dims.iter().map(|&d| d as usize).product()
    }

    /// The normalized position of voxel `index`'s centre.
    fn position(&self, index: [u32; 3]) -> Vec3 {
        (Vec3::from_array(index.map(|i| i as f32)) + 0.5) / self.scale - 1.0
    }

    /// The voxel index range (inclusive) covering normalized [lo, hi] plus the edge's reach,
    /// clamped to the grid; `None` when it misses the grid.
    fn index_range(&self, lo: Vec3, hi: Vec3) -> Option<[[u32; 2]; 3]> {
        let margin = EDGE_REACH * EDGE_SIGMA;
        // Voxel i's centre is at index i + 0.5 of the scaled box.
        let lo = ((lo + 1.0) * self.scale - 0.5 - margin).floor();
        let hi = ((hi + 1.0) * self.scale - 0.5 + margin).ceil();
        let mut range = [[0; 2]; 3];
        for axis in 0..3 {
            let max = self.dims[axis] as f32 - 1.0;
            if hi[axis] < 0.0 || lo[axis] > max {
                return None;
            }
            range[axis] = [lo[axis].max(0.0) as u32, hi[axis].min(max) as u32];
        }
        Some(range)
    }

    /// Blends `shape` into `data` by its coverage of each voxel in its bounding box.
    fn paint(&self, data: &mut [f32], shape: &Shape) {
        let (lo, hi) = bounds(&shape.region, self.scale);
        let Some([[x0, x1], [y0, y1], [z0, z1]]) = self.index_range(lo, hi) else { return };
        let [nx, ny, _] = self.dims.map(|d| d as usize);
        for z in z0..=z1 {
            for y in y0..=y1 {
                let row = (z as usize * ny + y as usize) * nx;
                for x in x0..=x1 {
                    let p = self.position([x, y, z]);
                    let mut c = coverage(self.distance(&shape.region, p));
                    if c > 0.0 && !shape.within.is_empty() {
                        c *= shape.within.iter().map(|r| coverage(self.distance(r, p))).fold(0.0, f32::max);
                    }
                    if c > 0.0 {
                        let v = &mut data[row + x as usize];
                        *v += (shape.value - *v) * c;
                    }
                }
            }
        }
    }

    /// Approximate signed distance (in voxels; negative inside) from `p` to the region's
    /// surface: exact for tubes, first order for ellipses, which is accurate near the surface,
    /// where the anti-aliasing needs it.
    fn distance(&self, region: &Region, p: Vec3) -> f32 {
        match *region {
            Region::Ellipsoid { centre, radii, rotation } => {
                let offset = p - centre;
                let inverse = Vec2::new(rotation.x, -rotation.y);
                let local = inverse.rotate(offset.truncate()).extend(offset.z);
                let local_gradient = local / (radii * radii);
                let gradient = rotation.rotate(local_gradient.truncate()).extend(local_gradient.z);
                ellipse_distance(local / radii, gradient * 2.0 / self.scale)
            }
            Region::Cylinder { centre, radii, half_length } => {
                let local = (p - centre).truncate();
                let gradient = (local / (radii * radii)).extend(0.0);
                let side = ellipse_distance((local / radii).extend(0.0), gradient * 2.0 / self.scale);
                let cap = ((p.z - centre.z).abs() - half_length) * self.scale.z;
                side.max(cap)
            }
            Region::Capsule { a, b, radius } => {
                let (p, a, b) = (p * self.scale, a * self.scale, b * self.scale);
                let ab = b - a;
                let t = ((p - a).dot(ab) / ab.length_squared().max(f32::MIN_POSITIVE)).clamp(0.0, 1.0);
                p.distance(a + ab * t) - radius * self.scale.min_element()
            }
        }
    }
}

/// Signed distance to a quadric's surface from its scaled position `u` (|u| = 1 on the surface)
/// and the gradient of |u|^2 in voxel units: f / |grad f| for f = |u| - 1.
fn ellipse_distance(u: Vec3, gradient: Vec3) -> f32 {
    let r = u.length();
    let slope = gradient.length() / (2.0 * r);
    if r == 0.0 || slope == 0.0 { f32::NEG_INFINITY } else { (r - 1.0) / slope }
}

/// The standard deviation, in voxels, of the Gaussian that blurs every edge: wide enough that
/// central differences of trilinear samples turn smoothly across a surface
/// (`runtime/tests/phantoms.rs` measures it), narrow enough that the head's skull, 1.8 voxels
/// thick at 128^3, keeps most of its value.
pub(crate) const EDGE_SIGMA: f32 = 0.8;

/// How far from a surface, in [`EDGE_SIGMA`]s, its edge reaches: beyond it a voxel is inside or
/// outside exactly (the Gaussian's tail there is 3e-5, a twentieth of a Hounsfield unit of the
/// largest step).
const EDGE_REACH: f32 = 4.0;

/// The fraction of a voxel inside a surface at signed distance `d` (voxels; negative inside):
/// the Gaussian's mass beyond `d`, `erfc(d / (sigma sqrt 2)) / 2`, exactly 0 or 1 past
/// [`EDGE_REACH`].
fn coverage(d: f32) -> f32 {
    let x = d / EDGE_SIGMA;
    if x >= EDGE_REACH {
        0.0
    } else if x <= -EDGE_REACH {
        1.0
    } else {
        0.5 * erfc(x * std::f32::consts::FRAC_1_SQRT_2)
    }
}

/// The complementary error function, by Abramowitz and Stegun's rational approximation 7.1.26
/// (absolute error below 1.5e-7).
fn erfc(x: f32) -> f32 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.327_591_1 * z);
    let poly = t * (0.254_829_6 + t * (-0.284_496_7 + t * (1.421_413_7 + t * (-1.453_152 + t * 1.061_405_4))));
    let tail = poly * (-z * z).exp();
    if x >= 0.0 { tail } else { 2.0 - tail }
}

/// A normalized-space box around a region (conservative for rotated ellipsoids).
fn bounds(region: &Region, scale: Vec3) -> (Vec3, Vec3) {
    match *region {
        Region::Ellipsoid { centre, radii, rotation } => {
            let r = radii.x.max(radii.y);
            let extent = if rotation.y == 0.0 { radii } else { Vec3::new(r, r, radii.z) };
            (centre - extent, centre + extent)
        }
        Region::Cylinder { centre, radii, half_length } => {
            let extent = radii.extend(half_length);
            (centre - extent, centre + extent)
        }
        Region::Capsule { a, b, radius } => {
            let extent = radius * scale.min_element() / scale;
            (a.min(b) - extent, a.max(b) + extent)
        }
    }
}

/// The 3D Shepp-Logan head: Kak & Slaney's ten ellipsoids (centre, semi-axes, rotation about z
/// in degrees), painted with CT-like values instead of the original additive densities so that
/// the levels are easy to pick with a transfer function.
fn head() -> Vec<Shape> {
    #[rustfmt::skip]
    let ellipsoids: [([f32; 3], [f32; 3], f32, f32); 10] = [
        ([0.0, 0.0, 0.0], [0.69, 0.92, 0.9], 0.0, 1000.0),          // skull
        ([0.0, -0.0184, 0.0], [0.6624, 0.874, 0.88], 0.0, 35.0),    // brain
        ([-0.22, 0.0, -0.25], [0.41, 0.16, 0.21], 108.0, 5.0),      // right ventricle
        ([0.22, 0.0, -0.25], [0.31, 0.11, 0.22], 72.0, 5.0),        // left ventricle
        ([0.0, 0.35, -0.25], [0.21, 0.25, 0.5], 0.0, 45.0),         // grey matter
        ([0.0, 0.1, -0.25], [0.046, 0.046, 0.046], 0.0, 75.0),      // lesion
        ([-0.08, -0.65, -0.25], [0.046, 0.023, 0.02], 0.0, 90.0),   // lesion
        ([0.06, -0.65, -0.25], [0.046, 0.023, 0.02], 90.0, 90.0),   // lesion
        ([0.06, -0.105, 0.625], [0.056, 0.04, 0.1], 90.0, 80.0),    // lesion
        ([0.0, 0.1, 0.625], [0.056, 0.056, 0.1], 0.0, 15.0),        // dark spot
    ];
    // The table's y axis points up the image; ours points down, so y and the angles are mirrored.
    ellipsoids
        .iter()
        .map(|&([x, y, z], radii, angle, value)| Shape::new(ellipsoid([x, -y, z], radii, -angle), value))
        .collect()
}

/// Tissue values of the abdomen phantom, in Hounsfield units after intravenous contrast.
mod level {
    pub(crate) const SKIN: f32 = 30.0;
    pub(crate) const FAT: f32 = -100.0;
    pub(crate) const MUSCLE: f32 = 55.0;
    pub(crate) const SOFT_TISSUE: f32 = 40.0;
    pub(crate) const LIVER: f32 = 65.0;
    pub(crate) const VESSEL: f32 = 250.0;
    pub(crate) const TUMOUR: f32 = 45.0;
    pub(crate) const TUMOUR_RIM: f32 = 150.0;
    pub(crate) const KIDNEY: f32 = 160.0;
    pub(crate) const BONE: f32 = 700.0;
    pub(crate) const DISC: f32 = 90.0;
    pub(crate) const CSF: f32 = 10.0;
}

/// The liver: a large right lobe and a smaller left lobe reaching across the midline.
fn liver() -> [Region; 2] {
    [
        ellipsoid([-0.4, -0.02, 0.35], [0.36, 0.38, 0.45], 12.0),
        ellipsoid([0.05, -0.22, 0.45], [0.32, 0.17, 0.28], -15.0),
    ]
}

/// The abdominal cavity, inside the muscle wall.
fn cavity() -> Region {
    cylinder([0.0, 0.0, 0.0], [0.79, 0.51], 0.96)
}

/// An abdomen: the body is an elliptic cylinder along z; y grows towards the back.
fn abdomen() -> Vec<Shape> {
    use level::*;
    let mut shapes = vec![
        Shape::new(cylinder([0.0, 0.0, 0.0], [0.94, 0.66], 0.96), SKIN),
        Shape::new(cylinder([0.0, 0.0, 0.0], [0.92, 0.64], 0.96), FAT),
        Shape::new(cylinder([0.0, 0.0, 0.0], [0.85, 0.57], 0.96), MUSCLE),
        Shape::new(cavity(), SOFT_TISSUE),
    ];
    shapes.extend(spine());
    shapes.extend(ribs());
    shapes.push(Shape::new(cylinder([0.06, 0.2, 0.0], [0.05, 0.05], 0.96), VESSEL)); // aorta
    let liver = liver();
    shapes.extend(liver.iter().map(|lobe| Shape::new(lobe.clone(), LIVER).within(&[cavity()])));
    shapes.extend(vessel_tree().into_iter().map(|tube| Shape::new(tube, VESSEL).within(&liver)));
    shapes.push(Shape::new(ellipsoid([-0.52, -0.12, 0.3], [0.105, 0.105, 0.105], 0.0), TUMOUR_RIM));
    shapes.push(Shape::new(ellipsoid([-0.52, -0.12, 0.3], [0.075, 0.075, 0.075], 0.0), TUMOUR));
    shapes.push(Shape::new(ellipsoid([-0.34, 0.3, -0.3], [0.1, 0.13, 0.22], 20.0), KIDNEY));
    shapes.push(Shape::new(ellipsoid([0.36, 0.3, -0.15], [0.1, 0.13, 0.22], -20.0), KIDNEY));
    shapes
}

/// Vertebral bodies with discs between them, the arch around the spinal canal and the spinous
/// process.
fn spine() -> Vec<Shape> {
    use level::*;
    let mut shapes = vec![
        Shape::new(cylinder([0.0, 0.36, 0.0], [0.11, 0.1], 0.96), BONE),
        Shape::new(cylinder([0.0, 0.5, 0.0], [0.075, 0.065], 0.96), BONE),
        Shape::new(cylinder([0.0, 0.6, 0.0], [0.025, 0.07], 0.96), BONE),
        Shape::new(cylinder([0.0, 0.5, 0.0], [0.04, 0.035], 0.96), CSF),
    ];
    for k in 0..6 {
        let z = -0.75 + 0.3 * k as f32;
        shapes.push(Shape::new(cylinder([0.0, 0.36, z], [0.11, 0.1], 0.025), DISC));
    }
    shapes
}

/// Pairs of ribs curving from the spine around the sides towards the front, each a chain of
/// tubes along an ellipse, dropping as they go forward.
fn ribs() -> Vec<Shape> {
    const SEGMENTS: usize = 10;
    let mut shapes = Vec::new();
    for k in 0..4 {
        let z = 0.85 - 0.25 * k as f32;
        for side in [-1.0f32, 1.0] {
            // From beside the spine (80 degrees from the x axis, towards the back) round to the front.
            let point = |t: f32| {
                let angle = (80.0 - 130.0 * t).to_radians();
                Vec3::new(side * 0.8 * angle.cos(), 0.52 * angle.sin(), z - 0.12 * t)
            };
            for s in 0..SEGMENTS {
                let (t0, t1) = (s as f32 / SEGMENTS as f32, (s + 1) as f32 / SEGMENTS as f32);
                let tube = Region::Capsule { a: point(t0), b: point(t1), radius: 0.02 };
                shapes.push(Shape::new(tube, level::BONE));
            }
        }
    }
    shapes
}

/// Hepatic vessels: two deterministic binary trees of tubes, branching from the liver's hilum.
fn vessel_tree() -> Vec<Region> {
    let mut tubes = Vec::new();
    branch(&mut tubes, Vec3::new(-0.12, 0.1, 0.55), Vec3::new(-0.55, -0.45, -0.5), 0.25, 0.03, 3);
    branch(&mut tubes, Vec3::new(-0.15, 0.05, 0.25), Vec3::new(-0.7, -0.5, 0.35), 0.22, 0.026, 3);
    tubes
}

/// One vessel segment from `start` along `direction`, then two thinner, shorter children turned
/// 35 degrees either way, about an axis that turns with the depth so the tree fills space.
fn branch(tubes: &mut Vec<Region>, start: Vec3, direction: Vec3, length: f32, radius: f32, depth: u32) {
    let direction = direction.normalize();
    let end = start + direction * length;
    tubes.push(Region::Capsule { a: start, b: end, radius });
    if depth == 0 {
        return;
    }
    let (side, up) = direction.any_orthonormal_pair();
    let turn = depth as f32 * std::f32::consts::FRAC_PI_3;
    let axis = side * turn.cos() + up * turn.sin();
    for sign in [-1.0, 1.0] {
        let child = Quat::from_axis_angle(axis, sign * 35f32.to_radians()) * direction;
        branch(tubes, end, child, length * 0.72, radius * 0.75, depth - 1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The value at normalized position `p`: the voxel whose centre is nearest.
    fn at(v: &Volume, p: [f32; 3]) -> f32 {
        let [x, y, z] = [0, 1, 2].map(|a| (((p[a] + 1.0) * v.dims[a] as f32 / 2.0) as u32).min(v.dims[a] - 1));
        v.value(((z * v.dims[1] + y) * v.dims[0] + x) as usize).unwrap()
    }

    #[test]
    fn unknown_name_lists_the_phantoms() {
        let e = phantom("haed", [8, 8, 8]).unwrap_err();
        assert_eq!(e.to_string(), "unknown phantom `haed` (did you mean `head`?); the phantoms are: head, abdomen");
        let e = phantom("lung", [8, 8, 8]).unwrap_err();
        assert_eq!(e.to_string(), "unknown phantom `lung`; the phantoms are: head, abdomen");
    }

    #[test]
    fn shape_range_and_placement() {
        for &name in PHANTOMS {
            let v = phantom(name, [40, 32, 24]).unwrap();
            assert_eq!(v.dims, [40, 32, 24]);
            assert_eq!(v.samples.len(), 40 * 32 * 24);
            assert_eq!(v.range[0], AIR, "{name}: air around the body");
            // Bone at the top; on so small a grid the head's skull, under a voxel thick, keeps
            // less than half its value (partial volume, as a scanner would see it).
            assert!(v.range[1] >= 400.0 && v.range[1] <= 1000.0, "{name}: bone at the top, {:?}", v.range);
            assert_eq!(crate::volume::auto_window(&v), v.range, "{name}: its window is its whole range");
            assert_eq!(v.spacing, [1.0; 3]);
            // The first and last voxel centres are symmetric about the origin.
            let first = v.grid_to_world.transform_point3(Vec3::ZERO);
            let last = v.grid_to_world.transform_point3(Vec3::new(39.0, 31.0, 23.0));
            assert!((first + last).length() < 1e-5, "{first} {last}");
        }
    }

    #[test]
    fn dims_are_clamped() {
        let v = phantom("head", [0, 2, 1]).unwrap();
        assert_eq!(v.dims, [1, 2, 1]);
        assert_eq!(v.samples.len(), 2);
    }

    #[test]
    fn deterministic() {
        assert_eq!(phantom("abdomen", [24, 24, 24]).unwrap(), phantom("abdomen", [24, 24, 24]).unwrap());
    }

    #[test]
    fn head_levels() {
        // At 128^3 the skull at the top is four voxels thick: its middle keeps over 90% of its
        // 1000 HU within the edges' blur.
        let v = phantom("head", [128, 128, 128]).unwrap();
        assert_eq!(at(&v, [0.95, 0.95, 0.95]), AIR, "air in the corner");
        assert!((at(&v, [0.0, 0.0, 0.0]) - 35.0).abs() < 1e-3, "brain in the centre");
        assert!(at(&v, [0.0, -0.9, 0.0]) > 900.0, "skull at the top: {}", at(&v, [0.0, -0.9, 0.0]));
        assert!((at(&v, [0.22, 0.0, -0.25]) - 5.0).abs() < 1e-3, "ventricle");
        assert!(at(&v, [0.0, -0.1, -0.25]) > 60.0, "hyperdense lesion");
        // Edges are smooth: some voxels lie strictly between air and skull.
        assert!(v.values().iter().any(|&x| x > -950.0 && x < 950.0 && ![5.0, 35.0, 45.0].contains(&x)));
    }

    #[test]
    fn abdomen_levels() {
        let v = phantom("abdomen", [192, 192, 192]).unwrap();
        let close = |p: [f32; 3], want: f32, what: &str| {
            // The shapes' image layout, mirrored into the RAS grid.
            let got = at(&v, [-p[0], -p[1], p[2]]);
            assert!((got - want).abs() < 2.0, "{what} at {p:?}: {got}, expected {want}");
        };
        close([0.95, 0.95, 0.0], AIR, "air");
        close([0.0, -0.54, 0.0], level::MUSCLE, "abdominal wall");
        close([0.0, -0.605, 0.0], level::FAT, "subcutaneous fat");
        close([0.3, -0.1, -0.5], level::SOFT_TISSUE, "abdominal cavity");
        close([-0.55, 0.1, 0.55], level::LIVER, "liver");
        close([-0.52, -0.12, 0.3], level::TUMOUR, "tumour centre");
        // The rim, three voxels thick at this size, keeps most of its contrast to the tumour.
        let rim = at(&v, [0.52, 0.12 - 0.09, 0.3]);
        assert!(rim > level::TUMOUR + 0.8 * (level::TUMOUR_RIM - level::TUMOUR), "tumour rim: {rim}");
        close([-0.34, 0.3, -0.3], level::KIDNEY, "right kidney");
        close([0.36, 0.3, -0.15], level::KIDNEY, "left kidney");
        close([0.0, 0.36, -0.6], level::BONE, "vertebral body");
        // A disc is five voxels thick here, between two vertebrae: within 2% of their contrast.
        let disc = at(&v, [0.0, -0.36, -0.75]);
        assert!((disc - level::DISC).abs() < 0.02 * (level::BONE - level::DISC), "disc: {disc}");
        close([0.0, 0.5, 0.0], level::CSF, "spinal canal");
        close([0.06, 0.2, -0.8], level::VESSEL, "aorta");
        // The vessel tree: its first segment's middle, inside the liver.
        let root = Vec3::new(-0.12, 0.1, 0.55) + Vec3::new(-0.55, -0.45, -0.5).normalize() * 0.125;
        close(root.to_array(), level::VESSEL, "hepatic vessel");
        // Vessels never leave the liver: nothing vessel-bright in front of it.
        close([-0.3, -0.45, 0.5], level::SOFT_TISSUE, "in front of the liver");
    }

    #[test]
    fn capsule_distance_is_exact() {
        let grid = Grid::new([10, 10, 10]);
        let tube = Region::Capsule { a: Vec3::new(-0.5, 0.0, 0.0), b: Vec3::new(0.5, 0.0, 0.0), radius: 0.2 };
        // 0.6 normalized units = 3 voxels from the axis, radius 1 voxel.
        assert!((grid.distance(&tube, Vec3::new(0.0, 0.6, 0.0)) - 2.0).abs() < 1e-5);
        assert!(grid.distance(&tube, Vec3::ZERO) < 0.0);
    }

    #[test]
    fn ellipsoid_distance_near_the_surface() {
        let grid = Grid::new([20, 20, 20]);
        let e = ellipsoid([0.0; 3], [0.5, 0.25, 0.5], 90.0);
        // Rotated by 90 degrees the short axis lies along x: the surface is at x = 0.25 (2.5 voxels).
        assert!((grid.distance(&e, Vec3::new(0.35, 0.0, 0.0)) - 1.0).abs() < 0.05);
        assert!((grid.distance(&e, Vec3::new(0.0, 0.4, 0.0)) + 1.0).abs() < 0.05);
    }
}
