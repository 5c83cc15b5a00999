//! A scene that follows its files: recomposition on demand, the last good state kept through a
//! broken edit, and the user's own settings carried across reloads.

use crate::save::{self, SaveError, SavedUniform};
use crate::streaming::Streaming;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};
use vrs_runtime::reflection::FunctionInfo;
use vrs_runtime::scene::{BrickProgress, MeshHandle};
use vrs_runtime::tf::TfCurve;
use vrs_runtime::view::Region;
use vrs_runtime::{Applied, OrbitCamera, ProbeImage, ProbeSpec, RuntimeError, SceneRenderer, SlicePlane, Value};
use vrsc::compose::build::{self, BuiltScene, Keep};
use vrsc::scene::{MeshSource, UniformValue};

/// Why a rebuild did not take effect (the last good state is still shown).
#[derive(Debug)]
pub enum Failure {
    /// The scene or a module has errors: see [`Rebuild::built`] for the diagnostics.
    Compose,
    /// The composition is fine, but the runtime could not use it (a volume that does not load,
    /// an unreadable scene file).
    Runtime(RuntimeError),
}

/// One attempt to follow the files.
pub struct Rebuild {
    /// Composing (or finding in the composition cache) every view.
    pub compose: Duration,
    /// Loading changed volumes, making pipelines, setting uniforms.
    pub apply: Duration,
    /// The composition with its diagnostics (warnings too); `None` when the scene file could
    /// not be read at all.
    pub built: Option<Arc<BuiltScene>>,
    /// What the runtime took on (volumes loaded, pipelines remade), or why nothing changed.
    pub outcome: Result<Applied, Failure>,
}

impl Rebuild {
    /// Whether the new state is in use.
    pub fn succeeded(&self) -> bool {
        self.outcome.is_ok()
    }

    /// The errors as `vrsc` prints them without colour (file:line, source excerpts), or the
    /// runtime's message; `None` after a success.
    pub fn error_text(&self) -> Option<String> {
        match &self.outcome {
            Ok(_) => None,
            Err(Failure::Runtime(e)) => Some(format!("error: {e}")),
            Err(Failure::Compose) => {
                let built = self.built.as_ref()?;
                Some(vrsc::diag::render_plain(&built.diags.sorted(), &built.sources))
            }
        }
    }
}

/// What the user changed by hand, which a reload keeps wherever it still applies.
#[derive(Clone, Debug, Default)]
pub struct UserState {
    /// Uniform values, with the scene's own value of that uniform in each view when the user
    /// set it: once the scene file's value for a view changes (its `[uniforms]`, or its render
    /// settings: the view's own `render` table over `[render]`), the file is the newer intent
    /// and wins in that view.
    uniforms: BTreeMap<String, (Value, SceneValuesThen)>,
    /// Cameras by view, with the scene's camera then (the same rule).
    cameras: BTreeMap<String, (OrbitCamera, OrbitCamera)>,
    slices: BTreeMap<String, (SlicePlane, SlicePlane)>,
    sizes: BTreeMap<String, [u32; 2]>,
    /// Transfer functions by volume, with the curve the scene gave it then.
    curves: BTreeMap<String, (TfCurve, Option<TfCurve>)>,
    /// Views' own transfer functions (a slice view's window/level), by view and volume; they
    /// last until reset or until the view or volume is gone.
    view_curves: BTreeMap<(String, String), TfCurve>,
    /// Mesh colours, opacities and placements by mesh, with the scene's style of it then.
    meshes: BTreeMap<String, (MeshStyle, Option<MeshStyle>)>,
    /// Occlusion groups' opacities of what they hide, with the scene's opacity then.
    groups: BTreeMap<String, (f32, Option<f32>)>,
}

/// A mesh's look and placement as the panel sets them (what `[[mesh]]` gives as `color`,
/// `opacity` and `transform`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshStyle {
    /// sRGB display colour, 0 to 1.
    pub color: [f32; 3],
    /// 1 is opaque.
    pub opacity: f32,
    /// The mesh's vertices to patient space (RAS mm): four columns of a 4x4 matrix, as a
    /// scene's `transform`.
    pub model: [[f32; 4]; 4],
}

