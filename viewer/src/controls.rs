//! Which control edits a uniform, decided from its reflection alone (type, range, name and doc
//! comment), so every uniform of every view gets one. The rules are in `docs/reference.md`
//! ("The parameter panel").

use vrs_runtime::reflection::UniformInfo;

/// How the parameter panel edits one uniform.
#[derive(Clone, Debug, PartialEq)]
pub enum Control {
    /// A scalar with an `in LO .. HI` range.
    Slider {
        /// The range's low end.
        lo: f64,
        /// The range's high end.
        hi: f64,
    },
    /// A scalar without a range.
    Drag,
    /// A `bool`.
    Checkbox,
    /// A vector: one slider per component when a range is given (per component, or one for
    /// all), one drag value otherwise.
    Vector {
        /// 2, 3 or 4.
        components: usize,
        /// Each component's `(lo, hi)` when the declaration has a range.
        ranges: Option<Vec<(f64, f64)>>,
    },
    /// A `vec3f` or `vec4f` colour (with alpha for `vec4f`).
    Colour {
        /// Whether it has a fourth, alpha component.
        alpha: bool,
    },
    /// A matrix: a grid of drag values, one column of the matrix per grid column.
    Matrix {
        /// The matrix's columns (grid columns).
        columns: usize,
        /// The matrix's rows (grid rows).
        rows: usize,
    },
    /// A volume or transfer function: edited in the transfer-function editor, not here.
    Resource,
    /// Set by the renderer before every frame (camera, slice plane, volume transforms): shown,
    /// not edited.
    SetByRenderer,
}

/// The control for `info`.
pub fn control_for(info: &UniformInfo) -> Control {
    if info.ty == "volume" || info.ty == "tf" {
        return Control::Resource;
    }
    if vrs_runtime::scene::is_set_by_renderer(&info.name) {
        return Control::SetByRenderer;
    }
    let Some(shape) = Shape::of(&info.ty) else { return Control::Drag };
    let ranges = info.range.as_ref().and_then(|r| component_ranges(r, shape.columns * shape.rows));
    match shape {
        Shape { columns: 1, rows: 1, boolean: true } => Control::Checkbox,
        Shape { columns: 1, rows: 1, .. } => match ranges.as_deref() {
            Some(&[(lo, hi)]) => Control::Slider { lo, hi },
            _ => Control::Drag,
        },
        Shape { columns: 1, rows, boolean: false } if (rows == 3 || rows == 4) && is_colour(info, &ranges) => {
            Control::Colour { alpha: rows == 4 }
        }
        Shape { columns: 1, rows, .. } => Control::Vector { components: rows, ranges },
        Shape { columns, rows, .. } => Control::Matrix { columns, rows },
    }
}

/// A colour: named so (`color` or `colour` in the name) or described so (the word in the doc
/// comment), with every component's range, if any, within 0..1 (a picker cannot go beyond).
fn is_colour(info: &UniformInfo, ranges: &Option<Vec<(f64, f64)>>) -> bool {
    let mentions = |text: &str| {
        let text = text.to_ascii_lowercase();
        text.split(|c: char| !c.is_ascii_alphanumeric()).any(|word| word == "color" || word == "colour")
    };
    let name = info.name.to_ascii_lowercase();
    let named = name.contains("color") || name.contains("colour");
    let described = info.doc.as_deref().is_some_and(mentions);
    let in_unit = ranges.as_ref().is_none_or(|r| r.iter().all(|&(lo, hi)| lo >= 0.0 && hi <= 1.0));
    (named || described) && in_unit
}

/// The range of each of `n` components: one scalar range for all, or one per component.
fn component_ranges(range: &[serde_json::Value; 2], n: usize) -> Option<Vec<(f64, f64)>> {
    let flat = |v: &serde_json::Value| -> Option<Vec<f64>> {
        match v {
            serde_json::Value::Array(items) => items.iter().map(serde_json::Value::as_f64).collect(),
            scalar => Some(vec![scalar.as_f64()?; n]),
        }
    };
    let (lo, hi) = (flat(&range[0])?, flat(&range[1])?);
    (lo.len() == n && hi.len() == n).then(|| lo.into_iter().zip(hi).collect())
}

