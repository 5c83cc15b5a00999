//! Scenes (section 11 of the language spec): what to compose and render, as TOML.
//!
//! The caller adds the scene file to the [`SourceMap`] and calls [`parse_scene`] with its id;
//! every diagnostic then points into that file, in the map's global offset space. Parsing has
//! two stages: serde (with `deny_unknown_fields` on every table) turns the TOML into raw tables
//! whose fields keep their byte ranges ([`toml::Spanned`]); validation then checks what serde
//! cannot (names, ranges, one primary volume, keys that need each other) and builds the typed
//! [`Scene`], in which every name and value a later pass may point at carries its [`Span`].
//!
//! Decisions beyond section 11 (documented for users in `stdlib/README.md`):
//! - `render.shading = true` without `lights` means `lights = ["key"]`; `lights` is ignored
//!   (warning) when shading is off. `lights = []` with shading gives ambient light only.
//! - `compositing = "iso"` requires `iso_value` (an error, not a silent default).
//! - `render.step_size`, `max_samples`, `jitter`, `background` and `iso_value` are initial values
//!   of the uniforms of the same names; setting one both there and in `[uniforms]` is an error.
//! - A volume's `window = [lo, hi]` (or `level` and `width`) is in data units; `lo < hi`.
//! - A volume's `tf` is a preset name when it is an identifier (`grayscale`), else a file path.
//!   It defaults to `grayscale` (`labels` for a tag volume) and is ignored for a mask volume.
//! - A module path `std::NAME` names a standard module; any other path is a file relative to the
//!   scene file.
//! - Keys that have no effect where they are (a raycast view's `axis`, a slice view's `camera`)
//!   are warnings, not errors.
//! - Names of volumes, lights, instances and uniforms are identifiers and not VRS keywords; view
//!   names (which name output files, `3d` in the spec's example) are `[A-Za-z0-9_-]+`.

use crate::ast::Ident;
use crate::diag::{Code, Diagnostic};
use crate::source::{FileId, SourceMap, Span};
use crate::steps::did_you_mean;
use serde::Deserialize;
use serde::de::{self, Deserializer, SeqAccess, Visitor};
use std::collections::BTreeMap;
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};
use toml::Spanned;

mod view_render;
pub use view_render::Convention;

/// The size of a view when `size` is not given.
pub const DEFAULT_VIEW_SIZE: [u32; 2] = [512, 512];
/// The largest width or height of a view.
pub const MAX_VIEW_SIZE: u32 = 16384;
/// The light that `shading = true` gets when `lights` is not given.
pub const DEFAULT_LIGHT: &str = "key";
/// The transfer function preset of primary and additional volumes without `tf`.
pub const DEFAULT_TF: &str = "grayscale";
/// The transfer function preset of tag volumes without `tf`.
pub const DEFAULT_TAG_TF: &str = "labels";
/// The default of the `step_size` uniform (mm); `stdlib/raycast.vrs` and `stdlib/slice.vrs`
/// declare the same value. The runtime replaces it by half the primary volume's smallest voxel
/// spacing when the scene sets no step size.
pub const DEFAULT_STEP_SIZE: f32 = 0.5;
/// The most samples per ray a scene may ask for.
pub const MAX_SAMPLES_LIMIT: u32 = 1 << 16;
/// Camera defaults: looking at the volume's centre along -z from `distance` 2.5, 30° vertical
/// field of view.
pub const DEFAULT_CAMERA: Camera = Camera { azimuth: 0.0, elevation: 0.0, distance: 2.5, fov: 30.0 };
/// Slice position when `position` is not given: the middle of the volume.
pub const DEFAULT_SLICE_POSITION: f32 = 0.5;

/// VRS keywords: not allowed as names that become identifiers in composed code.
const KEYWORDS: &[&str] = &[
    "import", "const", "lib", "fn", "pipeline", "state", "uniform", "use", "remove", "before", "after", "replace",
    "in", "when", "active", "let", "var", "if", "else", "for", "break", "continue", "return", "true", "false",
];

/// Uniforms that `[render]` keys set; `[uniforms]` must not set them again.
const RENDER_UNIFORMS: &[&str] = &["iso_value", "step_size", "max_samples", "jitter", "background"];

// ---------------------------------------------------------------------------------------------
// The typed scene.

/// A value with the span of its TOML value.
#[derive(Clone, Debug, PartialEq)]
pub struct Located<T> {
    pub value: T,
    pub span: Span,
}

/// A parsed and validated scene.
#[derive(Clone, Debug)]
pub struct Scene {
    pub render: Render,
    /// `[[volume]]` tables, in file order.
    pub volumes: Vec<Volume>,
    /// `[[module]]` tables: modules shared by every view, in file order.
    pub modules: Vec<ModuleRef>,
    /// `[uniforms]`: initial values by uniform name.
    pub uniforms: BTreeMap<String, UniformSetting>,
    /// `[[view]]` tables, in file order.
    pub views: Vec<View>,
    /// The directory that relative paths were resolved against.
    pub dir: PathBuf,
    /// Warnings found while validating (keys without effect).
    pub warnings: Vec<Diagnostic>,
}

