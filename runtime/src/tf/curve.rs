//! Transfer functions as control points: what the presets and ParaView colormaps are made of,
//! what the viewer's editor moves, and what it saves back as a ParaView colormap that
//! [`super::from_paraview_json`] loads to the same table.

use super::{ColorPoint, OpacityPoint, TfDomain, TransferFunction, from_data_points, from_points};
use serde_json::{Value, json};

/// A transfer function as its control points: colour stops and the opacity curve, in the units
/// of `domain` (the window's [0, 1] for a window-relative curve, data units otherwise).
/// Between points both are linear; beyond the first and last point the end values hold.
#[derive(Clone, Debug, PartialEq)]
pub struct TfCurve {
    /// The preset's or colormap's name, for editors and reports.
    pub name: String,
    /// Colour stops, by position in `domain`.
    pub color: Vec<ColorPoint>,
    /// The opacity curve's points, by position in `domain`.
    pub opacity: Vec<OpacityPoint>,
    pub(crate) domain: TfDomain,
}

impl TfCurve {
    /// The table the curve stands for (before it is resampled over a volume's window).
    pub fn table(&self) -> TransferFunction {
        match self.domain {
            TfDomain::Window => from_points(&self.name, &self.color, &self.opacity),
            TfDomain::Data(domain) => from_data_points(&self.name, &self.color, &self.opacity, domain),
        }
    }

    /// The same curve in data units for a volume of `window`: a window-relative curve's points
    /// are placed onto the window (which becomes its domain); a curve in data units is
    /// unchanged. The table over the window is the same either way.
    pub fn in_data_units(&self, [lo, hi]: [f32; 2]) -> TfCurve {
        if self.domain != TfDomain::Window || hi <= lo {
            return self.clone();
        }
        let at = |x: f32| lo + x * (hi - lo);
        TfCurve {
            name: self.name.clone(),
            color: self.color.iter().map(|&(x, c)| (at(x), c)).collect(),
            opacity: self.opacity.iter().map(|&(x, a)| (at(x), a)).collect(),
            domain: TfDomain::Data([lo, hi]),
        }
    }

    /// The data values the curve's domain spans: its own, or `window` for a window-relative
    /// curve (what reading software shows as its window: width `hi - lo`, level the middle).
    pub fn data_domain(&self, window: [f32; 2]) -> [f32; 2] {
        match self.domain {
            TfDomain::Data(domain) => domain,
            TfDomain::Window => window,
        }
    }

    /// The curve in data units (placed on `window` if window-relative, as [`in_data_units`]
    /// does) with its level (the middle of its domain) moved by `level_shift` data units and its
    /// width (the domain's length) scaled by `width_scale` around the level: what dragging
    /// window/level in a slice view does (3D Slicer's window/level mode). Every point keeps its
    /// place relative to the domain, so a grey ramp stays a ramp over the new window.
    ///
    /// [`in_data_units`]: TfCurve::in_data_units
    pub fn window_levelled(&self, window: [f32; 2], level_shift: f32, width_scale: f32) -> TfCurve {
        let curve = self.in_data_units(window);
        let TfDomain::Data([lo, hi]) = curve.domain else { return curve };
        let (level, width) = (0.5 * (lo + hi), hi - lo);
        let new_width = (width * width_scale).max(width.abs() * 1e-3).max(f32::MIN_POSITIVE);
        let new_level = level + level_shift;
        let at = |x: f32| new_level + (x - level) * new_width / width;
        TfCurve {
            name: curve.name.clone(),
            color: curve.color.iter().map(|&(x, c)| (at(x), c)).collect(),
            opacity: curve.opacity.iter().map(|&(x, a)| (at(x), a)).collect(),
            domain: TfDomain::Data([at(lo), at(hi)]),
        }
    }

    /// The curve as a ParaView colormap (the JSON of `File > Export` in ParaView's colour map
    /// editor) in data units; `window` places a window-relative curve. Points are added at the
    /// domain's ends with the values held there, so the colormap spans the same domain and
    /// loads back to the same table.
    pub fn to_paraview_json(&self, window: [f32; 2]) -> String {
        let curve = self.in_data_units(window);
        let domain = match curve.domain {
            TfDomain::Data(d) => d,
            TfDomain::Window => window,
        };
        let table = curve.table();
        let color = with_ends(&curve.color, domain, |x| rgb_at(&table, domain, x));
        let opacity: Vec<(f32, [f32; 1])> = curve.opacity.iter().map(|&(x, a)| (x, [a])).collect();
        let opacity = with_ends(&opacity, domain, |x| [alpha_at(&table, domain, x)]);
        let rgb: Vec<f32> = color.iter().flat_map(|&(x, [r, g, b])| [x, r, g, b]).collect();
        // ParaView's opacity points are (x, opacity, midpoint, sharpness); 0.5 and 0 are linear.
        let points: Vec<f32> = opacity.iter().flat_map(|&(x, [a])| [x, a, 0.5, 0.0]).collect();
        let map = json!([{ "Name": curve.name, "ColorSpace": "RGB", "RGBPoints": numbers(&rgb), "Points": numbers(&points) }]);
        serde_json::to_string_pretty(&map).unwrap_or_default()
    }
}

