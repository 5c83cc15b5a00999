//! A bricked volume on the GPU: a brick pool (one `r16float` 3D texture of slots), a page table
//! (a storage buffer of one word per brick of every level, level after level) and the requests
//! buffer rays write, a word per page-table word (`stdlib/bricks.wgsl`). After a frame the
//! runtime reads the requests back (`BrickedVolume::start_collect`, then `finish_collect`), loads
//! what rays asked for on loader threads (from the host cache when it is there), and places
//! arrived bricks in their own slots when the pool has one for every brick, else in free or
//! least recently used slots (`BrickedVolume::receive`). The coarsest level is loaded first and never evicted, so every
//! ray finds an answer. The pool starts with the layers of slots the coarsest level and
//! [`INITIAL_POOL_BYTES`] need, and grows once, to the slots the budget gives, when a brick
//! arrives for a slot beyond it: a device clears a texture before its first write, and
//! clearing the whole budget before the first picture held it up (half a second for 1 GiB on
//! a software device). Growing once (not doubling) keeps what the device holds during the copy
//! within the budget plus the first pool.

use std::collections::{HashMap, HashSet};
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::{Arc, Mutex};

use glam::{Mat4, Vec3};

use super::loader::{Loader, Normalized};
use super::ranges::RangeLearner;
use super::{APRON, BRICK, BrickSource, Level, MAX_BRICKS, STORED, lock, table_entries};
use crate::error::RuntimeError;
use crate::gpu::Gpu;
use crate::occupancy::BrickRanges;
use crate::textures::Image3d;

/// Page-table entry kinds (the top two bits), as the lookup reads them.
const MISSING: u32 = 0;
const RESIDENT: u32 = 1 << 30;
const CONSTANT: u32 = 2 << 30;
/// The low 30 bits: a slot's position in the pool (10 bits an axis, x highest), or a constant
/// value in fixed point.
const PAYLOAD: u32 = (1 << 30) - 1;

/// Request-buffer words: what rays said about a brick in the last frame.
const NEEDED: u32 = 1;
const USED: u32 = 2;

/// Levels the layout has room for (`BrickLayout`'s arrays).
pub(crate) const MAX_LEVELS: usize = 16;

/// Bricks staged for the pool before they are submitted (so that the staging memory of many
/// arrivals is not held at once: 16 bricks are 9 MiB).
const UPLOADS_PER_SUBMIT: usize = 16;

/// Bytes of one slot of the pool (half floats).
pub(crate) const SLOT_BYTES: u64 = (STORED as u64).pow(3) * 2;

/// What the pool holds at first besides the coarsest level (106 slots).
const INITIAL_POOL_BYTES: u64 = 64 << 20;

/// How a view looks at its bricked volumes this frame: what picks the level of a sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum BrickView {
    /// A perspective camera at `eye` (the primary volume's normalized coordinates) whose image
    /// spans `fov` radians vertically.
    Perspective { eye: Vec3, fov: f32 },
    /// A plane whose image spans `u` and `v` (the primary volume's normalized coordinates).
    Plane { u: Vec3, v: Vec3 },
}

/// Counts of a bricked volume's residency, for progress and reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Residency {
    /// Bricks in the pool now.
    pub resident: u32,
    /// Bricks found to hold one value (kept in the page table, never uploaded).
    pub constant: u32,
    /// Bricks asked for and not yet arrived.
    pub pending: u32,
    /// Bricks uploaded since the volume was made (again after an eviction).
    pub loaded: u64,
    /// Bricks evicted to make room.
    pub evicted: u64,
    /// Slots in the pool.
    pub slots: u32,
    /// Requests the pool had no room for in the last frame (every slot in use by that frame).
    pub refused: u32,
    /// The finest level rays may ask for now: 0, or higher while the pictures ask for more
    /// bricks than the pool holds.
    pub floor: u32,
}

/// The CPU side of the residency.
struct State {
    /// The page table as uploaded (plus changes not yet uploaded when `dirty`).
    table: Vec<u32>,
    dirty: bool,
    /// Per slot: the table entry it holds and the frame it was last used in.
    owner: Vec<Option<u32>>,
    used: Vec<u64>,
    /// Slots not given out yet, when bricks share the pool's slots (empty when every brick has
    /// its own: [`BrickedVolume::own_slot`]).
    free: Vec<u32>,
    /// Entries asked of the loader and not yet arrived.
    pending: HashSet<u32>,
    /// Entries of the coarsest level: never evicted.
    pinned: HashSet<u32>,
    frame: u64,
    stats: Residency,
    /// Loading errors, once each (a corrupt chunk is reported, its brick left missing).
    errors: Vec<String>,
    failed: HashSet<u32>,
}