/// `[render]`: how every view composites and shades.
#[derive(Clone, Debug)]
pub struct Render {
    pub compositing: Located<Compositing>,
    /// Initial value of the `iso_value` uniform; present when compositing is `iso`.
    pub iso_value: Option<Located<f32>>,
    /// Gradient and lighting steps of the standard library.
    pub shading: bool,
    /// One `shading.lights` substep per light (the instances of `std::light`); empty without
    /// shading.
    pub lights: Vec<Ident>,
    /// Boundary enhancement (`std::boundary`: opacity scaled by gradient magnitude).
    pub boundary: bool,
    /// Gooch-style tone shading (`std::tone`); needs `shading`.
    pub tone: bool,
    /// Empty-space skipping in raycast views (`std::skip`); DVR only.
    pub empty_space_skipping: bool,
    /// Initial value of the `step_size` uniform (mm); `None`: the runtime's default (half the
    /// primary volume's smallest voxel spacing).
    pub step_size: Option<Located<f32>>,
    /// The loop bound; `None`: the runtime derives it from the step size and the volume.
    pub max_samples: Option<Located<u32>>,
    /// Initial value of the `jitter` uniform (0: off, 1: up to one step).
    pub jitter: Option<Located<f32>>,
    /// Initial value of the `background` uniform (premultiplied RGBA).
    pub background: Option<Located<[f32; 4]>>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Compositing {
    /// Front-to-back emission-absorption.
    Dvr,
    /// Maximum intensity projection.
    Mip,
    /// First hit of an iso-surface.
    Iso,
    /// Minimum intensity projection.
    Minip,
    /// Average intensity along the ray (a radiograph-like projection).
    Average,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    Primary,
    Additional,
    Mask,
    Tag,
}

/// `[[volume]]`: a data set and how it is classified.
#[derive(Clone, Debug)]
pub struct Volume {
    /// The instance name of this volume's template functions (`value_t1`, `tf_t1`).
    pub name: Ident,
    pub role: Located<Role>,
    pub source: VolumeSource,
    /// `fallback = "NAME"`: the built-in phantom to use when the `path` file does not exist (so
    /// an example renders before its data is downloaded).
    pub fallback: Option<Located<String>>,
    /// The transfer function; `None` only for mask volumes, which have none.
    pub tf: Option<TfRef>,
    /// `window = [lo, hi]`, or `level` and `width` (as `[level - width / 2, level + width / 2]`):
    /// the data values (Hounsfield units for CT) that map to the ends of a window-relative
    /// transfer function. `None`: the runtime picks one (a data-unit transfer function's domain,
    /// else percentiles of the data).
    pub window: Option<Located<[f32; 2]>>,
    /// The whole `[[volume]]` table.
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub enum VolumeSource {
    /// `path = "..."`.
    File(FileRef),
    /// `phantom = "NAME"`: a built-in data set of the runtime.
    Phantom(Located<String>),
}

#[derive(Clone, Debug, PartialEq)]
pub enum TfRef {
    /// A built-in preset (the value is an identifier), or the role's default (dummy span).
    Preset(Located<String>),
    /// A transfer function file.
    File(FileRef),
}

/// A path as written in the scene and resolved against the scene file's directory.
#[derive(Clone, Debug, PartialEq)]
pub struct FileRef {
    pub given: String,
    pub resolved: PathBuf,
    pub span: Span,
}

/// A module to compose: `[[module]]`, or an entry of a view's `modules`.
#[derive(Clone, Debug)]
pub struct ModuleRef {
    pub source: ModuleSource,
    /// Instance names for a template module; `None` for a plain module.
    pub instances: Option<Vec<Ident>>,
    /// The whole table.
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub enum ModuleSource {
    /// `path = "std::NAME"`: the standard module `NAME`.
    Std(Located<String>),
    File(FileRef),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ViewKind {
    Raycast,
    Slice,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    #[serde(alias = "sagittal")]
    X,
    #[serde(alias = "coronal")]
    Y,
    #[serde(alias = "axial")]
    Z,
}

impl Axis {
    /// 0, 1 or 2.
    pub fn index(self) -> usize {
        self as usize
    }
}

/// An orbit camera around the volume's centre. Angles in degrees; `distance` in units of the
/// volume's largest extent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub azimuth: f32,
    pub elevation: f32,
    pub distance: f32,
    /// Vertical field of view.
    pub fov: f32,
}

impl Default for Camera {
    fn default() -> Camera {
        DEFAULT_CAMERA
    }
}

/// `[[view]]`: one rendered image and its own modules.
#[derive(Clone, Debug)]
pub struct View {
    pub name: Ident,
    pub kind: Located<ViewKind>,
    /// Width and height in pixels.
    pub size: [u32; 2],
    /// Raycast views only ([`DEFAULT_CAMERA`] when not given).
    pub camera: Camera,
    /// Slice views only: the patient axis the slice plane is normal to (`x` or `sagittal`, `y`
    /// or `coronal`, `z` or `axial`).
    pub axis: Option<Located<Axis>>,
    /// Slice views only: the plane's position along `axis` across the primary volume's box in
    /// patient space, 0 to 1 (0.5 without `position`).
    pub position: f32,
    /// Slice views only: slab thickness (mm); 0 is a single sample per pixel.
    pub slab: f32,
    /// Slice views only: how the image puts the patient's sides.
    pub convention: Convention,
    /// How this view composites and shades: its `render` table over the scene's `[render]`.
    pub render: Render,
    /// Modules of this view only, composed after the shared ones.
    pub modules: Vec<ModuleRef>,
    /// The whole `[[view]]` table.
    pub span: Span,
}

/// A `[uniforms]` entry.
#[derive(Clone, Debug, PartialEq)]
pub struct UniformSetting {
    pub value: UniformValue,
    /// The key.
    pub name_span: Span,
    /// The value.
    pub span: Span,
}

/// An initial uniform value: a number, a bool, or a (nested) array of them. Arrays are vectors;
/// an array of arrays is a matrix given column by column. The composer checks the value against
/// the uniform's declared type.
#[derive(Clone, Debug, PartialEq)]
pub enum UniformValue {
    Bool(bool),
    Int(i64),
    Float(f64),
    Array(Vec<UniformValue>),
}

impl<'de> Deserialize<'de> for UniformValue {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<UniformValue, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = UniformValue;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a number, a bool, or an array of them")
            }
            fn visit_bool<E: de::Error>(self, v: bool) -> Result<UniformValue, E> {
                Ok(UniformValue::Bool(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<UniformValue, E> {
                Ok(UniformValue::Int(v))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<UniformValue, E> {
                i64::try_from(v).map(UniformValue::Int).map_err(|_| E::custom("integer out of range"))
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<UniformValue, E> {
                Ok(UniformValue::Float(v))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<UniformValue, A::Error> {
                let mut items = Vec::new();
                while let Some(item) = seq.next_element()? {
                    items.push(item);
                }
                Ok(UniformValue::Array(items))
            }
        }
        deserializer.deserialize_any(V)
    }
}

impl UniformValue {
    /// The array lengths from the outside in: `[]` for a scalar, `[4]` for a vec4, `[4, 4]`
    /// for a mat4x4.
    pub fn shape(&self) -> Vec<usize> {
        match self {
            UniformValue::Array(items) => {
                let mut shape = vec![items.len()];
                if let Some(first) = items.first() {
                    shape.extend(first.shape());
                }
                shape
            }
            _ => Vec::new(),
        }
    }

    /// Every scalar, in order (columns of a matrix one after the other).
    pub fn flatten(&self) -> Vec<f64> {
        match self {
            UniformValue::Bool(b) => vec![f64::from(u8::from(*b))],
            UniformValue::Int(i) => vec![*i as f64],
            UniformValue::Float(x) => vec![*x],
            UniformValue::Array(items) => items.iter().flat_map(UniformValue::flatten).collect(),
        }
    }

    /// Why this value cannot initialise any VRS uniform, if it cannot.
    fn problem(&self, depth: usize) -> Option<String> {
        let UniformValue::Array(items) = self else {
            return match self {
                UniformValue::Float(x) if !x.is_finite() => Some("numbers must be finite".into()),
                _ => None,
            };
        };
        if depth >= 2 {
            return Some("arrays nest at most two deep (a matrix is an array of columns)".into());
        }
        if !(2..=4).contains(&items.len()) {
            return Some(format!("an array of {} elements; vectors and matrix columns have 2 to 4", items.len()));
        }
        let nested = items.iter().filter(|i| matches!(i, UniformValue::Array(_))).count();
        if nested != 0 && nested != items.len() {
            return Some("an array mixes numbers and arrays".into());
        }
        let bools = items.iter().filter(|i| matches!(i, UniformValue::Bool(_))).count();
        if bools != 0 && bools != items.len() {
            return Some("an array mixes bools and numbers".into());
        }
        if nested != 0 && items.iter().any(|i| i.shape() != items[0].shape()) {
            return Some("the columns of a matrix must all have the same length".into());
        }
        items.iter().find_map(|i| i.problem(depth + 1))
    }
}

// ---------------------------------------------------------------------------------------------
// Queries.

impl Scene {
    /// The primary volume (validation guarantees exactly one).
    pub fn primary(&self) -> &Volume {
        self.volumes.iter().find(|v| v.role.value == Role::Primary).expect("a validated scene has a primary volume")
    }

    /// Names of the volumes with `role`, in file order.
    pub fn volume_names(&self, role: Role) -> Vec<String> {
        self.volumes.iter().filter(|v| v.role.value == role).map(|v| v.name.name.clone()).collect()
    }

    pub fn view(&self, name: &str) -> Option<&View> {
        self.views.iter().find(|v| v.name.name == name)
    }

    /// Initial uniform values of views without their own `render` table: `[uniforms]`, plus
    /// those that `[render]` sets (`iso_value`, `step_size`, `jitter`, `background` and
    /// `max_samples` when given). [`Scene::view_uniform_values`] gives a view's own.
    pub fn uniform_values(&self) -> BTreeMap<String, UniformValue> {
        self.uniform_values_with(&self.render)
    }

    fn uniform_values_with(&self, r: &Render) -> BTreeMap<String, UniformValue> {
        let mut out: BTreeMap<String, UniformValue> =
            self.uniforms.iter().map(|(k, v)| (k.clone(), v.value.clone())).collect();
        let float = |x: f32| UniformValue::Float(f64::from(x));
        if let Some(v) = &r.iso_value {
            out.insert("iso_value".into(), float(v.value));
        }
        if let Some(v) = &r.step_size {
            out.insert("step_size".into(), float(v.value));
        }
        if let Some(v) = &r.jitter {
            out.insert("jitter".into(), float(v.value));
        }
        if let Some(v) = &r.background {
            out.insert("background".into(), UniformValue::Array(v.value.iter().map(|&c| float(c)).collect()));
        }
        if let Some(m) = &r.max_samples {
            out.insert("max_samples".into(), UniformValue::Int(i64::from(m.value)));
        }
        out
    }

    /// The standard modules the composer selects for `view`, in the order it gives them
    /// (before the scene's `[[module]]`s and then the view's own `modules`). See
    /// `stdlib/README.md`.
    pub fn standard_modules(&self, view: &View) -> Vec<StdModule> {
        let r = &view.render;
        let mut out = Vec::new();
        let mut add = |name: &'static str, instances: Vec<String>| out.push(StdModule { name, instances });
        let additional = self.volume_names(Role::Additional);
        let masks = self.volume_names(Role::Mask);
        let tags = self.volume_names(Role::Tag);
        match view.kind.value {
            ViewKind::Raycast => add("raycast", vec![]),
            ViewKind::Slice => add("slice", vec![]),
        }
        add("march", vec![]);
        add("background", vec![]);
        add("sample_primary", vec![]);
        if !additional.is_empty() {
            add("sample_volume", additional.clone());
        }
        if r.shading || r.boundary {
            add("gradient", vec![]);
        }
        add("classify", vec![]);
        if !additional.is_empty() {
            add("classify_volume", additional.clone());
        }
        // After `classify`: their functions append to `classification.primary`.
        if !masks.is_empty() {
            add("mask", masks);
        }
        if !tags.is_empty() {
            add("tag", tags);
        }
        if r.shading && !r.lights.is_empty() {
            add("light", r.lights.iter().map(|l| l.name.clone()).collect());
        }
        if r.boundary {
            add("boundary", vec![]);
        }
        if r.tone {
            add("tone", vec![]);
        }
        add("composite", vec![]);
        if r.shading {
            add("lighting", vec![]);
        }
        match r.compositing.value {
            Compositing::Dvr => {
                add("composite_dvr", vec![]);
                if !additional.is_empty() {
                    add("composite_volume", additional);
                }
            }
            Compositing::Mip => add("composite_mip", vec![]),
            Compositing::Iso => add("composite_iso", vec![]),
            Compositing::Minip => add("composite_minip", vec![]),
            Compositing::Average => add("composite_average", vec![]),
        }
        // Last: its functions append to `ray.setup` and `end` after the ones above.
        if r.empty_space_skipping && view.kind.value == ViewKind::Raycast {
            add("skip", vec![]);
        }
        out
    }
}

/// A standard module chosen by configuration: `std::NAME`, with instances for a template.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StdModule {
    pub name: &'static str,
    /// Empty for a plain module.
    pub instances: Vec<String>,
}

// ---------------------------------------------------------------------------------------------
// Errors and entry points.

/// A scene that does not parse or validate: its diagnostics (errors, and any warnings found
/// before the errors), sorted by position.
#[derive(Clone, Debug)]
pub struct SceneError {
    pub diagnostics: Vec<Diagnostic>,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let errors: Vec<&str> = self.diagnostics.iter().filter(|d| d.is_error()).map(|d| d.message.as_str()).collect();
        write!(f, "invalid scene: {}", errors.join("; "))
    }
}

impl std::error::Error for SceneError {}

/// Parses and validates the scene file `file` of `sources`. Relative paths resolve against the
/// directory of the file's `path` (or of its name when it has no path).
pub fn parse_scene(sources: &SourceMap, file: FileId) -> Result<Scene, SceneError> {
    let f = sources.file(file);
    let from = f.path.clone().unwrap_or_else(|| PathBuf::from(&f.name));
    let dir = from.parent().map(Path::to_path_buf).unwrap_or_default();
    parse_scene_text(&f.text, f.base, &dir)
}

/// Parses and validates scene text whose first byte has global offset `base`; relative paths
/// resolve against `dir`.
pub fn parse_scene_text(text: &str, base: u32, dir: &Path) -> Result<Scene, SceneError> {
    let mut cx = Cx { text, base, dir, errors: Vec::new(), warnings: Vec::new() };
    let raw: RawScene = match toml::from_str(text) {
        Ok(raw) => raw,
        Err(e) => return Err(SceneError { diagnostics: vec![cx.toml_error(&e)] }),
    };
    let scene = cx.scene(raw);
    if cx.errors.is_empty() {
        let mut warnings = cx.warnings;
        sort(&mut warnings);
        Ok(Scene { warnings, ..scene })
    } else {
        let mut diagnostics = cx.errors;
        diagnostics.extend(cx.warnings);
        sort(&mut diagnostics);
        Err(SceneError { diagnostics })
    }
}

/// Sorts by position; a diagnostic found twice (a shared `[render]` value validated again for a
/// view's own `render` table) is kept once.
fn sort(list: &mut Vec<Diagnostic>) {
    list.sort_by(|a, b| (a.span.start, a.code, &a.message).cmp(&(b.span.start, b.code, &b.message)));
    list.dedup();
}

// ---------------------------------------------------------------------------------------------
// Raw serde tables.

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    render: Option<Spanned<RawRender>>,
    #[serde(default, rename = "volume")]
    volumes: Vec<Spanned<RawVolume>>,
    #[serde(default, rename = "module")]
    modules: Vec<Spanned<RawModule>>,
    #[serde(default)]
    uniforms: BTreeMap<Spanned<String>, Spanned<UniformValue>>,
    #[serde(default, rename = "view")]
    views: Vec<Spanned<RawView>>,
}
const SCENE_KEYS: &[&str] = &["render", "volume", "module", "uniforms", "view"];

#[derive(Deserialize, Default, Clone)]
#[serde(deny_unknown_fields)]
struct RawRender {
    compositing: Option<Spanned<Compositing>>,
    iso_value: Option<Spanned<f32>>,
    shading: Option<Spanned<bool>>,
    lights: Option<Spanned<Vec<Spanned<String>>>>,
    boundary: Option<Spanned<bool>>,
    tone: Option<Spanned<bool>>,
    empty_space_skipping: Option<Spanned<bool>>,
    step_size: Option<Spanned<f32>>,
    max_samples: Option<Spanned<u32>>,
    jitter: Option<Spanned<f32>>,
    background: Option<Spanned<[f32; 4]>>,
}
const RENDER_KEYS: &[&str] = &[
    "compositing",
    "iso_value",
    "shading",
    "lights",
    "boundary",
    "tone",
    "empty_space_skipping",
    "step_size",
    "max_samples",
    "jitter",
    "background",
];

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawVolume {
    name: Spanned<String>,
    role: Spanned<Role>,
    path: Option<Spanned<String>>,
    phantom: Option<Spanned<String>>,
    fallback: Option<Spanned<String>>,
    tf: Option<Spanned<String>>,
    window: Option<Spanned<[f32; 2]>>,
    level: Option<Spanned<f32>>,
    width: Option<Spanned<f32>>,
}
const VOLUME_KEYS: &[&str] = &["name", "role", "path", "phantom", "fallback", "tf", "window", "level", "width"];

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawModule {
    path: Spanned<String>,
    instances: Option<Spanned<Vec<Spanned<String>>>>,
}
const MODULE_KEYS: &[&str] = &["path", "instances"];

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawView {
    name: Spanned<String>,
    kind: Option<Spanned<ViewKind>>,
    size: Option<Spanned<[u32; 2]>>,
    camera: Option<Spanned<RawCamera>>,
    axis: Option<Spanned<Axis>>,
    position: Option<Spanned<f32>>,
    slab: Option<Spanned<f32>>,
    convention: Option<Spanned<Convention>>,
    render: Option<Spanned<RawRender>>,
    #[serde(default)]
    modules: Vec<Spanned<RawModule>>,
}
const VIEW_KEYS: &[&str] =
    &["name", "kind", "size", "camera", "axis", "position", "slab", "convention", "render", "modules"];
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCamera {
    azimuth: Option<Spanned<f32>>,
    elevation: Option<Spanned<f32>>,
    distance: Option<Spanned<f32>>,
    fov: Option<Spanned<f32>>,
}
const CAMERA_KEYS: &[&str] = &["azimuth", "elevation", "distance", "fov"];

// ---------------------------------------------------------------------------------------------
// Validation.

struct Cx<'a> {
    text: &'a str,
    base: u32,
    dir: &'a Path,
    errors: Vec<Diagnostic>,
    warnings: Vec<Diagnostic>,
}

impl Cx<'_> {
    fn range(&self, r: Range<usize>) -> Span {
        let len = self.text.len();
        let (start, end) = (r.start.min(len), r.end.min(len));
        Span::new(self.base + start as u32, self.base + end.max(start) as u32)
    }

