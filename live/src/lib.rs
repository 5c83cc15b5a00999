//! vrs-live: the prototyping loop behind `vrsc view` and `vrsc watch`, without a window.
//!
//! Public API:
//! - [`LiveScene`]: a scene that follows its files. An edit recomposes through the composition
//!   cache (a uniform-only change never recompiles); a broken edit keeps the last good pipelines
//!   and pictures and hands back the diagnostics; what the user set (uniform values, cameras,
//!   slice positions, view sizes, mesh colours and placements; [`UserState`], [`MeshStyle`])
//!   survives a reload wherever it still applies. Each reload reports a [`Rebuild`], with a
//!   [`Failure`] when the last good state stays.
//! - [`save_uniforms`]: the parameter panel's values ([`SavedUniform`]) written back into the
//!   scene file, its comments and layout kept ([`with_uniforms`] on text; [`RENDER_UNIFORMS`]
//!   go to `[render]`); [`set_volume_tf`] sets a volume's `tf` (a preset or colormap); both fail
//!   with a [`SaveError`].
//! - [`FileWatcher`]: the scene file and every module file it reads, watched with a debouncer.
//! - [`Refiner`]: progressive refinement as a pure schedule (preview at a reduced resolution
//!   while the user interacts, full resolution in tiles when input stops; [`Work`] to do next,
//!   [`Quality`] reached), and [`ViewFrames`], which carries the views' schedules out on the GPU
//!   one piece at a time, the most urgent view's first ([`ViewFrames::step_views`]), without
//!   ever waiting for it ([`GpuWaiter`] waits on another thread), and gives the picture to draw
//!   ([`Shown`]).

mod frames;
mod refine;
mod save;
mod schedule;
mod session;
mod streaming;
mod watch;

pub use frames::{GpuWaiter, Shown, ViewFrames};
pub use refine::{Quality, Refiner, Work};
pub use save::{RENDER_UNIFORMS, SaveError, SavedUniform, save_uniforms, set_volume_tf, with_uniforms};
pub use session::{Failure, LiveScene, MeshStyle, Rebuild, UserState};
pub use watch::FileWatcher;
