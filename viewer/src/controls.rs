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
    /// A volume or transfer function (edited in the transfer-function editor, not here), or an
    /// image (a filter's input: the picture itself).
    Resource,
    /// Set by the renderer before every frame (camera, slice plane, volume transforms): shown,
    /// not edited.
    SetByRenderer,
}

/// The control for `info`.
pub fn control_for(info: &UniformInfo) -> Control {
    if ["volume", "tf", "image"].contains(&info.ty.as_str()) {
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

/// `control` with its slider ranges widened to contain every one of `values` (the value in use
/// and the scene's), so that a slider shows a value beyond the declared range instead of
/// clamping it (egui's sliders clamp what they show); with a note that says so, naming the
/// declared range. Ranges that already contain the values stay as declared.
pub fn widened(control: Control, values: &[&vrs_runtime::Value]) -> (Control, Option<String>) {
    let component = |i: usize| values.iter().filter_map(move |v| component_value(v, i));
    let widen = |(lo, hi): (f64, f64), i: usize| component(i).fold((lo, hi), |(lo, hi), x| (lo.min(x), hi.max(x)));
    let note = |declared: &[(f64, f64)], now: &[(f64, f64)]| {
        let mut ranges: Vec<String> =
            declared.iter().zip(now).filter(|(d, n)| d != n).map(|(&(lo, hi), _)| format!("{lo} .. {hi}")).collect();
        ranges.dedup();
        (!ranges.is_empty()).then(|| {
            format!("a value lies beyond the declared range {}: the slider is widened to show it", ranges.join(", "))
        })
    };
    match control {
        Control::Slider { lo, hi } => {
            let (wlo, whi) = widen((lo, hi), 0);
            let said = note(&[(lo, hi)], &[(wlo, whi)]);
            (Control::Slider { lo: wlo, hi: whi }, said)
        }
        Control::Vector { components, ranges: Some(ranges) } => {
            let wide: Vec<(f64, f64)> = ranges.iter().enumerate().map(|(i, &r)| widen(r, i)).collect();
            let said = note(&ranges, &wide);
            (Control::Vector { components, ranges: Some(wide) }, said)
        }
        other => (other, None),
    }
}

/// Component `i` of a numeric value, if it has one (and it is finite).
fn component_value(value: &vrs_runtime::Value, i: usize) -> Option<f64> {
    let x = match value {
        vrs_runtime::Value::Float(v) => f64::from(*v.get(i)?),
        vrs_runtime::Value::Int(v) => f64::from(*v.get(i)?),
        vrs_runtime::Value::Uint(v) => f64::from(*v.get(i)?),
        vrs_runtime::Value::Bool(_) => return None,
    };
    x.is_finite().then_some(x)
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
        assert_eq!(control_for(&uniform("picture", "image", None, None)), Control::Resource);
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

    #[test]
    fn ranges_widen_to_show_a_value_beyond_them_and_say_so() {
        use vrs_runtime::Value;
        let colour = Value::Float(vec![3.2, 3.0, 2.7]);
        let declared = Control::Vector { components: 3, ranges: Some(vec![(0.0, 2.0); 3]) };
        let (control, note) = widened(declared.clone(), &[&colour]);
        let wide = |hi: f32| (0.0, f64::from(hi));
        assert_eq!(control, Control::Vector { components: 3, ranges: Some(vec![wide(3.2), wide(3.0), wide(2.7)]) });
        assert_eq!(
            note.as_deref(),
            Some("a value lies beyond the declared range 0 .. 2: the slider is widened to show it")
        );
        // A value inside the range (here the scene's, while the user's is beyond) keeps it.
        let (same, none) = widened(declared.clone(), &[&Value::Float(vec![1.0, 0.5, 0.0])]);
        assert_eq!((same, none), (declared, None));
        let (slider, note) =
            widened(Control::Slider { lo: 0.0, hi: 1.0 }, &[&Value::Float(vec![-0.5]), &Value::Float(vec![0.2])]);
        assert_eq!(slider, Control::Slider { lo: -0.5, hi: 1.0 });
        assert!(note.is_some_and(|n| n.contains("0 .. 1")));
        // Not a number, or nothing to widen: unchanged.
        assert_eq!(widened(Control::Drag, &[&colour]), (Control::Drag, None));
        let nan = Value::Float(vec![f32::NAN]);
        assert_eq!(widened(Control::Slider { lo: 0.0, hi: 1.0 }, &[&nan]).0, Control::Slider { lo: 0.0, hi: 1.0 });
    }
}