impl MeshStyle {
    /// No placement: the mesh where its file or shape puts it.
    pub const IDENTITY: [[f32; 4]; 4] =
        [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]];

    /// The style a `[[mesh]]` table gives.
    fn of_table(table: &vrsc::scene::Mesh) -> MeshStyle {
        let model = table.transform.as_ref().map_or(MeshStyle::IDENTITY, |t| t.value);
        MeshStyle { color: table.color, opacity: table.opacity, model }
    }

    /// The style a mesh is drawn with now.
    fn of_instance(mesh: &vrs_runtime::mesh_layer::MeshInstance) -> MeshStyle {
        MeshStyle { color: mesh.color, opacity: mesh.opacity, model: mesh.model.to_cols_array_2d() }
    }

    /// Whether every number is finite (a NaN would never compare equal to itself).
    fn is_finite(&self) -> bool {
        self.color.iter().chain([&self.opacity]).chain(self.model.as_flattened()).all(|x| x.is_finite())
    }
}

/// Per view name, the scene file's values of its uniforms ([`vrsc::scene::Scene::view_uniform_values`]).
type SceneValues = BTreeMap<String, BTreeMap<String, UniformValue>>;

/// Per view name, the scene file's value of one uniform (`None` where it leaves it open).
type SceneValuesThen = BTreeMap<String, Option<UniformValue>>;

/// Each view's uniform values as `scene` gives them.
fn scene_values_of(scene: &vrsc::scene::Scene) -> SceneValues {
    scene.views.iter().map(|v| (v.name.name.clone(), scene.view_uniform_values(v))).collect()
}

/// A scene renderer that follows its files. See the crate documentation.
pub struct LiveScene {
    renderer: SceneRenderer,
    user: UserState,
    /// Each view's uniform values in the scene file (`[uniforms]`, and the view's render
    /// settings) as of the last good rebuild.
    scene_values: SceneValues,
    /// Each view's camera and slice plane as the scene file sets them.
    scene_cameras: BTreeMap<String, OrbitCamera>,
    scene_slices: BTreeMap<String, SlicePlane>,
    /// Each view's size as the scene gives it (what `vrsc render` renders at).
    scene_sizes: BTreeMap<String, [u32; 2]>,
    /// Bumped whenever something that shapes a view's image changes, per view.
    generations: BTreeMap<String, u64>,
    /// Every file the last two compositions read (the last good one and the last attempt), so
    /// fixing a file that broke the import graph is seen too.
    files: Vec<PathBuf>,
    last_error: Option<String>,
    /// The composition in use (the last good one), for the inspector.
    built: Option<Arc<BuiltScene>>,
    /// Each volume's transfer function as the scene file gives it (the last good load).
    scene_curves: BTreeMap<String, TfCurve>,
    /// Each mesh's style as the scene file gives it (the last good load).
    scene_meshes: BTreeMap<String, MeshStyle>,
    /// Each occlusion group's opacity of what it hides, as the scene file gives it.
    scene_groups: BTreeMap<String, f32>,
    /// The (mesh, uniform) pairs of the points meshes follow that are positions (a needle's
    /// tip, a cylinder's ends, a sphere's centre, a box's corners; not a needle's direction).
    mesh_points: Vec<(String, String)>,
    /// The streaming of bricked volumes between frames ([`LiveScene::stream_bricks`]).
    bricks: Streaming,
}

impl LiveScene {
    /// Takes over a renderer that opened its scene.
    pub fn new(renderer: SceneRenderer) -> LiveScene {
        let mut live = LiveScene {
            renderer,
            user: UserState::default(),
            scene_values: BTreeMap::new(),
            scene_cameras: BTreeMap::new(),
            scene_slices: BTreeMap::new(),
            scene_sizes: BTreeMap::new(),
            generations: BTreeMap::new(),
            files: Vec::new(),
            last_error: None,
            built: None,
            scene_curves: BTreeMap::new(),
            scene_meshes: BTreeMap::new(),
            scene_groups: BTreeMap::new(),
            mesh_points: Vec::new(),
            bricks: Streaming::default(),
        };
        live.note_scene_state();
        live.note_scene_curves();
        live.files = vec![live.renderer.path().to_path_buf()];
        if let Ok(cached) = live.renderer.compose() {
            live.files = files_of(&cached.built, live.renderer.path());
            live.scene_values = cached.scene.as_ref().map(scene_values_of).unwrap_or_default();
            if let Some(scene) = &cached.scene {
                live.note_scene_meshes(scene);
            }
            live.built = Some(cached.built);
        }
        live
    }

    /// The renderer of the last good state: its views, volumes and meshes.
    pub fn renderer(&self) -> &SceneRenderer {
        &self.renderer
    }

    /// The scene file and every module file the compositions read (imports included).
    pub fn files(&self) -> &[PathBuf] {
        &self.files
    }

    /// The errors of the last rebuild, while they stand (cleared by a good one).
    pub fn last_error(&self) -> Option<&str> {
        self.last_error.as_deref()
    }

