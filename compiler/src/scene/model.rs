//! The typed scene, and what later passes ask of it.

use super::*;
use std::fmt;

// ---------------------------------------------------------------------------------------------
// The typed scene.

/// A value with the span of its TOML value.
#[derive(Clone, Debug, PartialEq)]
pub struct Located<T> {
    /// The value as validated.
    pub value: T,
    /// Where the value is written in the scene file (global offsets), for diagnostics; a
    /// default the file does not write carries a nearby span (its table's, its name's) or
    /// [`Span::DUMMY`].
    pub span: Span,
}

/// A parsed and validated scene.
#[derive(Clone, Debug)]
pub struct Scene {
    /// `[render]`: the settings every view starts from.
    pub render: Render,
    /// `[[volume]]` tables, in file order.
    pub volumes: Vec<Volume>,
    /// `[[module]]` tables: modules shared by every view, in file order.
    pub modules: Vec<ModuleRef>,
    /// `[uniforms]`: initial values by uniform name.
    pub uniforms: BTreeMap<String, UniformSetting>,
    /// `[[view]]` tables, in file order.
    pub views: Vec<View>,
    /// `[[mesh]]` tables, in file order.
    pub meshes: Vec<Mesh>,
    /// `[[group]]` tables, in file order: the inner nodes of the views' renderer trees.
    pub groups: Vec<Group>,
    /// `[[image]]` tables, in file order: picture files on rectangles, leaves of renderer trees.
    pub images: Vec<Image>,
    /// The filters among groups' children, in file order ([`Node::Filter`] indexes them).
    pub tree_filters: Vec<ModuleRef>,
    /// `[render] memory` and `host_memory`: what bricked volumes may hold.
    pub memory: Memory,
    /// The directory that relative paths were resolved against.
    pub dir: PathBuf,
}

/// The memory budgets of bricked volumes (bytes): bricks beyond them are evicted, least
/// recently used first.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Memory {
    /// `[render] memory`: the GPU's brick pools, every bricked volume together.
    pub gpu: u64,
    /// `[render] host_memory`: bricks kept in the host's memory once read.
    pub host: u64,
}

impl Memory {
    /// Without `memory`: 1 GiB of bricks on the GPU.
    pub const DEFAULT_GPU: u64 = 1 << 30;
    /// Without `host_memory`: 1 GiB of bricks in host memory.
    pub const DEFAULT_HOST: u64 = 1 << 30;
}

impl Default for Memory {
    fn default() -> Memory {
        Memory { gpu: Memory::DEFAULT_GPU, host: Memory::DEFAULT_HOST }
    }
}

/// `[render]`: how every view composites and shades.
#[derive(Clone, Debug)]
pub struct Render {
    /// `compositing = "dvr" | "mip" | "minip" | "average" | "iso"`: how samples along a ray
    /// combine; `dvr` without the key.
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
    /// Empty-space skipping in raycast views (`std::skip`, `std::skip_mip`, `std::skip_iso`):
    /// `render.empty_space_skipping`, by default on for DVR, MIP and iso.
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
    /// High-dynamic-range light and its tone operator (`std::hdr`, `std::tonemap_*`).
    pub tone_mapping: ToneMapping,
    /// Initial value of the `exposure` uniform (stops); only with tone mapping.
    pub exposure: Option<Located<f32>>,
    /// Automatic exposure from the scene's log-average luminance (`std::auto_exposure`); only
    /// with tone mapping.
    pub auto_exposure: bool,
    /// Initial value of the `white_point` uniform; only with Reinhard's operator.
    pub white_point: Option<Located<f32>>,
    /// Pre-integration of the primary volume over each ray segment (`std::preintegrate`, and
    /// with lighting `std::preintegrate_lighting`); DVR only.
    pub preintegration: Preintegration,
    /// Volumetric shadows of the lights (`std::shadow_ray`); needs shading.
    pub shadows: Shadows,
    /// Local ambient occlusion (`std::occlusion`): the ambient light scaled by how open the
    /// sample's vicinity is; needs shading.
    pub ambient_occlusion: bool,
}

/// `[render] preintegration`: what is integrated over the ray segment between two samples
/// rather than taken at the sample. Written `false`, `true` (the same as `"classification"`)
/// or `"lighting"`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Preintegration {
    /// Every sample is classified and lit on its own (point sampling).
    #[default]
    Off,
    /// The segment's colour and opacity from a pre-integrated table (Engel et al. 2001); it is
    /// lit at its back sample.
    Classification,
    /// Classification as above, and the segment's light interpolated between its front and
    /// back samples' (Lum, Wilson and Ma 2004); needs shading.
    Lighting,
}

