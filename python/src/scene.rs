//! `vrsc._vrsc.SceneHandle`: a composed scene with its volumes on the GPU, rendering views into
//! numpy arrays. The Python `vrsc.Scene` owns one and describes what it renders (a scene file
//! the user wrote, or one written from Python calls).
//!
//! Locking: the state sits behind a mutex that is only ever taken with the GIL released (in
//! `Python::detach`), so a thread waiting for the scene never holds the GIL that the thread
//! rendering it needs to read a numpy volume.

use crate::check::on_big_stack;
use crate::diagnostics::{PyDiagnostic, collect, warnings_or_error};
use crate::errors::{raise, runtime_error, scene_error};
use crate::feed::ArrayFeed;
use crate::gpu;
use crate::values;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};
use vrs_runtime::scene::is_set_by_renderer;
use vrs_runtime::{ProbeAt, ProbeSpec, RenderOptions, RuntimeError, SceneRenderer, Value};
use vrsc::compose::cache::CompositionCache;

/// A scene ready to render.
#[pyclass(module = "vrsc._vrsc", frozen)]
pub struct SceneHandle {
    state: Mutex<State>,
}

struct State {
    renderer: SceneRenderer,
    /// The arrays its volumes are read from, by volume name.
    feeds: BTreeMap<String, Arc<ArrayFeed>>,
    /// Uniform values set from Python, set again after every recomposition.
    set: BTreeMap<String, Value>,
    /// Occlusion groups' opacities set from Python, likewise.
    group_opacities: BTreeMap<String, f32>,
    /// The size each view has in the scene (a render of another size resizes it for that
    /// render only).
    sizes: BTreeMap<String, [u32; 2]>,
    /// The warnings of the last composition.
    warnings: Vec<PyDiagnostic>,
}

/// What went wrong in work done without the GIL, made into a Python exception after it.
enum Failure {
    Runtime(RuntimeError),
    Compile(Vec<PyDiagnostic>),
    Io(PathBuf, std::io::Error),
    /// Unknown view or field: a `KeyError` (and `vrsc.SceneError`).
    Unknown(String),
    Scene(String),
}

impl From<RuntimeError> for Failure {
    fn from(e: RuntimeError) -> Failure {
        Failure::Runtime(e)
    }
}

impl Failure {
    fn into_py(self, py: Python<'_>) -> PyErr {
        match self {
            Failure::Runtime(e) => runtime_error(py, e),
            Failure::Compile(list) => match warnings_or_error(py, list) {
                Err(e) => e,
                Ok(_) => scene_error(py, "the scene did not compose"),
            },
            Failure::Io(path, e) => crate::check::io_error(&path, &e),
            Failure::Unknown(message) => raise(py, "UnknownNameError", (message,)),
            Failure::Scene(message) => scene_error(py, message),
        }
    }
}

type Outcome<T> = Result<T, Failure>;

impl SceneHandle {
    /// Runs `work` on the state with the GIL released.
    fn with_state<T: Send>(&self, py: Python<'_>, work: impl FnOnce(&mut State) -> Outcome<T> + Send) -> PyResult<T> {
        py.detach(|| {
            let mut guard: MutexGuard<State> = match self.state.lock() {
                Ok(guard) => guard,
                // A panic while rendering left the state as it was mid-way; the renderer keeps
                // its own consistency (errors are values), so carry on with it.
                Err(poisoned) => poisoned.into_inner(),
            };
            work(&mut guard)
        })
        .map_err(|f| f.into_py(py))
    }
}

