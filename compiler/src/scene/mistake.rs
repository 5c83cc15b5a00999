//! Scene mistakes: one variant per mistake a scene file can hold, with the data its wording
//! needs; the code, message, label, notes and help of each are written here and nowhere else
//! (as Gleam's `parse/error.rs` does for its parser). Validation builds a [`SceneError`] and
//! places it at a span with [`SceneError::at`].
//!
//! Variants are grouped in families, one enum per family; each family is one diagnostic code,
//! since its mistakes are fixed the same way (add the key, remove one of two keys, give a value
//! in range, ...) and the message names the key. The families' codes are E0704 to E0722, but
//! for E0719 (a file that cannot be read, found after composing).

use super::*;

/// A mistake in a scene file, found while validating it.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum SceneError {
    Missing(Missing),
    NoTable(NoTable),
    Conflict(Conflict),
    SecondPrimary {
        first: Span,
    },
    RenderRange(RenderRange),
    ViewRange(ViewRange),
    Memory {
        key: &'static str,
    },
    Empty(Empty),
    BadName(BadName),
    Twice(Twice),
    NoSuch(NoSuch),
    PlaneNotSlice {
        name: String,
        kind: Span,
    },
    UnknownValue(UnknownValue),
    WrongType(WrongType),
    TfCount {
        tfs: usize,
        channels: usize,
        list: Span,
    },
    UrlScheme {
        scheme: String,
    },
    TooFewChildren {
        group: String,
        kind: &'static str,
        needs: usize,
    },
    GroupCycle {
        path: Vec<String>,
    },
    PictureVolume(PictureVolume),
    /// E0723.
    FilterFirst {
        group: String,
    },
    /// E0724.
    FilterInGroupKind {
        group: String,
        kind: &'static str,
    },
}

/// E0722: the view's volume in its `picture`: listed once, with only meshes after it.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum PictureVolume {
    Missing,
    Twice { first: Span },
    AfterIt { name: String, what: &'static str },
}

/// E0704: a key that the table or another key needs.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Missing {
    /// Serde's "missing field": `table` names where.
    Key {
        key: String,
        table: String,
    },
    IsoValue,
    LevelNeedsWidth,
    WidthNeedsLevel,
    ToneNeedsShading,
    ShadowsNeedShading,
    OcclusionNeedsShading,
    TfListNeedsChannels,
    SliceAxis {
        view: String,
    },
    SphereRadius,
    ShapePoint {
        key: String,
    },
    VolumeData {
        volume: String,
    },
    MeshSurface {
        mesh: String,
    },
}

/// E0705: the scene has no view, or no primary volume.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum NoTable {
    View,
    Primary { no_volumes: bool },
}

/// E0706: two keys that exclude each other.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Conflict {
    WindowAndLevel,
    PathAndPhantom { path: Span },
    PathAndShape { path: Span },
    SurfaceAndSource { key: &'static str, volume: Span },
    RenderAndUniforms { name: String, render: Span },
    PictureAndList { key: &'static str, picture: Span },
}

/// E0708: a number of `[render]` or `[[volume]]` outside the range its key allows.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum RenderRange {
    WindowWidth { width: f32 },
    WindowOrder { lo: f32, hi: f32 },
    IsoValue,
    StepSize,
    MaxSamples,
    Jitter,
    Background,
    Exposure,
    WhitePoint,
    NegativeIndex { key: String, index: i64 },
}

/// E0708 too: a number of a `[[view]]` or `[[mesh]]` outside the range its key allows.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum ViewRange {
    ViewSize { width: u32, height: u32 },
    SlicePosition,
    Slab,
    CameraDistance { x: f32 },
    CameraFov { x: f32 },
    CameraAngle { key: &'static str, x: f32 },
    MeshUnit { key: &'static str },
    MeshTransform,
    SurfaceLevel,
    PointNotFinite { key: String },
    MeshSize { key: String, x: f32 },
    LightDirection,
    ImageSides,
}

/// E0710: an empty value where something is needed.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Empty {
    Path { key: String },
    Tf,
    Instances,
    Channels,
}

