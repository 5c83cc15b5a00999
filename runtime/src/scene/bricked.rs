//! Bricked volumes in a scene: opening their sources, how each view looks at them, and the
//! streaming between frames (requests read back, bricks loaded and placed).

use std::sync::Arc;

use glam::{Mat4, Vec4};

use super::{SceneRenderer, SceneView, VolumeGrid};
use crate::bricks::mapped::MappedSource;
use crate::bricks::pyramid::PyramidSource;
use crate::bricks::ranges::RangeLearner;
use crate::bricks::zarr::{Choice, StoreLocation, ZarrSelection, ZarrSource};
use crate::bricks::{BrickData, BrickSource, BrickView, BrickedVolume, Coarsening, Residency};
use crate::error::RuntimeError;
use crate::gpu::Gpu;
use crate::textures::HISTOGRAM_BINS;
use crate::volume::{self, Scaling, Volume};
use vrsc::scene::{Entry, Memory, Scene, VolumeSource, ZarrKeys, is_zarr};

/// How the note of what `render_all` loaded starts.
const LOADED_NOTE: &str = "bricked volumes: ";

/// Rounds of render, read requests, load that [`SceneRenderer::render_all`] runs at most before
/// it gives the picture as it is.
const MAX_ROUNDS: usize = 64;

/// A bricked volume's source, with its automatic window when it was read whole.
pub(super) type Opened = (Arc<dyn BrickSource>, Option<[f32; 2]>);

