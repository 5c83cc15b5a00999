//! `[[mesh]]` tables: opaque or translucent surfaces drawn with the volumes (a needle, an organ
//! surface, a tracked instrument), from a file or a built-in shape, in patient space (RAS mm).
//! The scene only says what each mesh is; the runtime loads the files (its checks run at
//! `build`) and rasterizes them into the views' geometry layer.

use super::*;
use crate::lexer::is_identifier;

/// A mesh's surface: a file, or a built-in shape whose parameters are millimetres in patient
/// space (RAS).
#[derive(Clone, Debug, PartialEq)]
pub enum MeshSource {
    /// `path = "FILE"`: OBJ, STL or PLY, by extension.
    File {
        /// The mesh file, resolved against the scene file's directory.
        file: FileRef,
        /// `coordinates`: the axes the file's vertices use (`ras` by default).
        coordinates: Coordinates,
    },
    /// `shape = "needle"`: a shaft ending in a cone whose apex is the tip.
    Needle {
        /// `tip`: the apex of the cone, where the needle ends (mm).
        tip: Point,
        /// `direction`: the way from the tip towards the handle.
        direction: Point,
        /// `length`: the shaft's length in mm, above 0; 150 without it (`DEFAULT_NEEDLE_LENGTH`).
        length: f32,
        /// `radius`: the shaft's radius in mm, above 0; 1 without it (`DEFAULT_NEEDLE_RADIUS`).
        radius: f32,
    },
    /// `shape = "cylinder"`: from `base` to `tip`, closed.
    Cylinder {
        /// `base`: the centre of one end (mm).
        base: Point,
        /// `tip`: the centre of the other end (mm).
        tip: Point,
        /// `radius` in mm, above 0; 1 without it (`DEFAULT_NEEDLE_RADIUS`).
        radius: f32,
    },
    /// `shape = "sphere"`.
    Sphere {
        /// `centre` (or `center`): the sphere's centre (mm).
        centre: Point,
        /// `radius` in mm, above 0; required (E0704 without it).
        radius: f32,
    },
    /// `shape = "box"`: the axis-aligned box from `min` to `max`.
    Box {
        /// `min`: the corner with the smallest coordinates (mm).
        min: Point,
        /// `max`: the corner with the largest coordinates (mm).
        max: Point,
    },
    /// `volume = "NAME"`: the surface where a volume's data values cross a level, by marching
    /// cubes.
    Surface {
        /// `volume`: the name of the `[[volume]]` whose surface this is.
        volume: Located<String>,
        /// `level`: the data value (data units) the surface passes through; 0.5 by default, the
        /// border of a label or mask.
        level: f32,
    },
}

/// The axes a mesh file's coordinates use.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Coordinates {
    /// Right, anterior, superior: patient space as the scene uses it.
    #[default]
    Ras,
    /// Left, posterior, superior (3D Slicer's and ITK's files): x and y are negated on load.
    Lps,
}

/// A point or direction of a built-in shape: three numbers, or the name of a `vec3f` uniform
/// whose value (patient space, mm) the shape follows as it changes.
#[derive(Clone, Debug, PartialEq)]
pub enum Point {
    /// `[x, y, z]`: a fixed point in patient space (RAS, mm).
    Value([f32; 3]),
    /// `"NAME"`: the current value of the `vec3f` uniform NAME.
    Uniform(Located<String>),
}

impl Point {
    /// The uniform this point follows, if it follows one.
    pub fn uniform(&self) -> Option<&Located<String>> {
        match self {
            Point::Uniform(u) => Some(u),
            Point::Value(_) => None,
        }
    }
}

/// `[[mesh]]`.
#[derive(Clone, Debug)]
pub struct Mesh {
    /// An identifier: views list meshes by name (`meshes = [...]`), the panel shows it.
    pub name: Ident,
    /// What the surface is: `path`, `shape` or `volume` (exactly one of them).
    pub source: MeshSource,
    /// Display colour (sRGB, 0 to 1).
    pub color: [f32; 3],
    /// 1 is opaque (rays end at the surface); below 1 the surface is blended (see "Meshes" in
    /// the reference).
    pub opacity: f32,
    /// Applied after loading, in millimetres: four columns of a 4x4 matrix.
    pub transform: Option<Located<[[f32; 4]; 4]>>,
    /// The whole table.
    pub span: Span,
}