    /// The names of the views, in scene order.
    pub fn view_names(&self) -> Vec<String> {
        self.renderer.views().iter().map(|v| v.name.clone()).collect()
    }

    /// A counter that changes whenever view `index`'s image would change.
    pub fn generation(&self, index: usize) -> u64 {
        self.renderer.views().get(index).and_then(|v| self.generations.get(&v.name)).copied().unwrap_or(0)
    }

    /// Recomposes from the files as they are now. On success the new pipelines, volumes and
    /// uniforms are in use with the user's settings applied again; on failure nothing changes.
    pub fn rebuild(&mut self) -> Rebuild {
        let started = Instant::now();
        let cached = self.renderer.compose();
        let compose = started.elapsed();
        let cached = match cached {
            Ok(cached) => cached,
            Err(e) => return self.failed(compose, Duration::ZERO, None, Failure::Runtime(e)),
        };
        let built = cached.built.clone();
        let mut files = files_of(&built, self.renderer.path());
        if cached.scene.is_none() || built.diags.has_errors() {
            merge(&mut files, &self.files);
            self.files = files;
            return self.failed(compose, Duration::ZERO, Some(built), Failure::Compose);
        }
        let scene_values = cached.scene.as_ref().map(scene_values_of).unwrap_or_default();
        let applying = Instant::now();
        let applied = self.renderer.apply(&cached);
        let apply = applying.elapsed();
        match applied {
            Ok(applied) => {
                self.files = files;
                self.scene_values = scene_values;
                self.built = Some(built.clone());
                self.note_scene_state();
                if let Some(scene) = &cached.scene {
                    self.note_scene_meshes(scene);
                }
                if applied.volumes_reloaded {
                    self.note_scene_curves();
                }
                self.restore_user_state();
                self.bump_all();
                self.last_error = None;
                Rebuild { compose, apply, built: Some(built), outcome: Ok(applied) }
            }
            Err(e) => {
                merge(&mut files, &self.files);
                self.files = files;
                self.failed(compose, apply, Some(built), Failure::Runtime(e))
            }
        }
    }

    fn failed(&mut self, compose: Duration, apply: Duration, built: Option<Arc<BuiltScene>>, f: Failure) -> Rebuild {
        let rebuild = Rebuild { compose, apply, built, outcome: Err(f) };
        self.last_error = rebuild.error_text();
        rebuild
    }

    /// Sets a uniform in every view that reads it; it survives reloads (see [`UserState`]).
    pub fn set_uniform(&mut self, name: &str, value: Value) -> Result<(), RuntimeError> {
        self.renderer.set_uniform(name, value.clone())?;
        let then = self.view_names().into_iter().map(|view| (view.clone(), self.scene_uniform(&view, name))).collect();
        self.user.uniforms.insert(name.to_string(), (value, then));
        self.bump_all();
        Ok(())
    }

    /// Forgets the user's value of uniform `name`: the scene's value (or the default) is used.
    pub fn reset_uniform(&mut self, name: &str) -> Result<(), RuntimeError> {
        self.user.uniforms.remove(name);
        // In each view, the scene file's value as of the last good rebuild (a reflection from
        // the composition cache may carry an older value), else the declaration's default.
        for view in self.renderer.views_mut() {
            let Some(info) = view.renderer.uniform_info(name) else { continue };
            let scene_value = self.scene_values.get(&view.name).and_then(|values| values.get(name));
            let json = scene_value.map(UniformValue::to_json).or_else(|| info.default.clone());
            if let Some(value) = json.and_then(|json| view.renderer.uniform_value_from_json(name, &json)) {
                view.renderer.set_uniform(name, value)?;
            }
        }
        self.bump_all();
        Ok(())
    }

    /// The current value of uniform `name` (in the first view that reads it).
    pub fn uniform(&self, name: &str) -> Option<Value> {
        self.renderer.views().iter().find_map(|v| v.renderer.uniform(name))
    }

    /// The scene file's value of uniform `name` (in the first view whose scene sets it), as the
    /// renderer holds values; `None` where the scene leaves it open.
    pub fn scene_uniform_value(&self, name: &str) -> Option<Value> {
        self.renderer.views().iter().find_map(|view| {
            let json = self.scene_uniform(&view.name, name)?.to_json();
            view.renderer.uniform_value_from_json(name, &json)
        })
    }

    /// Whether the user changed uniform `name` (a reset or a save that the file then carries
    /// makes it the scene's again).
    pub fn is_user_uniform(&self, name: &str) -> bool {
        self.user.uniforms.contains_key(name)
    }

