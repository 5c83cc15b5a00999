//! `[[image]]` tables: a picture file (a photograph, a screenshot of a plan, an atlas page) on a
//! rectangle in patient space, a leaf of renderer trees like a slice view on its plane. The
//! scene says where the rectangle lies; the runtime reads the file (`build` checks it first).

use super::*;

/// `[[image]]`: a picture file shown on a rectangle in patient space (RAS, mm).
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// An identifier: a `picture` or a group's `children` name the image by it.
    pub name: Ident,
    /// `path`: the picture file (PNG or JPEG), resolved against the scene file's
    /// directory.
    pub file: FileRef,
    /// `origin`: where the picture's top-left corner lies (mm).
    pub origin: [f32; 3],
    /// `right`: from the top-left corner to the top-right one (mm): the width and its
    /// direction.
    pub right: [f32; 3],
    /// `down`: from the top-left corner to the bottom-left one (mm).
    pub down: [f32; 3],
    /// The whole table.
    pub span: Span,
}

impl Image {
    /// The rectangle's corners, clockwise from the top-left one as the picture is seen: top
    /// left, top right, bottom right, bottom left (mm).
    pub fn corners(&self) -> [[f32; 3]; 4] {
        let at = |r: f32, d: f32| std::array::from_fn(|i| self.origin[i] + r * self.right[i] + d * self.down[i]);
        [at(0.0, 0.0), at(1.0, 0.0), at(1.0, 1.0), at(0.0, 1.0)]
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawImage {
    pub(super) name: Spanned<String>,
    pub(super) path: Spanned<String>,
    pub(super) origin: Spanned<[f32; 3]>,
    pub(super) right: Spanned<[f32; 3]>,
    pub(super) down: Spanned<[f32; 3]>,
}
pub(super) const IMAGE_KEYS: &[&str] = &["name", "path", "origin", "right", "down"];

impl Cx<'_> {
    /// `[[image]]` tables: names unique among images and meshes (E0712), finite corners, and
    /// sides that span a rectangle (E0708).
    pub(super) fn images(&mut self, raw: Vec<Spanned<RawImage>>, meshes: &[Mesh]) -> Vec<Image> {
        let mut out: Vec<Image> = Vec::new();
        for i in raw {
            let span = self.span(&i);
            let i = i.into_inner();
            let name = Ident { name: i.name.get_ref().clone(), span: self.span(&i.name) };
            if self.check_name(&name.name, name.span, "image") {
                let mesh = meshes.iter().find(|m| m.name.name == name.name).map(|m| (m.name.span, "mesh"));
                let image = out.iter().find(|o| o.name.name == name.name).map(|o| (o.name.span, "image"));
                if let Some((first, what)) = mesh.or(image) {
                    let twice = Twice::NodeNamed { name: name.name.clone(), first, kind: "image", what };
                    self.report(name.span, twice);
                }
            }
            let file = self.file_ref(&i.path, "path");
            let [origin, right, down] =
                [("origin", &i.origin), ("right", &i.right), ("down", &i.down)].map(|(key, v)| self.finite(v, key));
            if !spans_a_rectangle(right, down) {
                let sides = self.span(&i.right).to(self.span(&i.down));
                self.report(sides, ViewRange::ImageSides);
            }
            out.push(Image { name, file, origin, right, down, span });
        }
        out
    }

    /// `value`, reported (E0708) unless every number is finite.
    fn finite(&mut self, value: &Spanned<[f32; 3]>, key: &str) -> [f32; 3] {
        let v = *value.get_ref();
        if v.iter().any(|x| !x.is_finite()) {
            self.report(self.span(value), ViewRange::PointNotFinite { key: key.to_string() });
        }
        v
    }
}

/// Whether `right` and `down` are the sides of a rectangle (or a parallelogram) of some area:
/// neither zero, not parallel.
fn spans_a_rectangle(right: [f32; 3], down: [f32; 3]) -> bool {
    let [r, d] = [right, down].map(|v| v.map(f64::from));
    let cross = [r[1] * d[2] - r[2] * d[1], r[2] * d[0] - r[0] * d[2], r[0] * d[1] - r[1] * d[0]];
    let length = |v: [f64; 3]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let area = length(cross);
    // Nearly parallel sides (under a thousandth of a degree apart) give no picture either.
    area.is_finite() && area > 0.0 && area > 1e-5 * length(r) * length(d)
}