impl<'de> Deserialize<'de> for Preintegration {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl serde::de::Visitor<'_> for Visitor {
            type Value = Preintegration;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("`true`, `false`, \"classification\" or \"lighting\"")
            }
            fn visit_bool<E: serde::de::Error>(self, on: bool) -> Result<Preintegration, E> {
                Ok(if on { Preintegration::Classification } else { Preintegration::Off })
            }
            fn visit_str<E: serde::de::Error>(self, text: &str) -> Result<Preintegration, E> {
                match text {
                    "classification" => Ok(Preintegration::Classification),
                    "lighting" => Ok(Preintegration::Lighting),
                    _ => Err(E::unknown_variant(text, &["true", "false", "classification", "lighting"])),
                }
            }
        }
        deserializer.deserialize_any(Visitor)
    }
}

/// `[render] tone_mapping`: how linear radiance is mapped to the display.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ToneMapping {
    /// No HDR: colours are display values throughout, stored as composited.
    #[default]
    Off,
    /// Exposure, clipped at white.
    Exposure,
    /// Reinhard's global operator with a white point.
    Reinhard,
    /// A filmic curve (Narkowicz's ACES fit).
    Aces,
}

/// `[render] shadows`: how light is attenuated on its way to a sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Shadows {
    /// Lights reach every sample unattenuated.
    #[default]
    Off,
    /// A shadow ray per sample and light through the primary volume (reference quality).
    Rays,
    /// A light volume per light, computed when the light or the transfer function changes,
    /// read once per sample and light (interactive).
    Volume,
}

/// `[render] compositing`.
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
    /// A progressive Monte Carlo path tracer (cinematic rendering): raycast views only.
    Pathtrace,
}

/// A volume's `role`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// The volume every view is built on: its box and spacing place the views and set the
    /// step size. A scene has exactly one.
    Primary,
    /// Another data set, sampled in patient space, classified by its own transfer function and
    /// composited with the primary (`std::sample_volume`, `std::classify_volume`).
    Additional,
    /// A mask: where it is below the `mask_threshold_NAME` uniform the primary volume is hidden
    /// (`std::mask`); it has no transfer function.
    Mask,
    /// A label volume: its transfer function (`labels` by default) gives each label a colour
    /// that tints the primary colour (`std::tag`).
    Tag,
}

/// `[[volume]]`: a data set and how it is classified.
#[derive(Clone, Debug)]
pub struct Volume {
    /// The instance name of this volume's template functions (`value_t1`, `tf_t1`).
    pub name: Ident,
    /// `role`: what the volume is to the views.
    pub role: Located<Role>,
    /// `path` or `phantom`: where the samples come from.
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
    /// `bricks = true | false`: the user's choice of bricked storage, if made.
    pub bricks: Option<Located<bool>>,
    /// Whether the runtime keeps the volume in bricks (a page table over a brick pool, streamed
    /// and multi-resolution) rather than one texture: `bricks` when given, else for Zarr stores
    /// ([`is_zarr`]); the runtime also bricks a volume whose file is too large for one texture
    /// before it composes. What `vrsc explain` shows.
    pub bricked: bool,
    /// `lookup = "FILE.wgsl"`: the volume's own brick lookup in place of `stdlib/bricks.wgsl`
    /// (same interface), when it is bricked.
    pub lookup: Option<FileRef>,
    /// `labels = true | false` on a tag volume: whether its values are label ids (sampled at
    /// the nearest voxel, each id its own colour); `None`: the runtime decides (an OME-Zarr
    /// label image, one with `image-label` metadata, is one). Only tag volumes have it.
    pub labels: Option<Located<bool>>,
    /// What of a Zarr store the volume shows (`multiscale`, `channel`, `time`).
    pub zarr: ZarrKeys,
    /// The whole `[[volume]]` table.
    pub span: Span,
}

impl Volume {
    /// The name of the volume's resource in a view's shader: `volume` for the primary volume,
    /// `volume_NAME` for the others.
    pub fn binding(&self) -> String {
        if self.role.value == Role::Primary { "volume".to_string() } else { format!("volume_{}", self.name.name) }
    }
}

/// Whether `path` is a Zarr store (an array or an OME-Zarr group): a `.zarr` directory, or one
/// with Zarr metadata (`zarr.json`, `.zarray`, `.zgroup`).
pub fn is_zarr(path: &std::path::Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("zarr"))
        || ["zarr.json", ".zarray", ".zgroup"].iter().any(|m| path.join(m).is_file())
}