#[pymethods]
impl SceneHandle {
    /// Composes the scene file `path` and loads its volumes; `arrays` maps volume names to
    /// `(array, affine)` pairs read instead of the volumes' files.
    #[staticmethod]
    #[pyo3(signature = (path, arrays))]
    fn open(
        py: Python<'_>,
        path: PathBuf,
        arrays: Vec<(String, Bound<'_, PyAny>, [[f64; 4]; 4])>,
    ) -> PyResult<SceneHandle> {
        let mut feeds = BTreeMap::new();
        for (name, array, affine) in arrays {
            feeds.insert(name, Arc::new(ArrayFeed::new(&array, affine)?));
        }
        let composed = on_big_stack(py, "composing the scene", || {
            CompositionCache::new()
                .build(&path)
                .map(|cached| (collect(&cached.built.diags, &cached.built.sources), cached))
        })?;
        let (diagnostics, cached) = composed.map_err(|e| crate::check::io_error(&path, &e))?;
        let warnings = warnings_or_error(py, diagnostics)?;
        let scene = cached.scene.clone().ok_or_else(|| scene_error(py, "the scene did not compose"))?;
        let mut options = RenderOptions::default();
        for (name, feed) in &feeds {
            options.feeds.insert(name.clone(), feed.clone() as Arc<dyn vrs_runtime::volume::VolumeFeed>);
        }
        let opened = py.detach(|| -> Outcome<SceneRenderer> {
            let gpu = gpu::shared().map_err(Failure::Scene)?;
            Ok(SceneRenderer::from_built(gpu, &path, &scene, &cached.built, options, &mut |_, _, _| {})?)
        });
        let renderer = opened.map_err(|f| f.into_py(py))?;
        let sizes = renderer.views().iter().map(|v| (v.name.clone(), v.renderer.size())).collect();
        let state = State { renderer, feeds, set: BTreeMap::new(), group_opacities: BTreeMap::new(), sizes, warnings };
        Ok(SceneHandle { state: Mutex::new(state) })
    }

    /// Reads the scene file and its modules again: a changed composition is applied (volumes
    /// loaded again only when they changed), uniforms set from Python are kept. On an error the
    /// scene stays as it was.
    fn reload(&self, py: Python<'_>) -> PyResult<()> {
        self.with_state(py, |state| {
            let cached = state.renderer.compose()?;
            let diagnostics = collect(&cached.built.diags, &cached.built.sources);
            if diagnostics.iter().any(PyDiagnostic::is_error_diag) {
                return Err(Failure::Compile(diagnostics));
            }
            state.renderer.apply(&cached)?;
            state.sizes = state.renderer.views().iter().map(|v| (v.name.clone(), v.renderer.size())).collect();
            state.warnings = diagnostics;
            reapply_uniforms(state)
        })
    }

    /// Marks the array of volume `name` as written in place: the next reload uploads it again.
    fn touch(&self, py: Python<'_>, name: String) -> PyResult<()> {
        self.with_state(py, |state| match state.feeds.get(&name) {
            Some(feed) => {
                feed.touch();
                Ok(())
            }
            None => Err(Failure::Unknown(unknown("array volume", &name, state.feeds.keys()))),
        })
    }

    /// The views' names, in scene order.
    fn views(&self, py: Python<'_>) -> PyResult<Vec<String>> {
        self.with_state(py, |state| Ok(state.renderer.views().iter().map(|v| v.name.clone()).collect()))
    }

    /// The warnings of the last composition.
    fn warnings(&self, py: Python<'_>) -> PyResult<Vec<PyDiagnostic>> {
        self.with_state(py, |state| Ok(state.warnings.clone()))
    }

    /// What the renderer would like the user to know (automatic windows, missing files replaced
    /// by phantoms).
    fn notices(&self, py: Python<'_>) -> PyResult<Vec<String>> {
        self.with_state(py, |state| Ok(state.renderer.notices.clone()))
    }

    /// Renders view `view` (the first when `None`) at `size` (its own when `None`): an
    /// H x W x 4 `uint8` array, straight alpha; a progressive view (the path tracer) holds
    /// `samples` frames (its setting, 16 unless set, when `None`).
    #[pyo3(signature = (view=None, size=None, samples=None))]
    fn render<'py>(
        &self,
        py: Python<'py>,
        view: Option<String>,
        size: Option<(u32, u32)>,
        samples: Option<u32>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let image = self.with_state(py, |state| {
            let index = view_index(state, view.as_deref())?;
            resize(state, index, size)?;
            if let Some(samples) = samples {
                state.renderer.views_mut()[index].renderer.set_samples(samples);
            }
            Ok(state.renderer.render_view(index)?)
        })?;
        let (w, h) = image.dimensions();
        let flat = PyArray1::from_vec(py, image.into_raw());
        Ok(flat.reshape([h as usize, w as usize, 4])?.into_any())
    }

