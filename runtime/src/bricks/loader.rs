//! Reading bricks off the render thread: loader threads take asked-for bricks from a queue,
//! read them from the source, normalize them to half floats and send them back; a host cache
//! of normalized bricks (least recently used out past its budget) answers again without a read.

use std::collections::{HashMap, VecDeque};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::sync::{Arc, Condvar, Mutex};

use super::{BrickData, BrickError, BrickSource, lock};
use crate::volume::{Scaling, Window};

/// A brick ready for the pool: its value mapped to [0, 1] by the volume's window.
#[derive(Clone, Debug)]
pub(crate) enum Normalized {
    Constant(f32),
    Voxels(Arc<Vec<half::f16>>),
}

impl Normalized {
    fn bytes(&self) -> u64 {
        match self {
            Normalized::Constant(_) => 16,
            Normalized::Voxels(v) => v.len() as u64 * 2,
        }
    }
}

/// A loaded brick or why it could not be: (page-table entry, result).
pub(crate) type Arrival = (u32, Result<Normalized, BrickError>);

/// Loader threads reading bricks of one source.
pub(crate) struct Loader {
    source: Arc<dyn BrickSource>,
    queue: Arc<Queue>,
    /// In a mutex so that a volume can be shared between threads (`Receiver` is not `Sync`).
    arrivals: Mutex<Receiver<Arrival>>,
    /// Cache hits go straight to the arrivals.
    sender: Sender<Arrival>,
    cache: Arc<Mutex<HostCache>>,
}

/// A brick asked for: (page-table entry, level, brick).
type Job = (u32, usize, [u32; 3]);

/// Bricks asked for and not yet taken by a thread; `None` once the loader is dropped.
#[derive(Default)]
struct Queue {
    jobs: Mutex<Option<VecDeque<Job>>>,
    ready: Condvar,
}

/// Threads reading bricks: two (reading is decompression-bound; the render thread keeps a core).
const THREADS: usize = 2;

impl Loader {
    pub(crate) fn new(source: Arc<dyn BrickSource>, window: [f32; 2], host_budget: u64) -> Loader {
        let queue = Arc::new(Queue { jobs: Mutex::new(Some(VecDeque::new())), ready: Condvar::new() });
        let (sender, arrivals) = channel();
        let cache = Arc::new(Mutex::new(HostCache::new(host_budget)));
        let window = Window::new(window, Scaling::IDENTITY);
        for _ in 0..THREADS {
            let (queue, sender, source, cache) = (queue.clone(), sender.clone(), source.clone(), cache.clone());
            std::thread::spawn(move || {
                while let Some((entry, level, brick)) = queue.next() {
                    let result = source.read(level, brick).map(|data| normalize(data, window));
                    if let Ok(brick) = &result {
                        lock(&cache).insert(entry, brick.clone());
                    }
                    if sender.send((entry, result)).is_err() {
                        break;
                    }
                }
            });
        }
        Loader { source, queue, arrivals: Mutex::new(arrivals), sender, cache }
    }

    /// Asks for brick `brick` of level `level` (page-table entry `entry`).
    pub(crate) fn ask(&self, entry: u32, level: usize, brick: [u32; 3]) {
        if let Some(hit) = lock(&self.cache).get(entry) {
            let _ = self.sender.send((entry, Ok(hit)));
            return;
        }
        if let Some(jobs) = lock(&self.queue.jobs).as_mut() {
            jobs.push_back((entry, level, brick));
        }
        self.queue.ready.notify_one();
    }

    /// A brick that arrived, if any.
    pub(crate) fn try_next(&self) -> Option<Arrival> {
        lock(&self.arrivals).try_recv().ok()
    }

    /// The next brick to arrive, waiting for it.
    pub(crate) fn wait(&self) -> Option<Arrival> {
        lock(&self.arrivals).recv().ok()
    }

    /// The source bricks are read from.
    pub(crate) fn source(&self) -> &Arc<dyn BrickSource> {
        &self.source
    }

    pub(crate) fn warnings(&self) -> Vec<String> {
        self.source.warnings()
    }
}

impl Drop for Loader {
    fn drop(&mut self) {
        *lock(&self.queue.jobs) = None;
        self.queue.ready.notify_all();
    }
}

impl Queue {
    /// The next job, waiting for one; `None` when the loader is gone.
    fn next(&self) -> Option<Job> {
        let mut jobs = lock(&self.jobs);
        loop {
            match jobs.as_mut() {
                None => return None,
                Some(queue) => {
                    if let Some(job) = queue.pop_front() {
                        return Some(job);
                    }
                }
            }
            jobs = self.ready.wait(jobs).unwrap_or_else(std::sync::PoisonError::into_inner);
        }
    }
}

/// Data units to the half floats the pool holds.
fn normalize(data: BrickData, window: Window) -> Normalized {
    match data {
        BrickData::Constant(v) => Normalized::Constant(window.apply(v)),
        BrickData::Voxels(values) => {
            Normalized::Voxels(Arc::new(values.into_iter().map(|v| pool_value(window, v)).collect()))
        }
    }
}

/// A value in data units as the pool holds it.
pub(crate) fn pool_value(window: Window, value: f32) -> half::f16 {
    half::f16::from_f32(window.apply(value))
}

/// Normalized bricks by page-table entry, the least recently used dropped past the budget.
struct HostCache {
    budget: u64,
    bytes: u64,
    clock: u64,
    bricks: HashMap<u32, (Normalized, u64)>,
}

impl HostCache {
    fn new(budget: u64) -> HostCache {
        HostCache { budget, bytes: 0, clock: 0, bricks: HashMap::new() }
    }

    fn get(&mut self, entry: u32) -> Option<Normalized> {
        self.clock += 1;
        let clock = self.clock;
        self.bricks.get_mut(&entry).map(|(brick, used)| {
            *used = clock;
            brick.clone()
        })
    }

    fn insert(&mut self, entry: u32, brick: Normalized) {
        self.clock += 1;
        self.bytes += brick.bytes();
        if let Some((old, _)) = self.bricks.insert(entry, (brick, self.clock)) {
            self.bytes -= old.bytes();
        }
        while self.bytes > self.budget {
            let Some((&oldest, _)) = self.bricks.iter().min_by_key(|(_, (_, used))| *used) else { break };
            if let Some((gone, _)) = self.bricks.remove(&oldest) {
                self.bytes -= gone.bytes();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_host_cache_keeps_the_recently_used_within_its_budget() {
        let brick = || Normalized::Voxels(Arc::new(vec![half::f16::ZERO; 100]));
        let mut cache = HostCache::new(650);
        for entry in 0..3 {
            cache.insert(entry, brick());
        }
        assert!(cache.get(0).is_some());
        cache.insert(3, brick());
        assert!(cache.bytes <= 650);
        assert!(cache.get(1).is_none(), "the least recently used went first");
        assert!(cache.get(0).is_some() && cache.get(3).is_some());
    }
}
