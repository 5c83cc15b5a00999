//! vrs-runtime: renders the shaders that `vrsc` composes, with wgpu, headless or on an
//! application's device.
//!
//! Ways in:
//! - **Scenes** (feature `compiler`, on by default): [`SceneRenderer::open`] composes a scene
//!   file through the compiler library, loads its volumes and meshes once and renders every view;
//!   [`SceneRenderer::reload`] (or [`compose`](SceneRenderer::compose) then
//!   [`apply`](SceneRenderer::apply)) follows edits of the scene file.
//! - **Precompiled views**: [`ViewShader::load`] reads `VIEW.wgsl` + `VIEW.json` written by
//!   `vrsc build` (no compiler needed); bind volumes and transfer functions in [`Resources`]
//!   ([`Resources::bind_volume`], [`Resources::bind_tf`]), set uniforms by name and render with
//!   [`ViewRenderer::new`] and [`ViewRenderer::render`]. With the compiler,
//!   [`SceneRenderer::replace_shader`] also renders one in place of a view's composed shader.
//! - **Probes** (feature `compiler`): [`SceneRenderer::render_probe`] shows one state field of a
//!   view as an image (the view's probe variant, composed by the compiler), with its exact values
//!   and a legend; [`probe`] holds the decoded values.
//!
//! # The public API, by purpose
//!
//! - **Device**: [`Gpu`] ([`Gpu::headless`] with an [`AdapterChoice`], or
//!   [`Gpu::from_adapter`] on an application's adapter), [`GpuFault`] (a wgpu error as a value),
//!   [`gpu::request_adapter`].
//! - **Rendering a scene**: [`SceneRenderer`] with [`RenderOptions`]; its views
//!   ([`SceneRenderer::views`], each a [`scene::SceneView`] with a [`ViewRenderer`]) render to
//!   images ([`SceneRenderer::render_all`], [`SceneRenderer::render_view`]) or into an
//!   application's encoder ([`SceneRenderer::encode_view`], [`SceneRenderer::encode_view_into`]
//!   with a [`Region`] of a texture from [`view::create_output`]); [`Applied`] says what a reload
//!   changed; [`ViewShader`], [`PipelineCache`] and [`PipelineStats`] are the shaders and their
//!   compiled pipelines.
//! - **Uniforms**: [`SceneRenderer::set_uniform`] and [`ViewRenderer::set_uniform`] take a
//!   [`Value`]; [`uniforms::UniformBlock`] holds a view's current values;
//!   [`scene::is_set_by_renderer`] names those the renderer sets every frame;
//!   [`reflection`] describes a view's uniforms and functions.
//! - **Cameras and slices**: [`OrbitCamera`], [`SlicePlane`], [`SliceAxis`], [`Convention`],
//!   [`slice_edge_labels`], a slice view's image in patient space
//!   ([`SceneRenderer::slice_geometry`], [`SliceGeometry`]), and [`geometry`]'s patient-space
//!   helpers ([`geometry::PatientBox`], [`geometry::volume_to_world`]).
//! - **Volumes**: [`volume::load`] and [`volume::header`] read files, [`volume::phantom()`] makes
//!   test volumes, [`volume::VolumeFeed`] lets an application hand its own samples to a scene
//!   ([`RenderOptions::feeds`]); [`SceneRenderer::volumes`] and [`VolumeStatus`] show what is
//!   loaded and its histogram.
//! - **Transfer functions**: [`tf::TfCurve`] (editable control points), [`tf::preset_curve`],
//!   [`tf::from_paraview_json`]; [`SceneRenderer::set_tf_curve`] applies one.
//! - **Bricked (Zarr) volumes**: [`SceneRenderer::stream_bricks`] and [`scene::BrickProgress`],
//!   [`bricks::Residency`]; [`bricks::zarr`] opens stores ([`bricks::zarr::ZarrSource`]) and
//!   writes test ones; [`bricks::BrickSource`] is what a store of bricks provides.
//! - **Meshes**: [`SceneRenderer::meshes`] ([`mesh_layer::MeshInstance`]),
//!   [`SceneRenderer::set_mesh_style`], draggable [`scene::MeshHandle`]s,
//!   [`scene::mesh_surface`], [`mesh::Mesh`] and [`mesh::shapes`].
//! - **Errors**: [`RuntimeError`] (with [`RuntimeError::exit_code`]) wraps the module errors
//!   ([`volume::LoadError`], [`tf::TfError`], [`uniforms::UniformError`], [`gpu::GpuError`]).
//!
//! ```
//! use vrs_runtime::{AdapterChoice, Gpu, RenderOptions, SceneRenderer};
//! # let scene_file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/basic/scene.toml");
//! # let out = std::env::temp_dir();
//!
//! // scene_file: examples/basic/scene.toml (the built-in head phantom, a 3D and a slice view)
//! let gpu = Gpu::headless(AdapterChoice::PreferHardware)?; // lavapipe where there is no GPU
//! let mut scene = SceneRenderer::open(gpu, &scene_file, RenderOptions::default(), &mut |_, _, _| {})?;
//! scene.set_uniform("ambient", 0.4)?; // typed from the reflection: a wrong type is an error
//! for (view, image) in scene.render_all()? {
//!     image.save(out.join(format!("{view}.png")))?;
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

// Without scenes, the machinery only they drive (brick streaming, meshes, derived volumes) has no
// caller: the precompiled-view API above is what such a build offers.
#![cfg_attr(not(feature = "compiler"), allow(dead_code, unused_imports))]

pub(crate) mod bindings;
pub mod bricks;
pub(crate) mod error;
pub(crate) mod filter_pass;
pub mod geometry;
pub mod gpu;
pub(crate) mod history;
pub(crate) mod light_volume;
pub mod mesh;
pub mod mesh_layer;
pub(crate) mod metering;
pub(crate) mod node;
pub(crate) mod occupancy;
mod pass_bindings;
pub mod probe;
pub mod reflection;
mod region;
pub(crate) mod resources;
#[cfg(feature = "compiler")]
pub mod scene;
pub(crate) mod shader;
pub(crate) mod textures;
pub mod tf;
pub mod uniforms;
pub mod view;
pub mod volume;
pub(crate) mod volume_layer;

pub use error::RuntimeError;
pub use geometry::{Convention, OrbitCamera, SliceAxis, SlicePlane, slice_edge_labels};
pub use gpu::{AdapterChoice, Gpu, GpuFault};
pub use resources::Resources;
#[cfg(feature = "compiler")]
pub use scene::{Applied, ProbeAt, ProbeImage, ProbeSpec, RenderOptions, SceneRenderer, SliceGeometry, VolumeStatus};
pub use shader::{PipelineCache, PipelineStats, ViewPipeline, ViewShader};
pub use uniforms::Value;
pub use view::{Region, ViewRenderer};