/// The brick pool's texture, `layers` layers of slots deep (z).
struct Pool {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    layers: u32,
}

impl Pool {
    /// A pool of `slots[0] x slots[1] x layers` slots, cleared by the device before its first
    /// write; `name` names the volume in errors.
    fn new(gpu: &Gpu, name: &str, slots: [u32; 3], layers: u32) -> Result<Pool, RuntimeError> {
        let size = [slots[0], slots[1], layers].map(|n| n * STORED);
        let usage =
            wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST | wgpu::TextureUsages::COPY_SRC;
        let image = Image3d { label: "brick pool", size, format: wgpu::TextureFormat::R16Float, usage };
        let texture = image.create(gpu, &format!("creating the brick pool of volume `{name}`"))?;
        Ok(Pool { view: texture.create_view(&Default::default()), texture, layers })
    }

    /// Texels per axis.
    fn dims(&self) -> [u32; 3] {
        let size = self.texture.size();
        [size.width, size.height, size.depth_or_array_layers]
    }

    /// Grows the pool to `layers` layers, its slots copied (after the uploads queued so far).
    fn grow(&mut self, gpu: &Gpu, name: &str, slots: [u32; 3], layers: u32) -> Result<(), RuntimeError> {
        let grown = Pool::new(gpu, name, slots, layers)?;
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        let [w, h, d] = self.dims();
        let extent = wgpu::Extent3d { width: w, height: h, depth_or_array_layers: d };
        encoder.copy_texture_to_texture(self.texture.as_image_copy(), grown.texture.as_image_copy(), extent);
        gpu.capture(&format!("growing the brick pool of volume `{name}`"), || gpu.queue.submit([encoder.finish()]))?;
        *self = grown;
        Ok(())
    }
}

/// The layers of slots a pool of `slots` starts with: room for the coarsest level's `pinned`
/// bricks (the first slots) and [`INITIAL_POOL_BYTES`].
fn initial_layers(slots: [u32; 3], pinned: u64) -> u32 {
    let wanted = pinned + INITIAL_POOL_BYTES / SLOT_BYTES;
    let layer = u64::from(slots[0] * slots[1]);
    wanted.div_ceil(layer).clamp(1, u64::from(slots[2])) as u32
}

/// A bricked volume's GPU objects and residency.
pub(crate) struct BrickedVolume {
    pub name: String,
    levels: Vec<Level>,
    /// Slots per axis of the pool as large as the budget lets it grow.
    slots: [u32; 3],
    pub grid_to_world: Mat4,
    /// The primary volume's normalized coordinates to this volume's.
    pub primary_to: Mat4,
    /// The pool as large as it is now (locked after `state` where both are).
    pool: Mutex<Pool>,
    pub pages: wgpu::Buffer,
    pub requests: wgpu::Buffer,
    readback: wgpu::Buffer,
    loader: Loader,
    state: Mutex<State>,
    /// The read-back under way: set by the map's callback when the requests can be read.
    mapping: Mutex<Option<Arc<AtomicBool>>>,
    /// The finest level rays may ask for: raised while the pictures ask for more bricks than
    /// the pool holds (so coarser levels stand in rather than bricks evicting each other every
    /// frame), lowered again when a finer level would fit ([`next_floor`]).
    floor: AtomicU32,
    /// The pool has a slot for every brick of the pyramid: each brick goes to its own.
    own_slots: bool,
    /// What the level-0 bricks read so far tell of the values, for empty-space skipping (kept
    /// after an eviction): those that arrive, and those the source reads of itself
    /// ([`BrickSource::observe_level0`], from before the volume was made: `learnt` of
    /// [`BrickedVolume::new`]).
    learnt: Arc<Mutex<RangeLearner>>,
}

