//! OME-Zarr image metadata (NGFF v0.4 in `.zattrs`, v0.5 under `ome` in `zarr.json`): the
//! chosen multiscale, its axes (name, type, unit, and the anatomical orientation of RFC-4), its
//! datasets with their coordinate transformations, and the channels' names (`omero`).

use serde_json::Value;

use super::Choice;

/// What an axis of the arrays is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum AxisKind {
    /// x, y or z (index 0, 1, 2 of the grid).
    Space(usize),
    Time,
    Channel,
}

/// One axis of a multiscale's arrays.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Axis {
    pub(super) name: String,
    pub(super) kind: AxisKind,
    /// Millimetres per unit of the axis (1 for an axis without a unit, or not spatial).
    pub(super) mm: f64,
    /// For a spatial axis, the patient direction (RAS+) its index grows in.
    pub(super) direction: [f64; 3],
}

/// Scale and translation per array axis (OME's `coordinateTransformations`, composed).
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Transform {
    pub(super) scale: Vec<f64>,
    pub(super) translation: Vec<f64>,
}

impl Transform {
    fn identity(ndim: usize) -> Transform {
        Transform { scale: vec![1.0; ndim], translation: vec![0.0; ndim] }
    }

    /// `self` followed by `outer` (a dataset's transform, then its multiscale's).
    fn then(&self, outer: &Transform) -> Transform {
        let scale = self.scale.iter().zip(&outer.scale).map(|(a, b)| a * b).collect();
        let translation =
            self.translation.iter().zip(&outer.scale).zip(&outer.translation).map(|((t, s), u)| t * s + u).collect();
        Transform { scale, translation }
    }
}

/// One dataset (an array, a level of the pyramid) of a multiscale.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct DatasetMeta {
    pub(super) path: String,
    /// Array index to physical coordinates, in the axes' units (multiscale transform included).
    pub(super) transform: Transform,
}

/// The multiscale a volume shows.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Multiscale {
    pub(super) axes: Vec<Axis>,
    pub(super) datasets: Vec<DatasetMeta>,
    /// The channels' labels (`omero.channels[].label`), when the image names them.
    pub(super) channel_labels: Vec<String>,
}

/// The multiscales of a group's attributes (v0.5 under `ome`, v0.4 at the top).
fn multiscales(attributes: &Value) -> Result<&Vec<Value>, String> {
    let list = attributes
        .get("ome")
        .and_then(|o| o.get("multiscales"))
        .or_else(|| attributes.get("multiscales"))
        .ok_or("a group without OME-Zarr `multiscales` metadata: open one of its arrays instead")?;
    list.as_array().filter(|l| !l.is_empty()).ok_or_else(|| "`multiscales` is not a non-empty list".to_string())
}

/// A label's colour in an OME-Zarr label image: its id and RGBA in [0, 1].
pub type LabelColor = (u64, [f32; 4]);

/// The colours of an OME-Zarr label image (`image-label.colors`, v0.5 under `ome`): `None`
/// when the group is no label image; entries that are not a `label-value` with four 0-255
/// `rgba` numbers are left out.
pub(super) fn label_colors(attributes: &Value) -> Option<Vec<LabelColor>> {
    let label = attributes.get("ome").and_then(|o| o.get("image-label")).or_else(|| attributes.get("image-label"))?;
    let entries = label.get("colors").and_then(Value::as_array).map(Vec::as_slice).unwrap_or_default();
    let color = |entry: &Value| -> Option<LabelColor> {
        let id = entry.get("label-value")?.as_u64()?;
        let rgba: Vec<f64> = entry.get("rgba")?.as_array()?.iter().filter_map(Value::as_f64).collect();
        let rgba: [f64; 4] = rgba.try_into().ok()?;
        Some((id, rgba.map(|c| (c / 255.0).clamp(0.0, 1.0) as f32)))
    };
    Some(entries.iter().filter_map(color).collect())
}