/// `multiscale`, `channel` and `time` of a `[[volume]]` table: what of a Zarr store it shows.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ZarrKeys {
    /// The OME multiscale (the first when absent).
    pub multiscale: Option<Located<Entry>>,
    /// The channel, by index or by its `omero` label.
    pub channel: Option<Located<Entry>>,
    /// The time point.
    pub time: Option<Located<u64>>,
}

/// An entry of a store's list: its index or its name.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Entry {
    /// A number: the 0-based index in the store's list.
    Index(u64),
    /// A string: the entry's name (a multiscale's `name`, a channel's `omero` label).
    Name(String),
}

/// Whether `path` names a remote store: it has a URL scheme (`https://`, `s3://`, ...).
pub fn is_url(path: &str) -> bool {
    path.split_once("://").is_some_and(|(scheme, _)| {
        !scheme.is_empty() && scheme.chars().all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c))
    })
}

/// Where a volume's samples come from.
#[derive(Clone, Debug, PartialEq)]
pub enum VolumeSource {
    /// `path = "..."`.
    File(FileRef),
    /// `path = "https://..."`: a Zarr store served over HTTP(S).
    Url(Located<String>),
    /// `phantom = "NAME"`: a built-in data set of the runtime.
    Phantom(Located<String>),
}

/// A volume's transfer function: a preset name or a file.
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
    /// The path exactly as the scene writes it (what messages quote).
    pub given: String,
    /// The path to open: `given` joined to the scene file's directory when relative.
    pub resolved: PathBuf,
    /// The string's span in the scene file.
    pub span: Span,
}

/// A module to compose: `[[module]]`, or an entry of a view's `modules`.
#[derive(Clone, Debug)]
pub struct ModuleRef {
    /// `path`: a standard module or a file.
    pub source: ModuleSource,
    /// Instance names for a template module; `None` for a plain module.
    pub instances: Option<Vec<Ident>>,
    /// The whole table.
    pub span: Span,
}

/// Where a module comes from: a standard module or a file.
#[derive(Clone, Debug, PartialEq)]
pub enum ModuleSource {
    /// `path = "std::NAME"`: the standard module `NAME`.
    Std(Located<String>),
    /// Any other `path`: a VRS file, relative to the scene file.
    File(FileRef),
}

/// A view's `kind`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ViewKind {
    /// A 3D picture: rays from the orbit camera through the volumes (the default).
    Raycast,
    /// A 2D picture: a plane through the primary volume, normal to the view's `axis`.
    Slice,
}

/// A slice view's `axis`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    /// `x` or `sagittal`: the patient's left-right axis (+x towards the patient's right).
    #[serde(alias = "sagittal")]
    X,
    /// `y` or `coronal`: the posterior-anterior axis.
    #[serde(alias = "coronal")]
    Y,
    /// `z` or `axial`: the inferior-superior axis.
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
    /// `azimuth`: rotation about the patient's superior axis (degrees; 0, the default, looks
    /// from the front, anterior, towards -y).
    pub azimuth: f32,
    /// `elevation`: angle above the axial plane (degrees; 0 by default).
    pub elevation: f32,
    /// `distance` from the volume's centre, in units of its largest extent; above 0, 2.5 by
    /// default.
    pub distance: f32,
    /// `fov`: vertical field of view (degrees, between 0 and 180; 30 by default).
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
    /// `name`: `[A-Za-z0-9_-]+`, unique; it names the view's output files.
    pub name: Ident,
    /// `kind`: raycast (the default) or slice.
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
    /// `filters`: the modules of the view's filter pass, in order (empty: no filter pass). They
    /// place into the `filter.*` steps, after `std::filter_picture`.
    pub filters: Vec<ModuleRef>,
    /// The view's renderer tree: its `picture` list, or the one its `meshes`, `planes` and
    /// `overlay` lists make.
    pub picture: Picture,
    /// The whole `[[view]]` table.
    pub span: Span,
}

/// A view's picture: the root of its renderer tree, a depth group whose children are the view's
/// volume (its composed pipeline) and the nodes around it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Picture {
    /// The nodes listed before `"volume"`, combined by depth into the mesh layer that the volume
    /// layer reads (`std::meshes`): its rays end at their opaque surfaces.
    pub under: Vec<Node>,
    /// The meshes listed after `"volume"` (indices into `Scene::meshes`): drawn over the
    /// finished picture, depth-tested among themselves only (the overlay).
    pub over: Vec<usize>,
}