impl BrickedVolume {
    /// The GPU objects of `source` with a pool of at most `budgets.0` bytes, values mapped to
    /// [0, 1] by `window`; the coarsest level is loaded before it returns. `budgets.1` is the
    /// volume's host budget, of which the source's cache for built levels takes
    /// [`super::cache_bytes`] and the loader's cache of normalized bricks the rest. `learnt`
    /// holds what the source showed of level 0 so far ([`RangeLearner::of`]).
    pub(crate) fn new(
        gpu: &Gpu,
        name: &str,
        source: Arc<dyn BrickSource>,
        window: [f32; 2],
        budgets: (u64, u64),
        primary_to: Mat4,
        learnt: Arc<Mutex<RangeLearner>>,
    ) -> Result<BrickedVolume, RuntimeError> {
        let invalid = |m: String| RuntimeError::Invalid(format!("volume `{name}`: {m}"));
        let levels = source.levels().to_vec();
        if levels.is_empty() || levels.len() > MAX_LEVELS {
            return Err(invalid(format!("{} levels; bricked volumes have 1 to {MAX_LEVELS}", levels.len())));
        }
        let entries = table_entries(&levels);
        if entries > MAX_BRICKS {
            return Err(invalid(format!(
                "{entries} page-table entries are more than the {MAX_BRICKS} a volume may have"
            )));
        }
        let bricks: u64 = levels.iter().map(Level::brick_count).sum();
        let max_3d = gpu.device.limits().max_texture_dimension_3d;
        let slots = pool_slots(budgets.0, bricks, max_3d)
            .ok_or_else(|| invalid(format!("a memory budget of {} MiB holds no brick", budgets.0 >> 20)))?;
        let count = slots.iter().product::<u32>();
        let own_slots = bricks <= u64::from(count);
        let coarsest = levels.last().map_or(1, Level::brick_count);
        let pool = Pool::new(gpu, name, slots, initial_layers(slots, coarsest))?;
        let doing = format!("creating the brick pool of volume `{name}`");
        let words = entries;
        let buffer = |label: &str, usage| {
            gpu.capture(&doing, || {
                gpu.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size: words * 4,
                    usage,
                    mapped_at_creation: false,
                })
            })
        };
        use wgpu::BufferUsages as B;
        let pages = buffer("page table", B::STORAGE | B::COPY_DST)?;
        let requests = buffer("brick requests", B::STORAGE | B::COPY_SRC | B::COPY_DST)?;
        let readback = buffer("brick requests read back", B::MAP_READ | B::COPY_DST)?;
        let pinned = level_entries(&levels, levels.len() - 1).collect();
        let state = State {
            table: vec![MISSING; words as usize],
            dirty: true,
            owner: vec![None; count as usize],
            used: vec![0; count as usize],
            free: if own_slots { Vec::new() } else { (0..count).rev().collect() },
            pending: HashSet::new(),
            pinned,
            frame: 0,
            stats: Residency { slots: count, ..Residency::default() },
            errors: Vec::new(),
            failed: HashSet::new(),
        };
        lock(&learnt).set_window(window);
        let volume = BrickedVolume {
            name: name.to_string(),
            grid_to_world: source.grid_to_world(),
            loader: Loader::new(source, window, budgets.1 - super::cache_bytes(budgets.1)),
            levels,
            slots,
            primary_to,
            pool: Mutex::new(pool),
            pages,
            requests,
            readback,
            state: Mutex::new(state),
            mapping: Mutex::new(None),
            floor: AtomicU32::new(0),
            own_slots,
            learnt,
        };
        volume.load_coarsest(gpu)?;
        Ok(volume)
    }

    /// The source the bricks are read from.
    pub(crate) fn source(&self) -> &Arc<dyn BrickSource> {
        self.loader.source()
    }

    /// The pool's texture as it is now (it grows as bricks arrive), for a dispatch to bind.
    pub(crate) fn pool_view(&self) -> wgpu::TextureView {
        lock(&self.pool).view.clone()
    }

    /// The levels, finest first.
    pub(crate) fn levels(&self) -> &[Level] {
        &self.levels
    }

    /// The value ranges empty-space skipping reads (a grid as fine as a single texture's), as
    /// far as the level-0 bricks read so far tell, when they told something new since the last
    /// call (`None`: nothing new).
    pub(crate) fn new_ranges(&self) -> Option<BrickRanges> {
        lock(&self.learnt).take_changed()
    }

    /// Counts of the residency now.
    pub(crate) fn residency(&self) -> Residency {
        let state = self.lock();
        Residency { pending: state.pending.len() as u32, floor: self.floor.load(Ordering::Relaxed), ..state.stats }
    }

    /// Errors of bricks that could not be read (each brick once), and the source's warnings.
    pub(crate) fn messages(&self) -> Vec<String> {
        let mut out = self.loader.warnings();
        out.extend(self.lock().errors.iter().cloned());
        out
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, State> {
        lock(&self.state)
    }

    /// Loads every brick of the coarsest level and waits for them.
    fn load_coarsest(&self, gpu: &Gpu) -> Result<(), RuntimeError> {
        let entries: Vec<u32> = self.lock().pinned.iter().copied().collect();
        self.ask(&entries);
        self.receive(gpu, true)?;
        Ok(())
    }

    /// The `BrickLayout` uniform for a view looking as `view` into a target `height` pixels
    /// high; its finest level is the volume's floor (0 unless detail is held back).
    pub(crate) fn layout_bytes(&self, view: BrickView, height: u32) -> Vec<u8> {
        let dims = Vec3::from_array(self.levels[0].dims.map(|n| n as f32));
        let to_voxels = Mat4::from_scale(dims) * self.primary_to;
        let height = height.max(1) as f32;
        let (eye, angle, footprint) = match view {
            BrickView::Perspective { eye, fov } => (to_voxels.transform_point3(eye), fov / height, 0.0),
            BrickView::Plane { u, v } => {
                let across = to_voxels.transform_vector3(u).length().max(to_voxels.transform_vector3(v).length());
                (Vec3::ZERO, 0.0, across / height)
            }
        };
        let mut words: Vec<u32> = Vec::with_capacity(20);
        let f = |x: f32| x.to_bits();
        words.extend([f(dims.x), f(dims.y), f(dims.z), f(self.levels.len() as f32)]);
        words.extend([f(eye.x), f(eye.y), f(eye.z), f(angle * angle)]);
        let pool = lock(&self.pool).dims().map(|n| 1.0 / n as f32);
        words.extend([f(pool[0]), f(pool[1]), f(pool[2]), f(BRICK as f32)]);
        let finest = self.floor.load(Ordering::Relaxed).min(self.levels.len() as u32 - 1);
        words.extend([f(footprint * footprint), f(finest as f32), f(APRON as f32), 0]);
        let [bx, by, bz] = self.levels[0].bricks.map(|n| n as f32);
        words.extend([f(1.0), f(bx), f(bx * by), f(bx * by * bz)]);
        bytemuck::cast_slice(&words).to_vec()
    }

    /// Starts reading back the requests rays wrote since the last read (a copy after the work
    /// submitted so far, then a map), and clears them for the next frames. Does nothing while
    /// the last read is still under way; returns whether it started one.
    pub(crate) fn start_collect(&self, gpu: &Gpu) -> bool {
        let mut mapping = lock(&self.mapping);
        if mapping.is_some() {
            return false;
        }
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(&self.requests, 0, &self.readback, 0, self.requests.size());
        encoder.clear_buffer(&self.requests, 0, None);
        gpu.queue.submit([encoder.finish()]);
        let done = Arc::new(AtomicBool::new(false));
        let flag = done.clone();
        self.readback.slice(..).map_async(wgpu::MapMode::Read, move |_| flag.store(true, Ordering::Release));
        *mapping = Some(done);
        true
    }

    /// Finishes the read [`Self::start_collect`] started, waiting for it when `wait` (else only
    /// when it is done): marks the bricks rays used and asks the loader for those they needed,
    /// coarse levels first. Returns how many were asked for, `None` while the read is under way.
    pub(crate) fn finish_collect(&self, gpu: &Gpu, wait: bool) -> Result<Option<usize>, RuntimeError> {
        let Some(done) = lock(&self.mapping).clone() else { return Ok(Some(0)) };
        if wait {
            gpu.wait();
        } else {
            let _ = gpu.device.poll(wgpu::PollType::Poll);
        }
        if !done.load(Ordering::Acquire) {
            return Ok(None);
        }
        let needed = {
            let slice = self.readback.slice(..);
            let mapped = slice
                .get_mapped_range()
                .map_err(|e| RuntimeError::Invalid(format!("cannot read the brick requests back: {e}")))?;
            self.mark(bytemuck::cast_slice(&mapped))
        };
        self.readback.unmap();
        *lock(&self.mapping) = None;
        Ok(Some(self.ask(&needed)))
    }

    /// Marks the slots of the bricks rays used (a new frame of the least-recently-used clock)
    /// and returns the entries they needed, coarsest level first.
    fn mark(&self, words: &[u32]) -> Vec<u32> {
        let mut state = self.lock();
        state.frame += 1;
        let frame = state.frame;
        let mut needed = Vec::new();
        let mut used = 0u64;
        for (entry, &word) in words.iter().enumerate() {
            match word {
                USED => {
                    let table = state.table[entry];
                    if table & !PAYLOAD == RESIDENT {
                        let slot = self.slot_index(table & PAYLOAD) as usize;
                        state.used[slot] = frame;
                        used += 1;
                    }
                }
                NEEDED => needed.push(entry as u32),
                _ => {}
            }
        }
        let room = (state.owner.len() - state.pinned.len().min(state.owner.len())) as u64;
        drop(state);
        let floor = self.floor.load(Ordering::Relaxed);
        let next = next_floor(floor, used + needed.len() as u64, room, self.levels.len() as u32 - 1);
        self.floor.store(next, Ordering::Relaxed);
        needed.sort_by_key(|&e| std::cmp::Reverse(self.level_of(e)));
        needed
    }

    /// Asks the loader for `entries` not already resident, pending or failed; returns how many.
    fn ask(&self, entries: &[u32]) -> usize {
        let mut state = self.lock();
        let mut asked = 0;
        for &entry in entries {
            if state.table[entry as usize] != MISSING || state.failed.contains(&entry) || !state.pending.insert(entry) {
                continue;
            }
            let (level, brick) = self.brick_of(entry);
            self.loader.ask(entry, level, brick);
            asked += 1;
        }
        asked
    }

    /// Places the bricks that arrived (all pending ones when `wait`) in the pool and uploads
    /// the page table if it changed. Returns how many arrived.
    pub(crate) fn receive(&self, gpu: &Gpu, wait: bool) -> Result<usize, RuntimeError> {
        let mut arrived = 0;
        let mut uploads = 0usize;
        loop {
            let pending = !self.lock().pending.is_empty();
            let next = if wait && pending { self.loader.wait() } else { self.loader.try_next() };
            let Some((entry, result)) = next else { break };
            arrived += 1;
            if let Ok(data) = &result {
                let (level, brick) = self.brick_of(entry);
                if level == 0 {
                    lock(&self.learnt).record_arrival(brick, data);
                }
            }
            let mut state = self.lock();
            state.pending.remove(&entry);
            match result {
                Ok(Normalized::Constant(value)) => {
                    state.table[entry as usize] = CONSTANT | (value.clamp(0.0, 1.0) * PAYLOAD as f32).round() as u32;
                    state.stats.constant += 1;
                    state.dirty = true;
                }
                Ok(Normalized::Voxels(voxels)) => match self.slot_for(&mut state, entry) {
                    Some(slot) => {
                        self.upload(gpu, slot, &voxels)?;
                        uploads += 1;
                        if uploads.is_multiple_of(UPLOADS_PER_SUBMIT) {
                            // Let the staged bricks go to the pool before staging more: the
                            // staging memory of a frame's uploads is freed as they complete.
                            gpu.queue.submit([]);
                            let _ = gpu.device.poll(wgpu::PollType::Poll);
                        }
                        state.owner[slot as usize] = Some(entry);
                        state.used[slot as usize] = state.frame;
                        state.table[entry as usize] = RESIDENT | self.slot_bits(slot);
                        state.stats.loaded += 1;
                        state.dirty = true;
                    }
                    None => state.stats.refused += 1,
                },
                Err(error) => {
                    state.failed.insert(entry);
                    let shown = match self.level_of(entry) + 1 < self.levels.len() {
                        true => "the brick is drawn from the next coarser level",
                        false => "the brick is left empty (it is of the coarsest level)",
                    };
                    state.errors.push(format!("volume `{}`: {error}; {shown}", self.name));
                }
            }
        }
        let mut state = self.lock();
        state.stats.resident = state.owner.iter().filter(|o| o.is_some()).count() as u32;
        if state.dirty {
            state.dirty = false;
            gpu.queue.write_buffer(&self.pages, 0, bytemuck::cast_slice(&state.table));
        }
        Ok(arrived)
    }

    /// The slot for brick `entry`: its own when every brick has one, else a free slot, else the
    /// least recently used one not used in the current frame nor pinned (its brick evicted);
    /// `None` when every slot is in use.
    fn slot_for(&self, state: &mut State, entry: u32) -> Option<u32> {
        if self.own_slots {
            return Some(self.own_slot(entry));
        }
        if let Some(slot) = state.free.pop() {
            return Some(slot);
        }
        let frame = state.frame;
        let victim = (0..state.owner.len())
            .filter(|&s| state.used[s] < frame && state.owner[s].is_some_and(|e| !state.pinned.contains(&e)))
            .min_by_key(|&s| state.used[s])?;
        if let Some(entry) = state.owner[victim].take() {
            state.table[entry as usize] = MISSING;
            state.stats.evicted += 1;
        }
        Some(victim as u32)
    }

    /// Brick `entry`'s own slot when the pool has one for every brick: its place in the pyramid
    /// (level by level, the coarsest first, so that the first slots hold it; x fastest). So
    /// where a brick lands in the pool, and the rounding of its pool coordinates, does not
    /// depend on the order the loader threads finish in, and a picture repeats exactly (with
    /// slots taken in arrival order, early ray termination flipped at a few pixels from run to
    /// run, up to 5/255).
    fn own_slot(&self, entry: u32) -> u32 {
        let (level, [x, y, z]) = self.brick_of(entry);
        let coarser: u64 = self.levels[level + 1..].iter().map(Level::brick_count).sum();
        let [w, h, _] = self.levels[level].bricks;
        (coarser + u64::from(x + w * (y + h * z))) as u32
    }

    /// Slot `slot`'s position in the pool, in slots.
    fn slot_position(&self, slot: u32) -> [u32; 3] {
        let [sx, sy, _] = self.slots;
        [slot % sx, (slot / sx) % sy, slot / (sx * sy)]
    }

    /// The payload of a resident entry: the slot's position, 10 bits an axis (x highest), so
    /// the lookup finds it without dividing.
    fn slot_bits(&self, slot: u32) -> u32 {
        let [x, y, z] = self.slot_position(slot);
        (x << 20) | (y << 10) | z
    }

    /// The slot a resident entry names.
    fn slot_index(&self, entry: u32) -> u32 {
        let [sx, sy, _] = self.slots;
        let [x, y, z] = [(entry >> 20) & 1023, (entry >> 10) & 1023, entry & 1023];
        x + sx * (y + sy * z)
    }

    /// Writes a brick's half floats into its slot, growing the pool to all the budget's slots
    /// first when it does not reach the slot yet.
    fn upload(&self, gpu: &Gpu, slot: u32, voxels: &[half::f16]) -> Result<(), RuntimeError> {
        let position = self.slot_position(slot);
        let mut pool = lock(&self.pool);
        if position[2] >= pool.layers {
            pool.grow(gpu, &self.name, self.slots, self.slots[2])?;
        }
        let origin = position.map(|n| n * STORED);
        gpu.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &pool.texture,
                mip_level: 0,
                origin: wgpu::Origin3d { x: origin[0], y: origin[1], z: origin[2] },
                aspect: wgpu::TextureAspect::All,
            },
            bytemuck::cast_slice(voxels),
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(STORED * 2), rows_per_image: Some(STORED) },
            wgpu::Extent3d { width: STORED, height: STORED, depth_or_array_layers: STORED },
        );
        Ok(())
    }

    fn level_of(&self, entry: u32) -> usize {
        self.brick_of(entry).0
    }

    /// The level and brick of page-table entry `entry`.
    fn brick_of(&self, entry: u32) -> (usize, [u32; 3]) {
        entry_brick(&self.levels, entry)
    }
}

