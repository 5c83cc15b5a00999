//! Rendering whole scenes (cargo feature `compiler`): compose through the compiler library,
//! load each volume and transfer function once, and drive every view from the scene's camera,
//! slice and uniform settings. This is the paper's scene graph: volumes, transfer functions and
//! scene uniforms are shared nodes; each view owns its composed pipeline.

use crate::bricks::Coarsening;
use crate::error::RuntimeError;
use crate::filter_pass::FilterAt;
use crate::geometry::{self, Convention, OrbitCamera, ShaderPlane, SliceAxis, SlicePlane};
use crate::gpu::Gpu;
use crate::mesh_layer::resolve_lights;
use crate::resources::Resources;
use crate::shader::{PipelineCache, PipelineStats, ViewShader};
use crate::textures::{TfTexture, VolumeTexture};
use crate::tf::TfDomain;
use crate::view::ViewRenderer;
use crate::{tf, volume};
use glam::Mat4;
use picture::ViewPicture;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use vrsc::compose::build::BuiltScene;
use vrsc::compose::cache::{CachedBuild, CompositionCache};
use vrsc::scene::{self as vscene, Role, Scene, TfRef, UniformValue, ViewKind, VolumeSource};

mod bricked;
mod derived;
mod images;
mod meshes;
mod picture;
mod probe;
mod tf_edit;
pub use bricked::{BrickProgress, selection};
pub use images::read_image;
pub use meshes::{MeshHandle, SliceGeometry, mesh_surface};
pub use probe::{ProbeAt, ProbeImage, ProbeSpec};
pub use tf_edit::VolumeStatus;

/// Choices a scene file does not make.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// Replaces every view's `size`.
    pub size: Option<[u32; 2]>,
    /// Grid size of built-in phantoms.
    pub phantom_size: [u32; 3],
    /// Volumes the application holds in memory, by their names in the scene: each is read from
    /// its feed instead of its `path` or `phantom` (see [`crate::volume::VolumeFeed`]).
    pub feeds: volume::Feeds,
    /// Frames each picture of a progressive view (the path tracer) holds when
    /// [`SceneRenderer::render_all`] or [`SceneRenderer::render_view`] returns it: its samples
    /// per pixel.
    pub samples: u32,
}

impl Default for RenderOptions {
    fn default() -> RenderOptions {
        RenderOptions {
            size: None,
            phantom_size: [128, 128, 128],
            feeds: volume::Feeds::new(),
            samples: crate::view::DEFAULT_SAMPLES,
        }
    }
}

/// A view of the scene and how it looks at the volume.
pub struct SceneView {
    /// The view's name in the scene file.
    pub name: String,
    /// Its shader, uniforms and output image.
    pub renderer: ViewRenderer,
    /// Raycast views: the orbit camera.
    pub camera: Option<OrbitCamera>,
    /// Slice views: the plane and the slab thickness (mm).
    pub slice: Option<(SlicePlane, f32)>,
    /// Slice views: how the image puts the patient's sides (the scene's `convention`).
    pub(crate) convention: Convention,
    /// Its renderer tree: what its mesh layer and its overlay draw, the slice views it shows.
    pub(crate) picture: ViewPicture,
}

/// A loaded scene, ready to render every frame.
pub struct SceneRenderer {
    gpu: Gpu,
    path: PathBuf,
    options: RenderOptions,
    compositions: CompositionCache,
    pipelines: PipelineCache,
    resources: Resources,
    /// Grid and transform of each volume, primary first.
    grids: Vec<VolumeGrid>,
    /// Empty-space skipping: the value range of every brick of the primary volume and of the
    /// additional ones, to rebuild the occupancy grid when a transfer function changes without
    /// reading a volume again. `None` when the scene does not skip.
    skipping: Option<crate::occupancy::SceneRanges>,
    /// What the loaded volumes were loaded from ([`volumes_key`]).
    volumes_key: String,
    /// One per view of the scene, in its order (what the mesh and plane indices refer to).
    views: Vec<SceneView>,
    /// Things the user should know that are not errors (a volume replaced by its fallback
    /// phantom because its file is absent).
    pub notices: Vec<String>,
    /// Probe variants composed so far ([`SceneRenderer::render_probe`]).
    probes: probe::ProbeCache,
    /// What the light volumes were computed from.
    derived: derived::Derived,
    /// What the views' renderer trees are made of, shared by them.
    tree: picture::TreeContent,
}

/// What [`SceneRenderer::apply`] changed.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Applied {
    /// The scene was composed anew (a composition-cache miss).
    pub composed: bool,
    /// The views whose pipeline changed (compiled, or taken from the pipeline cache).
    pub recompiled: Vec<String>,
    /// How many pipelines were compiled (the pipeline cache's misses).
    pub compiled: u64,
    /// Volumes and transfer functions were loaded again.
    pub volumes_reloaded: bool,
}

/// Where a volume's voxels are: what `primary_to_NAME` is computed from.
struct VolumeGrid {
    name: String,
    dims: [u32; 3],
    grid_to_world: Mat4,
    /// The data values its texture's [0, 1] stands for; transfer functions are resampled over it.
    window: [f32; 2],
    /// Voxel counts over the window (see [`VolumeTexture::histogram`]).
    histogram: Vec<u64>,
    /// The control points of its transfer function (`None` for a mask, which has none).
    curve: Option<tf::TfCurve>,
    /// Whether it holds label ids (`labels_NAME` of `std::tag`).
    labels: bool,
}

/// Progress of loading a volume: (volume name, bytes done, bytes in all).
pub(crate) type Progress<'a> = &'a mut dyn FnMut(&str, u64, u64);