/// E0711: a name that is not a name of its kind (E0607 for an instance's name: a volume's, a
/// light's, a mesh's or a module instance's).
#[derive(Clone, Debug, PartialEq)]
pub(super) enum BadName {
    /// A uniform's name in `[uniforms]` that is not an identifier.
    NotIdentifier {
        what: String,
        name: String,
    },
    /// A uniform's name in `[uniforms]` that is a VRS keyword.
    Keyword {
        what: String,
        name: String,
    },
    Phantom {
        name: String,
    },
    StdModule {
        name: String,
    },
    View {
        name: String,
    },
    PointUniform {
        name: String,
        key: String,
    },
}

/// E0712: a view or mesh named twice, or listed twice (E0607 for volumes, lights and module
/// instances, as for other instance names).
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Twice {
    /// E0607, as for other instance names: `label` says how the volume got its name.
    VolumeNamed {
        name: String,
        first: Span,
        label: &'static str,
    },
    /// E0607: a light or module instance listed twice.
    Listed {
        what: String,
        name: String,
        first: Span,
    },
    ViewNamed {
        name: String,
        first: Span,
    },
    MeshNamed {
        name: String,
        first: Span,
    },
    MeshListed {
        name: String,
    },
    ViewListed {
        name: String,
    },
    /// A group or image (`kind`) named as an earlier node (`what`: a mesh, group or image).
    NodeNamed {
        name: String,
        first: Span,
        kind: &'static str,
        what: &'static str,
    },
    /// A group or image listed twice in one list.
    NodeListed {
        name: String,
    },
}

/// E0713: a name that names no volume, mesh or view of the scene.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum NoSuch {
    Volume {
        name: String,
        suggestion: Option<String>,
    },
    Mesh {
        name: String,
        suggestion: Option<String>,
    },
    View {
        name: String,
        suggestion: Option<String>,
    },
    /// A child of a group or a view's `picture`.
    Node {
        name: String,
        suggestion: Option<String>,
    },
    /// A shadow group's `light`.
    Light {
        name: String,
        suggestion: Option<String>,
    },
}

/// E0715: a value that is not one of its key's choices.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum UnknownValue {
    /// Serde's "unknown variant".
    Choice {
        value: String,
        expected: Vec<String>,
        suggestion: Option<String>,
    },
    Shape {
        shape: String,
        suggestion: Option<String>,
    },
}

/// E0716: a value of the wrong type or shape.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum WrongType {
    /// Serde's "invalid type", with the key when it is on the value's line.
    Value {
        key: Option<String>,
        found: String,
        expected: String,
    },
    Uniform {
        name: String,
        problem: String,
    },
}

macro_rules! from_family {
    ($($family:ident),*) => {$(
        impl From<$family> for SceneError {
            fn from(e: $family) -> SceneError {
                SceneError::$family(e)
            }
        }
    )*};
}
from_family!(
    PictureVolume,
    Missing,
    NoTable,
    Conflict,
    RenderRange,
    ViewRange,
    Empty,
    BadName,
    Twice,
    NoSuch,
    UnknownValue,
    WrongType
);

