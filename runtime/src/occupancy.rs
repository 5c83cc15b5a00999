//! The occupancy grid of empty-space skipping (`std::skip`): one texel per brick of about
//! `BRICK`^3 voxels of the primary volume, 1 where the transfer function gives some value that a
//! sample inside the brick can read a non-zero opacity, 0 where everything is invisible. It
//! depends on the transfer function, so it is rebuilt whenever that changes.
//!
//! Texel `j` of an axis with `n` texels covers the normalized interval `[j/n, (j+1)/n]`: its
//! range is taken over every voxel a trilinear sample inside that interval reads (the voxels
//! whose centres lie within one voxel of it), so no alignment of bricks and voxels is assumed.

use crate::tf::TransferFunction;
use crate::volume::Volume;

/// Voxels per brick edge.
pub(crate) const BRICK: u32 = 8;

#[cfg(test)]
/// The occupancy grid of the primary volume under `tf`, with its values normalized by `window`
/// as they are uploaded ([`Volume::normalized`]). Reads the volume a row at a time: no copy of
/// its values is made.
pub(crate) fn occupancy(volume: &Volume, window: Option<[f32; 2]>, tf: &TransferFunction) -> Volume {
    BrickRanges::new(volume, window).occupancy(tf)
}

/// The value range (normalized by the volume's window) of every brick: what the grids of
/// empty-space skipping are made from. It depends on the samples and the window only, so a new
/// transfer function rebuilds the occupancy from it without reading the volume again.
#[derive(Clone, Debug)]
pub(crate) struct BrickRanges {
    pub bricks: [u32; 3],
    /// Min and max per brick, x fastest, over the voxels a sample inside the brick can read.
    ranges: Vec<(f32, f32)>,
}

impl BrickRanges {
    /// Reads the volume once, a row at a time.
    pub(crate) fn new(volume: &Volume, window: Option<[f32; 2]>) -> BrickRanges {
        let mut builder = RangeBuilder::new(volume.dims);
        volume.for_each_normalized(window, 0..volume.samples.len(), |t| builder.push(t));
        builder.finish()
    }

    /// Ranges per texel of a grid of `bricks` texels (x fastest), as [`RangeBuilder`] makes them
    /// (`bricks::ranges` learns them brick by brick).
    pub(crate) fn from_ranges(bricks: [u32; 3], ranges: Vec<(f32, f32)>) -> BrickRanges {
        debug_assert_eq!(ranges.len(), bricks.iter().map(|&n| n as usize).product::<usize>());
        BrickRanges { bricks, ranges }
    }

    #[cfg(test)]
    /// `std::skip`'s grid: 1 where `tf` gives some value in the brick's range a non-zero
    /// opacity, else 0.
    pub(crate) fn occupancy(&self, tf: &TransferFunction) -> Volume {
        let visible = VisibleRanges::new(tf);
        let data = self.ranges.iter().map(|&(lo, hi)| if visible.any(lo, hi) { 1.0 } else { 0.0 }).collect();
        Volume::new(self.bricks, glam::Mat4::IDENTITY, data)
    }

    /// `std::skip_mip`'s and `std::skip_iso`'s grid: per brick, the least `R16Float` value that
    /// no sample inside it exceeds. The shaders read it at texel centres (`walk_bricks`), where
    /// linear filtering returns the texel itself, so a ray may leave a brick whose texel is at
    /// most a level knowing that no sample in it exceeds that level.
    pub(crate) fn max_grid(&self) -> Volume {
        let data = self.ranges.iter().map(|&(lo, hi)| sample_bound(lo, hi)).collect();
        Volume::new(self.bricks, glam::Mat4::IDENTITY, data)
    }
}

/// The least half float that no trilinear sample of voxels in `[lo, hi]` exceeds, as the
/// `R16Float` volume texture holds them: every voxel is a half float at most `half(hi)`
/// (rounding is monotonic), so a brick of one value samples exactly that value, and blending
/// different values in `f32` may round up past the largest by an `f32` unit in the last place,
/// which the next half float above it covers. Exact bounds let MIP skip space whose values equal
/// the ray's maximum (air in front of the head).
fn sample_bound(lo: f32, hi: f32) -> f32 {
    // Normalized values lie in [0, 1]; `+ 0.0` turns a -0 into +0.
    let (lo, hi) = (half::f16::from_f32(lo + 0.0), half::f16::from_f32(hi + 0.0));
    if lo == hi || !hi.is_finite() || hi.is_sign_negative() {
        return hi.to_f32();
    }
    half::f16::from_bits(hi.to_bits() + 1).to_f32()
}