impl SceneRenderer {
    /// Composes and loads the scene at `path`. Composition errors come back rendered as text in
    /// [`RuntimeError::Compose`]; use [`SceneRenderer::from_built`] to print them yourself.
    pub fn open(
        gpu: Gpu,
        path: &Path,
        options: RenderOptions,
        progress: Progress,
    ) -> Result<SceneRenderer, RuntimeError> {
        let mut compositions = CompositionCache::new();
        let cached = compositions.build(path).map_err(|error| RuntimeError::Io { path: path.to_path_buf(), error })?;
        let scene = composed_scene(&cached.built, cached.scene.clone())?;
        let mut renderer = SceneRenderer::from_built(gpu, path, &scene, &cached.built, options, progress)?;
        renderer.compositions = compositions;
        Ok(renderer)
    }

    /// A renderer for a scene the caller composed (and whose diagnostics it reported).
    pub fn from_built(
        gpu: Gpu,
        path: &Path,
        scene: &Scene,
        built: &BuiltScene,
        options: RenderOptions,
        progress: Progress,
    ) -> Result<SceneRenderer, RuntimeError> {
        let resources = Resources::new(&gpu);
        let mut renderer = SceneRenderer {
            gpu,
            path: path.to_path_buf(),
            options,
            compositions: CompositionCache::new(),
            pipelines: PipelineCache::new(),
            resources,
            grids: Vec::new(),
            skipping: None,
            volumes_key: String::new(),
            views: Vec::new(),
            notices: Vec::new(),
            probes: probe::ProbeCache::default(),
            derived: derived::Derived::default(),
            tree: picture::TreeContent::default(),
        };
        renderer.load_scene_volumes(scene, progress)?;
        renderer.set_views(scene, built)?;
        renderer.load_meshes(scene)?;
        renderer.load_images(scene)?;
        renderer.update_derived()?;
        Ok(renderer)
    }

    /// Loads every volume and transfer function of `scene` into fresh resources; on an error
    /// the current ones stay.
    fn load_scene_volumes(&mut self, scene: &Scene, progress: Progress) -> Result<(), RuntimeError> {
        let mut resources = Resources::new(&self.gpu);
        let mut notices = Vec::new();
        let loaded = load_volumes(&self.gpu, scene, &self.options, &mut resources, &mut notices, progress)?;
        self.resources = resources;
        self.notices = notices;
        self.grids = loaded.grids;
        self.skipping = loaded.ranges;
        self.volumes_key = volumes_key(scene, &self.options.feeds);
        self.derived.generation += 1;
        self.upload_max_grid();
        self.update_occupancy();
        Ok(())
    }

    /// The scene's views, in its order (`render_view`'s and the other methods' `index`).
    pub fn views(&self) -> &[SceneView] {
        &self.views
    }

    /// The scene's views, to move their cameras and planes or resize them (not to add or remove
    /// any: the scene's indices refer to them).
    pub fn views_mut(&mut self) -> &mut [SceneView] {
        &mut self.views
    }

    /// The device the scene renders on.
    pub fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    /// Pipeline cache hits and misses since the scene was opened.
    pub fn pipeline_stats(&self) -> PipelineStats {
        self.pipelines.stats()
    }

    /// Sets a uniform in every view whose shader reads it; an error if none does.
    pub fn set_uniform(&mut self, name: &str, value: impl Into<crate::uniforms::Value>) -> Result<(), RuntimeError> {
        let value = value.into();
        let mut found = false;
        for view in &mut self.views {
            if view.renderer.has_uniform(name) {
                view.renderer.set_uniform(name, value.clone())?;
                found = true;
            }
        }
        if found {
            return Ok(());
        }
        match self.views.first_mut() {
            // Let the view's block produce the message (unknown name, did you mean).
            Some(view) => view.renderer.set_uniform(name, value),
            None => Err(RuntimeError::Invalid(format!("the scene has no views to set `{name}` in"))),
        }
    }

    /// Reads the scene file again. Volumes stay loaded unless the scene's volumes changed; a
    /// structural change composes (and compiles) again, anything else only updates uniforms.
    /// Returns whether any view got a new shader.
    pub fn reload(&mut self) -> Result<bool, RuntimeError> {
        let cached = self.compose()?;
        Ok(self.apply(&cached)?.compiled > 0)
    }

    /// Composes the scene file as it is now, through the renderer's composition cache (a
    /// structure composed before is a hit). Nothing changes until [`SceneRenderer::apply`].
    pub fn compose(&mut self) -> Result<CachedBuild, RuntimeError> {
        self.compositions.build(&self.path).map_err(|error| RuntimeError::Io { path: self.path.clone(), error })
    }

    /// Makes a composition of this renderer's scene file current: volumes and transfer
    /// functions are loaded again when the scene's `[[volume]]`s changed, every view is set up
    /// from the new scene. An error (the composition's errors, a volume that does not load)
    /// leaves the renderer as it was.
    pub fn apply(&mut self, cached: &CachedBuild) -> Result<Applied, RuntimeError> {
        let scene = composed_scene(&cached.built, cached.scene.clone())?;
        let key = volumes_key(&scene, &self.options.feeds);
        let volumes_reloaded = key != self.volumes_key;
        if volumes_reloaded {
            self.load_scene_volumes(&scene, &mut |_, _, _| {})?;
        }
        let old: Vec<(String, String)> = self.views.iter().map(|v| (v.name.clone(), structural_hash(v))).collect();
        let misses = self.pipelines.stats().misses;
        self.set_views(&scene, &cached.built)?;
        self.load_meshes(&scene)?;
        self.load_images(&scene)?;
        self.update_derived()?;
        let recompiled = self
            .views
            .iter()
            .filter(|v| !old.contains(&(v.name.clone(), structural_hash(v))))
            .map(|v| v.name.clone())
            .collect();
        let compiled = self.pipelines.stats().misses - misses;
        Ok(Applied { composed: !cached.hit, recompiled, compiled, volumes_reloaded })
    }

    /// The scene file this renderer reads.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Renders every view; images in view order.
    /// Bricked volumes are streamed until every brick the rays asked for is resident (or the
    /// memory budget holds no more), so the images show the detail their pixels need.
    pub fn render_all(&mut self) -> Result<Vec<(String, image::RgbaImage)>, RuntimeError> {
        self.render_resident(SceneRenderer::render_all_once)
    }