    /// Writes the user's uniform values into the scene file's `[uniforms]` (and `[render]`),
    /// keeping its comments and layout. Returns how many were saved. The file watcher then
    /// sees the file change; the reload finds the same values.
    pub fn save_uniforms(&mut self) -> Result<usize, SaveError> {
        let uniforms: Vec<SavedUniform> = self
            .user
            .uniforms
            .iter()
            .filter_map(|(name, (value, _))| {
                let ty =
                    self.renderer.views().iter().find_map(|v| v.renderer.shader().reflection.uniform(name))?.ty.clone();
                Some(SavedUniform { name: name.clone(), ty, value: value.clone() })
            })
            .collect();
        save::save_uniforms(self.renderer.path(), &uniforms)?;
        Ok(uniforms.len())
    }

    /// Gives volume `volume` the transfer function `curve` (one table rewritten, no pipeline);
    /// it survives reloads until the scene file changes that volume's `tf`.
    pub fn set_tf_curve(&mut self, volume: &str, curve: TfCurve) -> Result<(), RuntimeError> {
        self.renderer.set_tf_curve(volume, curve.clone())?;
        let then = self.scene_curves.get(volume).cloned();
        self.user.curves.insert(volume.to_string(), (curve, then));
        self.bump_all();
        Ok(())
    }

    /// Saves volume `volume`'s transfer function as a ParaView colormap at `path` (in data
    /// units, loading back to the same table) and points the scene's `tf` of the volume at it
    /// (relative to the scene's folder when it is inside it).
    pub fn save_tf_curve(&mut self, volume: &str, path: &Path) -> Result<(), SaveError> {
        let io = |error| SaveError::Io { path: path.to_path_buf(), error };
        let status = self.renderer.volumes().into_iter().find(|v| v.name == volume);
        let (curve, window) = match status.and_then(|v| Some((v.curve?.clone(), v.window))) {
            Some(found) => found,
            None => return Err(io(std::io::Error::other(format!("volume `{volume}` has no transfer function")))),
        };
        std::fs::write(path, curve.to_paraview_json(window)).map_err(io)?;
        let scene = self.renderer.path();
        let folder = scene.parent().unwrap_or(Path::new("."));
        let shown = path.strip_prefix(folder).unwrap_or(path).to_string_lossy().into_owned();
        save::set_volume_tf(scene, volume, &shown)
    }

    /// Gives view `index` a transfer function of its own for volume `volume` (a slice view's
    /// window/level or window preset); the volume's, which the other views keep, is unchanged.
    /// It survives reloads.
    pub fn set_view_tf_curve(&mut self, index: usize, volume: &str, curve: TfCurve) -> Result<(), RuntimeError> {
        self.renderer.set_view_tf_curve(index, volume, Some(&curve))?;
        let name = self.view_names().get(index).cloned().unwrap_or_default();
        self.user.view_curves.insert((name.clone(), volume.to_string()), curve);
        self.bump(&name);
        Ok(())
    }

    /// View `index`'s own transfer function for volume `volume`, if it has one.
    pub fn view_tf_curve(&self, index: usize, volume: &str) -> Option<&TfCurve> {
        let name = self.view_names().get(index).cloned()?;
        self.user.view_curves.get(&(name, volume.to_string()))
    }

    /// View `index` shows volume `volume` with the volume's transfer function again.
    pub fn reset_view_tf_curve(&mut self, index: usize, volume: &str) -> Result<(), RuntimeError> {
        self.renderer.set_view_tf_curve(index, volume, None)?;
        let name = self.view_names().get(index).cloned().unwrap_or_default();
        self.user.view_curves.remove(&(name.clone(), volume.to_string()));
        self.bump(&name);
        Ok(())
    }

    /// Puts volume `volume`'s transfer function back to the scene file's.
    pub fn reset_tf_curve(&mut self, volume: &str) -> Result<(), RuntimeError> {
        self.user.curves.remove(volume);
        if let Some(curve) = self.scene_curves.get(volume).cloned() {
            self.renderer.set_tf_curve(volume, curve)?;
        }
        self.bump_all();
        Ok(())
    }

    /// Every mesh of the scene with the style it is drawn with now, in scene order.
    pub fn meshes(&self) -> Vec<(String, MeshStyle)> {
        self.renderer.meshes().iter().map(|m| (m.name.clone(), MeshStyle::of_instance(m))).collect()
    }