    /// Renders a probe of state field `field` of view `view`: float32 values, H x W for a
    /// scalar and H x W x N for an N-vector, NaN where the pixel has no value; with the legend.
    #[pyo3(signature = (field, view=None, size=None, threshold=None, sample=None))]
    fn probe<'py>(
        &self,
        py: Python<'py>,
        field: String,
        view: Option<String>,
        size: Option<(u32, u32)>,
        threshold: Option<f32>,
        sample: Option<u32>,
    ) -> PyResult<(Bound<'py, PyAny>, String)> {
        let at = match (threshold, sample) {
            (Some(_), Some(_)) => {
                return Err(pyo3::exceptions::PyValueError::new_err("give a threshold or a sample, not both"));
            }
            (Some(a), None) => Some(ProbeAt::Opacity(a)),
            (None, Some(n)) => Some(ProbeAt::Sample(n)),
            (None, None) => None,
        };
        let probe = self.with_state(py, |state| {
            let index = view_index(state, view.as_deref())?;
            resize(state, index, size)?;
            let fields = state.renderer.probe_fields(index)?;
            if !fields.iter().any(|f| f.name == field) {
                let names: Vec<String> = fields.iter().map(|f| f.name.clone()).collect();
                return Err(Failure::Unknown(unknown("state field", &field, names.iter())));
            }
            Ok(state.renderer.render_probe(index, &ProbeSpec { field: field.clone(), at })?)
        })?;
        let values = &probe.values;
        let components = values.format.components as usize;
        let mut data = Vec::with_capacity(values.pixels.len() * components);
        for pixel in &values.pixels {
            match pixel {
                Some(v) => data.extend(v[..components].iter().map(|&x| x as f32)),
                None => data.extend(std::iter::repeat_n(f32::NAN, components)),
            }
        }
        let (w, h) = (values.width as usize, values.height as usize);
        let flat = PyArray1::from_vec(py, data);
        let array = if components == 1 {
            flat.reshape([h, w])?.into_any()
        } else {
            flat.reshape([h, w, components])?.into_any()
        };
        Ok((array, probe.legend()))
    }

    /// Every uniform of the scene's views: dicts of name, type, value, default, range, doc,
    /// views, and whether the renderer sets it before every frame.
    fn uniforms<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        let listed = self.with_state(py, |state| {
            let mut seen: BTreeMap<String, (vrs_reflection_info::Info, Vec<String>)> = BTreeMap::new();
            let mut order = Vec::new();
            for view in state.renderer.views() {
                // The view's shader's uniforms, then its filter pass's.
                for u in view.renderer.reflections().flat_map(|r| r.uniforms.iter()) {
                    let Some(value) = view.renderer.uniform(&u.name) else { continue };
                    let entry = seen.entry(u.name.clone()).or_insert_with(|| {
                        order.push(u.name.clone());
                        (vrs_reflection_info::Info::new(u, value), Vec::new())
                    });
                    entry.1.push(view.name.clone());
                }
            }
            Ok(order.into_iter().filter_map(|name| seen.remove(&name)).collect::<Vec<_>>())
        })?;
        listed
            .into_iter()
            .map(|(info, views)| {
                let dict = PyDict::new(py);
                dict.set_item("name", &info.name)?;
                dict.set_item("type", &info.ty)?;
                dict.set_item("value", values::to_python(py, &info.ty, &info.value)?)?;
                let default = info.default.as_ref().map(|d| values::json_to_python(py, d)).transpose()?;
                dict.set_item("default", default)?;
                let range = match &info.range {
                    Some([lo, hi]) => Some((values::json_to_python(py, lo)?, values::json_to_python(py, hi)?)),
                    None => None,
                };
                dict.set_item("range", range)?;
                dict.set_item("doc", &info.doc)?;
                dict.set_item("views", views)?;
                dict.set_item("set_by_renderer", is_set_by_renderer(&info.name))?;
                Ok(dict)
            })
            .collect()
    }

    /// The value of uniform `name` (in the first view that reads it).
    fn get_uniform<'py>(&self, py: Python<'py>, name: String) -> PyResult<Bound<'py, PyAny>> {
        let (ty, value) = self.with_state(py, |state| current(state, &name))?;
        values::to_python(py, &ty, &value)
    }

    /// Sets uniform `name` in every view that reads it, typed by its declaration.
    fn set_uniform(&self, py: Python<'_>, name: String, value: Bound<'_, PyAny>) -> PyResult<()> {
        if is_set_by_renderer(&name) {
            return Err(scene_error(
                py,
                format!("uniform `{name}` is set by the renderer before every frame (from the camera or the volumes)"),
            ));
        }
        let (_, now) = self.with_state(py, |state| current(state, &name))?;
        let value = values::to_value(&name, &value, &now)?;
        self.with_state(py, |state| {
            state.renderer.set_uniform(&name, value.clone())?;
            state.set.insert(name.clone(), value);
            Ok(())
        })
    }

    /// The orbit camera of raycast view `view`: azimuth, elevation, distance, fov (degrees,
    /// and the distance in units of the volume's largest side).
    #[pyo3(signature = (view=None))]
    fn camera<'py>(&self, py: Python<'py>, view: Option<String>) -> PyResult<Bound<'py, PyDict>> {
        let camera = self.with_state(py, |state| {
            let index = view_index(state, view.as_deref())?;
            let v = &state.renderer.views()[index];
            v.camera.ok_or_else(|| Failure::Scene(format!("view `{}` is a slice view: it has no camera", v.name)))
        })?;
        let dict = PyDict::new(py);
        dict.set_item("azimuth", camera.azimuth)?;
        dict.set_item("elevation", camera.elevation)?;
        dict.set_item("distance", camera.distance)?;
        dict.set_item("fov", camera.fov)?;
        Ok(dict)
    }

    /// Moves the orbit camera of raycast view `view`; what is `None` stays.
    #[pyo3(signature = (view=None, azimuth=None, elevation=None, distance=None, fov=None))]
    fn set_camera(
        &self,
        py: Python<'_>,
        view: Option<String>,
        azimuth: Option<f32>,
        elevation: Option<f32>,
        distance: Option<f32>,
        fov: Option<f32>,
    ) -> PyResult<()> {
        for (what, v) in [("azimuth", azimuth), ("elevation", elevation), ("distance", distance), ("fov", fov)] {
            if v.is_some_and(|v| !v.is_finite()) {
                return Err(pyo3::exceptions::PyValueError::new_err(format!("the camera's {what} must be finite")));
            }
        }
        if distance.is_some_and(|d| d <= 0.0) {
            return Err(pyo3::exceptions::PyValueError::new_err("the camera's distance must be positive"));
        }
        if fov.is_some_and(|f| !(1.0..=179.0).contains(&f)) {
            return Err(pyo3::exceptions::PyValueError::new_err("the camera's fov must lie in 1 to 179 degrees"));
        }
        self.with_state(py, |state| {
            let index = view_index(state, view.as_deref())?;
            let v = &mut state.renderer.views_mut()[index];
            let name = v.name.clone();
            let camera = v
                .camera
                .as_mut()
                .ok_or_else(|| Failure::Scene(format!("view `{name}` is a slice view: it has no camera")))?;
            camera.azimuth = azimuth.unwrap_or(camera.azimuth);
            camera.elevation = elevation.unwrap_or(camera.elevation).clamp(-89.0, 89.0);
            camera.distance = distance.unwrap_or(camera.distance);
            camera.fov = fov.unwrap_or(camera.fov);
            Ok(())
        })
    }

    /// The composed WGSL of view `view` with every function annotated by the VRS file and line
    /// it came from (`vrsc explain`).
    #[pyo3(signature = (view=None))]
    fn explain(&self, py: Python<'_>, view: Option<String>) -> PyResult<String> {
        let (path, name) = self.with_state(py, |state| {
            let index = view_index(state, view.as_deref())?;
            Ok((state.renderer.path().to_path_buf(), state.renderer.views()[index].name.clone()))
        })?;
        let explained = on_big_stack(py, "explaining a view", || explain_view(&path, &name))?;
        explained.map_err(|f| f.into_py(py))
    }

    /// The occlusion groups the views draw, each once in scene order, with the opacity their
    /// hidden children show with.
    fn occlusion_groups(&self, py: Python<'_>) -> PyResult<Vec<(String, f32)>> {
        self.with_state(py, |state| Ok(state.renderer.occlusion_groups()))
    }

    /// Shows what occlusion group `name` hides with `opacity` (0 to 1) in every view; kept
    /// across reloads.
    fn set_group_opacity(&self, py: Python<'_>, name: String, opacity: f32) -> PyResult<()> {
        if !(0.0..=1.0).contains(&opacity) {
            return Err(pyo3::exceptions::PyValueError::new_err("an opacity lies in 0 to 1"));
        }
        self.with_state(py, |state| {
            let groups = state.renderer.occlusion_groups();
            if !groups.iter().any(|(g, _)| *g == name) {
                return Err(Failure::Unknown(unknown("occlusion group", &name, groups.iter().map(|(g, _)| g))));
            }
            state.renderer.set_group_opacity(&name, opacity)?;
            state.group_opacities.insert(name, opacity);
            Ok(())
        })
    }

    /// The pipeline map of view `view` (`vrsc pipeline`): steps, their functions, where each
    /// came from.
    #[pyo3(signature = (view=None))]
    fn pipeline(&self, py: Python<'_>, view: Option<String>) -> PyResult<String> {
        let (path, name) = self.with_state(py, |state| {
            let index = view_index(state, view.as_deref())?;
            Ok((state.renderer.path().to_path_buf(), state.renderer.views()[index].name.clone()))
        })?;
        let mapped = on_big_stack(py, "mapping a pipeline", || pipeline_map(&path, &name))?;
        mapped.map_err(|f| f.into_py(py))
    }
}