/// The page-table entry of brick `brick` of level `level`: its level's block, then the brick
/// in level 0's strides (what the lookup computes).
fn brick_entry(levels: &[Level], level: usize, [x, y, z]: [u32; 3]) -> u32 {
    let [w, h, d] = levels[0].bricks;
    level as u32 * (w * h * d) + x + w * (y + h * z)
}

/// The level and brick of page-table entry `entry`: the inverse of [`brick_entry`].
fn entry_brick(levels: &[Level], entry: u32) -> (usize, [u32; 3]) {
    let [w, h, d] = levels[0].bricks;
    let i = entry % (w * h * d);
    ((entry / (w * h * d)) as usize, [i % w, (i / w) % h, i / (w * h)])
}

/// The page-table entries of level `level`'s bricks.
fn level_entries(levels: &[Level], level: usize) -> impl Iterator<Item = u32> + '_ {
    let [bx, by, bz] = levels[level].bricks;
    (0..bz).flat_map(move |z| (0..by).flat_map(move |y| (0..bx).map(move |x| brick_entry(levels, level, [x, y, z]))))
}

/// The finest level rays may ask for next, from the bricks the last pictures asked for at
/// `floor` (`demand`: used and needed) and the unpinned slots (`room`): one level coarser when
/// they asked for more than the pool holds; one finer when even 8 times the demand (a level
/// finer has at most 8 bricks for each) fits, so the floor does not swing back and forth.
fn next_floor(floor: u32, demand: u64, room: u64, coarsest: u32) -> u32 {
    if demand > room && floor < coarsest {
        floor + 1
    } else if floor > 0 && demand.saturating_mul(8) <= room {
        floor - 1
    } else {
        floor
    }
}