/// The multiscale `choice` picks (by index or `name`; the first without a choice), for arrays
/// of `ndim` axes (the first dataset's, read by the caller once it knows the path: see
/// [`Multiscale::parse`]).
pub(super) fn choose<'a>(attributes: &'a Value, choice: Option<&Choice>) -> Result<&'a Value, String> {
    let list = multiscales(attributes)?;
    let names: Vec<String> = list
        .iter()
        .enumerate()
        .map(|(i, m)| m.get("name").and_then(Value::as_str).map_or_else(|| i.to_string(), str::to_string))
        .collect();
    let found = match choice {
        None => Some(0),
        Some(Choice::Index(i)) => usize::try_from(*i).ok().filter(|&i| i < list.len()),
        Some(Choice::Name(n)) => names.iter().position(|m| m == n),
    };
    found.map(|i| &list[i]).ok_or_else(|| {
        format!("the store has no multiscale {}; it has {} ({})", choice_text(choice), list.len(), names.join(", "))
    })
}

fn choice_text(choice: Option<&Choice>) -> String {
    match choice {
        Some(Choice::Index(i)) => i.to_string(),
        Some(Choice::Name(n)) => format!("`{n}`"),
        None => "0".into(),
    }
}

/// The paths of a multiscale's datasets, finest first as OME lists them.
pub(super) fn dataset_paths(multiscale: &Value) -> Result<Vec<String>, String> {
    let datasets = multiscale
        .get("datasets")
        .and_then(Value::as_array)
        .filter(|d| !d.is_empty())
        .ok_or("`datasets` of the multiscale is not a non-empty list")?;
    datasets
        .iter()
        .enumerate()
        .map(|(i, d)| {
            d.get("path")
                .and_then(Value::as_str)
                .map(|p| p.trim_matches('/').to_string())
                .ok_or_else(|| format!("`datasets[{i}]` has no `path`"))
        })
        .collect()
}

impl Multiscale {
    /// The multiscale `value` over arrays of `ndim` axes, with the image's `attributes` (for the
    /// channels' labels).
    pub(super) fn parse(value: &Value, attributes: &Value, ndim: usize) -> Result<Multiscale, String> {
        let axes = match value.get("axes").and_then(Value::as_array) {
            Some(list) if !list.is_empty() => {
                if list.len() != ndim {
                    return Err(format!("`axes` names {} axes but the arrays have {ndim}", list.len()));
                }
                list.iter().map(parse_axis).collect::<Result<Vec<_>, _>>()?
            }
            _ => unnamed_axes(ndim)?,
        };
        check_axes(&axes)?;
        let common = transform(value.get("coordinateTransformations"), ndim)?;
        let datasets = dataset_paths(value)?
            .into_iter()
            .zip(value["datasets"].as_array().into_iter().flatten())
            .map(|(path, d)| {
                let own = transform(d.get("coordinateTransformations"), ndim)?;
                Ok(DatasetMeta { path, transform: own.then(&common) })
            })
            .collect::<Result<Vec<_>, String>>()?;
        let omero = attributes.get("ome").and_then(|o| o.get("omero")).or_else(|| attributes.get("omero"));
        let channel_labels = omero
            .and_then(|o| o.get("channels"))
            .and_then(Value::as_array)
            .map(|c| c.iter().map(|c| c.get("label").and_then(Value::as_str).unwrap_or("").to_string()).collect())
            .unwrap_or_default();
        Ok(Multiscale { axes, datasets, channel_labels })
    }
}

/// The axes of arrays without names: the last three z, y, x; before them channel (4 axes), or
/// time and channel (5), in OME's order.
pub(super) fn unnamed_axes(ndim: usize) -> Result<Vec<Axis>, String> {
    let names: &[&str] = match ndim {
        3 => &["z", "y", "x"],
        4 => &["c", "z", "y", "x"],
        5 => &["t", "c", "z", "y", "x"],
        _ => return Err(format!("the arrays have {ndim} axes; a volume has 3 (z, y, x), after time and channel")),
    };
    names.iter().map(|n| named_axis(n, None, None, None)).collect()
}

/// The axes of an array whose Zarr v3 `dimension_names` name them all.
pub(super) fn named_axes(names: &[Option<String>]) -> Result<Vec<Axis>, String> {
    let axes = names
        .iter()
        .map(|n| n.as_deref().ok_or(()).and_then(|n| named_axis(n, None, None, None).map_err(|_| ())))
        .collect::<Result<Vec<_>, ()>>()
        .or_else(|()| unnamed_axes(names.len()))?;
    check_axes(&axes)?;
    Ok(axes)
}