impl PyDiagnostic {
    fn is_error_diag(&self) -> bool {
        self.severity == "error"
    }
}

/// The index of view `name` (the first view for `None`).
fn view_index(state: &State, name: Option<&str>) -> Outcome<usize> {
    let views = state.renderer.views();
    match name {
        None if views.is_empty() => Err(Failure::Scene("the scene has no views".into())),
        None => Ok(0),
        Some(name) => views
            .iter()
            .position(|v| v.name == name)
            .ok_or_else(|| Failure::Unknown(unknown("view", name, views.iter().map(|v| &v.name)))),
    }
}

/// "the scene has no view `x`; did you mean `y`? (known: a, b)". The suggestion follows the
/// compiler's rule (at most two edits, or one per four characters of a longer name).
fn unknown<'a>(what: &str, name: &str, known: impl Iterator<Item = &'a String>) -> String {
    let known: Vec<&str> = known.map(String::as_str).collect();
    let mut message = format!("the scene has no {what} `{name}`");
    let best = known
        .iter()
        .map(|k| (strsim::levenshtein(name, k), *k))
        .filter(|(d, k)| *d > 0 && *d <= 2.max(k.len() / 4))
        .min();
    if let Some((_, best)) = best {
        message.push_str(&format!("; did you mean `{best}`?"));
    }
    if !known.is_empty() {
        message.push_str(&format!(" (known: {})", known.join(", ")));
    }
    message
}