/// What `std::skip`'s occupancy grid is made from: the brick ranges of the primary volume and of
/// every additional volume, each with its transfer function. Additional volumes are composited
/// over the primary (`std::composite_volume`), so a sample is visible where any of them is: a
/// primary brick is occupied when the primary is visible in it or when it overlaps an
/// additional volume's occupied brick (its box taken into the primary's normalized coordinates
/// and bounded there, so oblique and coarser grids are covered too).
#[derive(Clone, Debug)]
pub(crate) struct SceneRanges {
    primary: (BrickRanges, VisibleRanges),
    additional: Vec<AdditionalRanges>,
}

/// An additional volume's part of [`SceneRanges`].
#[derive(Clone, Debug)]
struct AdditionalRanges {
    name: String,
    ranges: BrickRanges,
    /// Its normalized coordinates to the primary's (the inverse of `primary_to_NAME`).
    to_primary: glam::Mat4,
    visible: VisibleRanges,
}

impl SceneRanges {
    /// The primary volume's ranges and its transfer function (resampled over its window).
    pub(crate) fn new(primary: BrickRanges, tf: &TransferFunction) -> SceneRanges {
        SceneRanges { primary: (primary, VisibleRanges::new(tf)), additional: Vec::new() }
    }

    /// Adds additional volume `name`: its ranges, its normalized coordinates to the primary's,
    /// and its transfer function over its window.
    pub(crate) fn add(&mut self, name: &str, ranges: BrickRanges, to_primary: glam::Mat4, tf: &TransferFunction) {
        let visible = VisibleRanges::new(tf);
        self.additional.push(AdditionalRanges { name: name.to_string(), ranges, to_primary, visible });
    }

    /// Replaces the ranges of volume `name` (the primary when `primary`) with what is known of
    /// them now (a bricked volume learns as its bricks are read); false when the volume takes
    /// no part in the grid.
    pub(crate) fn set_ranges(&mut self, name: &str, primary: bool, ranges: BrickRanges) -> bool {
        if primary {
            self.primary.0 = ranges;
            return true;
        }
        match self.additional.iter_mut().find(|a| a.name == name) {
            Some(a) => {
                a.ranges = ranges;
                true
            }
            None => false,
        }
    }

    /// The primary volume's ranges (what `std::skip_mip` and `std::skip_iso` bound).
    pub(crate) fn primary(&self) -> &BrickRanges {
        &self.primary.0
    }

    /// Takes a new transfer function (over its window) for volume `name`, the primary when
    /// `primary`; false when the volume takes no part in the grid.
    pub(crate) fn set_tf(&mut self, name: &str, primary: bool, tf: &TransferFunction) -> bool {
        if primary {
            self.primary.1 = VisibleRanges::new(tf);
            return true;
        }
        match self.additional.iter_mut().find(|a| a.name == name) {
            Some(a) => {
                a.visible = VisibleRanges::new(tf);
                true
            }
            None => false,
        }
    }

    /// `std::skip`'s grid over the primary's bricks: 1 where some volume may be visible.
    pub(crate) fn occupancy(&self) -> Volume {
        let (primary, visible) = &self.primary;
        let mut occupied: Vec<bool> = primary.ranges.iter().map(|&(lo, hi)| visible.any(lo, hi)).collect();
        for a in &self.additional {
            a.mark_footprint(primary.bricks, &mut occupied);
        }
        let data = occupied.into_iter().map(|o| if o { 1.0 } else { 0.0 }).collect();
        Volume::new(primary.bricks, glam::Mat4::IDENTITY, data)
    }
}

impl AdditionalRanges {
    /// Marks in `occupied` (a grid of `bricks` over the primary) every brick that a visible
    /// sample of this volume may fall in.
    fn mark_footprint(&self, bricks: [u32; 3], occupied: &mut [bool]) {
        // Outside its grid the volume samples 0 (std::sample_volume): visible there, it may be
        // visible anywhere.
        if self.visible.any(0.0, 0.0) {
            occupied.fill(true);
            return;
        }
        let n = self.ranges.bricks.map(|b| b as usize);
        for (index, &(lo, hi)) in self.ranges.ranges.iter().enumerate() {
            if !self.visible.any(lo, hi) {
                continue;
            }
            let brick = [index % n[0], index / n[0] % n[1], index / (n[0] * n[1])];
            let (min, max) = self.box_in_primary(brick);
            if !(min.is_finite() && max.is_finite()) {
                occupied.fill(true);
                return;
            }
            mark_box(bricks, min, max, occupied);
        }
    }