impl Mesh {
    /// The uniforms the mesh's shape follows, each with the span of its use.
    pub fn followed_uniforms(&self) -> Vec<&Located<String>> {
        let points: Vec<&Point> = match &self.source {
            MeshSource::File { .. } | MeshSource::Surface { .. } => vec![],
            MeshSource::Needle { tip, direction, .. } => vec![tip, direction],
            MeshSource::Cylinder { base, tip, .. } => vec![base, tip],
            MeshSource::Sphere { centre, .. } => vec![centre],
            MeshSource::Box { min, max } => vec![min, max],
        };
        points.into_iter().filter_map(Point::uniform).collect()
    }
}

/// Default mesh colour: a light grey, like a metal instrument.
pub const DEFAULT_MESH_COLOR: [f32; 3] = [0.85, 0.85, 0.85];
/// Default needle length (mm), a typical ablation applicator's shaft.
pub const DEFAULT_NEEDLE_LENGTH: f32 = 150.0;
/// Default needle radius (mm): a 14-gauge applicator.
pub const DEFAULT_NEEDLE_RADIUS: f32 = 1.0;

// ---------------------------------------------------------------------------------------------
// Raw tables.

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawMesh {
    pub(super) name: Spanned<String>,
    pub(super) path: Option<Spanned<String>>,
    pub(super) shape: Option<Spanned<String>>,
    pub(super) volume: Option<Spanned<String>>,
    pub(super) level: Option<Spanned<f32>>,
    pub(super) coordinates: Option<Spanned<Coordinates>>,
    pub(super) tip: Option<Spanned<RawPoint>>,
    pub(super) direction: Option<Spanned<RawPoint>>,
    pub(super) base: Option<Spanned<RawPoint>>,
    #[serde(alias = "center")]
    pub(super) centre: Option<Spanned<RawPoint>>,
    pub(super) min: Option<Spanned<RawPoint>>,
    pub(super) max: Option<Spanned<RawPoint>>,
    pub(super) length: Option<Spanned<f32>>,
    pub(super) radius: Option<Spanned<f32>>,
    pub(super) color: Option<Spanned<[f32; 3]>>,
    pub(super) opacity: Option<Spanned<f32>>,
    pub(super) transform: Option<Spanned<[[f32; 4]; 4]>>,
}
pub(super) const MESH_KEYS: &[&str] = &[
    "name",
    "path",
    "shape",
    "volume",
    "level",
    "coordinates",
    "tip",
    "direction",
    "base",
    "centre",
    "min",
    "max",
    "length",
    "radius",
    "color",
    "opacity",
    "transform",
];

/// The built-in shapes, as `shape` names them.
pub const SHAPES: &[&str] = &["needle", "cylinder", "sphere", "box"];

#[derive(Deserialize)]
#[serde(untagged)]
pub(super) enum RawPoint {
    Value([f32; 3]),
    Uniform(String),
}

// ---------------------------------------------------------------------------------------------
// Validation.

