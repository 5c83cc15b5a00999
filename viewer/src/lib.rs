//! vrs-viewer: the window of `vrsc view`. Every view of a scene, drawn straight from the view's
//! output texture on the renderer's own device; orbit, pan and zoom of 3D views, stepping and
//! turning of slices; the scene and its modules followed live (see `vrs-live`), with the
//! diagnostics of a broken edit over the last good picture; progressive refinement so the window
//! stays responsive on a software adapter.
//!
//! The side panel is generated from the views' reflection: a control for every uniform
//! ([`controls`], [`params`]), a transfer-function editor per volume ([`tf_editor`]), and an
//! inspector of each view's pipeline and composed WGSL ([`inspector`]), and the colour, opacity
//! and placement of each mesh ([`mesh_panel`]); each view can show any state field as a probe
//! instead of its picture. In slice views the points meshes follow (an ablation needle's tip)
//! are marked and can be dragged in the plane ([`handles`]). The panels only draw and return
//! [`actions::Action`]s, applied to the live scene in one place, so they are tested headless.
//!
//! The compiler and the runtime stay free of GUI dependencies: winit and egui live here only.
//!
//! Public API:
//! - [`run`] with [`ViewerOptions`]: opens the window on a scene (`vrsc view`).
//! - The panels, each a `show` that draws into an `egui::Ui` and returns [`actions::Action`]s,
//!   and the plain data it draws: [`params`] ([`params::groups`] of [`params::UniformRow`]s, each
//!   with its [`controls::Control`] from [`controls::control_for`]), [`tf_editor`]
//!   ([`tf_editor::EditedVolume`], [`tf_editor::TfEditorState`]), [`inspector`]
//!   ([`inspector::InspectorState`], [`inspector::Sources`]) and [`mesh_panel`]
//!   ([`mesh_panel::rows`] of [`mesh_panel::MeshRow`]s).
//! - [`actions::apply`]: an [`actions::Action`] carried out on a `vrs_live::LiveScene`.
//! - [`handles`]: the draggable points of slice views ([`handles::slice_markers`],
//!   [`handles::grab`], [`handles::drag_to`]).
//! - [`navigate`]: orbit, pan and zoom of cameras, stepping and turning of slice planes.
//! - [`crosshair`]: a click in a slice view moves the others through the point; where they cut it.
//! - [`notices`]: the renderer's notices as the status bar shows them.

pub mod actions;
mod app;
pub mod controls;
pub mod crosshair;
pub mod handles;
pub mod inspector;
pub mod mesh_panel;
pub mod navigate;
mod panel;
pub mod params;
mod side;
pub mod tf_editor;
mod window;

pub use app::{ViewerOptions, run};
pub use panel::notices;