    /// Renders view `index` alone, as [`SceneRenderer::render_all`] renders each view (an
    /// application that shows one view at a time need not render the others).
    pub fn render_view(&mut self, index: usize) -> Result<image::RgbaImage, RuntimeError> {
        if index >= self.views.len() {
            return Err(RuntimeError::Invalid(format!("the scene has no view {index}")));
        }
        let images = self.render_resident(|scene| scene.render_views_once(index..index + 1))?;
        let image = images.into_iter().next().map(|(_, image)| image);
        image.ok_or_else(|| RuntimeError::Invalid(format!("view {index} gave no image")))
    }

    /// Renders every view once with the bricks resident now.
    fn render_all_once(&mut self) -> Result<Vec<(String, image::RgbaImage)>, RuntimeError> {
        self.render_views_once(0..self.views.len())
    }

    /// Renders views `indices` once with the bricks resident now.
    fn render_views_once(
        &mut self,
        indices: std::ops::Range<usize>,
    ) -> Result<Vec<(String, image::RgbaImage)>, RuntimeError> {
        self.update_light_volumes()?;
        self.update_followed_meshes()?;
        let mut images = Vec::new();
        for index in indices {
            self.render_planes(index)?;
            let view = &mut self.views[index];
            apply_view_uniforms(view, &self.grids)?;
            images.push((view.name.clone(), view.renderer.render(&self.gpu, &self.resources)?));
        }
        Ok(images)
    }

    /// Replaces the shader of view `index` (an application's own variant of the composed one,
    /// with the same bindings and uniform block); uniforms start again from its reflection.
    pub fn replace_shader(&mut self, index: usize, shader: ViewShader) -> Result<(), RuntimeError> {
        let view = self.views.get_mut(index).ok_or_else(|| RuntimeError::Invalid(format!("no view {index}")))?;
        view.renderer.set_shader(&self.gpu, &mut self.pipelines, shader)
    }

    /// Replaces the transfer function of volume `volume` (its name in the scene) in every view:
    /// the table is rewritten in place, no shader or pipeline changes; with empty-space skipping
    /// the primary volume's occupancy grid is rebuilt from the brick ranges kept at load (the
    /// volume is not read again). This is what a viewer calls when only a transfer function
    /// changed.
    pub(crate) fn set_transfer_function(
        &mut self,
        volume: &str,
        tf: &crate::tf::TransferFunction,
    ) -> Result<(), RuntimeError> {
        let grid = self.grids.iter().find(|g| g.name == volume);
        let tf = &grid.map_or_else(|| tf.clone(), |g| tf.over_window(g.window));
        let is_primary = self.grids.first().is_some_and(|g| g.name == volume);
        let binding = tf_binding(volume, is_primary);
        let texture = self.resources.tfs.get(&binding).ok_or_else(|| {
            RuntimeError::Invalid(format!("the scene has no volume `{volume}` with a transfer function"))
        })?;
        texture.write(&self.gpu, tf);
        self.resources.content_changed();
        if self.skipping.as_mut().is_some_and(|s| s.set_tf(volume, is_primary, tf)) {
            self.update_occupancy();
        }
        if is_primary {
            self.derived.generation += 1;
            self.rewrite_preintegration(tf);
        }
        Ok(())
    }

    /// Builds the occupancy grid of empty-space skipping (`std::skip`) for the current transfer
    /// functions.
    fn update_occupancy(&mut self) {
        let Some(ranges) = &self.skipping else { return };
        let grid = ranges.occupancy();
        if let Ok(texture) = VolumeTexture::upload(&self.gpu, "occupancy", &grid, Some([0.0, 1.0])) {
            self.resources.volumes.insert("occupancy".into(), Arc::new(texture));
        }
    }

    /// Uploads the brick maxima of `std::skip_mip` and `std::skip_iso` (they depend on the
    /// samples and the window only: built once per load).
    fn upload_max_grid(&mut self) {
        let Some(ranges) = &self.skipping else { return };
        let grid = ranges.primary().max_grid();
        // Window [0, 1]: the grid holds normalized values already; above 1 stays above 1.
        if let Ok(texture) = VolumeTexture::upload(&self.gpu, "brick_max", &grid, Some([0.0, 1.0])) {
            self.resources.volumes.insert("brick_max".into(), Arc::new(texture));
        }
    }

    /// Records one frame of view `index` (for benchmarks: no read-back).
    pub fn encode_view(&mut self, index: usize, encoder: &mut wgpu::CommandEncoder) -> Result<(), RuntimeError> {
        self.update_light_volumes()?;
        self.update_followed_meshes()?;
        self.encode_planes(index, encoder)?;
        let view = &mut self.views[index];
        apply_view_uniforms(view, &self.grids)?;
        view.renderer.encode(&self.gpu, &self.resources, encoder)
    }

    /// Records `region` of view `index` into `target` (see `ViewRenderer::encode_into`), with
    /// the view's camera or slice plane applied.
    pub fn encode_view_into(
        &mut self,
        index: usize,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        region: crate::view::Region,
    ) -> Result<(), RuntimeError> {
        self.update_light_volumes()?;
        self.update_followed_meshes()?;
        // The slice pictures on the view's planes, once per frame: by its first region (a
        // preview, the whole image, or the first of its tiles), not again for every tile.
        if region.x0 == 0 && region.y0 == 0 {
            self.encode_planes(index, encoder)?;
        }
        let view = self.views.get_mut(index).ok_or_else(|| RuntimeError::Invalid(format!("no view {index}")))?;
        apply_view_uniforms(view, &self.grids)?;
        view.renderer.encode_into(&self.gpu, &self.resources, encoder, target, region)
    }