    /// The bounds, in the primary's normalized coordinates, of this volume's brick `brick`.
    fn box_in_primary(&self, brick: [usize; 3]) -> (glam::Vec3, glam::Vec3) {
        let n = glam::UVec3::from(self.ranges.bricks).as_vec3();
        let lo = glam::Vec3::new(brick[0] as f32, brick[1] as f32, brick[2] as f32) / n;
        let hi = lo + glam::Vec3::ONE / n;
        let mut min = glam::Vec3::INFINITY;
        let mut max = glam::Vec3::NEG_INFINITY;
        for corner in 0..8 {
            let pick = |bit: usize, l: f32, h: f32| if corner & bit == 0 { l } else { h };
            let c = glam::Vec3::new(pick(1, lo.x, hi.x), pick(2, lo.y, hi.y), pick(4, lo.z, hi.z));
            let p = self.to_primary.transform_point3(c);
            min = min.min(p);
            max = max.max(p);
        }
        (min, max)
    }
}

/// Marks the bricks of a grid of `bricks` over [0, 1]^3 that the box `[min, max]` touches,
/// widened by a little for the rounding of the transforms.
fn mark_box(bricks: [u32; 3], min: glam::Vec3, max: glam::Vec3, occupied: &mut [bool]) {
    const SLACK: f32 = 1e-4;
    let range = |axis: usize| {
        let n = bricks[axis] as f32;
        let first = ((min[axis] - SLACK) * n).floor().clamp(0.0, n) as usize;
        let last = ((max[axis] + SLACK) * n).ceil().clamp(0.0, n) as usize;
        first..last
    };
    let [bx, by, _] = bricks.map(|b| b as usize);
    for k in range(2) {
        for j in range(1) {
            for i in range(0) {
                occupied[(k * by + j) * bx + i] = true;
            }
        }
    }
}

/// For each texel along one axis, the voxels a trilinear sample in its interval may read.
pub(crate) fn texel_voxels(voxels: u32, texels: u32) -> Vec<std::ops::RangeInclusive<u32>> {
    (0..texels)
        .map(|j| {
            // The interval [j, j + 1] / texels is [j, j + 1] * scale - 0.5 in voxel-index
            // coordinates (centres at integers); a trilinear sample at c reads floor(c) and
            // floor(c) + 1.
            let scale = voxels as f32 / texels as f32;
            let first = (j as f32 * scale - 0.5).floor().max(0.0) as u32;
            let last = (((j + 1) as f32 * scale - 0.5).floor() as i64 + 1).clamp(0, i64::from(voxels) - 1) as u32;
            first..=last
        })
        .collect()
}

/// Builds [`BrickRanges`] from a volume's normalized values as they arrive in voxel order (x
/// fastest, then y, then z): a loader's stream or a texture upload can take the ranges on the
/// way, and only one z slice of row ranges is held, never the volume. The ranges are separable:
/// each row's along x, each slice's along y as the slice completes, along z at the end.
pub(crate) struct RangeBuilder {
    dims: [usize; 3],
    bricks: [u32; 3],
    /// Per brick along each axis, the voxels its samples may read ([`texel_voxels`]).
    spans: [Vec<std::ops::RangeInclusive<u32>>; 3],
    /// The current row's values.
    row: Vec<f32>,
    /// The current slice's ranges along x, per row: `bx * ny`.
    slice: Vec<(f32, f32)>,
    /// Rows of the current slice done.
    y: usize,
    /// Every slice's ranges along x and y: `bx * by * nz`.
    along_y: Vec<(f32, f32)>,
    /// Slices done.
    z: usize,
}

pub(crate) const EMPTY: (f32, f32) = (f32::INFINITY, f32::NEG_INFINITY);

pub(crate) fn merge(a: (f32, f32), b: (f32, f32)) -> (f32, f32) {
    (a.0.min(b.0), a.1.max(b.1))
}

impl RangeBuilder {
    /// A builder for a volume of `dims` voxels.
    pub(crate) fn new(dims: [u32; 3]) -> RangeBuilder {
        let bricks = dims.map(|d| d.div_ceil(BRICK).max(1));
        let spans = [0, 1, 2].map(|axis| texel_voxels(dims[axis], bricks[axis]));
        let [nx, ny, nz] = dims.map(|d| d as usize);
        let [bx, by, _] = bricks.map(|b| b as usize);
        RangeBuilder {
            dims: [nx, ny, nz],
            bricks,
            spans,
            row: Vec::with_capacity(nx),
            slice: vec![EMPTY; bx * ny],
            y: 0,
            along_y: vec![EMPTY; bx * by * nz],
            z: 0,
        }
    }