fn parse_axis(value: &Value) -> Result<Axis, String> {
    // v0.3 lists names only.
    if let Some(name) = value.as_str() {
        return named_axis(name, None, None, None);
    }
    let name = value.get("name").and_then(Value::as_str).ok_or("an axis without a `name`")?;
    let kind = value.get("type").and_then(Value::as_str);
    let unit = value.get("unit").and_then(Value::as_str);
    let orientation = value.get("orientation").and_then(|o| o.get("value")).and_then(Value::as_str);
    named_axis(name, kind, unit, orientation)
}

/// An axis from its name, type, unit and anatomical orientation: spatial axes by type `space`
/// or, without a type, by the names x, y and z.
fn named_axis(name: &str, kind: Option<&str>, unit: Option<&str>, orientation: Option<&str>) -> Result<Axis, String> {
    let lower = name.to_ascii_lowercase();
    let space = |name: &str| match name {
        "x" => Some(0),
        "y" => Some(1),
        "z" => Some(2),
        _ => None,
    };
    let kind = match (kind, lower.as_str()) {
        (Some("time"), _) | (None, "t" | "time") => AxisKind::Time,
        (Some("channel"), _) | (None, "c" | "channel" | "ch") => AxisKind::Channel,
        (Some("space") | None, n) => match space(n) {
            Some(i) => AxisKind::Space(i),
            None => return Err(format!("spatial axis `{name}` is not x, y or z")),
        },
        (Some(other), _) => {
            return Err(format!("axis `{name}` has type `{other}`; volumes have space, time and channel axes"));
        }
    };
    let mm = match kind {
        AxisKind::Space(_) => unit_mm(unit)?,
        _ => 1.0,
    };
    let direction = match (kind, orientation) {
        (AxisKind::Space(_), Some(o)) => anatomical(o).ok_or_else(|| {
            format!("axis `{name}` has the orientation `{o}`, not one of left-to-right, right-to-left, posterior-to-anterior, anterior-to-posterior, inferior-to-superior, superior-to-inferior")
        })?,
        (AxisKind::Space(i), None) => {
            let mut d = [0.0; 3];
            d[i] = 1.0;
            d
        }
        _ => [0.0; 3],
    };
    Ok(Axis { name: name.to_string(), kind, mm, direction })
}

/// Exactly one axis each of x, y and z, at most one time and one channel axis.
fn check_axes(axes: &[Axis]) -> Result<(), String> {
    let count = |k: AxisKind| axes.iter().filter(|a| a.kind == k).count();
    for (i, name) in ["x", "y", "z"].iter().enumerate() {
        if count(AxisKind::Space(i)) != 1 {
            let names: Vec<&str> = axes.iter().map(|a| a.name.as_str()).collect();
            return Err(format!(
                "the axes {names:?} do not name `{name}` once; a volume has the spatial axes x, y and z"
            ));
        }
    }
    if count(AxisKind::Time) > 1 || count(AxisKind::Channel) > 1 {
        return Err("more than one time or channel axis".into());
    }
    let directions: Vec<[f64; 3]> =
        axes.iter().filter(|a| matches!(a.kind, AxisKind::Space(_))).map(|a| a.direction.map(f64::abs)).collect();
    if (0..3).any(|d| directions.iter().filter(|v| v[d] > 0.0).count() != 1) {
        return Err(
            "the spatial axes' orientations do not name left-right, posterior-anterior and inferior-superior once each"
                .into(),
        );
    }
    Ok(())
}

/// The RAS+ direction of an RFC-4 anatomical orientation (the direction the index grows in).
fn anatomical(value: &str) -> Option<[f64; 3]> {
    Some(match value {
        "left-to-right" => [1.0, 0.0, 0.0],
        "right-to-left" => [-1.0, 0.0, 0.0],
        "posterior-to-anterior" => [0.0, 1.0, 0.0],
        "anterior-to-posterior" => [0.0, -1.0, 0.0],
        "inferior-to-superior" => [0.0, 0.0, 1.0],
        "superior-to-inferior" => [0.0, 0.0, -1.0],
        _ => return None,
    })
}

/// Millimetres per unit of an OME axis unit (`None`: millimetres, as medical data is).
fn unit_mm(unit: Option<&str>) -> Result<f64, String> {
    Ok(match unit {
        None | Some("millimeter") => 1.0,
        Some("micrometer") => 1e-3,
        Some("nanometer") => 1e-6,
        Some("picometer") => 1e-9,
        Some("angstrom") => 1e-7,
        Some("centimeter") => 10.0,
        Some("decimeter") => 100.0,
        Some("meter") => 1e3,
        Some("inch") => 25.4,
        Some(other) => return Err(format!("axis unit `{other}` is not a length this viewer knows")),
    })
}

