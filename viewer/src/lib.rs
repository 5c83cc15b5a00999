//! vrs-viewer: the window of `vrsc view`. Every view of a scene, drawn straight from the view's
//! output texture on the renderer's own device; orbit, pan and zoom of 3D views, stepping and
//! turning of slices; the scene and its modules followed live (see `vrs-live`), with the
//! diagnostics of a broken edit over the last good picture; progressive refinement so the window
//! stays responsive on a software adapter.
//!
//! The compiler and the runtime stay free of GUI dependencies: winit and egui live here only.

mod app;
pub mod navigate;
mod panel;
mod window;

pub use app::{ViewerOptions, run};