/// The points sorted by x, with a point at each end of `domain` holding the value there
/// (`value_at`) unless one is there already.
fn with_ends<const N: usize>(
    points: &[(f32, [f32; N])],
    [lo, hi]: [f32; 2],
    value_at: impl Fn(f32) -> [f32; N],
) -> Vec<(f32, [f32; N])> {
    let mut sorted: Vec<(f32, [f32; N])> = points.iter().filter(|p| p.0.is_finite()).copied().collect();
    sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
    if sorted.first().is_none_or(|p| p.0 > lo) {
        sorted.insert(0, (lo, value_at(lo)));
    }
    if sorted.last().is_none_or(|p| p.0 < hi) {
        sorted.push((hi, value_at(hi)));
    }
    sorted
}

/// The table's entry nearest to data value `x` of `domain` (only used at the domain's ends,
/// where it is exact).
fn entry(table: &TransferFunction, [lo, hi]: [f32; 2], x: f32) -> [f32; 4] {
    let last = table.rgba.len().saturating_sub(1);
    let t = if hi > lo { ((x - lo) / (hi - lo)).clamp(0.0, 1.0) } else { 0.0 };
    table.rgba.get((t * last as f32).round() as usize).copied().unwrap_or([0.0; 4])
}

fn rgb_at(table: &TransferFunction, domain: [f32; 2], x: f32) -> [f32; 3] {
    let [r, g, b, _] = entry(table, domain, x);
    [r, g, b]
}

fn alpha_at(table: &TransferFunction, domain: [f32; 2], x: f32) -> f32 {
    entry(table, domain, x)[3]
}

/// JSON numbers, as short as they round-trip (f32 printed through f64 would add digits).
fn numbers(values: &[f32]) -> Value {
    Value::Array(values.iter().map(|&v| v.to_string().parse::<f64>().map_or(Value::Null, Value::from)).collect())
}

#[cfg(test)]
mod tests {
    use super::super::{PRESETS, TF_WIDTH, TfDomain, parse_paraview, preset, preset_curve};
    use super::*;

    fn max_difference(a: &TransferFunction, b: &TransferFunction) -> f32 {
        a.rgba.iter().flatten().zip(b.rgba.iter().flatten()).map(|(x, y)| (x - y).abs()).fold(0.0, f32::max)
    }

    #[test]
    fn every_preset_is_its_curve() {
        for &name in PRESETS {
            let curve = preset_curve(name).unwrap();
            assert_eq!(curve.table(), preset(name).unwrap(), "{name}");
        }
    }

    #[test]
    fn a_curve_in_data_units_gives_the_same_table_over_its_window() {
        let window = [-50.0, 350.0];
        for name in ["mr_default", "labels", "ct_bone"] {
            let curve = preset_curve(name).unwrap();
            let before = curve.table().over_window(window);
            let after = curve.in_data_units(window).table().over_window(window);
            assert!(max_difference(&before, &after) < 1e-4, "{name}");
        }
    }

    #[test]
    fn saved_colormaps_load_back_to_the_same_table() {
        // A window curve placed on a window, a CT preset over its Hounsfield domain, and one
        // whose points stop short of its domain's ends.
        let short = TfCurve {
            name: "short".into(),
            color: vec![(100.0, [1.0, 0.0, 0.0]), (200.0, [0.0, 0.0, 1.0])],
            opacity: vec![(150.0, 0.2), (180.0, 0.9)],
            domain: TfDomain::Data([0.0, 1000.0]),
        };
        let window = [20.0, 900.0];
        for curve in [preset_curve("mr_default").unwrap(), preset_curve("ct_soft_tissue").unwrap(), short] {
            let json = curve.to_paraview_json(window);
            let loaded = parse_paraview(&json, "fallback").unwrap();
            assert_eq!(loaded.name, curve.name);
            let (before, after) = (curve.table().over_window(window), loaded.table().over_window(window));
            assert!(max_difference(&before, &after) < 1e-4, "{}: {json}", curve.name);
            assert_eq!(before.to_rgba16f(), after.to_rgba16f(), "{}", curve.name);
        }
    }

    #[test]
    fn a_saved_colormap_is_paraview_json() {
        let json: Value = serde_json::from_str(&preset_curve("ct_bone").unwrap().to_paraview_json([0.0, 1.0])).unwrap();
        let map = &json[0];
        assert_eq!(map["Name"], "ct_bone");
        let rgb = map["RGBPoints"].as_array().unwrap();
        assert_eq!(rgb.len() % 4, 0);
        assert_eq!(rgb[0].as_f64(), Some(-1024.0), "the domain's low end, in Hounsfield units");
        assert_eq!(map["Points"].as_array().unwrap().len() % 4, 0);
        assert_eq!(TF_WIDTH, 1024);
    }

    #[test]
    fn window_level_moves_and_scales_the_domain_around_its_middle() {
        let grey = preset_curve("grayscale").unwrap();
        // Over a window of [0, 100]: level 50, width 100; level +10 and half the width.
        let levelled = grey.window_levelled([0.0, 100.0], 10.0, 0.5);
        assert_eq!(levelled.domain, TfDomain::Data([35.0, 85.0]));
        let table = levelled.table().over_window([0.0, 100.0]);
        let at = |v: f32| table.sample(v / 100.0)[0];
        assert!(at(30.0) < 1e-3 && at(90.0) > 0.999, "black below the window, white above");
        assert!((at(60.0) - 0.5).abs() < 0.01, "grey at the level: {}", at(60.0));
        // Twice: the moves add up, the scales multiply.
        let again = levelled.window_levelled([0.0, 100.0], -10.0, 2.0);
        assert_eq!(again.domain, TfDomain::Data([0.0, 100.0]));
    }
}