/// The source of a bricked volume: a Zarr store as it is, a file whose samples are stored
/// uncompressed (NRRD, MetaImage, `.nii`) memory-mapped and read a brick at a time, any other
/// file or phantom through a pyramid built from it in memory. With the automatic window of the
/// whole volume when it was read whole (a Zarr store's and a mapped file's come from their
/// coarsest level, [`load`]).
pub(super) fn open_source(
    source: &VolumeSource,
    keys: &ZarrKeys,
    (cache, coarsening): (u64, Coarsening),
    phantom: impl Fn(&str) -> Result<Volume, RuntimeError>,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<Opened, RuntimeError> {
    let in_memory = |volume: Volume| -> Opened {
        let window = volume::auto_window(&volume);
        (Arc::new(PyramidSource::from_volume(&volume, coarsening)), Some(window))
    };
    if let Some(location) = store_location(source) {
        return Ok((Arc::new(open_store(&location, keys, cache)?.coarsened_by(coarsening)), None));
    }
    Ok(match source {
        VolumeSource::File(file) => match volume::raw_layout(&file.resolved).map_err(RuntimeError::Volume)? {
            Some(raw) => {
                let mapped = MappedSource::new(&raw, cache)
                    .map_err(|e| RuntimeError::Invalid(format!("`{}`: {e}", file.resolved.display())))?;
                (Arc::new(mapped.coarsened_by(coarsening)), None)
            }
            None => in_memory(volume::load(&file.resolved, progress).map_err(RuntimeError::Volume)?),
        },
        VolumeSource::Phantom(p) => in_memory(phantom(&p.value)?),
        VolumeSource::Url(u) => return Err(RuntimeError::Invalid(format!("`{}` is not a Zarr store", u.value))),
    })
}

/// Where the Zarr store of `source` is, when it is one (a `.zarr` folder or any URL).
pub(crate) fn store_location(source: &VolumeSource) -> Option<StoreLocation> {
    match source {
        VolumeSource::File(file) if is_zarr(&file.resolved) => Some(StoreLocation::Path(file.resolved.clone())),
        VolumeSource::Url(url) => Some(StoreLocation::Url(url.value.clone())),
        _ => None,
    }
}

/// What of a store the scene's keys pick.
pub fn selection(keys: &ZarrKeys) -> ZarrSelection {
    let choice = |e: &Entry| match e {
        Entry::Index(i) => Choice::Index(*i),
        Entry::Name(n) => Choice::Name(n.clone()),
    };
    ZarrSelection {
        multiscale: keys.multiscale.as_ref().map(|m| choice(&m.value)),
        channel: keys.channel.as_ref().map(|c| choice(&c.value)),
        time: keys.time.as_ref().map(|t| t.value),
    }
}

/// Opens the store at `location` as `keys` choose, with `cache` bytes for built levels.
pub(crate) fn open_store(location: &StoreLocation, keys: &ZarrKeys, cache: u64) -> Result<ZarrSource, RuntimeError> {
    ZarrSource::open_at(location, &selection(keys), cache)
        .map_err(|e| RuntimeError::Invalid(format!("`{location}`: {e}")))
}

/// Voxels of the level that stands in for a bricked volume where its voxels are needed in one
/// piece: the light volumes of a bricked primary, a surface extracted from a bricked volume.
pub(super) const STANDIN_VOXELS: u64 = 1 << 24;

/// The finest level of `source` of at most [`STANDIN_VOXELS`] voxels (256^3), as a volume in
/// memory placed in patient space as that level is (its box covers level 0's, a little more
/// where a level rounds up).
pub(super) fn standin(source: &dyn BrickSource) -> Result<Volume, RuntimeError> {
    let levels = source.levels();
    let fits = |l: &crate::bricks::Level| l.dims.iter().map(|&n| n as u64).product::<u64>() <= STANDIN_VOXELS;
    let level = levels.iter().position(fits).unwrap_or(levels.len() - 1);
    level_volume(source, level)
}

/// The coarsest level of `source` as a volume in memory (one brick or a few): what the
/// automatic window and the histogram of a bricked volume are taken from.
pub(super) fn coarsest(source: &dyn BrickSource) -> Result<Volume, RuntimeError> {
    level_volume(source, source.levels().len() - 1)
}

/// A Zarr store read whole into memory, for a volume the scene keeps in one texture
/// (`bricks = false`); refused beyond [`volume::MAX_VOXELS`].
pub(super) fn zarr_volume(location: &StoreLocation, keys: &ZarrKeys) -> Result<Volume, RuntimeError> {
    level_volume(&open_store(location, keys, 64 << 20)?, 0)
}

/// Level `level` of `source` as a volume in memory, its voxels in data units.
fn level_volume(source: &dyn BrickSource, level: usize) -> Result<Volume, RuntimeError> {
    let top = source.levels()[level];
    let [w, h, d] = top.dims;
    let voxels = w as u64 * h as u64 * d as u64;
    if voxels > volume::MAX_VOXELS {
        return Err(RuntimeError::Invalid(format!(
            "a {w}x{h}x{d} grid is too large for one texture; remove `bricks = false` to stream it in bricks"
        )));
    }
    let mut data = vec![0.0f32; voxels as usize];
    for bz in 0..top.bricks[2] {
        for by in 0..top.bricks[1] {
            for bx in 0..top.bricks[0] {
                let brick = source.read(level, [bx, by, bz]).map_err(|e| RuntimeError::Invalid(e.to_string()))?;
                copy_interior(&brick, [bx, by, bz], top.dims, &mut data);
            }
        }
    }
    // Level voxel i covers level-0 voxels [i s, (i + 1) s): its centre is at i s + (s - 1) / 2.
    let s = (1u32 << level) as f32;
    let grid_to_world = source.grid_to_world()
        * Mat4::from_translation(glam::Vec3::splat((s - 1.0) / 2.0))
        * Mat4::from_scale(glam::Vec3::splat(s));
    Ok(Volume::from_samples(top.dims, grid_to_world, volume::Samples::F32(data), Scaling::IDENTITY))
}

/// Copies a brick's voxels (without apron) into a level's voxels, x fastest.
fn copy_interior(brick: &BrickData, [bx, by, bz]: [u32; 3], dims: [u32; 3], out: &mut [f32]) {
    let edge = crate::bricks::BRICK;
    for z in 0..edge {
        for y in 0..edge {
            for x in 0..edge {
                let v = [bx * edge + x, by * edge + y, bz * edge + z];
                if v.iter().zip(dims).any(|(&i, n)| i >= n) {
                    continue;
                }
                let index = v[0] as usize + dims[0] as usize * (v[1] as usize + dims[1] as usize * v[2] as usize);
                out[index] = brick.voxel([x, y, z]);
            }
        }
    }
}

/// Opens and places bricked volume `name`: its window (the scene's, else percentiles of its
/// coarsest level), its GPU objects within its share of the scene's budgets, and its grid.
pub(super) fn load(
    gpu: &Gpu,
    name: &str,
    (source, automatic): Opened,
    rule: super::WindowRule,
    (memory, share): (&Memory, u64),
    primary: Option<&VolumeGrid>,
) -> Result<(BrickedVolume, [f32; 2], Vec<u64>), RuntimeError> {
    // Before the coarsest level is read: a source without a stored pyramid reads all of level
    // 0 for it, and what that pass shows of the values is kept for empty-space skipping.
    let learnt = RangeLearner::of(source.as_ref());
    let top = coarsest(source.as_ref())?;
    let window = match automatic {
        Some(automatic) => rule.with_automatic(automatic),
        None => rule.known().unwrap_or_else(|| volume::auto_window(&top)),
    };
    let dims = source.levels()[0].dims;
    let primary_to = match primary {
        Some(p) => crate::geometry::primary_to((&p.dims, p.grid_to_world), (&dims, source.grid_to_world())),
        None => Mat4::IDENTITY,
    };
    let budgets = (memory.gpu / share.max(1), memory.host / share.max(1));
    let bricked = BrickedVolume::new(gpu, name, source, window, budgets, primary_to, learnt)?;
    Ok((bricked, window, histogram(&top, window)))
}

/// Voxel counts of `volume` over [`HISTOGRAM_BINS`] parts of `window` (as a texture's).
fn histogram(volume: &Volume, window: [f32; 2]) -> Vec<u64> {
    let mut counts = vec![0u64; HISTOGRAM_BINS];
    let span = (window[1] - window[0]).max(f32::MIN_POSITIVE);
    for v in volume.values() {
        let bin = ((v - window[0]) / span * HISTOGRAM_BINS as f32).floor();
        if bin.is_finite() {
            counts[(bin.max(0.0) as usize).min(HISTOGRAM_BINS - 1)] += 1;
        }
    }
    counts
}

/// How `view` looks at bricked volumes: its camera's eye (the primary volume's normalized
/// coordinates, from the inverse view-projection: clip `(0, 0, 1, 0)` is the eye) or its plane.
pub(super) fn brick_view(
    view: &SceneView,
    inv_view_proj: Option<Mat4>,
    plane: Option<(glam::Vec3, glam::Vec3)>,
) -> Option<BrickView> {
    if let (Some(camera), Some(m)) = (view.camera, inv_view_proj) {
        let e = m * Vec4::new(0.0, 0.0, 1.0, 0.0);
        if e.w.abs() > f32::EPSILON {
            return Some(BrickView::Perspective {
                eye: e.truncate() / e.w,
                fov: camera.fov.clamp(1.0, 170.0).to_radians(),
            });
        }
    }
    plane.map(|(u, v)| BrickView::Plane { u, v })
}

/// The scene's bricked volumes' residency, summed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BrickProgress {
    /// Bricks resident, pending, refused, and so on, over every bricked volume.
    pub residency: Residency,
    /// Bricks that arrived in this call.
    pub arrived: usize,
    /// Bricks asked for in this call.
    pub asked: usize,
    /// A read-back of the requests was still under way when the call returned (a later call
    /// finishes it): a viewer must call again before it knows what its frames asked for.
    pub reading: bool,
}