impl SceneError {
    /// The mistake's code.
    pub(super) fn code(&self) -> Code {
        match self {
            SceneError::Missing(_) => Code::SceneMissingKey,
            SceneError::NoTable(_) => Code::SceneNoTable,
            SceneError::Conflict(_) => Code::SceneConflict,
            SceneError::SecondPrimary { .. } => Code::SceneSecondPrimary,
            SceneError::RenderRange(_) | SceneError::ViewRange(_) => Code::SceneOutOfRange,
            SceneError::Memory { .. } => Code::SceneMemorySize,
            SceneError::Empty(_) => Code::SceneEmpty,
            SceneError::BadName(BadName::NotIdentifier { what, .. } | BadName::Keyword { what, .. })
                if what != "uniform" =>
            {
                Code::InvalidInstance
            }
            SceneError::BadName(_) => Code::SceneBadName,
            SceneError::Twice(Twice::VolumeNamed { .. } | Twice::Listed { .. }) => Code::InvalidInstance,
            SceneError::Twice(_) => Code::SceneTwice,
            SceneError::NoSuch(_) => Code::SceneNoSuch,
            SceneError::PlaneNotSlice { .. } => Code::ScenePlaneNotSlice,
            SceneError::UnknownValue(_) => Code::SceneUnknownValue,
            SceneError::WrongType(_) => Code::SceneWrongType,
            SceneError::TfCount { .. } => Code::SceneTfCount,
            SceneError::UrlScheme { .. } => Code::SceneUrlScheme,
            SceneError::TooFewChildren { .. } => Code::TreeFewChildren,
            SceneError::GroupCycle { .. } => Code::TreeCycle,
            SceneError::PictureVolume(_) => Code::TreePictureVolume,
            SceneError::FilterFirst { .. } => Code::TreeFilterFirst,
            SceneError::FilterInGroupKind { .. } => Code::TreeFilterGroupKind,
        }
    }

    /// The mistake as a diagnostic at `span`.
    pub(super) fn at(self, span: Span) -> Diagnostic {
        let d = Diagnostic::new(self.code(), span, "");
        match self {
            SceneError::Missing(e) => e.words(d),
            SceneError::NoTable(e) => e.words(d),
            SceneError::Conflict(e) => e.words(d),
            SceneError::SecondPrimary { first } => said(d, "a scene has exactly one primary volume")
                .with_label("a second primary volume")
                .with_secondary(first, "the primary volume")
                .with_help("make this one `role = \"additional\"`"),
            SceneError::RenderRange(e) => e.words(d),
            SceneError::ViewRange(e) => e.words(d),
            SceneError::Memory { key } => said(d, format!("`{key}` must be a size of at least 64 MiB"))
                .with_label("like \"512 MiB\" or \"2 GiB\""),
            SceneError::Empty(e) => e.words(d),
            SceneError::BadName(e) => e.words(d),
            SceneError::Twice(e) => e.words(d),
            SceneError::NoSuch(e) => e.words(d),
            SceneError::PlaneNotSlice { name, kind } => {
                said(d, format!("`{name}` is a raycast view; `planes` lists slice views"))
                    .with_secondary(kind, "its kind")
            }
            SceneError::UnknownValue(e) => e.words(d),
            SceneError::WrongType(e) => e.words(d),
            SceneError::TfCount { tfs, channels, list } => {
                said(d, format!("{tfs} transfer functions for {channels} channels"))
                    .with_label("one per channel")
                    .with_secondary(list, "the channels")
            }
            SceneError::UrlScheme { scheme } => said(d, format!("`{scheme}://` stores are not supported"))
                .with_label("not an HTTP(S) URL")
                .with_help(
                    "a remote Zarr store is read over `https://` or `http://` (an S3 or GCS bucket by its HTTPS address)",
                ),
            SceneError::TooFewChildren { group, kind, needs } => {
                let children = if needs == 1 { "a child" } else { "two children" };
                said(d, format!("the {kind} group `{group}` needs at least {children}"))
                    .with_label("too few children")
                    .with_help(match needs {
                        1 => "list meshes, groups or slice views in `children`, or leave the group out",
                        _ => "the first child is what hides the others: list it and what it hides",
                    })
            }
            SceneError::GroupCycle { path } => {
                said(d, format!("the group `{}` contains itself", path[0]))
                    .with_label("this child leads back to it")
                    .with_note(format!("through {}", path.iter().map(|p| format!("`{p}`")).collect::<Vec<_>>().join(" -> ")))
                    .with_help("a renderer tree has no cycles: take one of these children out")
            }
            SceneError::PictureVolume(e) => e.words(d),
            SceneError::FilterFirst { group } => {
                said(d, format!("the first child of the group `{group}` is a filter, with nothing before it to filter"))
                    .with_label("filters the children listed before it")
                    .with_help("list the meshes or groups it filters before it")
            }
            SceneError::FilterInGroupKind { group, kind } => {
                said(d, format!("a filter among the children of the {kind} group `{group}`"))
                    .with_label(format!("{} group combines its children by its own rule", with_article(kind)))
                    .with_note("filters belong to depth groups, where they filter the children listed before them")
                    .with_help(format!(
                        "filter this group's picture in a depth group around it: `children = [\"{group}\", {{ filter = ... }}]`"
                    ))
            }
        }
    }
}

