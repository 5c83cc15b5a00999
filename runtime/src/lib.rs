//! vrs-runtime: renders the shaders that `vrsc` composes, with wgpu, headless or on an
//! application's device.
//!
//! Two ways in:
//! - **Precompiled views**: load `VIEW.wgsl` + `VIEW.json` written by `vrsc build` with
//!   [`ViewShader::load`] (no compiler needed), bind volumes and transfer functions in
//!   [`Resources`], set uniforms by name and render with [`ViewRenderer`].
//! - **Scenes** (feature `compiler`, on by default): [`SceneRenderer::open`] composes a scene
//!   file through the compiler library, loads its volumes once and renders every view.
//! - **Probes** (feature `compiler`): [`SceneRenderer::render_probe`] shows one state field of a
//!   view as an image (the view's probe variant, composed by the compiler), with its exact values
//!   and a legend; [`probe`] decodes and colours them.
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

pub(crate) mod bindings;
pub mod bricks;
pub(crate) mod error;
pub mod geometry;
pub mod gpu;
pub(crate) mod light_volume;
pub mod mesh;
pub mod mesh_layer;
pub(crate) mod metering;
pub(crate) mod occupancy;
mod pass_bindings;
pub mod probe;
pub mod reflection;
pub(crate) mod resources;
#[cfg(feature = "compiler")]
pub mod scene;
pub(crate) mod shader;
pub(crate) mod textures;
pub mod tf;
pub mod uniforms;
pub mod view;
pub mod volume;

pub use error::RuntimeError;
pub use geometry::{Convention, OrbitCamera, SliceAxis, SlicePlane, slice_edge_labels};
pub use gpu::{AdapterChoice, Gpu, GpuFault};
#[cfg(feature = "compiler")]
pub use scene::{Applied, ProbeAt, ProbeImage, ProbeSpec, RenderOptions, SceneRenderer, VolumeStatus};
pub use shader::{PipelineCache, PipelineStats, ViewPipeline, ViewShader};
pub use uniforms::Value;
pub use view::{Region, ViewRenderer};