    /// Gives mesh `name` a colour, opacity (clamped to [0, 1]) and placement; it survives
    /// reloads until the scene file changes that mesh's `color`, `opacity` or `transform`.
    /// Every view's picture is out of date (each draws the scene's meshes).
    pub fn set_mesh_style(&mut self, name: &str, style: MeshStyle) -> Result<(), RuntimeError> {
        if !style.is_finite() {
            return Err(RuntimeError::Invalid(format!("mesh `{name}`: a style with a non-finite number")));
        }
        let style = MeshStyle { opacity: style.opacity.clamp(0.0, 1.0), ..style };
        self.apply_mesh_style(name, &style)?;
        let then = self.scene_meshes.get(name).copied();
        self.user.meshes.insert(name.to_string(), (style, then));
        self.bump_all();
        Ok(())
    }

    /// Puts mesh `name` back to the scene file's colour, opacity and placement.
    pub fn reset_mesh_style(&mut self, name: &str) -> Result<(), RuntimeError> {
        self.user.meshes.remove(name);
        if let Some(style) = self.scene_meshes.get(name).copied() {
            self.apply_mesh_style(name, &style)?;
        }
        self.bump_all();
        Ok(())
    }

    /// The occlusion groups the views draw, each once in scene order, with the opacity their
    /// hidden children show with now.
    pub fn occlusion_groups(&self) -> Vec<(String, f32)> {
        self.renderer.occlusion_groups()
    }

    /// Shows what occlusion group `name` hides with `opacity` (clamped to [0, 1]); it survives
    /// reloads until the scene file changes that group's opacity.
    pub fn set_group_opacity(&mut self, name: &str, opacity: f32) -> Result<(), RuntimeError> {
        self.renderer.set_group_opacity(name, opacity)?;
        let then = self.scene_groups.get(name).copied();
        self.user.groups.insert(name.to_string(), (opacity.clamp(0.0, 1.0), then));
        self.bump_all();
        Ok(())
    }

    /// Puts occlusion group `name` back to the scene file's opacity.
    pub fn reset_group_opacity(&mut self, name: &str) -> Result<(), RuntimeError> {
        self.user.groups.remove(name);
        if let Some(&opacity) = self.scene_groups.get(name) {
            self.renderer.set_group_opacity(name, opacity)?;
        }
        self.bump_all();
        Ok(())
    }

    /// Whether the user changed occlusion group `name`'s opacity.
    pub fn is_user_group(&self, name: &str) -> bool {
        self.user.groups.contains_key(name)
    }

    /// Whether the user changed mesh `name`'s style.
    pub fn is_user_mesh(&self, name: &str) -> bool {
        self.user.meshes.contains_key(name)
    }

    /// The points of meshes that follow uniforms and are positions (what a viewer lets the user
    /// drag: a needle's tip, not its direction), with their uniforms' values now.
    pub fn mesh_handles(&self) -> Vec<MeshHandle> {
        let is_point = |h: &MeshHandle| self.mesh_points.iter().any(|(m, u)| *m == h.mesh && *u == h.uniform);
        self.renderer.mesh_handles().into_iter().filter(is_point).collect()
    }

    fn apply_mesh_style(&mut self, name: &str, style: &MeshStyle) -> Result<(), RuntimeError> {
        // The renderer's placement type is built on the one it has (this crate names no
        // matrix type of its own).
        let mut model = self
            .renderer
            .meshes()
            .iter()
            .find(|m| m.name == name)
            .ok_or_else(|| RuntimeError::Invalid(format!("the scene has no mesh `{name}`")))?
            .model;
        model.x_axis = style.model[0].into();
        model.y_axis = style.model[1].into();
        model.z_axis = style.model[2].into();
        model.w_axis = style.model[3].into();
        self.renderer.set_mesh_style(name, style.color, style.opacity, model)
    }

    /// The composition in use (the last good one).
    pub fn built(&self) -> Option<&BuiltScene> {
        self.built.as_deref()
    }

    /// View `index`'s composed WGSL with each function annotated by its origin, as
    /// `vrsc explain` prints it (composes the view again, keeping its IR: a few milliseconds).
    pub fn explain(&self, index: usize) -> Result<String, String> {
        let name = self.renderer.views().get(index).map(|v| v.name.clone()).ok_or("no such view")?;
        let built = build::build_scene_keeping(self.renderer.path(), Some(&name), Keep::Ir)
            .map_err(|e| format!("`{}`: {e}", self.renderer.path().display()))?;
        if built.diags.has_errors() {
            return Err(vrsc::diag::render_plain(&built.diags.sorted(), &built.sources));
        }
        let view = built.views.first().ok_or("the view did not compose")?;
        vrsc::compose::explain::explain_with_filters(view, &built.sources)
            .ok_or_else(|| "the view did not compose".to_string())
    }