    /// The primary volume's grid: its voxel counts and its grid-to-world transform (voxel
    /// indices to patient space, RAS mm), what slice views step through.
    pub fn primary_grid(&self) -> Option<([u32; 3], Mat4)> {
        self.grids.first().map(|g| (g.dims, g.grid_to_world))
    }

    /// The shader of a filter pass of view `view`.
    fn filter_shader(&self, view: &str, pass: &vrsc::compose::build::FilterOutput) -> Result<ViewShader, RuntimeError> {
        let shader = pass
            .shader
            .as_ref()
            .ok_or_else(|| RuntimeError::Invalid(format!("the filters of view `{view}` did not compose")))?;
        ViewShader::new(shader.wgsl.clone(), shader.reflection.clone(), &self.path)
    }

    fn set_views(&mut self, scene: &Scene, built: &BuiltScene) -> Result<(), RuntimeError> {
        // The views' notes are made again below (the volumes' stay).
        self.notices.retain(|n| !n.ends_with(CUT_RAYS));
        let mut views = Vec::new();
        for (view, output) in scene.views.iter().zip(&built.views) {
            let values = scene.view_uniform_values(view);
            let shader = output
                .shader
                .as_ref()
                .ok_or_else(|| RuntimeError::Invalid(format!("view `{}` did not compose", output.name)))?;
            let shader = ViewShader::new(shader.wgsl.clone(), shader.reflection.clone(), &self.path)?;
            let size = self.options.size.unwrap_or(view.size);
            let mut renderer = ViewRenderer::new(&self.gpu, &mut self.pipelines, shader, size)?;
            renderer.set_samples(self.options.samples);
            let at_picture = output.filter.iter().map(|f| (FilterAt::Picture, f));
            let filters = at_picture.chain(output.tree_filters.iter().map(|(i, f)| (FilterAt::Tree(*i), f)));
            let shaders = filters.map(|(at, f)| Ok((at, self.filter_shader(&output.name, f)?)));
            let shaders = shaders.collect::<Result<_, RuntimeError>>()?;
            renderer.set_filters(&self.gpu, &mut self.pipelines, shaders)?;
            for (name, value) in &values {
                if renderer.has_uniform(name)
                    && let Some(value) = renderer.uniform_value_from_json(name, &value.to_json())
                {
                    renderer.set_uniform(name, value)?;
                }
            }
            if let Some(note) = self.set_physical_defaults(&mut renderer, &values)? {
                let note = format!("view `{}`: {note}", view.name.name);
                if !self.notices.contains(&note) {
                    self.notices.push(note);
                }
            }
            let (camera, slice) = match view.kind.value {
                ViewKind::Raycast => (Some(orbit(view.camera)), None),
                ViewKind::Slice => {
                    let axis = match view.axis.as_ref().map(|a| a.value) {
                        Some(vscene::Axis::X) => SliceAxis::X,
                        Some(vscene::Axis::Y) => SliceAxis::Y,
                        _ => SliceAxis::Z,
                    };
                    (None, Some((SlicePlane::new(axis, view.position), view.slab)))
                }
            };
            let convention = match view.convention {
                vscene::Convention::Radiological => Convention::Radiological,
                vscene::Convention::Neurological => Convention::Neurological,
            };
            let picture = ViewPicture::of(scene, view);
            views.push(SceneView { name: output.name.clone(), renderer, camera, slice, convention, picture });
        }
        self.views = views;
        self.tree.group_names = scene.groups.iter().map(|g| g.name.name.clone()).collect();
        Ok(())
    }
}

impl SceneRenderer {
    /// Physical sampling where the scene leaves it open: `step_size` half the primary volume's
    /// smallest voxel spacing, `ref_step` (the distance transfer-function opacities are
    /// defined for) that spacing, and `max_samples` enough steps for the grid's longest chord, at
    /// most [`vscene::MAX_SAMPLES_LIMIT`]. A note when that cap cuts the longest rays short (a
    /// small step through a large volume), which would otherwise go unnoticed.
    fn set_physical_defaults(
        &self,
        renderer: &mut ViewRenderer,
        values: &std::collections::BTreeMap<String, UniformValue>,
    ) -> Result<Option<String>, RuntimeError> {
        let Some(primary) = self.grids.first() else { return Ok(None) };
        let spacing = geometry::smallest_spacing(primary.grid_to_world);
        let spacing = if spacing.is_finite() { spacing } else { 1.0 };
        let step = match values.get("step_size") {
            Some(UniformValue::Float(s)) => *s as f32,
            Some(UniformValue::Int(s)) => *s as f32,
            _ => 0.5 * spacing,
        };
        let chord = geometry::longest_chord(geometry::volume_to_world(primary.dims, primary.grid_to_world));
        // A progressive view's path continues after each scattering: room for four flights
        // along the longest chord (most are far shorter: a scattered path soon leaves or ends).
        let flights = if renderer.is_progressive() { PATH_FLIGHTS } else { 1.0 };
        let needed = (chord / step).ceil() * flights + 2.0;
        let limit = vscene::MAX_SAMPLES_LIMIT;
        let samples = if needed.is_finite() { needed.min(limit as f32) as u32 } else { 1 };
        let cut = needed.is_finite()
            && needed > limit as f32
            && renderer.has_uniform("max_samples")
            && !values.contains_key("max_samples");
        let note = cut.then(|| {
            format!(
                "rays need {needed} samples of {step} mm to cross the volume ({chord:.0} mm), more than the \
                 {limit} a ray takes: the longest stop after {:.0} mm; {CUT_RAYS}",
                step * (limit - 2) as f32
            )
        });
        // In the order of PHYSICAL_DEFAULTS, which says how each is derived.
        let derived: [crate::uniforms::Value; 3] = [step.into(), spacing.into(), samples.into()];
        let defaults = PHYSICAL_DEFAULTS.map(|(name, _)| name).into_iter().zip(derived);
        for (name, value) in defaults {
            if renderer.has_uniform(name) && !values.contains_key(name) {
                renderer.set_uniform(name, value)?;
            }
        }
        Ok(note)
    }
}