/// `d` with its message.
fn said(mut d: Diagnostic, message: impl Into<String>) -> Diagnostic {
    d.message = message.into();
    d
}

/// `d` with a "did you mean" help when there is a suggestion.
fn maybe(d: Diagnostic, suggestion: Option<String>) -> Diagnostic {
    match suggestion {
        Some(s) => d.with_help(format!("did you mean `{s}`?")),
        None => d,
    }
}

impl Missing {
    fn words(self, d: Diagnostic) -> Diagnostic {
        let needs_shading = |d: Diagnostic, what: &str, label: &str| {
            said(d, format!("{what} `shading = true`")).with_label(label).with_help("add `shading = true` to [render]")
        };
        match self {
            Missing::Key { key, table } => {
                said(d, format!("missing key `{key}` in {table}")).with_label(format!("this table needs `{key}`"))
            }
            Missing::IsoValue => said(d, "`compositing = \"iso\"` needs an `iso_value`")
                .with_label("iso-surface compositing")
                .with_help("add `iso_value = 0.5` (a normalized data value) to [render]"),
            Missing::LevelNeedsWidth => said(d, "`level` needs `width`").with_help("add `width = W` (data units)"),
            Missing::WidthNeedsLevel => said(d, "`width` needs `level`").with_help("add `level = L` (data units)"),
            Missing::ToneNeedsShading => needs_shading(d, "tone shading needs", "tone shading modulates the lighting"),
            Missing::ShadowsNeedShading => needs_shading(d, "shadows need", "shadows attenuate the lights"),
            Missing::OcclusionNeedsShading => {
                needs_shading(d, "ambient occlusion needs", "ambient occlusion scales the ambient light")
            }
            Missing::TfListNeedsChannels => {
                said(d, "a list of `tf` needs a list of `channel`").with_label("one per channel")
            }
            Missing::SliceAxis { view } => {
                said(d, format!("the slice view `{view}` needs an `axis`")).with_label("a slice view").with_help(
                    "add `axis = \"axial\"` (axial, coronal or sagittal: the plane's orientation in the patient)",
                )
            }
            Missing::SphereRadius => said(d, "a sphere needs a `radius` (mm)"),
            Missing::ShapePoint { key } => said(d, format!("this shape needs `{key}`"))
                .with_help(format!("add `{key} = [x, y, z]` (patient space, mm) or the name of a vec3f uniform")),
            Missing::VolumeData { volume } => said(d, format!("the volume `{volume}` has no data"))
                .with_label("neither `path` nor `phantom`")
                .with_help("add `path = \"FILE\"` (relative to the scene) or `phantom = \"NAME\"`"),
            Missing::MeshSurface { mesh } => {
                said(d, format!("the mesh `{mesh}` has no surface")).with_label("neither `path` nor `shape`").with_help(
                    "add `path = \"FILE\"` (OBJ, STL or PLY) or `shape = \"needle\"` (needle, cylinder, sphere, box)",
                )
            }
        }
    }
}

impl NoTable {
    fn words(self, d: Diagnostic) -> Diagnostic {
        match self {
            NoTable::View => said(d, "the scene has no [[view]]")
                .with_label("nothing to render")
                .with_help("add a view: `[[view]]`, `name = \"3d\"`, `kind = \"raycast\"`"),
            NoTable::Primary { no_volumes } => {
                let d = said(d, "the scene has no primary volume").with_help(
                    "give one [[volume]] `role = \"primary\"`: it defines the coordinates the rays march in",
                );
                if no_volumes { d.with_label("no [[volume]] tables") } else { d }
            }
        }
    }
}