    /// The next voxel's normalized value; values past the last voxel are ignored.
    pub(crate) fn push(&mut self, t: f32) {
        if self.z >= self.dims[2] {
            return;
        }
        self.row.push(t);
        if self.row.len() == self.dims[0] {
            self.end_row();
        }
    }

    fn end_row(&mut self) {
        let bx = self.bricks[0] as usize;
        for (i, span) in self.spans[0].iter().enumerate() {
            let r = span.clone().fold(EMPTY, |r, x| merge(r, (self.row[x as usize], self.row[x as usize])));
            self.slice[self.y * bx + i] = r;
        }
        self.row.clear();
        self.y += 1;
        if self.y == self.dims[1] {
            self.end_slice();
        }
    }

    fn end_slice(&mut self) {
        let [bx, by, _] = self.bricks.map(|b| b as usize);
        for (j, span) in self.spans[1].iter().enumerate() {
            for i in 0..bx {
                self.along_y[(self.z * by + j) * bx + i] =
                    span.clone().fold(EMPTY, |r, y| merge(r, self.slice[y as usize * bx + i]));
            }
        }
        self.y = 0;
        self.z += 1;
    }

    /// The ranges of every brick (slices that never arrived count as empty).
    pub(crate) fn finish(self) -> BrickRanges {
        let [bx, by, bz] = self.bricks.map(|b| b as usize);
        let mut ranges = vec![EMPTY; bx * by * bz];
        for (k, span) in self.spans[2].iter().enumerate() {
            for j in 0..by {
                for i in 0..bx {
                    ranges[(k * by + j) * bx + i] =
                        span.clone().fold(EMPTY, |r, z| merge(r, self.along_y[(z as usize * by + j) * bx + i]));
                }
            }
        }
        BrickRanges { bricks: self.bricks, ranges }
    }
}

/// Answers "does the transfer function give any value in [lo, hi] a non-zero opacity?" in
/// constant time, from a prefix count of visible table entries.
#[derive(Clone, Debug)]
struct VisibleRanges {
    prefix: Vec<u32>,
}

impl VisibleRanges {
    fn new(tf: &TransferFunction) -> VisibleRanges {
        let mut prefix = Vec::with_capacity(tf.rgba.len() + 1);
        prefix.push(0);
        for entry in &tf.rgba {
            prefix.push(prefix.last().copied().unwrap_or(0) + u32::from(entry[3] > 0.0));
        }
        VisibleRanges { prefix }
    }