/// Gives view `index` the size asked for, or its scene size back.
fn resize(state: &mut State, index: usize, size: Option<(u32, u32)>) -> Outcome<()> {
    let view = &mut state.renderer.views_mut()[index];
    let wanted = match size {
        Some((w, h)) => [w, h],
        None => state.sizes.get(&view.name).copied().unwrap_or(view.renderer.size()),
    };
    if wanted.contains(&0) || wanted.iter().any(|&n| n > 16384) {
        return Err(Failure::Scene(format!(
            "an image of {} x {} pixels cannot be rendered (1 to 16384 each)",
            wanted[0], wanted[1]
        )));
    }
    if view.renderer.size() != wanted {
        let gpu = state.renderer.gpu().clone();
        state.renderer.views_mut()[index].renderer.resize(&gpu, wanted)?;
    }
    Ok(())
}

/// The type and current value of uniform `name` in the first view that reads it.
fn current(state: &State, name: &str) -> Outcome<(String, Value)> {
    for view in state.renderer.views() {
        if let (Some(u), Some(value)) = (view.renderer.uniform_info(name), view.renderer.uniform(name)) {
            return Ok((u.ty.clone(), value));
        }
    }
    let names: Vec<String> = state
        .renderer
        .views()
        .iter()
        .flat_map(|v| v.renderer.reflections())
        .flat_map(|r| r.uniforms.iter().filter(|u| u.offset.is_some()).map(|u| u.name.clone()))
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    Err(Failure::Unknown(unknown("uniform", name, names.iter())))
}