/// Flights along the primary volume's longest chord that a progressive view's `max_samples`
/// leaves room for (`set_physical_defaults`).
const PATH_FLIGHTS: f32 = 4.0;

/// Where a volume's window (the values its texture is normalized over) comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum WindowRule {
    /// The scene's `window` (or a label volume's fixed one), as it is.
    Given([f32; 2]),
    /// The domain of a transfer function in data units (a CT preset's Hounsfield range, a
    /// ParaView colormap's). A volume read whole into memory (a phantom) widens it to cover its
    /// automatic window too: a narrow map (the light example's `skin.json`, 0 to 100) would
    /// otherwise flatten every denser value in the texture, and with them the gradients that
    /// shade the surface the map shows. A streamed file takes the domain alone (one pass over
    /// it instead of three).
    Domain([f32; 2]),
    /// The data's automatic window (percentiles, or the source's own).
    Automatic,
}

impl WindowRule {
    /// The window known before the data is read, if any.
    pub(crate) fn known(self) -> Option<[f32; 2]> {
        match self {
            WindowRule::Given(window) | WindowRule::Domain(window) => Some(window),
            WindowRule::Automatic => None,
        }
    }

    /// The window of a volume read whole, whose automatic window is `automatic`.
    pub(crate) fn with_automatic(self, automatic: [f32; 2]) -> [f32; 2] {
        match self {
            WindowRule::Given(window) => window,
            WindowRule::Domain([lo, hi]) => [lo.min(automatic[0]), hi.max(automatic[1])],
            WindowRule::Automatic => automatic,
        }
    }
}

/// Everything of a scene's volumes that loading reads: equal keys, same textures.
fn volumes_key(scene: &Scene, feeds: &volume::Feeds) -> String {
    let mut key = format!("skip {}\n", scene.skips_empty_space());
    for v in &scene.volumes {
        let source = match (feeds.get(&v.name.name), &v.source) {
            (Some(feed), _) => format!("feed {}", feed.version()),
            (None, VolumeSource::File(f)) => f.resolved.display().to_string(),
            (None, VolumeSource::Url(u)) => format!("url {}", u.value),
            (None, VolumeSource::Phantom(p)) => format!("phantom {}", p.value),
        };
        let tf = match &v.tf {
            Some(TfRef::Preset(p)) => format!("preset {}", p.value),
            Some(TfRef::File(f)) => format!(
                "file {} {:?}",
                f.resolved.display(),
                std::fs::metadata(&f.resolved).and_then(|m| m.modified()).ok()
            ),
            None => "none".into(),
        };
        let fallback = v.fallback.as_ref().map(|f| f.value.as_str());
        let window = format!("{:?}", v.window.as_ref().map(|w| w.value));
        let zarr = format!("{:?}", v.zarr);
        key.push_str(&format!("{} {:?} {source} {tf} {fallback:?} {window} {zarr}\n", v.name.name, v.role.value));
    }
    key
}

fn structural_hash(view: &SceneView) -> String {
    view.renderer.shader().reflection.structural_hash.clone()
}

/// The scene of a composition, or its errors rendered as text.
fn composed_scene(built: &BuiltScene, scene: Option<Scene>) -> Result<Scene, RuntimeError> {
    let diags = built.diags.sorted();
    match scene {
        Some(scene) if !built.diags.has_errors() => Ok(scene),
        _ => Err(RuntimeError::Compose { rendered: vrsc::diag::render_plain(&diags, &built.sources) }),
    }
}

fn orbit(c: vscene::Camera) -> OrbitCamera {
    OrbitCamera { azimuth: c.azimuth, elevation: c.elevation, distance: c.distance, fov: c.fov, ..Default::default() }
}

/// Camera or slice plane, and the transforms from the primary volume to the others.
fn apply_view_uniforms(view: &mut SceneView, grids: &[VolumeGrid]) -> Result<(), RuntimeError> {
    let r = &mut view.renderer;
    let Some(primary) = grids.first() else { return Ok(()) };
    let (primary_dims, primary_g) = (&primary.dims, primary.grid_to_world);
    let to_world = geometry::volume_to_world(*primary_dims, primary_g);
    let [w, h] = r.size();
    let aspect = w as f32 / h.max(1) as f32;
    if r.has_uniform("volume_to_world") {
        r.set_uniform("volume_to_world", to_world)?;
    }
    if r.has_uniform("gradient_to_world") {
        r.set_uniform("gradient_to_world", geometry::gradient_to_world(to_world))?;
    }
    let inv_view_proj = view.camera.map(|camera| camera.inv_view_proj(to_world, aspect));
    if let Some(m) = inv_view_proj
        && r.has_uniform("inv_view_proj")
    {
        r.set_uniform("inv_view_proj", m)?;
    }
    let mut plane_edges = None;
    if let Some((plane, slab)) = view.slice {
        let plane = ShaderPlane::new(plane.oriented(view.convention), to_world, aspect);
        plane_edges = Some((plane.u, plane.v));
        let uniforms = [
            ("slice_origin", plane.origin),
            ("slice_u", plane.u),
            ("slice_v", plane.v),
            ("slice_normal", plane.normal),
        ];
        for (name, v) in uniforms {
            if r.has_uniform(name) {
                r.set_uniform(name, v)?;
            }
        }
        if r.has_uniform("slab") {
            r.set_uniform("slab", slab)?;
        }
    }
    if let Some(brick_view) = bricked::brick_view(view, inv_view_proj, plane_edges) {
        view.renderer.set_brick_view(brick_view);
    }
    let r = &mut view.renderer;
    for other in &grids[1..] {
        let uniform = format!("primary_to_{}", other.name);
        if r.has_uniform(&uniform) {
            let m = geometry::primary_to((primary_dims, primary_g), (&other.dims, other.grid_to_world));
            r.set_uniform(&uniform, m)?;
        }
        let labels = format!("labels_{}", other.name);
        if r.has_uniform(&labels) {
            r.set_uniform(&labels, other.labels)?;
        }
    }
    if (view.renderer.reads_mesh_layer() || !view.picture.overlay.is_empty())
        && let Some((camera, inv_proj)) = meshes::layer_camera(view, primary)
    {
        if view.renderer.has_uniform(GEOMETRY_INV_PROJ) {
            view.renderer.set_uniform(GEOMETRY_INV_PROJ, inv_proj)?;
        }
        let mut tree = view.picture.tree.clone();
        let uniforms = view.renderer.uniforms();
        resolve_lights(&mut tree, &|name| match uniforms.get(name) {
            Some(crate::uniforms::Value::Float(v)) if v.len() == 3 => Some([v[0], v[1], v[2]]),
            _ => None,
        });
        view.renderer.set_mesh_layer(camera, tree, view.picture.overlay.clone());
        view.renderer.set_world_to_volume(to_world.inverse());
    }
    Ok(())
}