    fn span<T>(&self, s: &Spanned<T>) -> Span {
        self.range(s.span())
    }

    fn emit(&mut self, d: Diagnostic) {
        self.errors.push(d);
    }

    fn invalid(&self, span: Span, message: impl Into<String>) -> Diagnostic {
        Diagnostic::new(Code::SceneInvalid, span, message)
    }

    /// A volume's value window from `window`, or from `level` and `width` (never both).
    fn window(
        &mut self,
        window: &Option<Spanned<[f32; 2]>>,
        level: &Option<Spanned<f32>>,
        width: &Option<Spanned<f32>>,
    ) -> Option<Located<[f32; 2]>> {
        let located = match (window, level, width) {
            (Some(w), None, None) => Located { value: *w.get_ref(), span: self.span(w) },
            (None, Some(l), Some(w)) => {
                let (level, width) = (*l.get_ref(), *w.get_ref());
                let span = self.span(w);
                if width.is_nan() || width <= 0.0 {
                    self.emit(self.invalid(span, format!("the window `width` must be positive, not {width}")));
                    return None;
                }
                Located { value: [level - width / 2.0, level + width / 2.0], span }
            }
            (None, None, None) => return None,
            (Some(w), _, _) => {
                let d = self.invalid(self.span(w), "a volume has either `window` or `level` and `width`, not both");
                self.emit(d);
                return None;
            }
            (None, Some(l), None) => {
                self.emit(
                    self.invalid(self.span(l), "`level` needs `width`").with_help("add `width = W` (data units)"),
                );
                return None;
            }
            (None, None, Some(w)) => {
                self.emit(
                    self.invalid(self.span(w), "`width` needs `level`").with_help("add `level = L` (data units)"),
                );
                return None;
            }
        };
        let [lo, hi] = located.value;
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            self.emit(
                self.invalid(located.span, format!("the window [{lo}, {hi}] must have its low end below its high end")),
            );
            return None;
        }
        Some(located)
    }

    fn ignored<T>(&mut self, value: &Spanned<T>, key: &str, why: &str) {
        let span = self.span(value);
        self.ignored_at(span, key, why);
    }

    fn ignored_at(&mut self, span: Span, key: &str, why: &str) {
        self.warnings.push(
            Diagnostic::new(Code::SceneIgnored, span, format!("`{key}` has no effect {why}"))
                .with_label("ignored")
                .with_help(format!("remove `{key}`")),
        );
    }