    /// The VRS source text of a pipeline function of the composition in use.
    pub fn function_source(&self, function: &FunctionInfo) -> Option<String> {
        let sources = &self.built.as_ref()?.sources;
        let (_, file) = sources.files().find(|(_, f)| f.name == function.file)?;
        let [start, end] = function.span.map(|x| x as usize);
        file.text.get(start..end).map(str::to_string)
    }

    /// Renders a probe of view `index` as it shows now (see [`SceneRenderer::render_probe`]).
    pub fn render_probe(&mut self, index: usize, spec: &ProbeSpec) -> Result<ProbeImage, RuntimeError> {
        self.renderer.render_probe(index, spec)
    }

    /// The camera of raycast view `index`.
    pub fn camera(&self, index: usize) -> Option<OrbitCamera> {
        self.renderer.views().get(index)?.camera
    }

    /// Moves the camera of raycast view `index` (kept across reloads).
    pub fn set_camera(&mut self, index: usize, camera: OrbitCamera) {
        let Some(view) = self.renderer.views_mut().get_mut(index) else { return };
        if view.camera.is_none() {
            return;
        }
        view.camera = Some(camera);
        let name = view.name.clone();
        let scene = self.scene_cameras.get(&name).copied().unwrap_or_default();
        self.user.cameras.insert(name.clone(), (camera, scene));
        self.bump(&name);
    }

    /// The slice plane of slice view `index`.
    pub fn slice(&self, index: usize) -> Option<SlicePlane> {
        self.renderer.views().get(index)?.slice.map(|(plane, _)| plane)
    }

    /// Moves the plane of slice view `index` (kept across reloads).
    pub fn set_slice(&mut self, index: usize, plane: SlicePlane) {
        let Some(view) = self.renderer.views_mut().get_mut(index) else { return };
        let Some((_, slab)) = view.slice else { return };
        view.slice = Some((plane, slab));
        let name = view.name.clone();
        let scene = self.scene_slices.get(&name).copied().unwrap_or(plane);
        self.user.slices.insert(name.clone(), (plane, scene));
        self.bump(&name);
    }

    /// Puts view `index`'s camera or plane back where the scene file has it.
    pub fn reset_view(&mut self, index: usize) {
        let Some(view) = self.renderer.views_mut().get_mut(index) else { return };
        let name = view.name.clone();
        if view.camera.is_some() {
            view.camera = self.scene_cameras.get(&name).copied();
        }
        if let (Some((_, slab)), Some(plane)) = (view.slice, self.scene_slices.get(&name)) {
            view.slice = Some((*plane, slab));
        }
        self.user.cameras.remove(&name);
        self.user.slices.remove(&name);
        self.bump(&name);
    }

    /// The image size of view `index`.
    pub fn size(&self, index: usize) -> Option<[u32; 2]> {
        Some(self.renderer.views().get(index)?.renderer.size())
    }

    /// Renders view `index` at `size` from now on (kept across reloads). A size the device
    /// cannot hold is an error, and the view keeps its size and picture.
    pub fn set_size(&mut self, index: usize, size: [u32; 2]) -> Result<(), RuntimeError> {
        let size = [size[0].max(1), size[1].max(1)];
        if self.size(index) == Some(size) {
            return Ok(());
        }
        let gpu = self.renderer.gpu().clone();
        let Some(view) = self.renderer.views_mut().get_mut(index) else { return Ok(()) };
        view.renderer.resize(&gpu, size)?;
        let name = view.name.clone();
        self.user.sizes.insert(name.clone(), size);
        self.bump(&name);
        Ok(())
    }

    /// Renders view `index` as `vrsc render` does, at the size the scene gives it, with what the
    /// user changed here (camera, plane, uniforms, meshes), and writes it to `path` as a PNG:
    /// the same pixels `vrsc render` writes for the same state. Blocks until the GPU is done.
    /// Returns the size written.
    pub fn export_view(&mut self, index: usize, path: &Path) -> Result<[u32; 2], RuntimeError> {
        let gpu = self.renderer.gpu().clone();
        let view = self
            .renderer
            .views_mut()
            .get_mut(index)
            .ok_or_else(|| RuntimeError::Invalid(format!("the scene has no view {index}")))?;
        let (name, shown) = (view.name.clone(), view.renderer.size());
        let size = self.scene_sizes.get(&name).copied().unwrap_or(shown);
        view.renderer.resize(&gpu, size)?;
        let image = self.renderer.render_view(index);
        if let Some(view) = self.renderer.views_mut().get_mut(index) {
            view.renderer.resize(&gpu, shown)?;
        }
        self.bump(&name);
        let image = image?;
        image
            .save(path)
            .map_err(|e| RuntimeError::Invalid(format!("cannot write view `{name}` to {}: {e}", path.display())))?;
        Ok(size)
    }