/// `std::meshes`' matrix from the mesh layer's clip space to normalized volume coordinates.
const GEOMETRY_INV_PROJ: &str = "geometry_inv_proj";

/// The uniforms the renderer derives from the primary volume where the scene leaves them open
/// (`set_physical_defaults`), and how, as the parameter panel says it.
const PHYSICAL_DEFAULTS: [(&str, &str); 3] = [
    ("step_size", "half the primary volume's smallest voxel spacing"),
    ("ref_step", "the primary volume's smallest voxel spacing"),
    (
        "max_samples",
        "enough steps of `step_size` to cross the primary volume's longest chord (four times, for the paths of a path-traced view)",
    ),
];

/// How the renderer derives uniform `name` where the scene leaves it open, if it does.
pub fn derived_default(name: &str) -> Option<&'static str> {
    PHYSICAL_DEFAULTS.iter().find(|(n, _)| *n == name).map(|(_, how)| *how)
}

/// Whether the renderer sets uniform `name` itself before every frame (what
/// `apply_view_uniforms` writes: the camera, the slice plane, the transforms of the primary
/// volume to patient space and to the other volumes, whether a tag volume holds label ids), so a
/// value set by hand would not last.
pub fn is_set_by_renderer(name: &str) -> bool {
    matches!(
        name,
        "inv_view_proj"
            | "volume_to_world"
            | "gradient_to_world"
            | "slice_origin"
            | "slice_u"
            | "slice_v"
            | "slice_normal"
            | "slab"
            | GEOMETRY_INV_PROJ
    ) || name.starts_with("primary_to_")
        || name.starts_with("labels_")
        || name.starts_with(crate::volume_layer::MESH_SHADOW_CLIP_PREFIX)
}

/// What [`load_volumes`] leaves for the renderer besides the uploaded textures.
struct Loaded {
    /// Every volume's grid, primary first.
    grids: Vec<VolumeGrid>,
    /// The brick ranges of the primary and additional volumes when the scene skips empty space
    /// (taken as they were uploaded; no volume's samples are kept), with their transfer
    /// functions.
    ranges: Option<crate::occupancy::SceneRanges>,
}

/// The end of the note that rays are cut short by the cap on samples.
const CUT_RAYS: &str = "a larger `step_size` reaches the far side";

/// Loads and uploads every volume and transfer function of the scene, the primary volume first.
fn load_volumes(
    gpu: &Gpu,
    scene: &Scene,
    options: &RenderOptions,
    resources: &mut Resources,
    notices: &mut Vec<String>,
    progress: Progress,
) -> Result<Loaded, RuntimeError> {
    let mut grids: Vec<VolumeGrid> = Vec::new();
    let mut scene_ranges: Option<crate::occupancy::SceneRanges> = None;
    let default_tf = tf::preset(vscene::DEFAULT_TF)?;
    let primary = scene.primary().ok_or_else(|| RuntimeError::Invalid("the scene has no primary volume".into()))?;
    let ordered = std::iter::once(primary).chain(scene.volumes.iter().filter(|v| v.role.value != Role::Primary));
    for v in ordered {
        let plan = VolumePlan::of(scene, v, notices)?;
        let name = &v.name.name;
        let fed = options.feeds.get(name);
        if v.bricked && fed.is_some() {
            return Err(RuntimeError::Invalid(format!(
                "volume `{name}`: a volume held in memory is kept in one texture, not in bricks (`bricks = true`)"
            )));
        }
        if v.bricked {
            let ranges = plan.ranges;
            let (volume, grid) = load_bricked(gpu, scene, v, plan, grids.first(), options, notices, progress)?;
            let table = insert_tf(gpu, resources, v, grid.curve.as_ref(), grid.window)?;
            grids.push(grid);
            // Nothing is known of its bricks yet: the grid skips nothing until they are read.
            if let Some(known) = volume.new_ranges().filter(|_| ranges) {
                add_ranges(&mut scene_ranges, &grids, known, table.as_ref().unwrap_or(&default_tf));
            }
            resources.bricked.insert(v.binding(), Arc::new(volume));
            continue;
        }
        let (texture, window, bricks) = upload_volume(gpu, v, &plan, fed, options, notices, progress)?;
        let grid = VolumeGrid {
            name: name.clone(),
            dims: texture.dims,
            grid_to_world: texture.grid_to_world,
            window,
            histogram: texture.histogram.clone(),
            curve: plan.curve,
            labels: plan.labels,
        };
        resources.volumes.insert(v.binding(), Arc::new(texture));
        let table = insert_tf(gpu, resources, v, grid.curve.as_ref(), window)?;
        grids.push(grid);
        if let Some(bricks) = bricks {
            add_ranges(&mut scene_ranges, &grids, bricks, table.as_ref().unwrap_or(&default_tf));
        }
    }
    Ok(Loaded { grids, ranges: scene_ranges })
}