    /// The TOML or serde error as a diagnostic at its span.
    fn toml_error(&self, e: &toml::de::Error) -> Diagnostic {
        let span = e.span().map_or(Span::new(self.base, self.base), |r| self.range(r));
        let raw = e.message().trim();
        let offset = e.span().map_or(0, |r| r.start);
        if let Some(rest) = raw.strip_prefix("unknown field `") {
            let key = rest.split('`').next().unwrap_or_default();
            let expected = backticked(rest.get(key.len() + 1..).unwrap_or_default());
            let context = self.keys_context(&expected, offset);
            let mut d = Diagnostic::new(Code::SceneUnknownKey, span, format!("unknown key `{key}` in {context}"))
                .with_label("unknown key");
            if let Some(s) = did_you_mean(key, expected.iter().map(String::as_str)) {
                d = d.with_help(format!("did you mean `{s}`?"));
            }
            if !expected.is_empty() {
                d = d.with_note(format!("expected one of {}", quote_list(&expected)));
            }
            return d;
        }
        if let Some(rest) = raw.strip_prefix("unknown variant `") {
            let value = rest.split('`').next().unwrap_or_default();
            let expected = backticked(rest.get(value.len() + 1..).unwrap_or_default());
            let mut d =
                Diagnostic::new(Code::SceneInvalid, span, format!("`{value}` is not one of {}", quote_list(&expected)))
                    .with_label("unknown value");
            if let Some(s) = did_you_mean(value, expected.iter().map(String::as_str)) {
                d = d.with_help(format!("did you mean `{s}`?"));
            }
            return d;
        }
        if let Some(rest) = raw.strip_prefix("missing field `") {
            let key = rest.split('`').next().unwrap_or_default();
            let context = self.table_context(offset, key);
            return Diagnostic::new(Code::SceneInvalid, span, format!("missing key `{key}` in {context}"))
                .with_label(format!("this table needs `{key}`"));
        }
        if let Some((found, expected)) = serde_mismatch(raw) {
            let message = match self.key_before(offset) {
                Some(key) => format!("`{key}` expects {expected}, found {found}"),
                None => format!("expected {expected}, found {found}"),
            };
            return Diagnostic::new(Code::SceneInvalid, span, message).with_label(format!("expected {expected}"));
        }
        let (code, label) = (Code::SceneSyntax, "invalid TOML");
        let mut lines = raw.lines().map(str::trim).filter(|l| !l.is_empty());
        let mut message = lines.next().unwrap_or("invalid TOML").to_string();
        let key = e.span().and_then(|r| self.text.get(r)).unwrap_or_default();
        if message == "duplicate key" && !key.is_empty() {
            message = format!("duplicate key `{key}`");
        }
        let mut d = Diagnostic::new(code, span, message).with_label(label);
        for line in lines {
            d = d.with_note(line.to_string());
        }
        d
    }