    /// Records `region` of view `index` into `target` (a texture of
    /// [`vrs_runtime::view::create_output`], of any size).
    pub fn encode(
        &mut self,
        index: usize,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        region: Region,
    ) -> Result<(), RuntimeError> {
        self.bricks.drawn();
        self.renderer.encode_view_into(index, encoder, target, region)
    }

    /// After the frames of a redraw were submitted: reads back (without waiting) what their
    /// rays asked of the bricked volumes, asks the loaders and places the bricks that arrived;
    /// every view renders again when any was placed. Does nothing, and returns `None`, for a
    /// scene without bricked volumes; skips the GPU when nothing was drawn or is on its way
    /// since streaming settled ([`Self::bricks_busy`]).
    pub fn stream_bricks(&mut self) -> Result<Option<BrickProgress>, RuntimeError> {
        let Some(before) = self.renderer.brick_residency() else {
            self.bricks.clear();
            return Ok(None);
        };
        if !self.bricks.busy() && self.bricks.last().is_some() {
            return Ok(self.bricks.last());
        }
        let progress = self.renderer.stream_bricks(false)?;
        if self.bricks.note(before, progress) {
            for name in self.view_names() {
                self.advance(&name);
            }
        }
        Ok(Some(progress))
    }

    /// What the last [`Self::stream_bricks`] found (`None` without bricked volumes).
    pub fn brick_progress(&self) -> Option<BrickProgress> {
        self.bricks.last()
    }

    /// Whether [`Self::stream_bricks`] has more to do: frames whose requests were not read
    /// back yet, a read-back under way, bricks loading or just placed. A viewer keeps drawing
    /// (after a short pause: the loaders do not wake it) while this holds.
    pub fn bricks_busy(&self) -> bool {
        self.renderer.brick_residency().is_some() && self.bricks.busy()
    }

    /// Renders every view at full quality and reads the images back (for `vrsc watch`).
    pub fn render_all(&mut self) -> Result<Vec<(String, image::RgbaImage)>, RuntimeError> {
        self.renderer.render_all()
    }

    /// The output texture of view `index`: where its full-resolution image is rendered.
    pub fn output(&self, index: usize) -> Option<&wgpu::Texture> {
        Some(self.renderer.views().get(index)?.renderer.output())
    }

    /// The scene file's value of uniform `name` in view `view` (`None` when it leaves it to
    /// the default).
    fn scene_uniform(&self, view: &str, name: &str) -> Option<UniformValue> {
        self.scene_values.get(view)?.get(name).cloned()
    }

    /// Remembers the scene file's cameras and planes (right after a load, before the user's).
    fn note_scene_state(&mut self) {
        self.scene_cameras.clear();
        self.scene_slices.clear();
        self.scene_sizes.clear();
        for view in self.renderer.views() {
            self.scene_sizes.insert(view.name.clone(), view.renderer.size());
            if let Some(camera) = view.camera {
                self.scene_cameras.insert(view.name.clone(), camera);
            }
            if let Some((plane, _)) = view.slice {
                self.scene_slices.insert(view.name.clone(), plane);
            }
        }
    }

    /// Remembers each mesh's style as the scene file gives it and which of the points meshes
    /// follow are positions.
    fn note_scene_meshes(&mut self, scene: &vrsc::scene::Scene) {
        self.scene_meshes = scene.meshes.iter().map(|m| (m.name.name.clone(), MeshStyle::of_table(m))).collect();
        self.scene_groups = scene
            .groups
            .iter()
            .filter_map(|g| match &g.kind {
                vrsc::scene::GroupKind::Occlusion { hidden_opacity } => Some((g.name.name.clone(), *hidden_opacity)),
                _ => None,
            })
            .collect();
        self.mesh_points = scene
            .meshes
            .iter()
            .flat_map(|m| {
                let direction = match &m.source {
                    MeshSource::Needle { direction, .. } => direction.uniform().map(|u| u.value.as_str()),
                    _ => None,
                };
                let points = m.followed_uniforms().into_iter().filter(move |u| Some(u.value.as_str()) != direction);
                points.map(|u| (m.name.name.clone(), u.value.clone()))
            })
            .collect();
    }

    /// Remembers the transfer functions as the scene file gives them (right after the volumes
    /// were loaded, before the user's are applied again).
    fn note_scene_curves(&mut self) {
        self.scene_curves =
            self.renderer.volumes().iter().filter_map(|v| Some((v.name.to_string(), v.curve?.clone()))).collect();
    }