/// What the scene says about one volume before it is read: its transfer function's curve, the
/// window its texture's [0, 1] stands for when the scene fixes one, and whether the brick
/// ranges of empty-space skipping are taken from it.
struct VolumePlan {
    curve: Option<tf::TfCurve>,
    /// Where its window comes from.
    window: WindowRule,
    /// Empty-space skipping needs the brick ranges of the primary volume and of the additional
    /// ones (composited over it), taken from the texels as they are uploaded: every volume file
    /// is streamed into its texture without a copy in memory.
    ranges: bool,
    /// A tag volume of label ids (`labels = true`, or an OME-Zarr label image): read at the
    /// nearest voxel, over [`tf::LABEL_WINDOW`].
    labels: bool,
}

impl VolumePlan {
    fn of(scene: &Scene, v: &vscene::Volume, notices: &mut Vec<String>) -> Result<VolumePlan, RuntimeError> {
        let mut curve = match &v.tf {
            Some(TfRef::Preset(p)) => Some(tf::preset_curve(&p.value)?),
            Some(TfRef::File(file)) => Some(tf::paraview_curve(&file.resolved)?),
            None => None,
        };
        let label_colors = if v.role.value == Role::Tag { store_label_colors(&v.source) } else { None };
        let labels = v.role.value == Role::Tag && v.labels.as_ref().map_or(label_colors.is_some(), |l| l.value);
        if labels {
            // The `labels` preset's 16 bins over a window become one entry per id.
            let own_colours = curve.as_ref().is_some_and(|c| c.name == vscene::DEFAULT_TAG_TF);
            if own_colours {
                curve = Some(tf::label_curve(vscene::DEFAULT_TAG_TF, label_colors.as_deref().unwrap_or_default()));
            }
            let colours = own_colours.then_some(label_colors.as_deref().unwrap_or_default());
            notices.push(labels_notice(&v.name.name, v.labels.is_none(), colours));
        }
        let domain = curve.as_ref().map(|c| c.table().domain);
        let given = if labels { Some(tf::LABEL_WINDOW) } else { v.window.as_ref().map(|w| w.value) };
        let window = match (given, domain) {
            (Some(window), _) => WindowRule::Given(window),
            (None, Some(TfDomain::Data(domain))) => WindowRule::Domain(domain),
            (None, _) => WindowRule::Automatic,
        };
        let ranges = matches!(v.role.value, Role::Primary | Role::Additional) && scene.skips_empty_space();
        Ok(VolumePlan { curve, window, ranges, labels })
    }
}

/// The label colours of an OME-Zarr label image at `source`; `None` for any other source (and
/// for a store that cannot be read: loading it says why).
fn store_label_colors(source: &VolumeSource) -> Option<Vec<crate::bricks::zarr::LabelColor>> {
    crate::bricks::zarr::label_colors(&bricked::store_location(source)?).ok().flatten()
}

/// The notice that tag volume `name` is shown as labels (`automatic`: because it is an OME-Zarr
/// label image), with the colours of the `labels` preset and its store (`colours`) or with its
/// own transfer function (`None`).
fn labels_notice(name: &str, automatic: bool, colours: Option<&[crate::bricks::zarr::LabelColor]>) -> String {
    let why = if automatic { "an OME-Zarr label image" } else { "`labels = true`" };
    let colours = match colours {
        Some(listed) if !listed.is_empty() => format!(
            "in the colours of its {} listed labels and 16 colours in turn for the rest (id 0 transparent unless listed)",
            listed.len()
        ),
        Some(_) => "in 16 colours in turn (id 0 transparent)".to_string(),
        None => "id k taking entry k of its transfer function".to_string(),
    };
    format!("volume `{name}`: label ids ({why}) read at the nearest voxel, {colours}")
}

/// The built-in phantom `p` standing in for volume `name`, at the options' size.
fn phantom_of(name: &str, p: &str, options: &RenderOptions) -> Result<volume::Volume, RuntimeError> {
    volume::phantom::phantom(p, options.phantom_size)
        .map_err(|e| RuntimeError::Invalid(format!("volume `{name}`: {e}")))
}

/// The notice that volume `name`'s file is absent and the phantom `fallback` stands in.
fn fallback_notice(name: &str, file: &Path, fallback: &str) -> String {
    format!("volume `{name}`: `{}` is absent; using the built-in `{fallback}` phantom instead", file.display())
}

/// The notice of a window taken from the data: its percentiles, or a phantom's whole range.
fn automatic_window_notice(name: &str, window: [f32; 2], whole_range: bool) -> String {
    let [lo, hi] = volume::histogram::AUTO_PERCENTILES;
    let how = if whole_range {
        "a phantom's whole range".to_string()
    } else {
        format!("the {lo}th to {hi}th percentile of its values")
    };
    format!(
        "volume `{name}`: automatic window [{:.4}, {:.4}] ({how}); `window = [LO, HI]` in its [[volume]] table \
         sets another",
        window[0], window[1]
    )
}

