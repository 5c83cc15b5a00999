//! vrs-live: the prototyping loop behind `vrsc view` and `vrsc watch`, without a window.
//!
//! - [`LiveScene`]: a scene that follows its files. An edit recomposes through the composition
//!   cache (a uniform-only change never recompiles); a broken edit keeps the last good pipelines
//!   and pictures and hands back the diagnostics; what the user set (uniform values, cameras,
//!   slice positions, view sizes, mesh colours and placements) survives a reload wherever it
//!   still applies.
//! - [`save_uniforms`]: the parameter panel's values written back into the scene file, its
//!   comments and layout kept.
//! - [`FileWatcher`]: the scene file and every module file it reads, watched with a debouncer.
//! - [`Refiner`]: progressive refinement as a pure schedule (preview at a reduced resolution
//!   while the user interacts, full resolution in tiles when input stops), and [`ViewFrames`],
//!   which carries the schedule out on the GPU without ever waiting for it.

mod frames;
mod refine;
mod save;
mod session;
mod streaming;
mod watch;

pub use frames::{GpuWaiter, Shown, ViewFrames};
pub use refine::{Quality, Refiner, Work};
pub use save::{RENDER_UNIFORMS, SaveError, SavedUniform, save_uniforms, set_volume_tf, with_uniforms};
pub use session::{Failure, LiveScene, MeshStyle, Rebuild, UserState};
pub use watch::FileWatcher;