/// The shape of a VRS value type: `f32` 1x1, `vec3u` 1x3, `mat4x3f` 4 columns of 3.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Shape {
    columns: usize,
    rows: usize,
    boolean: bool,
}

impl Shape {
    fn of(ty: &str) -> Option<Shape> {
        let digit = |b: u8| (b as char).to_digit(10).map(|d| d as usize).filter(|d| (2..=4).contains(d));
        let scalar = |s: &str| matches!(s, "f" | "i" | "u" | "h" | "b");
        match ty {
            "f32" | "i32" | "u32" | "f16" => Some(Shape { columns: 1, rows: 1, boolean: false }),
            "bool" => Some(Shape { columns: 1, rows: 1, boolean: true }),
            _ => {
                if let Some(rest) = ty.strip_prefix("vec") {
                    let rows = digit(*rest.as_bytes().first()?)?;
                    scalar(&rest[1..]).then_some(Shape { columns: 1, rows, boolean: &rest[1..] == "b" })
                } else {
                    let rest = ty.strip_prefix("mat")?.as_bytes();
                    let (columns, rows) = (digit(*rest.first()?)?, digit(*rest.get(2)?)?);
                    (rest.get(1) == Some(&b'x')).then_some(Shape { columns, rows, boolean: false })
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn uniform(name: &str, ty: &str, range: Option<[serde_json::Value; 2]>, doc: Option<&str>) -> UniformInfo {
        UniformInfo {
            name: name.into(),
            ty: ty.into(),
            offset: Some(0),
            size: Some(4),
            default: None,
            value: None,
            range,
            doc: doc.map(str::to_string),
        }
    }

    #[test]
    fn scalars_by_range_and_type() {
        let r = Some([json!(0.0), json!(2.0)]);
        assert_eq!(control_for(&uniform("gain", "f32", r, None)), Control::Slider { lo: 0.0, hi: 2.0 });
        assert_eq!(control_for(&uniform("gain", "f32", None, None)), Control::Drag);
        assert_eq!(control_for(&uniform("count", "u32", None, None)), Control::Drag);
        assert_eq!(control_for(&uniform("show", "bool", None, None)), Control::Checkbox);
    }

    #[test]
    fn colours_by_name_or_doc_within_unit_range() {
        let unit = Some([json!(0.0), json!(1.0)]);
        assert_eq!(
            control_for(&uniform("zone_color_a", "vec3f", unit.clone(), None)),
            Control::Colour { alpha: false }
        );
        let doc = Some("The colour behind the volume (premultiplied RGBA).");
        assert_eq!(control_for(&uniform("background", "vec4f", unit.clone(), doc)), Control::Colour { alpha: true });
        // Brighter than white is not a picker's job; nor is a direction.
        let bright = Some([json!(0.0), json!(2.0)]);
        assert!(matches!(control_for(&uniform("light_color", "vec3f", bright, None)), Control::Vector { .. }));
        let dir = uniform("light_dir", "vec3f", Some([json!(-1.0), json!(1.0)]), Some("Direction to the light."));
        assert_eq!(control_for(&dir), Control::Vector { components: 3, ranges: Some(vec![(-1.0, 1.0); 3]) });
        // "discolouration" is not the word.
        assert!(matches!(control_for(&uniform("x", "vec3f", None, Some("Discolouration."))), Control::Vector { .. }));
    }

    #[test]
    fn matrices_resources_and_renderer_uniforms() {
        assert_eq!(control_for(&uniform("warp", "mat4x3f", None, None)), Control::Matrix { columns: 4, rows: 3 });
        assert_eq!(control_for(&uniform("volume_gm", "volume", None, None)), Control::Resource);
        assert_eq!(control_for(&uniform("tf", "tf", None, None)), Control::Resource);
        assert_eq!(control_for(&uniform("inv_view_proj", "mat4x4f", None, None)), Control::SetByRenderer);
        assert_eq!(control_for(&uniform("primary_to_gm", "mat4x4f", None, None)), Control::SetByRenderer);
    }

    #[test]
    fn per_component_ranges() {
        let r = Some([json!([0.0, -1.0]), json!([1.0, 1.0])]);
        assert_eq!(
            control_for(&uniform("radii", "vec2f", r, None)),
            Control::Vector { components: 2, ranges: Some(vec![(0.0, 1.0), (-1.0, 1.0)]) }
        );
    }
}