/// Slots per axis of a pool of at most `budget` bytes with room for `wanted` slots (every
/// brick of the pyramid) where the budget allows, each axis within `max_3d` texels; `None`
/// when not one slot fits. Of the shapes that hold the most of `wanted`, the one wasting the
/// fewest slots (a prime count may need a few spare ones), then the most even one.
fn pool_slots(budget: u64, wanted: u64, max_3d: u32) -> Option<[u32; 3]> {
    // Entries hold a slot's position in 10 bits an axis.
    let per_axis = (max_3d / STORED).clamp(1, 1024) as u64;
    let cap = (budget / SLOT_BYTES).min(per_axis.pow(3));
    let wanted = wanted.max(1);
    if cap == 0 {
        return None;
    }
    let key = |s: [u64; 3]| {
        let n = s.iter().product::<u64>();
        (n.min(wanted), std::cmp::Reverse(n), std::cmp::Reverse(s[0].max(s[1]).max(s[2])))
    };
    let mut best = [1u64, 1, 1];
    // z <= y, and x the fewest that hold `wanted` within the cap: at most per_axis^2 / 2
    // pairs (per_axis is max_3d / 66: 62 on lavapipe).
    for z in 1..=per_axis.min(cap) {
        for y in z..=per_axis.min(cap / z) {
            let x = wanted.div_ceil(y * z).min(per_axis).min(cap / (y * z));
            if x == 0 {
                break;
            }
            if key([x, y, z]) > key(best) {
                best = [x, y, z];
            }
        }
    }
    Some(best.map(|n| n as u32))
}