    /// The key of the `key = value` pair whose value holds `offset`, when it is on the same line.
    fn key_before(&self, offset: usize) -> Option<String> {
        let upto = self.text.get(..offset.min(self.text.len()))?;
        let line = &upto[upto.rfind('\n').map_or(0, |i| i + 1)..];
        let before_eq = line[..line.rfind('=')?].trim_end();
        let start =
            before_eq.rfind(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == '-')).map_or(0, |i| i + 1);
        let key = &before_eq[start..];
        (!key.is_empty()).then(|| key.to_string())
    }

    /// Names the table whose key list is `expected`.
    fn keys_context(&self, expected: &[String], offset: usize) -> String {
        let is = |keys: &[&str]| keys.len() == expected.len() && keys.iter().zip(expected).all(|(a, b)| a == b);
        if is(SCENE_KEYS) {
            "the scene's top level".into()
        } else if is(RENDER_KEYS) {
            "[render]".into()
        } else if is(VOLUME_KEYS) {
            "[[volume]]".into()
        } else if is(VIEW_KEYS) {
            "[[view]]".into()
        } else if is(CAMERA_KEYS) {
            "the `camera` of a [[view]]".into()
        } else if is(MODULE_KEYS) {
            self.table_context(offset, "path")
        } else {
            self.header_before(offset).unwrap_or_else(|| "the scene".into())
        }
    }

    /// Names the table around `offset` for an error about `key`.
    fn table_context(&self, offset: usize, key: &str) -> String {
        match self.header_before(offset) {
            Some(h) if h == "[[view]]" && (key == "path" || key == "instances") => "a module of a [[view]]".into(),
            Some(h) => h,
            None => "the scene's top level".into(),
        }
    }

    /// The last table header (`[render]`, `[[view]]`) that starts a line before `offset`.
    fn header_before(&self, offset: usize) -> Option<String> {
        let upto = self.text.get(..offset.min(self.text.len()))?;
        // Headers cover the line they are on, so include the line holding `offset`.
        let line_end = self.text[upto.len()..].find('\n').map_or(self.text.len(), |i| upto.len() + i);
        self.text[..line_end].lines().rev().find_map(|line| {
            let l = line.trim();
            let (open, close) = if l.starts_with("[[") { ("[[", "]]") } else { ("[", "]") };
            let inner = l.strip_prefix(open)?.split(close).next()?.trim();
            let ok = !inner.is_empty()
                && inner.chars().all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.' | ' ' | '"'));
            let looks_like_number = inner.chars().next().is_some_and(|c| c.is_ascii_digit() || c == '-');
            (ok && !looks_like_number && l.contains(close)).then(|| format!("{open}{inner}{close}"))
        })
    }

    fn scene(&mut self, raw: RawScene) -> Scene {
        let shared = raw.render.clone();
        let render = self.render(raw.render);
        let volumes = self.volumes(raw.volumes);
        let modules = raw.modules.into_iter().map(|m| self.module(m)).collect();
        let uniforms = self.uniforms(raw.uniforms, &render);
        let views = self.views(raw.views, shared.as_ref(), &render);
        Scene { render, volumes, modules, uniforms, views, dir: self.dir.to_path_buf(), warnings: Vec::new() }
    }

    fn render(&mut self, raw: Option<Spanned<RawRender>>) -> Render {
        let (table, r) = match raw {
            Some(r) => (self.span(&r), r.into_inner()),
            None => (Span::new(self.base, self.base), RawRender::default()),
        };
        let compositing = match &r.compositing {
            Some(c) => Located { value: *c.get_ref(), span: self.span(c) },
            None => Located { value: Compositing::Dvr, span: table },
        };
        let iso_value = r.iso_value.as_ref().map(|v| Located { value: *v.get_ref(), span: self.span(v) });
        match (&iso_value, compositing.value) {
            (None, Compositing::Iso) => {
                self.emit(
                    self.invalid(compositing.span, "`compositing = \"iso\"` needs an `iso_value`")
                        .with_label("iso-surface compositing")
                        .with_help("add `iso_value = 0.5` (a normalized data value) to [render]"),
                );
            }
            (Some(_), Compositing::Iso) => {}
            (Some(_), _) => {
                self.ignored(r.iso_value.as_ref().expect("some"), "iso_value", "unless compositing is \"iso\"")
            }
            (None, _) => {}
        }
        let iso_value = iso_value.filter(|_| compositing.value == Compositing::Iso);
        if let Some(v) = &iso_value
            && !v.value.is_finite()
        {
            self.emit(self.invalid(v.span, "`iso_value` must be a finite number"));
        }
        let shading = r.shading.as_ref().is_some_and(|s| *s.get_ref());
        let lights = match &r.lights {
            Some(list) if !shading => {
                self.ignored(list, "lights", "without `shading = true`");
                Vec::new()
            }
            Some(list) => self.names(list.get_ref(), "light"),
            None if shading => {
                let span = r.shading.as_ref().map_or(table, |s| self.span(s));
                vec![Ident { name: DEFAULT_LIGHT.into(), span }]
            }
            None => Vec::new(),
        };
        let boundary = r.boundary.as_ref().is_some_and(|b| *b.get_ref());
        let tone = r.tone.as_ref().is_some_and(|t| *t.get_ref());
        if tone && !shading {
            let span = self.span(r.tone.as_ref().expect("tone is set"));
            self.emit(
                self.invalid(span, "tone shading needs `shading = true`")
                    .with_label("tone shading modulates the lighting")
                    .with_help("add `shading = true` to [render]"),
            );
        }
        let step_size = r.step_size.as_ref().map(|s| Located { value: *s.get_ref(), span: self.span(s) });
        if let Some(s) = &step_size
            && !(s.value > 0.0 && s.value.is_finite())
        {
            self.emit(
                self.invalid(s.span, "`step_size` must be a distance greater than 0")
                    .with_label("millimetres")
                    .with_note("without `step_size`, rays step half the primary volume's smallest voxel spacing"),
            );
        }
        let max_samples = r.max_samples.as_ref().map(|s| Located { value: *s.get_ref(), span: self.span(s) });
        if let Some(m) = &max_samples
            && !(1..=MAX_SAMPLES_LIMIT).contains(&m.value)
        {
            self.emit(self.invalid(m.span, format!("`max_samples` must be between 1 and {MAX_SAMPLES_LIMIT}")));
        }
        let jitter = r.jitter.as_ref().map(|s| Located { value: *s.get_ref(), span: self.span(s) });
        if let Some(j) = &jitter
            && !(0.0..=1.0).contains(&j.value)
        {
            self.emit(self.invalid(j.span, "`jitter` must be between 0 (off) and 1 (up to one step)"));
        }
        let background = r.background.as_ref().map(|s| Located { value: *s.get_ref(), span: self.span(s) });
        if let Some(b) = &background
            && !b.value.iter().all(|c| (0.0..=1.0).contains(c))
        {
            self.emit(
                self.invalid(b.span, "`background` components must be between 0 and 1")
                    .with_label("premultiplied RGBA"),
            );
        }
        let empty_space_skipping = match &r.empty_space_skipping {
            Some(skip) if *skip.get_ref() && compositing.value != Compositing::Dvr => {
                self.ignored(skip, "empty_space_skipping", "without `compositing = \"dvr\"`");
                false
            }
            Some(skip) => *skip.get_ref(),
            None => false,
        };
        Render {
            compositing,
            iso_value,
            shading,
            lights,
            boundary,
            tone,
            empty_space_skipping,
            step_size,
            max_samples,
            jitter,
            background,
        }
    }

    /// Checks a list of instance-like names: identifiers, not keywords, no duplicates.
    fn names(&mut self, list: &[Spanned<String>], what: &str) -> Vec<Ident> {
        let mut out: Vec<Ident> = Vec::new();
        for item in list {
            let span = self.span(item);
            let name = item.get_ref().clone();
            if !self.check_name(&name, span, what) {
                continue;
            }
            if let Some(earlier) = out.iter().find(|i| i.name == name) {
                let earlier = earlier.span;
                self.emit(
                    Diagnostic::new(Code::InvalidInstance, span, format!("the {what} `{name}` is listed twice"))
                        .with_label("again here")
                        .with_secondary(earlier, "first here"),
                );
                continue;
            }
            out.push(Ident { name, span });
        }
        out
    }

    /// Reports a name that is not an identifier or is a keyword; returns whether it is fine.
    /// Instance names (volumes, lights, module instances) report E0607, other names E0702.
    fn check_name(&mut self, name: &str, span: Span, what: &str) -> bool {
        let code = if what == "uniform" { Code::SceneInvalid } else { Code::InvalidInstance };
        if !is_identifier(name) {
            self.emit(
                Diagnostic::new(code, span, format!("the {what} name `{name}` is not an identifier"))
                    .with_label("not an identifier")
                    .with_note("names are letters, digits and `_`, and do not start with a digit"),
            );
            false
        } else if KEYWORDS.contains(&name) {
            self.emit(
                Diagnostic::new(code, span, format!("the {what} name `{name}` is a VRS keyword"))
                    .with_label("a keyword")
                    .with_help("choose another name"),
            );
            false
        } else {
            true
        }
    }

    fn volumes(&mut self, raw: Vec<Spanned<RawVolume>>) -> Vec<Volume> {
        let mut out: Vec<Volume> = Vec::new();
        for v in raw {
            let span = self.span(&v);
            let v = v.into_inner();
            let name = Ident { name: v.name.get_ref().clone(), span: self.span(&v.name) };
            let name_ok = self.check_name(&name.name, name.span, "volume");
            if name_ok && let Some(earlier) = out.iter().find(|o| o.name.name == name.name) {
                let earlier = earlier.name.span;
                self.emit(
                    Diagnostic::new(Code::InvalidInstance, name.span, format!("two volumes are named `{}`", name.name))
                        .with_label("second volume with this name")
                        .with_secondary(earlier, "first here"),
                );
            }
            let role = Located { value: *v.role.get_ref(), span: self.span(&v.role) };
            if role.value == Role::Primary
                && let Some(first) = out.iter().find(|o| o.role.value == Role::Primary)
            {
                let first = first.role.span;
                self.emit(
                    self.invalid(role.span, "a scene has exactly one primary volume")
                        .with_label("a second primary volume")
                        .with_secondary(first, "the primary volume")
                        .with_help("make this one `role = \"additional\"`"),
                );
            }
            let source = match (v.path, v.phantom) {
                (Some(path), None) => VolumeSource::File(self.file_ref(&path, "path")),
                (None, Some(p)) => {
                    let span = self.span(&p);
                    if !is_identifier(p.get_ref()) {
                        self.emit(
                            self.invalid(span, format!("the phantom name `{}` is not an identifier", p.get_ref())),
                        );
                    }
                    VolumeSource::Phantom(Located { value: p.into_inner(), span })
                }
                (Some(path), Some(p)) => {
                    let span = self.span(&p);
                    self.emit(
                        self.invalid(span, "a volume has either `path` or `phantom`, not both")
                            .with_label("second source")
                            .with_secondary(self.span(&path), "the volume's file"),
                    );
                    VolumeSource::File(self.file_ref(&path, "path"))
                }
                (None, None) => {
                    self.emit(
                        self.invalid(name.span, format!("the volume `{}` has no data", name.name))
                            .with_label("neither `path` nor `phantom`")
                            .with_help("add `path = \"FILE\"` (relative to the scene) or `phantom = \"NAME\"`"),
                    );
                    VolumeSource::Phantom(Located { value: String::new(), span })
                }
            };
            let fallback = match (v.fallback, &source) {
                (Some(f), VolumeSource::Phantom(_)) => {
                    self.ignored(&f, "fallback", "on a volume that is a phantom");
                    None
                }
                (Some(f), _) => {
                    let span = self.span(&f);
                    if !is_identifier(f.get_ref()) {
                        self.emit(
                            self.invalid(span, format!("the phantom name `{}` is not an identifier", f.get_ref())),
                        );
                    }
                    Some(Located { value: f.into_inner(), span })
                }
                (None, _) => None,
            };
            let tf = match (&v.tf, role.value) {
                (Some(tf), Role::Mask) => {
                    self.ignored(tf, "tf", "on a mask volume");
                    None
                }
                (Some(tf), _) => Some(self.tf_ref(tf)),
                (None, Role::Mask) => None,
                (None, Role::Tag) => Some(TfRef::Preset(Located { value: DEFAULT_TAG_TF.into(), span: Span::DUMMY })),
                (None, _) => Some(TfRef::Preset(Located { value: DEFAULT_TF.into(), span: Span::DUMMY })),
            };
            let window = self.window(&v.window, &v.level, &v.width);
            out.push(Volume { name, role, source, fallback, tf, window, span });
        }
        if !out.iter().any(|v| v.role.value == Role::Primary) {
            let span = out.first().map_or(Span::new(self.base, self.base), |v| v.role.span);
            let mut d = self
                .invalid(span, "the scene has no primary volume")
                .with_help("give one [[volume]] `role = \"primary\"`: it defines the coordinates the rays march in");
            if out.is_empty() {
                d.label = "no [[volume]] tables".into();
            }
            self.emit(d);
        }
        out
    }

    fn tf_ref(&mut self, tf: &Spanned<String>) -> TfRef {
        let span = self.span(tf);
        let value = tf.get_ref();
        if value.is_empty() {
            self.emit(self.invalid(span, "an empty `tf`").with_help("name a preset such as `grayscale`, or a file"));
        }
        if is_identifier(value) || value.is_empty() {
            TfRef::Preset(Located { value: value.clone(), span })
        } else {
            TfRef::File(self.file_ref(tf, "tf"))
        }
    }

    fn file_ref(&mut self, path: &Spanned<String>, key: &str) -> FileRef {
        let span = self.span(path);
        let given = path.get_ref().clone();
        if given.trim().is_empty() {
            self.emit(self.invalid(span, format!("an empty `{key}`")).with_label("a path is needed here"));
        }
        let resolved = self.dir.join(&given);
        FileRef { given, resolved, span }
    }

    fn module(&mut self, raw: Spanned<RawModule>) -> ModuleRef {
        let span = self.span(&raw);
        let m = raw.into_inner();
        let path_span = self.span(&m.path);
        let source = match m.path.get_ref().strip_prefix("std::") {
            Some(name) => {
                if !is_identifier(name) {
                    self.emit(
                        self.invalid(path_span, format!("`std::{name}` does not name a standard module"))
                            .with_note("standard modules are `std::NAME`, NAME an identifier (see stdlib/README.md)"),
                    );
                }
                ModuleSource::Std(Located { value: name.to_string(), span: path_span })
            }
            None => ModuleSource::File(self.file_ref(&m.path, "path")),
        };
        let instances = m.instances.map(|list| {
            if list.get_ref().is_empty() {
                self.emit(
                    self.invalid(self.span(&list), "an empty `instances` list")
                        .with_label("instantiates nothing")
                        .with_help("list instance names, or leave `instances` out for a plain module"),
                );
            }
            self.names(list.get_ref(), "instance")
        });
        ModuleRef { source, instances, span }
    }

    fn uniforms(
        &mut self,
        raw: BTreeMap<Spanned<String>, Spanned<UniformValue>>,
        render: &Render,
    ) -> BTreeMap<String, UniformSetting> {
        let mut out = BTreeMap::new();
        let mut entries: Vec<_> = raw.into_iter().collect();
        entries.sort_by_key(|(k, _)| k.span().start);
        for (key, value) in entries {
            let name_span = self.span(&key);
            let span = self.span(&value);
            let name = key.into_inner();
            if !self.check_name(&name, name_span, "uniform") {
                continue;
            }
            if RENDER_UNIFORMS.contains(&name.as_str()) {
                let set_in_render = match name.as_str() {
                    "iso_value" => render.iso_value.as_ref().map(|v| v.span),
                    "step_size" => render.step_size.as_ref().map(|v| v.span),
                    "max_samples" => render.max_samples.as_ref().map(|v| v.span),
                    "jitter" => render.jitter.as_ref().map(|v| v.span),
                    _ => render.background.as_ref().map(|v| v.span),
                };
                if let Some(earlier) = set_in_render {
                    self.emit(
                        self.invalid(name_span, format!("`{name}` is set both in [render] and in [uniforms]"))
                            .with_label("set again here")
                            .with_secondary(earlier, "set in [render]")
                            .with_help("keep one of them"),
                    );
                    continue;
                }
            }
            let value = value.into_inner();
            if let Some(problem) = value.problem(0) {
                self.emit(self.invalid(span, format!("invalid value for the uniform `{name}`: {problem}")));
                continue;
            }
            out.insert(name, UniformSetting { value, name_span, span });
        }
        out
    }

    fn views(&mut self, raw: Vec<Spanned<RawView>>, shared: Option<&Spanned<RawRender>>, render: &Render) -> Vec<View> {
        if raw.is_empty() {
            self.emit(
                self.invalid(Span::new(self.base, self.base), "the scene has no [[view]]")
                    .with_label("nothing to render")
                    .with_help("add a view: `[[view]]`, `name = \"3d\"`, `kind = \"raycast\"`"),
            );
        }
        let mut out: Vec<View> = Vec::new();
        for v in raw {
            let span = self.span(&v);
            let v = v.into_inner();
            let name = Ident { name: v.name.get_ref().clone(), span: self.span(&v.name) };
            let name_ok = is_view_name(&name.name);
            if !name_ok {
                self.emit(
                    self.invalid(name.span, format!("the view name `{}` is not a plain file name", name.name))
                        .with_label("letters, digits, `_` and `-` only")
                        .with_note("a view's name names its output files (`NAME.wgsl`, `NAME.png`)"),
                );
            }
            if name_ok && let Some(earlier) = out.iter().find(|o| o.name.name == name.name) {
                let earlier = earlier.name.span;
                self.emit(
                    self.invalid(name.span, format!("two views are named `{}`", name.name))
                        .with_label("second view with this name")
                        .with_secondary(earlier, "first here")
                        .with_note("a view's name names its output files (`NAME.wgsl`, `NAME.png`)"),
                );
            }
            let kind = match &v.kind {
                Some(k) => Located { value: *k.get_ref(), span: self.span(k) },
                None => Located { value: ViewKind::Raycast, span: name.span },
            };
            let size = match &v.size {
                Some(s) => {
                    let [w, h] = *s.get_ref();
                    if !(1..=MAX_VIEW_SIZE).contains(&w) || !(1..=MAX_VIEW_SIZE).contains(&h) {
                        self.emit(
                            self.invalid(
                                self.span(s),
                                format!("a view's width and height must be 1 to {MAX_VIEW_SIZE}"),
                            )
                            .with_label(format!("{w} x {h} pixels")),
                        );
                    }
                    [w, h]
                }
                None => DEFAULT_VIEW_SIZE,
            };
            let mut camera = DEFAULT_CAMERA;
            let mut axis = None;
            let mut position = DEFAULT_SLICE_POSITION;
            let mut slab = 0.0;
            let mut convention = Convention::default();
            match kind.value {
                ViewKind::Raycast => {
                    if let Some(c) = &v.camera {
                        camera = self.camera(c.get_ref());
                    }
                    let slice_keys = [
                        (v.axis.as_ref().map(|a| a.span()), "axis"),
                        (v.position.as_ref().map(|p| p.span()), "position"),
                        (v.slab.as_ref().map(|s| s.span()), "slab"),
                        (v.convention.as_ref().map(|c| c.span()), "convention"),
                    ];
                    for (range, key) in slice_keys {
                        if let Some(r) = range {
                            let span = self.range(r);
                            self.ignored_at(span, key, "on a raycast view");
                        }
                    }
                }
                ViewKind::Slice => {
                    if let Some(c) = &v.camera {
                        self.ignored(c, "camera", "on a slice view");
                    }
                    match &v.axis {
                        Some(a) => axis = Some(Located { value: *a.get_ref(), span: self.span(a) }),
                        None => {
                            self.emit(
                                self.invalid(kind.span, format!("the slice view `{}` needs an `axis`", name.name))
                                    .with_label("a slice view")
                                    .with_help("add `axis = \"axial\"` (axial, coronal or sagittal: the plane's orientation in the patient)"),
                            );
                        }
                    }
                    if let Some(p) = &v.position {
                        position = *p.get_ref();
                        if !(0.0..=1.0).contains(&position) {
                            self.emit(
                                self.invalid(self.span(p), "a slice `position` must be between 0 and 1")
                                    .with_label("normalized along the axis"),
                            );
                        }
                    }
                    if let Some(s) = &v.slab {
                        slab = *s.get_ref();
                        if !(slab >= 0.0 && slab.is_finite()) {
                            self.emit(
                                self.invalid(self.span(s), "a `slab` thickness must be 0 or more")
                                    .with_label("millimetres"),
                            );
                        }
                    }
                    if let Some(c) = &v.convention {
                        convention = *c.get_ref();
                    }
                }
            }
            let modules = v.modules.into_iter().map(|m| self.module(m)).collect();
            let render = match &v.render {
                Some(own) => self.view_render(shared, own),
                None => render.clone(),
            };
            out.push(View { name, kind, size, camera, axis, position, slab, convention, render, modules, span });
        }
        out
    }

    fn camera(&mut self, c: &RawCamera) -> Camera {
        let mut out = DEFAULT_CAMERA;
        for (field, key, slot) in [
            (&c.azimuth, "azimuth", &mut out.azimuth),
            (&c.elevation, "elevation", &mut out.elevation),
            (&c.distance, "distance", &mut out.distance),
            (&c.fov, "fov", &mut out.fov),
        ] {
            let Some(value) = field else { continue };
            let x = *value.get_ref();
            *slot = x;
            let problem = match key {
                "distance" if !(x > 0.0 && x.is_finite()) => Some("the camera `distance` must be greater than 0"),
                "fov" if !(x > 0.0 && x < 180.0) => Some("the camera `fov` must be between 0 and 180 degrees"),
                _ if !x.is_finite() => Some("camera angles must be finite numbers"),
                _ => None,
            };
            if let Some(problem) = problem {
                self.emit(self.invalid(self.span(value), problem).with_label(format!("{key} = {x}")));
            }
        }
        out
    }
}