    fn any(&self, lo: f32, hi: f32) -> bool {
        let last = self.prefix.len().saturating_sub(2);
        if lo.is_nan() || hi.is_nan() || lo > hi {
            return false;
        }
        // Lookups interpolate linearly between entries (each at its texel's centre, the end
        // ones held beyond): take the entries on both sides.
        let entries = (last + 1) as f32;
        let entry = |v: f32| (v.clamp(0.0, 1.0) * entries - 0.5).clamp(0.0, last as f32);
        let first = entry(lo).floor() as usize;
        let end = (entry(hi).ceil() as usize).min(last) + 1;
        self.prefix[end] > self.prefix[first]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tf::from_points;

    #[test]
    fn only_bricks_whose_samples_can_read_a_visible_value_are_occupied() {
        // Opacity only above 0.5.
        let tf =
            from_points("t", &[(0.0, [1.0; 3]), (1.0, [1.0; 3])], &[(0.0, 0.0), (0.5, 0.0), (0.6, 1.0), (1.0, 1.0)]);
        let dims = [32, 8, 8];
        let mut values = vec![0.1; 32 * 8 * 8];
        values[31] = 0.9; // one bright voxel in the last brick along x
        let volume = |values: &[f32]| Volume::new(dims, glam::Mat4::IDENTITY, values.to_vec());
        let grid = occupancy(&volume(&values), Some([0.0, 1.0]), &tf);
        assert_eq!(grid.dims, [4, 1, 1]);
        assert_eq!(grid.values(), vec![0.0, 0.0, 0.0, 1.0], "only the bright voxel's brick");
        // A bright voxel at a brick's edge is read by samples in the next brick too.
        values[31] = 0.1;
        values[8] = 0.9;
        assert_eq!(occupancy(&volume(&values), Some([0.0, 1.0]), &tf).values(), vec![1.0, 1.0, 0.0, 0.0]);
        // The window normalizes as the upload does: 0.9 in a window [0, 2] is 0.45, invisible.
        assert_eq!(occupancy(&volume(&values), Some([0.0, 2.0]), &tf).values(), vec![0.0; 4]);
    }

    #[test]
    fn an_additional_volume_occupies_the_primary_bricks_its_visible_bricks_overlap() {
        let above_half =
            from_points("t", &[(0.0, [1.0; 3]), (1.0, [1.0; 3])], &[(0.0, 0.0), (0.5, 0.0), (0.6, 1.0), (1.0, 1.0)]);
        let primary = Volume::new([32, 8, 8], glam::Mat4::IDENTITY, vec![0.1; 32 * 8 * 8]);
        let mut values = vec![0.1; 16 * 8 * 8];
        values[15] = 0.9; // the additional volume's last voxel along x: its second brick
        let additional = Volume::new([16, 8, 8], glam::Mat4::IDENTITY, values);
        let mut scene = SceneRanges::new(BrickRanges::new(&primary, Some([0.0, 1.0])), &above_half);
        assert_eq!(scene.occupancy().values(), vec![0.0; 4], "the primary alone is transparent");
        // The same box: the additional brick [0.5, 1] covers the primary's last two bricks, and
        // the one that only touches it at 0.5 counts too (the box is widened for rounding).
        let ranges = BrickRanges::new(&additional, Some([0.0, 1.0]));
        scene.add("a", ranges.clone(), glam::Mat4::IDENTITY, &above_half);
        assert_eq!(scene.occupancy().values(), vec![0.0, 1.0, 1.0, 1.0]);
        // Shifted by 0.3 of the box towards -x, it covers [0.2, 0.7]: the first three bricks.
        let shifted = glam::Mat4::from_translation(glam::Vec3::new(-0.3, 0.0, 0.0));
        let mut moved = SceneRanges::new(BrickRanges::new(&primary, Some([0.0, 1.0])), &above_half);
        moved.add("a", ranges, shifted, &above_half);
        assert_eq!(moved.occupancy().values(), vec![1.0, 1.0, 1.0, 0.0]);
        // Visible at 0 (what it samples outside its grid): visible anywhere.
        let everywhere = from_points("t", &[(0.0, [1.0; 3]), (1.0, [1.0; 3])], &[(0.0, 1.0), (1.0, 1.0)]);
        assert!(moved.set_tf("a", false, &everywhere));
        assert_eq!(moved.occupancy().values(), vec![1.0; 4]);
        assert!(!moved.set_tf("b", false, &everywhere), "no volume `b` takes part");
    }

    #[test]
    fn the_max_grid_bounds_what_samples_inside_each_brick_read() {
        let mut values = vec![0.1; 32 * 8 * 8];
        values[8] = 0.9; // voxel 8 along x: read by samples in bricks 0 and 1
        let volume = Volume::new([32, 8, 8], glam::Mat4::IDENTITY, values);
        let grid = BrickRanges::new(&volume, Some([0.0, 1.0])).max_grid();
        let half = |v: f32| half::f16::from_f32(v);
        let above = |v: f32| half::f16::from_bits(half(v).to_bits() + 1).to_f32();
        // Bricks 0 and 1 read 0.9 among 0.1s: the next half above 0.9; bricks 2 and 3 read 0.1
        // alone, which is what every sample there returns.
        assert_eq!(grid.values(), vec![above(0.9), above(0.9), half(0.1).to_f32(), half(0.1).to_f32()]);
    }

    #[test]
    fn transparent_everywhere_is_empty() {
        let tf = from_points("t", &[(0.0, [1.0; 3]), (1.0, [1.0; 3])], &[(0.0, 0.0), (1.0, 0.0)]);
        let volume = Volume::new([16, 16, 16], glam::Mat4::IDENTITY, vec![0.7; 16 * 16 * 16]);
        let grid = occupancy(&volume, None, &tf);
        assert!(grid.values().iter().all(|&v| v == 0.0));
    }

    #[test]
    fn every_voxel_read_from_a_texel_is_in_its_span() {
        // 20 voxels on 3 texels: texel 1 covers normalized [1/3, 2/3], voxel coordinates
        // 6.17 ..= 12.83, so samples there read voxels 6 to 13.
        let spans = super::texel_voxels(20, 3);
        assert_eq!(spans, vec![0..=7, 6..=13, 12..=19]);
    }
}