/// Sets the uniforms set from Python again (after a recomposition reset them to the scene's).
fn reapply_uniforms(state: &mut State) -> Outcome<()> {
    for (name, value) in &state.set {
        // A uniform a module no longer declares is dropped, not an error.
        let declared = state.renderer.views().iter().any(|v| v.renderer.has_uniform(name));
        if declared {
            state.renderer.set_uniform(name, value.clone())?;
        }
    }
    // A group the scene no longer draws is dropped, likewise.
    let drawn = state.renderer.occlusion_groups();
    for (name, &opacity) in &state.group_opacities {
        if drawn.iter().any(|(g, _)| g == name) {
            state.renderer.set_group_opacity(name, opacity)?;
        }
    }
    Ok(())
}

fn explain_view(path: &Path, view: &str) -> Outcome<String> {
    use vrsc::compose::build::{Keep, build_scene_keeping};
    let built = build_scene_keeping(path, Some(view), Keep::Ir).map_err(|e| Failure::Io(path.to_path_buf(), e))?;
    if built.diags.has_errors() {
        return Err(Failure::Compile(collect(&built.diags, &built.sources)));
    }
    let text: Vec<String> =
        built.views.iter().filter_map(|v| vrsc::compose::explain::explain_with_filters(v, &built.sources)).collect();
    Ok(text.concat())
}

fn pipeline_map(path: &Path, view: &str) -> Outcome<String> {
    use vrsc::compose::build::{Keep, build_scene_keeping};
    let built = build_scene_keeping(path, Some(view), Keep::Ir).map_err(|e| Failure::Io(path.to_path_buf(), e))?;
    if built.diags.has_errors() {
        return Err(Failure::Compile(collect(&built.diags, &built.sources)));
    }
    let mut text = String::new();
    // The view's renderer tree first, as `vrsc pipeline` prints it.
    if let Some(scene) = &built.scene
        && let Some(table) = scene.views.iter().find(|v| v.name.name == view)
    {
        text.push_str(&format!("picture: {}\n", scene.describe_picture(table)));
    }
    for v in &built.views {
        text.push_str(&v.render_maps(&built.sources));
    }
    Ok(text)
}

/// What `uniforms()` lists of one uniform, taken while the state is locked.
mod vrs_reflection_info {
    use vrs_runtime::Value;

    pub struct Info {
        pub name: String,
        pub ty: String,
        pub value: Value,
        pub default: Option<serde_json::Value>,
        pub range: Option<[serde_json::Value; 2]>,
        pub doc: Option<String>,
    }

    impl Info {
        pub fn new(u: &vrs_runtime::reflection::UniformInfo, value: Value) -> Info {
            Info {
                name: u.name.clone(),
                ty: u.ty.clone(),
                value,
                default: u.default.clone(),
                range: u.range.clone(),
                doc: u.doc.clone(),
            }
        }
    }
}