/// `[A-Za-z_][A-Za-z0-9_]*`.
pub fn is_identifier(s: &str) -> bool {
    let mut chars = s.chars();
    chars.next().is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// `[A-Za-z0-9_-]+`: a view name, which names output files (`3d` is fine).
pub fn is_view_name(s: &str) -> bool {
    !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

/// Splits serde's "invalid type: FOUND, expected EXPECTED" (and "invalid value: ...",
/// "invalid length N, expected ...") into plain words: (found, expected).
fn serde_mismatch(message: &str) -> Option<(String, String)> {
    let (found, expected) = if let Some(rest) = message.strip_prefix("invalid type: ") {
        rest.split_once(", expected ")?
    } else if let Some(rest) = message.strip_prefix("invalid value: ") {
        rest.split_once(", expected ")?
    } else if let Some(rest) = message.strip_prefix("invalid length ") {
        let (n, expected) = rest.split_once(", expected ")?;
        let found = if n == "1" { "1 element".to_string() } else { format!("{n} elements") };
        return Some((found, plain_type(expected)));
    } else {
        return None;
    };
    let found = found.replace("map", "a table").replace("sequence", "an array");
    Some((found, plain_type(expected)))
}

/// Serde's and Rust's type words as a scene author reads them.
fn plain_type(expected: &str) -> String {
    match expected {
        "u32" => "a whole number, 0 or more".into(),
        "f32" | "f64" => "a number".into(),
        "a sequence" => "an array".into(),
        "a boolean" => "`true` or `false`".into(),
        other => other.replace("a sequence", "an array").replace("an array of length", "an array of"),
    }
}

/// The backticked words of a serde "expected one of `a`, `b`" tail.
fn backticked(s: &str) -> Vec<String> {
    s.split('`').skip(1).step_by(2).map(String::from).collect()
}

fn quote_list(items: &[String]) -> String {
    items.iter().map(|i| format!("`{i}`")).collect::<Vec<_>>().join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::source::SourceMap;

    const EXAMPLE: &str = r#"[render]
compositing = "dvr"            # dvr | mip | iso (iso takes `iso_value`)
shading = true                 # activates gradient + lighting steps of the standard library
lights = ["key"]               # one substep of shading.lights per name

[[volume]]
name = "t1"                    # an identifier; the instance name of this volume's functions
role = "primary"               # primary | additional | mask | tag
path = "t1.nii.gz"             # relative to the scene file; or `phantom = "NAME"` for a built-in one
tf = "grayscale"               # a built-in transfer function preset, or a path to a transfer function file

[[module]]                     # shared by every view
path = "clip_plane.vrs"
instances = ["gm"]             # for a template; omitted for a plain module

[uniforms]                     # initial values, by uniform name
clip_plane_gm = [1.0, 0.0, 0.0, -0.5]

[[view]]
name = "3d"
kind = "raycast"               # raycast | slice
size = [512, 512]
camera = { azimuth = 30.0, elevation = 20.0, distance = 2.5 }
modules = [{ path = "compose_3d.vrs" }]      # only this view

[[view]]
name = "axial"
kind = "slice"
axis = "z"                     # x | y | z
position = 0.5                 # normalized
modules = [{ path = "compose_2d.vrs" }]
"#;

    /// Parses `text` as `scenes/test.toml` in a fresh source map.
    fn parse(text: &str) -> (SourceMap, Result<Scene, SceneError>) {
        let mut map = SourceMap::new();
        map.add("x.vrs", None, "// another file first, so bases are not 0\n".into());
        let id = map.add("scenes/test.toml", None, text.to_string());
        let result = parse_scene(&map, id);
        (map, result)
    }

    /// The errors of a scene that must fail, as (code, line, column, message).
    fn errors(text: &str) -> Vec<(&'static str, usize, usize, String)> {
        let (map, result) = parse(text);
        let err = result.expect_err("the scene should not validate");
        err.diagnostics
            .iter()
            .filter(|d| d.is_error())
            .map(|d| {
                let (_, p) = map.position(d.span.start).expect("the span is in the file");
                (d.code.as_str(), p.line, p.column, d.message.clone())
            })
            .collect()
    }

    const MINIMAL: &str =
        "[[volume]]\nname = \"v\"\nrole = \"primary\"\nphantom = \"sphere\"\n\n[[view]]\nname = \"3d\"\n";

    #[test]
    fn the_spec_example_parses() {
        let (map, result) = parse(EXAMPLE);
        let scene = result.unwrap_or_else(|e| panic!("{:?}", e.diagnostics));
        assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
        assert_eq!(scene.render.compositing.value, Compositing::Dvr);
        assert!(scene.render.shading);
        assert_eq!(scene.render.lights.iter().map(|l| l.name.as_str()).collect::<Vec<_>>(), ["key"]);
        assert_eq!(map.snippet(scene.render.lights[0].span), "\"key\"");
        let t1 = scene.primary();
        assert_eq!(t1.name.name, "t1");
        match &t1.source {
            VolumeSource::File(f) => {
                assert_eq!(f.given, "t1.nii.gz");
                assert_eq!(f.resolved, Path::new("scenes/t1.nii.gz"));
                assert_eq!(map.snippet(f.span), "\"t1.nii.gz\"");
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(&t1.tf, Some(TfRef::Preset(p)) if p.value == "grayscale"));
        assert_eq!(scene.modules.len(), 1);
        let m = &scene.modules[0];
        assert!(matches!(&m.source, ModuleSource::File(f) if f.resolved == Path::new("scenes/clip_plane.vrs")));
        assert_eq!(m.instances.as_ref().map(|i| i[0].name.as_str()), Some("gm"));
        let clip = &scene.uniforms["clip_plane_gm"];
        assert_eq!(clip.value.shape(), [4]);
        assert_eq!(clip.value.flatten(), [1.0, 0.0, 0.0, -0.5]);
        assert_eq!(map.snippet(clip.name_span), "clip_plane_gm");
        assert_eq!(scene.views.len(), 2);
        let v3 = &scene.views[0];
        assert_eq!((v3.name.name.as_str(), v3.kind.value, v3.size), ("3d", ViewKind::Raycast, [512, 512]));
        assert_eq!(v3.camera, Camera { azimuth: 30.0, elevation: 20.0, distance: 2.5, fov: 30.0 });
        assert!(matches!(&v3.modules[0].source, ModuleSource::File(f) if f.given == "compose_3d.vrs"));
        let axial = scene.view("axial").expect("axial view");
        assert_eq!(axial.kind.value, ViewKind::Slice);
        assert_eq!(axial.axis.as_ref().map(|a| a.value), Some(Axis::Z));
        assert_eq!((axial.position, axial.slab, axial.size), (0.5, 0.0, DEFAULT_VIEW_SIZE));
        let values = scene.uniform_values();
        assert!(!values.contains_key("max_samples"), "without `max_samples` the runtime derives it");
        assert!(values.contains_key("clip_plane_gm"));
    }

    #[test]
    fn standard_modules_follow_the_configuration() {
        let (_, result) = parse(EXAMPLE);
        let scene = result.expect("valid");
        let names = |view: &str| {
            scene.standard_modules(scene.view(view).expect("view")).iter().map(|m| m.name).collect::<Vec<_>>()
        };
        assert_eq!(
            names("3d"),
            [
                "raycast",
                "march",
                "background",
                "sample_primary",
                "gradient",
                "classify",
                "light",
                "composite",
                "lighting",
                "composite_dvr"
            ]
        );
        assert_eq!(names("axial")[0], "slice");
        let text = format!(
            "[render]\ncompositing = \"iso\"\niso_value = 0.3\n{MINIMAL}\n[[volume]]\nname = \"gm\"\nrole = \"additional\"\nphantom = \"ball\"\n[[volume]]\nname = \"brain\"\nrole = \"mask\"\npath = \"m.nii\"\n"
        );
        let (_, result) = parse(&text);
        let scene = result.unwrap_or_else(|e| panic!("{:?}", e.diagnostics));
        let modules = scene.standard_modules(&scene.views[0]);
        let find = |n: &str| modules.iter().find(|m| m.name == n).map(|m| m.instances.clone());
        assert_eq!(find("sample_volume"), Some(vec!["gm".to_string()]));
        assert_eq!(find("mask"), Some(vec!["brain".to_string()]));
        assert_eq!(find("composite_iso"), Some(vec![]));
        assert_eq!(find("composite_volume"), None);
        assert_eq!(find("gradient"), None);
        assert_eq!(scene.uniform_values()["iso_value"], UniformValue::Float(f64::from(0.3f32)));
    }

    #[test]
    fn every_standard_module_exists() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../stdlib");
        let text = format!(
            "[render]\nshading = true\nboundary = true\ntone = true\n{MINIMAL}\n[[volume]]\nname = \"a\"\nrole = \"additional\"\nphantom = \"p\"\n[[volume]]\nname = \"m\"\nrole = \"mask\"\nphantom = \"p\"\n[[volume]]\nname = \"t\"\nrole = \"tag\"\nphantom = \"p\"\n"
        );
        for mode in ["dvr", "mip", "iso"] {
            let text =
                text.replace("shading = true", &format!("shading = true\ncompositing = \"{mode}\"\niso_value = 0.5"));
            let (_, result) = parse(&text);
            let scene = result.unwrap_or_else(|e| panic!("{:?}", e.diagnostics));
            for kind in [ViewKind::Raycast, ViewKind::Slice] {
                let mut view = scene.views[0].clone();
                view.kind.value = kind;
                for m in scene.standard_modules(&view) {
                    assert!(dir.join(format!("{}.vrs", m.name)).is_file(), "stdlib/{}.vrs is missing", m.name);
                }
            }
        }
    }

    #[test]
    fn the_step_size_default_matches_the_stdlib() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../stdlib");
        for file in ["raycast.vrs", "slice.vrs"] {
            let text = std::fs::read_to_string(dir.join(file)).expect("stdlib file");
            assert!(
                text.contains(&format!("uniform step_size: f32 = {DEFAULT_STEP_SIZE}")),
                "{file} declares another step_size default than DEFAULT_STEP_SIZE"
            );
        }
    }

    #[test]
    fn unknown_keys_point_at_the_key() {
        let text = EXAMPLE.replace("camera = {", "camra = {");
        let errs = errors(&text);
        assert_eq!(errs.len(), 1, "{errs:?}");
        let (code, line, column, message) = &errs[0];
        assert_eq!((*code, *line, *column), ("E0703", 23, 1));
        assert_eq!(message, "unknown key `camra` in [[view]]");
        let (_, result) = parse(&text);
        let d = &result.expect_err("invalid").diagnostics[0];
        assert!(d.notes.iter().any(|n| n.contains("did you mean `camera`?")), "{:?}", d.notes);
        assert!(d.notes.iter().any(|n| n.starts_with("expected one of `name`, `kind`")), "{:?}", d.notes);

        let errs = errors(&EXAMPLE.replace("azimuth = 30.0", "azimut = 30.0"));
        assert_eq!(errs[0].3, "unknown key `azimut` in the `camera` of a [[view]]");
        assert_eq!((errs[0].1, errs[0].2), (23, 12));

        let errs = errors(&EXAMPLE.replace("shading = true", "shadows = true"));
        assert_eq!((errs[0].0, errs[0].1, errs[0].3.as_str()), ("E0703", 3, "unknown key `shadows` in [render]"));

        let errs = errors(&format!("{MINIMAL}modules = [{{ path = \"a.vrs\", instance = [\"x\"] }}]\n"));
        assert_eq!(errs[0].3, "unknown key `instance` in a module of a [[view]]");

        let errs = errors(&format!("{MINIMAL}[[module]]\npaths = \"a.vrs\"\n"));
        assert_eq!(errs[0].3, "unknown key `paths` in [[module]]");

        let errs = errors(&format!("title = \"x\"\n{MINIMAL}"));
        assert_eq!((errs[0].1, errs[0].3.as_str()), (1, "unknown key `title` in the scene's top level"));
    }

    #[test]
    fn a_missing_primary_volume_is_an_error() {
        let errs = errors(&EXAMPLE.replace("role = \"primary\"", "role = \"additional\""));
        assert_eq!(errs.len(), 1, "{errs:?}");
        assert_eq!((errs[0].0, errs[0].1, errs[0].3.as_str()), ("E0702", 8, "the scene has no primary volume"));

        let errs = errors(&format!("{MINIMAL}[[volume]]\nname = \"w\"\nrole = \"primary\"\nphantom = \"sphere\"\n"));
        assert_eq!((errs[0].1, errs[0].3.as_str()), (10, "a scene has exactly one primary volume"));

        let errs = errors("[[view]]\nname = \"3d\"\n");
        assert_eq!(errs[0].3, "the scene has no primary volume");
    }

    #[test]
    fn duplicate_names_are_errors() {
        let errs = errors(&EXAMPLE.replace("name = \"axial\"", "name = \"3d\""));
        assert_eq!(errs.len(), 1, "{errs:?}");
        assert_eq!((errs[0].0, errs[0].1, errs[0].2), ("E0702", 27, 8));
        assert_eq!(errs[0].3, "two views are named `3d`");
        let (_, result) = parse(&EXAMPLE.replace("name = \"axial\"", "name = \"3d\""));
        let d = &result.expect_err("invalid").diagnostics[0];
        assert_eq!(d.secondary.len(), 1);

        let errs = errors(&format!("{MINIMAL}[[volume]]\nname = \"v\"\nrole = \"tag\"\nphantom = \"x\"\n"));
        assert_eq!((errs[0].0, errs[0].3.as_str()), ("E0607", "two volumes are named `v`"));

        let errs = errors(&EXAMPLE.replace("lights = [\"key\"]", "lights = [\"key\", \"fill\", \"key\"]"));
        assert_eq!(errs[0].3, "the light `key` is listed twice");
    }

    #[test]
    fn bad_enum_values_point_at_the_value() {
        let errs = errors(&EXAMPLE.replace("compositing = \"dvr\"", "compositing = \"dvrr\""));
        assert_eq!(errs.len(), 1, "{errs:?}");
        assert_eq!((errs[0].0, errs[0].1, errs[0].2), ("E0702", 2, 15));
        assert_eq!(errs[0].3, "`dvrr` is not one of `dvr`, `mip`, `iso`, `minip`, `average`");

        let errs = errors(&EXAMPLE.replace("axis = \"z\"", "axis = \"w\""));
        assert_eq!(
            (errs[0].1, errs[0].3.as_str()),
            (29, "`w` is not one of `sagittal`, `x`, `coronal`, `y`, `axial`, `z`")
        );
    }

    #[test]
    fn bad_values_and_syntax() {
        let errs = errors(&EXAMPLE.replace("size = [512, 512]", "size = [512, 0]"));
        assert_eq!((errs[0].0, errs[0].1, errs[0].2), ("E0702", 22, 8));

        let errs = errors(&EXAMPLE.replace("size = [512, 512]", "size = [512]"));
        assert_eq!((errs[0].0, errs[0].1), ("E0702", 22));

        let errs = errors(&EXAMPLE.replace("shading = true", "shading = \"yes\""));
        assert_eq!((errs[0].0, errs[0].1), ("E0702", 3));

        let errs = errors(&EXAMPLE.replace("[render]", "[render"));
        assert_eq!((errs[0].0, errs[0].1), ("E0701", 1));

        let errs = errors(&EXAMPLE.replace("name = \"t1\"", "name = \"t1\"\nname = \"t2\""));
        assert_eq!((errs[0].0, errs[0].1), ("E0701", 8));

        let errs = errors(&EXAMPLE.replace("name = \"t1\"", "name = \"1t\""));
        assert_eq!(
            (errs[0].0, errs[0].1, errs[0].3.as_str()),
            ("E0607", 7, "the volume name `1t` is not an identifier")
        );

        let errs = errors(&EXAMPLE.replace("instances = [\"gm\"]", "instances = [\"g-m\", \"if\"]"));
        assert_eq!(errs.len(), 2, "{errs:?}");

        let errs = errors(&EXAMPLE.replace("path = \"t1.nii.gz\"", "path = \"t1.nii.gz\"\nphantom = \"ball\""));
        assert_eq!(errs[0].3, "a volume has either `path` or `phantom`, not both");

        let errs = errors(&EXAMPLE.replace("path = \"t1.nii.gz\"", ""));
        assert_eq!(errs[0].3, "the volume `t1` has no data");

        let errs = errors(&EXAMPLE.replace("role = \"primary\"", ""));
        assert_eq!((errs[0].1, errs[0].3.as_str()), (6, "missing key `role` in [[volume]]"));

        let errs = errors(&EXAMPLE.replace("axis = \"z\"", ""));
        assert_eq!((errs[0].1, errs[0].3.as_str()), (28, "the slice view `axial` needs an `axis`"));

        let errs = errors(&EXAMPLE.replace("clip_plane_gm = [1.0, 0.0, 0.0, -0.5]", "clip_plane_gm = \"x\""));
        assert_eq!((errs[0].0, errs[0].1), ("E0702", 17));

        let errs = errors(&EXAMPLE.replace("clip_plane_gm = [1.0, 0.0, 0.0, -0.5]", "clip_plane_gm = [1.0, [0.0]]"));
        assert_eq!((errs[0].0, errs[0].1, errs[0].2), ("E0702", 17, 17));

        let errs = errors(&EXAMPLE.replace("compositing = \"dvr\"", "compositing = \"iso\""));
        assert_eq!((errs[0].1, errs[0].3.as_str()), (2, "`compositing = \"iso\"` needs an `iso_value`"));

        let errs = errors(
            &EXAMPLE
                .replace("[uniforms]", "[uniforms]\nstep_size = 0.01")
                .replace("shading = true", "shading = true\nstep_size = 0.002"),
        );
        assert_eq!(errs[0].3, "`step_size` is set both in [render] and in [uniforms]");
    }

    #[test]
    fn keys_without_effect_are_warnings() {
        let text = EXAMPLE
            .replace("kind = \"raycast\"", "kind = \"raycast\"\naxis = \"x\"")
            .replace("position = 0.5", "position = 0.5\ncamera = { fov = 20.0 }");
        let (map, result) = parse(&text);
        let scene = result.unwrap_or_else(|e| panic!("{:?}", e.diagnostics));
        let w: Vec<_> = scene
            .warnings
            .iter()
            .map(|d| (d.code.as_str(), map.position(d.span.start).expect("in file").1.line, d.message.as_str()))
            .collect();
        assert_eq!(
            w,
            [
                ("W0701", 22, "`axis` has no effect on a raycast view"),
                ("W0701", 32, "`camera` has no effect on a slice view")
            ]
        );
    }

    #[test]
    fn defaults() {
        let (_, result) = parse(MINIMAL);
        let scene = result.unwrap_or_else(|e| panic!("{:?}", e.diagnostics));
        let r = &scene.render;
        assert_eq!(r.compositing.value, Compositing::Dvr);
        assert!(!r.shading && r.lights.is_empty() && !r.boundary && !r.tone);
        assert!(r.max_samples.is_none() && r.step_size.is_none());
        let v = &scene.views[0];
        assert_eq!((v.kind.value, v.size, v.camera), (ViewKind::Raycast, DEFAULT_VIEW_SIZE, DEFAULT_CAMERA));
        let (_, result) = parse(&format!("[render]\nshading = true\n{MINIMAL}"));
        assert_eq!(result.expect("valid").render.lights[0].name, "key");
    }

    #[test]
    fn standard_module_paths_and_tf_files() {
        let text = MINIMAL.replace("phantom = \"sphere\"", "phantom = \"sphere\"\ntf = \"tfs/bone.json\"")
            + "modules = [{ path = \"std::tone\" }]\n";
        let (_, result) = parse(&text);
        let scene = result.unwrap_or_else(|e| panic!("{:?}", e.diagnostics));
        assert!(matches!(&scene.primary().tf, Some(TfRef::File(f)) if f.resolved == Path::new("scenes/tfs/bone.json")));
        assert!(matches!(&scene.views[0].modules[0].source, ModuleSource::Std(n) if n.value == "tone"));
        let errs = errors(&(MINIMAL.to_string() + "modules = [{ path = \"std::no such\" }]\n"));
        assert_eq!(errs[0].3, "`std::no such` does not name a standard module");
    }

    #[test]
    fn a_volume_window_is_lo_hi_or_level_width_in_data_units() {
        let with = |keys: &str| MINIMAL.replace("phantom = \"sphere\"", &format!("phantom = \"sphere\"\n{keys}"));
        let window = |keys: &str| {
            let (_, result) = parse(&with(keys));
            result.unwrap_or_else(|e| panic!("{:?}", e.diagnostics)).primary().window.as_ref().map(|w| w.value)
        };
        assert_eq!(window(""), None);
        assert_eq!(window("window = [-1000, 400.5]"), Some([-1000.0, 400.5]));
        assert_eq!(window("level = 40\nwidth = 400"), Some([-160.0, 240.0]));
        let message = |keys: &str| errors(&with(keys))[0].3.clone();
        assert_eq!(message("window = [5, 5]"), "the window [5, 5] must have its low end below its high end");
        assert_eq!(message("level = 40"), "`level` needs `width`");
        assert_eq!(message("width = 40"), "`width` needs `level`");
        assert_eq!(message("level = 40\nwidth = 0"), "the window `width` must be positive, not 0");
        assert_eq!(
            message("window = [0, 1]\nlevel = 1\nwidth = 2"),
            "a volume has either `window` or `level` and `width`, not both"
        );
    }

    #[test]
    fn garbage_never_panics() {
        for text in ["", "[", "[[view]]\nname = 3", "x = [[[[[[1]]]]]]", "\u{feff}[render]\n", "[uniforms]\na = 1e999"]
        {
            let _ = parse(text);
        }
    }
}