impl Conflict {
    fn words(self, d: Diagnostic) -> Diagnostic {
        match self {
            Conflict::WindowAndLevel => said(d, "a volume has either `window` or `level` and `width`, not both"),
            Conflict::PathAndPhantom { path } => said(d, "a volume has either `path` or `phantom`, not both")
                .with_label("second source")
                .with_secondary(path, "the volume's file"),
            Conflict::PathAndShape { path } => said(d, "a mesh has either `path` or `shape`, not both")
                .with_label("second source")
                .with_secondary(path, "the mesh's file"),
            Conflict::SurfaceAndSource { key, volume } => {
                said(d, format!("a mesh has one source: `volume` or `{key}`, not both"))
                    .with_secondary(volume, "the surface's volume")
            }
            Conflict::RenderAndUniforms { name, render } => {
                said(d, format!("`{name}` is set both in [render] and in [uniforms]"))
                    .with_label("set again here")
                    .with_secondary(render, "set in [render]")
                    .with_help("keep one of them")
            }
            Conflict::PictureAndList { key, picture } => {
                said(d, format!("a view has either `picture` or `{key}`, not both"))
                    .with_secondary(picture, "the view's renderer tree")
                    .with_help(format!("list what `{key}` lists in `picture` (the reference's \"Renderer trees\")"))
            }
        }
    }
}

impl PictureVolume {
    fn words(self, d: Diagnostic) -> Diagnostic {
        match self {
            PictureVolume::Missing => said(d, "a view's `picture` lists its volume, `\"volume\"`, once")
                .with_label("no `\"volume\"` here")
                .with_help("add `\"volume\"` after what the rays end at and before what is drawn over the picture"),
            PictureVolume::Twice { first } => said(d, "the view's volume is listed twice")
                .with_label("listed again")
                .with_secondary(first, "first here"),
            PictureVolume::AfterIt { name, what } => said(
                d,
                format!("only meshes follow `\"volume\"` in a `picture`, and `{name}` is {}", with_article(what)),
            )
            .with_label("drawn over the picture")
            .with_help(
                "what follows the volume is drawn over the finished picture: list groups and slice views before it",
            ),
        }
    }
}

impl RenderRange {
    fn words(self, d: Diagnostic) -> Diagnostic {
        match self {
            RenderRange::WindowWidth { width } => said(d, format!("the window `width` must be positive, not {width}")),
            RenderRange::WindowOrder { lo, hi } => {
                said(d, format!("the window [{lo}, {hi}] must have its low end below its high end"))
            }
            RenderRange::IsoValue => said(d, "`iso_value` must be a finite number"),
            RenderRange::StepSize => said(d, "`step_size` must be a distance greater than 0")
                .with_label("millimetres")
                .with_note("without `step_size`, rays step half the primary volume's smallest voxel spacing"),
            RenderRange::MaxSamples => said(d, format!("`max_samples` must be between 1 and {MAX_SAMPLES_LIMIT}")),
            RenderRange::Jitter => said(d, "`jitter` must be between 0 (off) and 1 (up to one step)"),
            RenderRange::Background => {
                said(d, "`background` components must be between 0 and 1").with_label("premultiplied RGBA")
            }
            RenderRange::Exposure => said(d, "`exposure` must be a finite number of stops"),
            RenderRange::WhitePoint => said(d, "`white_point` must be a radiance greater than 0")
                .with_label("the smallest radiance shown as white"),
            RenderRange::NegativeIndex { key, index } => {
                said(d, format!("`{key} = {index}` is negative")).with_label("an index from 0")
            }
        }
    }
}