impl Cx<'_> {
    pub(super) fn meshes(&mut self, raw: Vec<Spanned<RawMesh>>, volumes: &[Volume]) -> Vec<Mesh> {
        let mut out: Vec<Mesh> = Vec::new();
        for m in raw {
            let span = self.span(&m);
            let m = m.into_inner();
            let name = Ident { name: m.name.get_ref().clone(), span: self.span(&m.name) };
            if self.check_name(&name.name, name.span, "mesh")
                && let Some(earlier) = out.iter().find(|o| o.name.name == name.name)
            {
                self.report(name.span, Twice::MeshNamed { name: name.name.clone(), first: earlier.name.span });
            }
            let source = self.mesh_source(&m, &name);
            if let MeshSource::Surface { volume, .. } = &source
                && !volumes.iter().any(|v| v.name.name == volume.value)
            {
                let suggestion =
                    did_you_mean(&volume.value, volumes.iter().map(|v| v.name.name.as_str())).map(String::from);
                self.report(volume.span, NoSuch::Volume { name: volume.value.clone(), suggestion });
            }
            let color = match &m.color {
                Some(c) => self.unit_components(c, "color"),
                None => DEFAULT_MESH_COLOR,
            };
            let opacity = match &m.opacity {
                Some(o) => self.unit_components(&Spanned::new(o.span(), [*o.get_ref()]), "opacity")[0],
                None => 1.0,
            };
            let transform = m.transform.as_ref().map(|t| {
                let span = self.span(t);
                if t.get_ref().iter().flatten().any(|x| !x.is_finite()) {
                    self.report(span, ViewRange::MeshTransform);
                }
                Located { value: *t.get_ref(), span }
            });
            out.push(Mesh { name, source, color, opacity, transform, span });
        }
        out
    }

    /// Each component in [0, 1].
    fn unit_components<const N: usize>(&mut self, value: &Spanned<[f32; N]>, key: &'static str) -> [f32; N] {
        let v = *value.get_ref();
        if v.iter().any(|c| !(0.0..=1.0).contains(c)) {
            self.report(self.span(value), ViewRange::MeshUnit { key });
        }
        v
    }

    fn mesh_source(&mut self, m: &RawMesh, name: &Ident) -> MeshSource {
        if let Some(volume) = &m.volume {
            return self.surface(m, volume);
        }
        if let Some(level) = &m.level {
            self.ignored(level, "level", "without `volume` (it is the surface's value)");
        }
        match (&m.path, &m.shape) {
            (Some(path), None) => {
                self.keys_unused(m, &[], "on a mesh read from a file");
                let coordinates = m.coordinates.as_ref().map_or(Coordinates::Ras, |c| *c.get_ref());
                MeshSource::File { file: self.file_ref(path, "path"), coordinates }
            }
            (None, Some(shape)) => self.shape(m, shape),
            (Some(path), Some(shape)) => {
                self.report(self.span(shape), Conflict::PathAndShape { path: self.span(path) });
                MeshSource::File { file: self.file_ref(path, "path"), coordinates: Coordinates::Ras }
            }
            (None, None) => {
                self.report(name.span, Missing::MeshSurface { mesh: name.name.clone() });
                MeshSource::Box { min: Point::Value([0.0; 3]), max: Point::Value([1.0; 3]) }
            }
        }
    }

    /// The surface of a volume at a level.
    fn surface(&mut self, m: &RawMesh, volume: &Spanned<String>) -> MeshSource {
        for (other, key) in [(&m.path, "path"), (&m.shape, "shape")] {
            if let Some(o) = other {
                self.report(self.span(o), Conflict::SurfaceAndSource { key, volume: self.span(volume) });
            }
        }
        self.keys_unused(m, &[], "on a surface extracted from a volume");
        let level = match &m.level {
            Some(l) if !l.get_ref().is_finite() => {
                self.report(self.span(l), ViewRange::SurfaceLevel);
                0.5
            }
            Some(l) => *l.get_ref(),
            None => 0.5,
        };
        MeshSource::Surface { volume: Located { value: volume.get_ref().clone(), span: self.span(volume) }, level }
    }

    /// A built-in shape and its parameters; parameters of other shapes are warned about.
    fn shape(&mut self, m: &RawMesh, shape: &Spanned<String>) -> MeshSource {
        let span = self.span(shape);
        if let Some(c) = &m.coordinates {
            self.ignored(c, "coordinates", "on a built-in shape (its values are patient space, RAS)");
        }
        match shape.get_ref().as_str() {
            "needle" => {
                self.keys_unused(m, &["tip", "direction", "length", "radius"], "on a needle");
                MeshSource::Needle {
                    tip: self.point(&m.tip, "tip", span),
                    direction: self.point(&m.direction, "direction", span),
                    length: self.size(&m.length, "length", DEFAULT_NEEDLE_LENGTH),
                    radius: self.size(&m.radius, "radius", DEFAULT_NEEDLE_RADIUS),
                }
            }
            "cylinder" => {
                self.keys_unused(m, &["base", "tip", "radius"], "on a cylinder");
                MeshSource::Cylinder {
                    base: self.point(&m.base, "base", span),
                    tip: self.point(&m.tip, "tip", span),
                    radius: self.size(&m.radius, "radius", DEFAULT_NEEDLE_RADIUS),
                }
            }
            "sphere" => {
                self.keys_unused(m, &["centre", "radius"], "on a sphere");
                let radius = match &m.radius {
                    Some(_) => self.size(&m.radius, "radius", 1.0),
                    None => {
                        self.report(span, Missing::SphereRadius);
                        1.0
                    }
                };
                MeshSource::Sphere { centre: self.point(&m.centre, "centre", span), radius }
            }
            "box" => {
                self.keys_unused(m, &["min", "max"], "on a box");
                MeshSource::Box { min: self.point(&m.min, "min", span), max: self.point(&m.max, "max", span) }
            }
            other => {
                let suggestion = did_you_mean(other, SHAPES.iter().copied()).map(String::from);
                self.report(span, UnknownValue::Shape { shape: other.to_string(), suggestion });
                MeshSource::Box { min: Point::Value([0.0; 3]), max: Point::Value([1.0; 3]) }
            }
        }
    }

    /// A required point of a shape.
    fn point(&mut self, raw: &Option<Spanned<RawPoint>>, key: &str, shape: Span) -> Point {
        let Some(p) = raw else {
            self.report(shape, Missing::ShapePoint { key: key.to_string() });
            return Point::Value([0.0; 3]);
        };
        let span = self.span(p);
        match p.get_ref() {
            RawPoint::Value(v) => {
                if v.iter().any(|x| !x.is_finite()) {
                    self.report(span, ViewRange::PointNotFinite { key: key.to_string() });
                }
                Point::Value(*v)
            }
            RawPoint::Uniform(name) => {
                if !is_identifier(name) {
                    self.report(span, BadName::PointUniform { name: name.clone(), key: key.to_string() });
                }
                Point::Uniform(Located { value: name.clone(), span })
            }
        }
    }

    /// A positive size in millimetres, or `default`.
    fn size(&mut self, raw: &Option<Spanned<f32>>, key: &str, default: f32) -> f32 {
        let Some(v) = raw else { return default };
        let x = *v.get_ref();
        if !(x.is_finite() && x > 0.0) {
            self.report(self.span(v), ViewRange::MeshSize { key: key.to_string(), x });
            return default;
        }
        x
    }

    /// Warns about the shape keys given that `used` does not list.
    fn keys_unused(&mut self, m: &RawMesh, used: &[&str], why: &str) {
        let point = |p: &Option<Spanned<RawPoint>>| p.as_ref().map(Spanned::span);
        let keys = [
            ("tip", point(&m.tip)),
            ("direction", point(&m.direction)),
            ("base", point(&m.base)),
            ("centre", point(&m.centre)),
            ("min", point(&m.min)),
            ("max", point(&m.max)),
            ("length", m.length.as_ref().map(Spanned::span)),
            ("radius", m.radius.as_ref().map(Spanned::span)),
        ];
        for (key, range) in keys {
            if let Some(r) = range
                && !used.contains(&key)
            {
                let span = self.range(r);
                self.ignored_at(span, key, why);
            }
        }
    }
}