impl SceneRenderer {
    /// After a frame: reads back what the rays of the frames so far asked of the bricked
    /// volumes, asks the loaders, and places the bricks that arrived since. With `wait` it waits
    /// for the read-back and for every brick asked for (what `render` does); without, nothing
    /// blocks: a read still under way is finished by a later call (a viewer calls this after
    /// every frame and draws again while bricks are pending or arrived).
    pub fn stream_bricks(&mut self, wait: bool) -> Result<BrickProgress, RuntimeError> {
        let mut progress = BrickProgress::default();
        for volume in self.resources.bricked.values() {
            volume.start_collect(&self.gpu);
            let asked = volume.finish_collect(&self.gpu, wait)?;
            progress.reading |= asked.is_none();
            progress.asked += asked.unwrap_or(0);
            progress.arrived += volume.receive(&self.gpu, wait)?;
            progress.residency = sum(progress.residency, volume.residency());
        }
        if progress.arrived > 0 {
            self.resources.content_changed();
        }
        self.skip_what_bricks_showed();
        Ok(progress)
    }

    /// Rebuilds the grids of empty-space skipping when the bricks read so far told something
    /// new of a bricked volume's values: bricks its transfer function makes invisible are
    /// skipped from then on, and so never asked for again.
    fn skip_what_bricks_showed(&mut self) {
        let Some(skipping) = &mut self.skipping else { return };
        let mut changed = false;
        for volume in self.resources.bricked.values() {
            if let Some(ranges) = volume.new_ranges() {
                let primary = self.grids.first().is_some_and(|g| g.name == volume.name);
                changed |= skipping.set_ranges(&volume.name, primary, ranges);
            }
        }
        if changed {
            self.update_occupancy();
            self.upload_max_grid();
        }
    }