/// How deep a walk down groups goes: validation refuses cycles, and a walk over a scene made by
/// hand with one must still end.
pub const MAX_GROUP_DEPTH: usize = 64;

/// A node of a renderer tree other than the view's volume.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Node {
    /// A `[[mesh]]` (index into `Scene::meshes`).
    Mesh(usize),
    /// A `[[group]]` (index into `Scene::groups`).
    Group(usize),
    /// A slice view's picture on its plane in patient space (index into `Scene::views`).
    Plane(usize),
    /// An `[[image]]` on its rectangle in patient space (index into `Scene::images`).
    Image(usize),
    /// A filter among a depth group's children (`{ filter = "PATH" }`, index into
    /// `Scene::tree_filters`): an image-space pass over the picture of the children listed
    /// before it.
    Filter(usize),
}

impl Node {
    /// Whether the node is a picture on a plane: a slice view's or an image's.
    pub fn is_plane(self) -> bool {
        matches!(self, Node::Plane(_) | Node::Image(_))
    }
}

/// `[[group]]`: an inner node of renderer trees, which combines its children's pictures (colour
/// and depth).
#[derive(Clone, Debug, PartialEq)]
pub struct Group {
    /// `name`: an identifier, unique among groups and meshes.
    pub name: Ident,
    /// `kind`, with `show` and `opacity`.
    pub kind: GroupKind,
    /// `children`: meshes, groups, images, slice views and (in depth groups) filters, in order.
    pub children: Vec<Node>,
    /// The whole table.
    pub span: Span,
}

/// How a group combines its children.
#[derive(Clone, Debug, PartialEq)]
pub enum GroupKind {
    /// `kind = "depth"` (the default): the nearest surface of any child at each pixel.
    Depth,
    /// `kind = "occlusion"`: the first child hides the others as a depth group would, except
    /// that where it hides them they show through it with `hidden_opacity`.
    Occlusion {
        /// 1 for `show = "visible"`; `opacity` (0.5 by default) for `show =
        /// "semi_transparent"`, the default.
        hidden_opacity: f32,
    },
    /// `kind = "shadow"`: its children combined by depth, lit by a directional light and
    /// shadowing each other.
    Shadow {
        /// Where the light is.
        light: ShadowLight,
    },
}

/// A shadow group's `light`.
#[derive(Clone, Debug, PartialEq)]
pub enum ShadowLight {
    /// `light = [x, y, z]`: towards the light, in patient space (not zero).
    Towards([f32; 3]),
    /// `light = "NAME"`: light NAME of the views' `lights`, following its `light_dir_NAME` in
    /// each view (from the viewer where that is (0, 0, 0), or where a view has no such light).
    Light(Ident),
}

/// `show` of an occlusion group: how the children it hides are shown.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Show {
    /// As if nothing hid them.
    Visible,
    /// Blended over what hides them with the group's `opacity`.
    SemiTransparent,
}

/// The `kind` of a `[[group]]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GroupKindName {
    /// Combined by depth.
    Depth,
    /// What the first child hides shows through it.
    Occlusion,
    /// The children cast shadows onto each other.
    Shadow,
}

/// A `[uniforms]` entry.
#[derive(Clone, Debug, PartialEq)]
pub struct UniformSetting {
    /// The initial value, not yet checked against the uniform's type.
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
    /// `true` or `false`.
    Bool(bool),
    /// A TOML integer (`3`); it also initialises a float uniform.
    Int(i64),
    /// A TOML float (`0.5`).
    Float(f64),
    /// `[...]`: a vector, or a matrix as an array of columns.
    Array(Vec<UniformValue>),
}