/// Opens a volume the scene keeps in bricks (`bricks = true`) and uploads what it starts with:
/// the volume and its grid.
#[allow(clippy::too_many_arguments)]
fn load_bricked(
    gpu: &Gpu,
    scene: &Scene,
    v: &vscene::Volume,
    plan: VolumePlan,
    primary: Option<&VolumeGrid>,
    options: &RenderOptions,
    notices: &mut Vec<String>,
    progress: Progress,
) -> Result<(crate::bricks::BrickedVolume, VolumeGrid), RuntimeError> {
    let name = &v.name.name;
    // The source's cache for built levels: its part of this volume's host budget.
    let cache = crate::bricks::cache_bytes(scene.memory.host / bricked::sharing(scene).max(1));
    // Label ids keep one id per coarse voxel; a mean would make other ids.
    let coarsening = if plan.labels { Coarsening::First } else { Coarsening::Mean };
    let building = (cache, coarsening);
    let report = &mut |done, total| progress(name, done, total);
    let phantom = |p: &str| phantom_of(name, p, options);
    let source = match (&v.source, &v.fallback) {
        (VolumeSource::File(file), Some(fallback)) if !file.resolved.exists() => {
            notices.push(fallback_notice(name, &file.resolved, &fallback.value));
            bricked::open_source(&VolumeSource::Phantom(fallback.clone()), &v.zarr, building, phantom, report)?
        }
        (source, _) => bricked::open_source(source, &v.zarr, building, phantom, report)?,
    };
    let budget = (&scene.memory, bricked::sharing(scene));
    let (volume, window, histogram) = bricked::load(gpu, name, source, plan.window, budget, primary)?;
    let grid = VolumeGrid {
        name: name.clone(),
        dims: volume.levels()[0].dims,
        grid_to_world: volume.grid_to_world,
        window,
        histogram,
        labels: plan.labels,
        curve: plan.curve,
    };
    Ok((volume, grid))
}

/// Reads a volume the scene keeps in one texture (fed by the application, from its file or
/// store, or a phantom) into its texture: the texture, its window and, when `plan.ranges`, the
/// brick ranges of its texels. An automatic window is said in a notice.
fn upload_volume(
    gpu: &Gpu,
    v: &vscene::Volume,
    plan: &VolumePlan,
    fed: Option<&Arc<dyn volume::VolumeFeed>>,
    options: &RenderOptions,
    notices: &mut Vec<String>,
    progress: Progress,
) -> Result<(VolumeTexture, [f32; 2], Option<crate::occupancy::BrickRanges>), RuntimeError> {
    let name = &v.name.name;
    let (fixed, ranges) = (plan.window.known(), plan.ranges);
    let uploaded = |data: volume::Volume, notices: &mut Vec<String>| -> Result<_, RuntimeError> {
        let window = plan.window.with_automatic(volume::auto_window(&data));
        if plan.window == WindowRule::Automatic {
            notices.push(automatic_window_notice(name, window, data.own_window.is_some()));
        }
        let bricks = ranges.then(|| crate::occupancy::BrickRanges::new(&data, Some(window)));
        Ok((VolumeTexture::upload(gpu, name, &data, Some(window))?, window, bricks))
    };
    let report = &mut |done, total| progress(name, done, total);
    let streamed = |loaded: (VolumeTexture, [f32; 2], _), notices: &mut Vec<String>| {
        if plan.window == WindowRule::Automatic {
            notices.push(automatic_window_notice(name, loaded.1, false));
        }
        Ok(loaded)
    };
    match (&v.source, &v.fallback) {
        (source, _) if let Some(feed) = fed => {
            let path = match source {
                VolumeSource::File(file) => file.resolved.clone(),
                VolumeSource::Url(u) => PathBuf::from(&u.value),
                VolumeSource::Phantom(p) => PathBuf::from(&p.value),
            };
            streamed(VolumeTexture::stream_feed(gpu, name, &path, feed.as_ref(), fixed, ranges, report)?, notices)
        }
        (VolumeSource::File(file), Some(fallback)) if !file.resolved.exists() => {
            notices.push(fallback_notice(name, &file.resolved, &fallback.value));
            uploaded(phantom_of(name, &fallback.value, options)?, notices)
        }
        (VolumeSource::Url(url), _) => {
            let store = crate::bricks::zarr::StoreLocation::Url(url.value.clone());
            uploaded(bricked::zarr_volume(&store, &v.zarr)?, notices)
        }
        (VolumeSource::File(file), _) if vscene::is_zarr(&file.resolved) => {
            let store = crate::bricks::zarr::StoreLocation::Path(file.resolved.clone());
            uploaded(bricked::zarr_volume(&store, &v.zarr)?, notices)
        }
        (VolumeSource::File(file), _) => {
            streamed(VolumeTexture::stream_file(gpu, name, &file.resolved, fixed, ranges, report)?, notices)
        }
        (VolumeSource::Phantom(p), _) => uploaded(phantom_of(name, &p.value, options)?, notices),
    }
}

/// The uniform a volume's transfer-function table is bound as: `tf` for the primary volume,
/// `tf_NAME` for another (the compiler's `bound_resources` names them so).
pub(crate) fn tf_binding(volume: &str, primary: bool) -> String {
    if primary { "tf".to_string() } else { format!("tf_{volume}") }
}

/// Uploads volume `v`'s transfer function, its curve resampled over `window`, under the
/// binding its shaders read ([`tf_binding`]): the table.
fn insert_tf(
    gpu: &Gpu,
    resources: &mut Resources,
    v: &vscene::Volume,
    curve: Option<&tf::TfCurve>,
    window: [f32; 2],
) -> Result<Option<tf::TransferFunction>, RuntimeError> {
    let Some(table) = curve.map(|c| c.table().over_window(window)) else { return Ok(None) };
    let binding = tf_binding(&v.name.name, v.role.value == Role::Primary);
    resources.tfs.insert(binding, Arc::new(TfTexture::upload(gpu, &table)?));
    Ok(Some(table))
}

/// Adds the brick ranges of the volume whose grid is the last of `grids` (the primary's when it
/// is the first) to `scene`.
fn add_ranges(
    scene: &mut Option<crate::occupancy::SceneRanges>,
    grids: &[VolumeGrid],
    bricks: crate::occupancy::BrickRanges,
    tf: &tf::TransferFunction,
) {
    let (Some(primary), Some(volume)) = (grids.first(), grids.last()) else { return };
    match scene {
        None => *scene = Some(crate::occupancy::SceneRanges::new(bricks, tf)),
        Some(ranges) => {
            let primary_to =
                geometry::primary_to((&primary.dims, primary.grid_to_world), (&volume.dims, volume.grid_to_world));
            ranges.add(&volume.name, bricks, primary_to.inverse(), tf);
        }
    }
}