    /// Applies the user's settings again after a reload, wherever they still apply: a uniform
    /// that still exists with the same type, a view of the same name and kind; a setting whose
    /// scene value changed in the meantime gives way to the file (per view for uniforms: a
    /// view's own `render` table can change its value alone). A view added since the user set
    /// a uniform gets the user's value.
    fn restore_user_state(&mut self) {
        let uniforms = std::mem::take(&mut self.user.uniforms);
        for (name, (value, then)) in uniforms {
            let mut applies = false;
            for view in self.renderer.views_mut() {
                let now = self.scene_values.get(&view.name).and_then(|values| values.get(&name)).cloned();
                let unchanged = then.get(&view.name).is_none_or(|then| *then == now);
                if unchanged
                    && view.renderer.has_uniform(&name)
                    && view.renderer.set_uniform(&name, value.clone()).is_ok()
                {
                    applies = true;
                }
            }
            if applies {
                self.user.uniforms.insert(name, (value, then));
            }
        }
        let gpu = self.renderer.gpu().clone();
        for view in self.renderer.views_mut() {
            if let (Some(_), Some((camera, then))) = (view.camera, self.user.cameras.get(&view.name))
                && self.scene_cameras.get(&view.name) == Some(then)
            {
                view.camera = Some(*camera);
            }
            if let (Some((_, slab)), Some((plane, then))) = (view.slice, self.user.slices.get(&view.name))
                && self.scene_slices.get(&view.name) == Some(then)
            {
                view.slice = Some((*plane, slab));
            }
            if let Some(&size) = self.user.sizes.get(&view.name)
                && view.renderer.resize(&gpu, size).is_err()
            {
                // It fitted the old pipeline's device; if it no longer does, the scene's wins.
                self.user.sizes.remove(&view.name);
            }
        }
        let curves = std::mem::take(&mut self.user.curves);
        for (volume, (curve, then)) in curves {
            if self.scene_curves.get(&volume) == then.as_ref()
                && self.renderer.set_tf_curve(&volume, curve.clone()).is_ok()
            {
                self.user.curves.insert(volume, (curve, then));
            }
        }
        let view_curves = std::mem::take(&mut self.user.view_curves);
        let names = self.view_names();
        for ((view, volume), curve) in view_curves {
            let applied = names
                .iter()
                .position(|n| *n == view)
                .map(|index| self.renderer.set_view_tf_curve(index, &volume, Some(&curve)).is_ok());
            if applied == Some(true) {
                self.user.view_curves.insert((view, volume), curve);
            }
        }
        let meshes = std::mem::take(&mut self.user.meshes);
        for (mesh, (style, then)) in meshes {
            if self.scene_meshes.get(&mesh) == then.as_ref() && self.apply_mesh_style(&mesh, &style).is_ok() {
                self.user.meshes.insert(mesh, (style, then));
            }
        }
        self.restore_user_groups();
        let names = self.view_names();
        self.user.cameras.retain(|n, (_, then)| names.contains(n) && self.scene_cameras.get(n) == Some(then));
        self.user.slices.retain(|n, (_, then)| names.contains(n) && self.scene_slices.get(n) == Some(then));
    }

    /// The user's occlusion-group opacities again, where the group is still there and the scene
    /// file's opacity for it has not changed.
    fn restore_user_groups(&mut self) {
        let groups = std::mem::take(&mut self.user.groups);
        for (group, (opacity, then)) in groups {
            if self.scene_groups.get(&group) == then.as_ref()
                && self.renderer.set_group_opacity(&group, opacity).is_ok()
            {
                self.user.groups.insert(group, (opacity, then));
            }
        }
    }

    /// A change of the user's or the files' to `view`: it renders again, and may ask for bricks
    /// anew.
    fn bump(&mut self, view: &str) {
        self.bricks.restart();
        self.advance(view);
    }

    /// `view` renders again.
    fn advance(&mut self, view: &str) {
        *self.generations.entry(view.to_string()).or_default() += 1;
    }

    fn bump_all(&mut self) {
        for name in self.view_names() {
            self.bump(&name);
        }
    }
}

/// The scene file and every module file a composition read.
fn files_of(built: &BuiltScene, scene: &Path) -> Vec<PathBuf> {
    let mut files = vec![scene.to_path_buf()];
    let read = built.sources.files().filter_map(|(_, f)| f.path.clone());
    merge(&mut files, &read.collect::<Vec<_>>());
    files
}

fn merge(into: &mut Vec<PathBuf>, more: &[PathBuf]) {
    for path in more {
        if !into.contains(path) {
            into.push(path.clone());
        }
    }
}