/// The scale and translation (per array axis) of a list of OME coordinate transformations.
fn transform(list: Option<&Value>, ndim: usize) -> Result<Transform, String> {
    let mut out = Transform::identity(ndim);
    let Some(list) = list else { return Ok(out) };
    let list = list.as_array().ok_or("`coordinateTransformations` is not a list")?;
    for t in list {
        let kind = t.get("type").and_then(Value::as_str).unwrap_or("");
        let numbers = |field: &str| -> Result<Vec<f64>, String> {
            let v: Option<Vec<f64>> =
                t.get(field).and_then(Value::as_array).map(|a| a.iter().filter_map(Value::as_f64).collect());
            match v {
                Some(v) if v.len() == ndim && v.iter().all(|x| x.is_finite()) => Ok(v),
                _ => Err(format!("a `{kind}` transformation needs {ndim} finite numbers in `{field}`")),
            }
        };
        match kind {
            "identity" => {}
            "scale" => {
                let s = numbers("scale")?;
                if s.iter().any(|&v| v <= 0.0) {
                    return Err(format!("scale {s:?} is not positive"));
                }
                out = out.then(&Transform { scale: s, translation: vec![0.0; ndim] });
            }
            "translation" => {
                let t = numbers("translation")?;
                out = out.then(&Transform { scale: vec![1.0; ndim], translation: t });
            }
            other => return Err(format!("coordinate transformation `{other}` is not supported")),
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use serde_json::json;

    use super::*;

    #[test]
    fn transforms_compose_dataset_then_multiscale() {
        let ms = json!({
            "axes": [{"name": "z", "type": "space", "unit": "micrometer"}, {"name": "y", "type": "space"}, {"name": "x", "type": "space"}],
            "datasets": [{"path": "0", "coordinateTransformations": [
                {"type": "scale", "scale": [2.0, 1.0, 1.0]}, {"type": "translation", "translation": [1.0, 2.0, 3.0]}]}],
            "coordinateTransformations": [{"type": "scale", "scale": [10.0, 10.0, 10.0]}],
        });
        let m = Multiscale::parse(&ms, &json!({}), 3).unwrap();
        assert_eq!(m.datasets[0].transform.scale, [20.0, 10.0, 10.0]);
        assert_eq!(m.datasets[0].transform.translation, [10.0, 20.0, 30.0]);
        assert_eq!(m.axes[0].mm, 1e-3);
        assert_eq!(m.axes[0].kind, AxisKind::Space(2));
    }

    #[test]
    fn axes_are_found_by_name_and_type_and_orientation() {
        let axes = named_axes(&[Some("x".into()), Some("y".into()), Some("z".into())]).unwrap();
        assert_eq!(axes.iter().map(|a| a.kind).collect::<Vec<_>>(), [0, 1, 2].map(AxisKind::Space));
        assert_eq!(unnamed_axes(5).unwrap()[1].kind, AxisKind::Channel);
        assert!(unnamed_axes(2).is_err());
        let lps =
            json!({"name": "x", "type": "space", "orientation": {"type": "anatomical", "value": "right-to-left"}});
        assert_eq!(parse_axis(&lps).unwrap().direction, [-1.0, 0.0, 0.0]);
        assert!(check_axes(&unnamed_axes(3).unwrap()[1..]).is_err());
        let bad = json!({"name": "x", "type": "space", "unit": "parsec"});
        assert!(parse_axis(&bad).unwrap_err().contains("parsec"));
    }

    #[test]
    fn multiscales_are_chosen_by_index_or_name() {
        let attrs = json!({"multiscales": [{"name": "a", "datasets": [{"path": "0"}]}, {"name": "b", "datasets": [{"path": "1/"}]}]});
        assert_eq!(dataset_paths(choose(&attrs, Some(&Choice::Name("b".into()))).unwrap()).unwrap(), ["1"]);
        assert_eq!(dataset_paths(choose(&attrs, Some(&Choice::Index(0))).unwrap()).unwrap(), ["0"]);
        let error = choose(&attrs, Some(&Choice::Index(2))).unwrap_err();
        assert!(error.contains("no multiscale 2") && error.contains("a, b"), "{error}");
    }
}