    /// Renders until the rays of every view find the bricks they asked for (or no more can be
    /// placed); returns the images of the last round and what was loaded, in the notices.
    pub(super) fn render_resident(
        &mut self,
        render: impl Fn(&mut SceneRenderer) -> Result<Vec<(String, image::RgbaImage)>, RuntimeError>,
    ) -> Result<Vec<(String, image::RgbaImage)>, RuntimeError> {
        let mut images = render(self)?;
        let Some(before) = self.brick_residency() else { return Ok(images) };
        for _ in 0..MAX_ROUNDS {
            let progress = self.stream_bricks(true)?;
            if progress.asked == 0 || progress.arrived == 0 {
                break;
            }
            images = render(self)?;
        }
        let after = self.brick_residency().unwrap_or_default();
        // One residency note (the last render's) and each source's message once, however
        // often the scene renders (`vrsc watch` renders on every edit).
        self.notices.retain(|n| !n.starts_with(LOADED_NOTE));
        self.notices.push(format!(
            "{LOADED_NOTE}{} bricks loaded for this picture ({} resident in {} slots, {} of one value, {} evicted{})",
            after.loaded - before.loaded,
            after.resident,
            after.slots,
            after.constant,
            after.evicted,
            if after.refused > 0 { "; the memory budget held no more: parts are shown coarser" } else { "" }
        ));
        let messages: Vec<String> = self.resources.bricked.values().flat_map(|v| v.messages()).collect();
        for message in messages {
            if !self.notices.contains(&message) {
                self.notices.push(message);
            }
        }
        Ok(images)
    }

    /// The residency of every bricked volume, summed; `None` for a scene without bricked
    /// volumes.
    pub fn brick_residency(&self) -> Option<Residency> {
        let bricked = self.resources.bricked.values();
        bricked.map(|v| v.residency()).reduce(sum)
    }
}

fn sum(a: Residency, b: Residency) -> Residency {
    Residency {
        resident: a.resident + b.resident,
        constant: a.constant + b.constant,
        pending: a.pending + b.pending,
        loaded: a.loaded + b.loaded,
        evicted: a.evicted + b.evicted,
        slots: a.slots + b.slots,
        refused: a.refused + b.refused,
        floor: a.floor.max(b.floor),
    }
}

/// How many volumes share the scene's budgets.
pub(super) fn sharing(scene: &Scene) -> u64 {
    scene.volumes.iter().filter(|v| v.bricked).count() as u64
}