/// Which pages each bricked volume of a view's shader binds, by binding name.
pub(crate) type BrickedVolumes = HashMap<String, Arc<BrickedVolume>>;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bricks::levels_for;

    #[test]
    fn pools_stay_within_the_budget_and_the_texture_limit() {
        for (budget, wanted) in [(512u64 << 20, 18725u64), (64 << 20, 10), (8 << 30, 100000), (1 << 30, 73)] {
            let slots = pool_slots(budget, wanted, 2048).expect("some slots");
            let count: u64 = slots.iter().map(|&n| n as u64).product();
            assert!(count * SLOT_BYTES <= budget, "{budget} {wanted}: {slots:?}");
            assert!(slots.iter().all(|&n| n * STORED <= 2048), "{slots:?}");
            // All of what fits is used, with few spare slots.
            let fits = (budget / SLOT_BYTES).min(wanted).min(31u64.pow(3));
            // (A budget-bound count may have no shape within the texture limit: 933 = 3 x 311.)
            assert!(count + fits / 50 >= fits && count <= fits + fits / 8 + 2, "{budget} {wanted}: {count} of {fits}");
        }
        assert_eq!(pool_slots(SLOT_BYTES - 1, 5, 2048), None);
    }

    /// Whenever the budget and the texture limit hold every brick of the pyramid, the pool
    /// has a slot for each (a 128^3 volume's 9 bricks once got 2 x 2 x 2 slots).
    #[test]
    fn a_pool_holds_every_brick_when_the_budget_allows() {
        let mut sizes = vec![[128, 128, 128], [256, 256, 256], [65, 64, 64], [1000, 30, 30], [300, 200, 100]];
        for n in [1u32, 63, 64, 65, 127, 129, 200, 333, 512, 700] {
            sizes.push([n, n, n]);
            sizes.push([n, (n / 2).max(1), (3 * n / 4).max(1)]);
        }
        for dims in sizes {
            let wanted: u64 = levels_for(dims).iter().map(Level::brick_count).sum();
            for max_3d in [2048, 4096] {
                let per_axis = (max_3d / STORED) as u64;
                if wanted > per_axis.pow(3) {
                    continue;
                }
                let slots = pool_slots(1 << 30, wanted, max_3d).expect("some slots");
                let count: u64 = slots.iter().map(|&n| n as u64).product();
                assert!(count >= wanted, "{dims:?}: {slots:?} for {wanted} bricks");
                assert!(slots.iter().all(|&n| n * STORED <= max_3d), "{dims:?}: {slots:?}");
            }
        }
        // Prime counts fit too, with at most a few spare slots.
        for wanted in [2u64, 3, 5, 7, 11, 13, 17, 31, 61, 73, 997, 7919] {
            let slots = pool_slots(8 << 30, wanted, 4096).expect("some slots");
            let count = slots.iter().map(|&n| n as u64).product::<u64>();
            assert!(count >= wanted && count <= wanted + wanted / 16 + 2, "{wanted}: {slots:?}");
        }
    }

    /// A pool starts with the layers the coarsest level and [`INITIAL_POOL_BYTES`] need, within
    /// its slots.
    #[test]
    fn a_pool_starts_small() {
        let initial = INITIAL_POOL_BYTES / SLOT_BYTES;
        assert_eq!(initial, 106);
        assert_eq!(initial_layers([12, 12, 13], 1), 1);
        assert_eq!(initial_layers([4, 4, 100], 1), 7);
        assert_eq!(initial_layers([4, 4, 100], 200), 20);
        assert_eq!(initial_layers([4, 4, 3], 1), 3);
    }

    /// Growing a pool keeps what its slots hold, and the slots past its old end take bricks.
    #[test]
    fn a_growing_pool_keeps_its_slots() {
        let gpu = Gpu::headless(crate::AdapterChoice::Software).expect("the software adapter (lavapipe)");
        let slots = [2, 1, 4];
        let mut pool = Pool::new(&gpu, "grown", slots, 1).expect("a pool");
        let brick = |value: f32| vec![half::f16::from_f32(value); (STORED as usize).pow(3)];
        let write = |pool: &Pool, slot: [u32; 3], value: f32| {
            gpu.queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &pool.texture,
                    mip_level: 0,
                    origin: wgpu::Origin3d { x: slot[0] * STORED, y: slot[1] * STORED, z: slot[2] * STORED },
                    aspect: wgpu::TextureAspect::All,
                },
                bytemuck::cast_slice(&brick(value)),
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(STORED * 2),
                    rows_per_image: Some(STORED),
                },
                wgpu::Extent3d { width: STORED, height: STORED, depth_or_array_layers: STORED },
            );
        };
        write(&pool, [1, 0, 0], 1.5);
        pool.grow(&gpu, "grown", slots, 3).expect("grown");
        assert_eq!(pool.layers, 3);
        assert_eq!(pool.dims(), [2 * STORED, STORED, 3 * STORED]);
        write(&pool, [0, 0, 2], 2.5);
        let texels = read_pool(&gpu, &pool);
        let at = |[x, y, z]: [u32; 3]| texels[((z * pool.dims()[1] + y) * pool.dims()[0] + x) as usize].to_f32();
        assert_eq!(at([STORED + 3, 5, 7]), 1.5, "the slot written before growing");
        assert_eq!(at([3, 5, 2 * STORED + 7]), 2.5, "a slot of the new layers");
        assert_eq!(at([3, 5, 7]), 0.0, "a slot never written");
    }

    /// Every texel of `pool`, x fastest.
    fn read_pool(gpu: &Gpu, pool: &Pool) -> Vec<half::f16> {
        let [w, h, d] = pool.dims();
        let row = (w * 2).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size: u64::from(row * h * d),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        encoder.copy_texture_to_buffer(
            pool.texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(row), rows_per_image: Some(h) },
            },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: d },
        );
        gpu.queue.submit([encoder.finish()]);
        buffer.slice(..).map_async(wgpu::MapMode::Read, |_| {});
        gpu.wait();
        let mapped = buffer.slice(..).get_mapped_range().expect("mapped");
        let rows =
            mapped.chunks(row as usize).flat_map(|r| bytemuck::cast_slice::<u8, half::f16>(&r[..(w * 2) as usize]));
        rows.copied().collect()
    }

    #[test]
    fn a_pool_too_small_for_the_picture_shows_coarser_levels_rather_than_thrash() {
        // 100 slots, pictures asking for 150 bricks: one level coarser, then stays.
        assert_eq!(next_floor(0, 150, 100, 5), 1);
        assert_eq!(next_floor(1, 40, 100, 5), 1);
        // Finer again only when a finer level's bricks (up to 8 each) would fit.
        assert_eq!(next_floor(1, 12, 100, 5), 0);
        // Never past the coarsest level, never below 0.
        assert_eq!(next_floor(5, 1000, 100, 5), 5);
        assert_eq!(next_floor(0, 0, 100, 5), 0);
    }

    #[test]
    fn every_level_has_a_block_of_the_page_table_indexed_as_level_0() {
        let levels = levels_for([300, 200, 100]);
        assert_eq!(levels.iter().map(|l| l.bricks).collect::<Vec<_>>(), [[5, 4, 2], [3, 2, 1], [2, 1, 1], [1, 1, 1]]);
        assert_eq!(level_entries(&levels, 3).collect::<Vec<_>>(), [120]);
        assert_eq!(level_entries(&levels, 1).collect::<Vec<_>>(), [40, 41, 42, 45, 46, 47]);
        // Every brick of every level has its own entry, found again from it.
        let mut seen = HashSet::new();
        for level in 0..levels.len() {
            for entry in level_entries(&levels, level) {
                let (found, brick) = entry_brick(&levels, entry);
                assert_eq!(brick_entry(&levels, found, brick), entry);
                assert!(found == level && seen.insert(entry), "{entry}");
            }
        }
    }
}