impl ViewRange {
    fn words(self, d: Diagnostic) -> Diagnostic {
        match self {
            ViewRange::ViewSize { width, height } => {
                said(d, format!("a view's width and height must be 1 to {MAX_VIEW_SIZE}"))
                    .with_label(format!("{width} x {height} pixels"))
            }
            ViewRange::SlicePosition => {
                said(d, "a slice `position` must be between 0 and 1").with_label("normalized along the axis")
            }
            ViewRange::Slab => said(d, "a `slab` thickness must be 0 or more").with_label("millimetres"),
            ViewRange::CameraDistance { x } => {
                said(d, "the camera `distance` must be greater than 0").with_label(format!("distance = {x}"))
            }
            ViewRange::CameraFov { x } => {
                said(d, "the camera `fov` must be between 0 and 180 degrees").with_label(format!("fov = {x}"))
            }
            ViewRange::CameraAngle { key, x } => {
                said(d, "camera angles must be finite numbers").with_label(format!("{key} = {x}"))
            }
            ViewRange::MeshUnit { key } => said(d, format!("a mesh `{key}` is between 0 and 1")),
            ViewRange::MeshTransform => said(d, "a mesh `transform` must hold finite numbers"),
            ViewRange::SurfaceLevel => said(d, "a surface's `level` must be a number (data units)"),
            ViewRange::PointNotFinite { key } => said(d, format!("`{key}` must hold finite numbers")),
            ViewRange::MeshSize { key, x } => said(d, format!("a mesh `{key}` must be positive (mm), not {x}")),
            ViewRange::LightDirection => {
                said(d, "a shadow group's `light` must be a direction: finite numbers, not all zero".to_string())
            }
            ViewRange::ImageSides => said(d, "an image's `right` and `down` must be the sides of a rectangle")
                .with_label("zero, or parallel")
                .with_note("`right` goes from the picture's top-left corner to its top-right one, `down` to its bottom-left one (mm)"),
        }
    }
}

impl Empty {
    fn words(self, d: Diagnostic) -> Diagnostic {
        match self {
            Empty::Path { key } => said(d, format!("an empty `{key}`")).with_label("a path is needed here"),
            Empty::Tf => said(d, "an empty `tf`").with_help("name a preset such as `grayscale`, or a file"),
            Empty::Instances => said(d, "an empty `instances` list")
                .with_label("instantiates nothing")
                .with_help("list instance names, or leave `instances` out for a plain module"),
            Empty::Channels => said(d, "an empty `channel` list").with_label("name at least one channel"),
        }
    }
}

impl BadName {
    fn words(self, d: Diagnostic) -> Diagnostic {
        match self {
            BadName::NotIdentifier { what, name } => said(d, format!("the {what} name `{name}` is not an identifier"))
                .with_label("not an identifier")
                .with_note("names are letters, digits and `_`, and do not start with a digit"),
            BadName::Keyword { what, name } => said(d, format!("the {what} name `{name}` is a VRS keyword"))
                .with_label("a keyword")
                .with_help("choose another name"),
            BadName::Phantom { name } => said(d, format!("the phantom name `{name}` is not an identifier")),
            BadName::StdModule { name } => said(d, format!("`std::{name}` does not name a standard module"))
                .with_note("standard modules are `std::NAME`, NAME an identifier (see stdlib/README.md)"),
            BadName::View { name } => said(d, format!("the view name `{name}` is not a plain file name"))
                .with_label("letters, digits, `_` and `-` only")
                .with_note("a view's name names its output files (`NAME.wgsl`, `NAME.png`)"),
            BadName::PointUniform { name, key } => said(d, format!("`{name}` is not a uniform name"))
                .with_help(format!("give `{key}` as `[x, y, z]` or name a vec3f uniform")),
        }
    }
}