impl UniformValue {
    /// The value as JSON (what reflection writes and the runtime reads).
    pub fn to_json(&self) -> serde_json::Value {
        match self {
            UniformValue::Bool(b) => serde_json::Value::Bool(*b),
            UniformValue::Int(i) => (*i).into(),
            UniformValue::Float(f) => serde_json::Number::from_f64(*f).map_or(serde_json::Value::Null, Into::into),
            UniformValue::Array(items) => items.iter().map(UniformValue::to_json).collect(),
        }
    }
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
    pub(super) fn problem(&self, depth: usize) -> Option<String> {
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
    /// The resource names (`volume`, `volume_NAME`) of the volumes kept in bricks, with their
    /// own lookups (`lookup`), if any.
    pub fn bricked_bindings(&self) -> Vec<(String, Option<&FileRef>)> {
        self.volumes.iter().filter(|v| v.bricked).map(|v| (v.binding(), v.lookup.as_ref())).collect()
    }

    /// The primary volume: validation guarantees exactly one, but a scene built by hand may
    /// have none.
    pub fn primary(&self) -> Option<&Volume> {
        self.volumes.iter().find(|v| v.role.value == Role::Primary)
    }

    /// Names of the volumes with `role`, in file order.
    pub fn volume_names(&self, role: Role) -> Vec<String> {
        self.volumes.iter().filter(|v| v.role.value == role).map(|v| v.name.name.clone()).collect()
    }

    /// The view named `name`.
    pub fn view(&self, name: &str) -> Option<&View> {
        self.views.iter().find(|v| v.name.name == name)
    }

    /// Every module the scene names, in order: its `[[module]]`s, then each view's `modules`
    /// and `filters`, then the filters among groups' children.
    pub fn module_refs(&self) -> impl Iterator<Item = &ModuleRef> {
        let views = self.views.iter().flat_map(|v| v.modules.iter().chain(&v.filters));
        self.modules.iter().chain(views).chain(&self.tree_filters)
    }

    /// Where tree filter `f` is, for people and file names: `GROUP-K`, the group whose
    /// children list it and its place among them (from 1).
    pub fn tree_filter_label(&self, f: usize) -> String {
        for group in &self.groups {
            if let Some(k) = group.children.iter().position(|c| *c == Node::Filter(f)) {
                return format!("{}-{}", group.name.name, k + 1);
            }
        }
        format!("filter-{f}")
    }

    /// The filters in `view`'s tree under its volume (indices into `Scene::tree_filters`), each
    /// once, in the tree's order; none in a slice view (its tree is outlined, not combined).
    pub fn filters_under(&self, view: &View) -> Vec<usize> {
        if view.kind.value != ViewKind::Raycast {
            return Vec::new();
        }
        let filter = |node| match node {
            Node::Filter(f) => Some(f),
            _ => None,
        };
        self.nodes_under(view).into_iter().filter_map(filter).collect()
    }

    /// Every node under `view`'s volume other than groups, through its groups, each once, in the
    /// tree's order (depth first).
    fn nodes_under(&self, view: &View) -> Vec<Node> {
        let mut out = Vec::new();
        let mut stack: Vec<Node> = view.picture.under.iter().rev().copied().collect();
        let mut seen_groups = Vec::new();
        while let Some(node) = stack.pop() {
            match node {
                // Validation refuses cycles; a scene made by hand with one still ends.
                Node::Group(g) if !seen_groups.contains(&g) => {
                    seen_groups.push(g);
                    let children = self.groups.get(g).map_or(&[][..], |g| &g.children[..]);
                    stack.extend(children.iter().rev().copied());
                }
                Node::Group(_) => {}
                _ if !out.contains(&node) => out.push(node),
                _ => {}
            }
        }
        out
    }

    /// Whether `view` has a mesh layer: meshes, groups, or slice views' pictures on their planes
    /// under its volume.
    pub fn has_mesh_layer(view: &View) -> bool {
        !view.picture.under.is_empty()
    }

    /// The leaves under `view`'s volume, through its groups, each once, in the tree's order:
    /// its meshes (indices into `Scene::meshes`) and its pictures on planes (slice views and
    /// images, [`Node::Plane`] and [`Node::Image`]).
    pub fn leaves_under(&self, view: &View) -> (Vec<usize>, Vec<Node>) {
        let nodes = self.nodes_under(view);
        let meshes = nodes.iter().filter_map(|n| if let Node::Mesh(i) = n { Some(*i) } else { None }).collect();
        (meshes, nodes.into_iter().filter(|n| n.is_plane()).collect())
    }

    /// `view`'s renderer tree in one line, for people (`vrsc pipeline`): groups as
    /// `NAME (KIND) [CHILDREN]` (an occlusion group's first child apart, `|`), slice views as
    /// `NAME (plane)`, images as `NAME (image)`, then `volume`, then what is drawn over it.
    pub fn describe_picture(&self, view: &View) -> String {
        let mut parts: Vec<String> = view.picture.under.iter().map(|&n| self.describe_node(n, 0)).collect();
        parts.push("volume".into());
        let over: Vec<&str> =
            view.picture.over.iter().filter_map(|&m| self.meshes.get(m)).map(|m| &*m.name.name).collect();
        if !over.is_empty() {
            parts.push(format!("over it: {}", over.join(", ")));
        }
        parts.join(", ")
    }

    fn describe_node(&self, node: Node, depth: usize) -> String {
        let name = |n: Option<&Ident>| n.map_or("?".to_string(), |n| n.name.clone());
        match node {
            Node::Mesh(i) => name(self.meshes.get(i).map(|m| &m.name)),
            Node::Plane(i) => format!("{} (plane)", name(self.views.get(i).map(|v| &v.name))),
            Node::Image(i) => format!("{} (image)", name(self.images.get(i).map(|v| &v.name))),
            Node::Filter(f) => match self.tree_filters.get(f).map(|m| &m.source) {
                Some(ModuleSource::Std(name)) => format!("filter std::{}", name.value),
                Some(ModuleSource::File(file)) => format!("filter {}", file.given),
                None => "filter ?".into(),
            },
            Node::Group(g) if depth < MAX_GROUP_DEPTH => {
                let Some(group) = self.groups.get(g) else { return "?".into() };
                let child = |n: &Node| self.describe_node(*n, depth + 1);
                let list = |nodes: &[Node]| nodes.iter().map(child).collect::<Vec<_>>().join(", ");
                let (kind, children) = match &group.kind {
                    GroupKind::Depth => ("depth".to_string(), list(&group.children)),
                    GroupKind::Occlusion { hidden_opacity } => {
                        let (first, rest) = group.children.split_at(group.children.len().min(1));
                        (format!("occlusion {hidden_opacity:.2}"), format!("{} | {}", list(first), list(rest)))
                    }
                    GroupKind::Shadow { light: ShadowLight::Towards(v) } => {
                        (format!("shadow, light towards {v:?}"), list(&group.children))
                    }
                    GroupKind::Shadow { light: ShadowLight::Light(l) } => {
                        (format!("shadow, light `{}`", l.name), list(&group.children))
                    }
                };
                format!("{} ({kind}) [{children}]", group.name.name)
            }
            Node::Group(_) => "...".into(),
        }
    }

    /// Initial uniform values of views without their own `render` table: `[uniforms]`, plus
    /// those that `[render]` sets (`iso_value`, `step_size`, `jitter`, `background` and
    /// `max_samples` when given). [`Scene::view_uniform_values`] gives a view's own.
    pub fn uniform_values(&self) -> BTreeMap<String, UniformValue> {
        self.uniform_values_with(&self.render)
    }

    pub(super) fn uniform_values_with(&self, r: &Render) -> BTreeMap<String, UniformValue> {
        let mut out: BTreeMap<String, UniformValue> =
            self.uniforms.iter().map(|(k, v)| (k.clone(), v.value.clone())).collect();
        out.extend(render_uniform_values(r).into_iter().map(|(name, value, _)| (name.to_string(), value)));
        out
    }

    /// Every uniform value the scene gives, each with the span of its value: `[uniforms]`, and
    /// the values of `[render]` and of each view's own `render` table. A value that a view's
    /// table takes from `[render]` keeps its span there.
    pub fn placed_uniform_values(&self) -> Vec<(&str, UniformValue, Span)> {
        let mut out: Vec<(&str, UniformValue, Span)> =
            self.uniforms.iter().map(|(k, v)| (k.as_str(), v.value.clone(), v.span)).collect();
        for r in std::iter::once(&self.render).chain(self.views.iter().map(|v| &v.render)) {
            for value in render_uniform_values(r) {
                if !out.contains(&value) {
                    out.push(value);
                }
            }
        }
        out
    }
}

/// The uniform values that `r` sets (`iso_value`, `step_size`, `jitter`, `background`,
/// `max_samples`, `exposure` and `white_point` when given), each with the span of its value.
pub fn render_uniform_values(r: &Render) -> Vec<(&'static str, UniformValue, Span)> {
    let float = |x: f32| UniformValue::Float(f64::from(x));
    let floats = [
        ("iso_value", &r.iso_value),
        ("step_size", &r.step_size),
        ("jitter", &r.jitter),
        ("exposure", &r.exposure),
        ("white_point", &r.white_point),
    ];
    let mut out: Vec<_> =
        floats.into_iter().filter_map(|(n, v)| v.as_ref().map(|v| (n, float(v.value), v.span))).collect();
    if let Some(v) = &r.background {
        out.push(("background", UniformValue::Array(v.value.iter().map(|&c| float(c)).collect()), v.span));
    }
    if let Some(m) = &r.max_samples {
        out.push(("max_samples", UniformValue::Int(i64::from(m.value)), m.span));
    }
    out
}