impl Cx<'_> {
    /// A view's `meshes` list as indices into the scene's meshes; every mesh without one.
    pub(super) fn view_meshes(&mut self, list: Option<&Spanned<Vec<Spanned<String>>>>, meshes: &[Mesh]) -> Vec<usize> {
        let Some(list) = list else { return (0..meshes.len()).collect() };
        let mut out = Vec::new();
        for name in list.get_ref() {
            match meshes.iter().position(|m| &m.name.name == name.get_ref()) {
                Some(i) if !out.contains(&i) => out.push(i),
                Some(_) => self.report(self.span(name), Twice::MeshListed { name: name.get_ref().clone() }),
                None => {
                    let suggestion =
                        did_you_mean(name.get_ref(), meshes.iter().map(|m| m.name.name.as_str())).map(String::from);
                    self.report(self.span(name), NoSuch::Mesh { name: name.get_ref().clone(), suggestion });
                }
            }
        }
        out
    }
}

impl Cx<'_> {
    /// A raycast view's `planes`: slice views of the scene, by name, as indices into `views`.
    pub(super) fn view_planes(
        &mut self,
        views: &[View],
        index: usize,
        list: &Spanned<Vec<Spanned<String>>>,
    ) -> Vec<usize> {
        if views[index].kind.value != ViewKind::Raycast {
            self.ignored(list, "planes", "on a slice view (a raycast view shows slice views on their planes)");
            return Vec::new();
        }
        let mut out = Vec::new();
        for name in list.get_ref() {
            let span = self.span(name);
            match views.iter().position(|v| &v.name.name == name.get_ref()) {
                Some(i) if views[i].kind.value != ViewKind::Slice => {
                    let name = name.get_ref().clone();
                    self.report(span, SceneError::PlaneNotSlice { name, kind: views[i].kind.span });
                }
                Some(i) if out.contains(&i) => {
                    self.report(span, Twice::ViewListed { name: name.get_ref().clone() });
                }
                Some(i) => out.push(i),
                None => {
                    let slices = views.iter().filter(|v| v.kind.value == ViewKind::Slice).map(|v| v.name.name.as_str());
                    let suggestion = did_you_mean(name.get_ref(), slices).map(String::from);
                    self.report(span, NoSuch::View { name: name.get_ref().clone(), suggestion });
                }
            }
        }
        out
    }
}