impl Twice {
    fn words(self, d: Diagnostic) -> Diagnostic {
        match self {
            Twice::VolumeNamed { name, first, label } => {
                said(d, format!("two volumes are named `{name}`")).with_label(label).with_secondary(first, "first here")
            }
            Twice::Listed { what, name, first } => said(d, format!("the {what} `{name}` is listed twice"))
                .with_label("again here")
                .with_secondary(first, "first here"),
            Twice::ViewNamed { name, first } => said(d, format!("two views are named `{name}`"))
                .with_label("second view with this name")
                .with_secondary(first, "first here")
                .with_note("a view's name names its output files (`NAME.wgsl`, `NAME.png`)"),
            Twice::MeshNamed { name, first } => said(d, format!("two meshes are named `{name}`"))
                .with_label("second mesh with this name")
                .with_secondary(first, "first here"),
            Twice::MeshListed { name } => said(d, format!("the mesh `{name}` is listed twice")),
            Twice::ViewListed { name } => said(d, format!("the view `{name}` is listed twice")),
            Twice::NodeNamed { name, first, kind, what } if kind == what => {
                said(d, format!("two {kind}s are named `{name}`"))
                    .with_label(format!("second {kind} with this name"))
                    .with_secondary(first, "first here")
            }
            Twice::NodeNamed { name, first, kind, what } => {
                said(d, format!("{} and {} are named `{name}`", with_article(kind), with_article(what)))
                    .with_label(format!("{} with this name", with_article(kind)))
                    .with_secondary(first, format!("the {what}"))
                    .with_help(format!(
                        "a group's children name meshes, groups and images alike: give the {kind} a name of its own"
                    ))
            }
            Twice::NodeListed { name } => said(d, format!("`{name}` is listed twice in the same list")),
        }
    }
}

impl NoSuch {
    fn words(self, d: Diagnostic) -> Diagnostic {
        let (what, name, suggestion) = match self {
            NoSuch::Volume { name, suggestion } => ("volume", name, suggestion),
            NoSuch::Mesh { name, suggestion } => ("mesh", name, suggestion),
            NoSuch::View { name, suggestion } => ("view", name, suggestion),
            NoSuch::Light { name, suggestion } => {
                return maybe(
                    said(d, format!("no view has a light `{name}`"))
                        .with_label("not in any view's `lights`")
                        .with_help("name a light of `[render] lights`, or give a direction: `light = [0.0, 0.0, 1.0]`"),
                    suggestion,
                );
            }
            NoSuch::Node { name, suggestion } => {
                return maybe(
                    said(d, format!("the scene has no mesh, group, image or slice view `{name}`"))
                        .with_label("not a [[mesh]], [[group]], [[image]] or [[view]] name"),
                    suggestion,
                );
            }
        };
        maybe(
            said(d, format!("the scene has no {what} `{name}`")).with_label(format!("not a [[{what}]] name")),
            suggestion,
        )
    }
}

impl UnknownValue {
    fn words(self, d: Diagnostic) -> Diagnostic {
        match self {
            UnknownValue::Choice { value, expected, suggestion } => {
                let list = expected.iter().map(|i| format!("`{i}`")).collect::<Vec<_>>().join(", ");
                maybe(said(d, format!("`{value}` is not one of {list}")).with_label("unknown value"), suggestion)
            }
            UnknownValue::Shape { shape, suggestion } => maybe(
                said(d, format!("`{shape}` is not a built-in shape"))
                    .with_note(format!("the shapes are {}", mesh::SHAPES.join(", "))),
                suggestion,
            ),
        }
    }
}

impl WrongType {
    fn words(self, d: Diagnostic) -> Diagnostic {
        match self {
            WrongType::Value { key, found, expected } => {
                let message = match key {
                    Some(key) => format!("`{key}` expects {expected}, found {found}"),
                    None => format!("expected {expected}, found {found}"),
                };
                said(d, message).with_label(format!("expected {expected}"))
            }
            WrongType::Uniform { name, problem } => {
                said(d, format!("invalid value for the uniform `{name}`: {problem}"))
            }
        }
    }
}

/// `word` with its indefinite article.
fn with_article(word: &str) -> String {
    let article = if word.starts_with(['a', 'e', 'i', 'o', 'u']) { "an" } else { "a" };
    format!("{article} {word}")
}
