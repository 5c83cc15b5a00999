//! Transfer functions: a colour and an opacity for each sample value.
//!
//! A transfer function is a table of `TF_WIDTH` RGBA entries with straight (not premultiplied)
//! alpha, uploaded as a 1D `Rgba16Float` texture, and the [`TfDomain`] its entries stand for: data values
//! (Hounsfield units for the CT presets, the file's values for a ParaView colormap), or the
//! window of the volume it classifies (the MR and generic presets). Before upload the table is
//! resampled over the volume's window ([`TransferFunction::over_window`]), which is also what
//! the volume's texture is normalized by, so the shader's `lookup(tf, value)` of a normalized
//! value reads the entry of that data value. The opacity of an entry is the opacity of one sample
//! at the compositor's reference step: `ref_step`, a uniform of `dvr_opacity` in
//! `std::composite_dvr`, in millimetres (the scene's value, else the runtime's default, the
//! primary volume's smallest voxel spacing; other steps are corrected to it). So a value that
//! fills a region should have a small opacity (a few hundredths) to stay see-through, and only
//! surfaces meant to look solid should approach 1.
//!
//! CT presets (`ct_*`) are defined in Hounsfield units over `CT_DOMAIN`, whatever the window;
//! the others over the window, so they fit any volume (an MR, a probability map) once its
//! window picks the interesting values.

use std::fmt;
use std::path::{Path, PathBuf};

use serde_json::Value;

mod curve;
mod labels;
pub(crate) mod preintegrate;
pub use curve::TfCurve;
pub(crate) use labels::{LABEL_WINDOW, label_curve};

/// Entries in a transfer function table.
pub(crate) const TF_WIDTH: u32 = 1024;

/// The centre of texel `i` of a table of `n` texels, `(i + 0.5) / n`: where a linear sampler
/// reads that entry alone.
pub(crate) fn texel_centre(i: usize, n: usize) -> f64 {
    (i as f64 + 0.5) / n as f64
}

/// The normalized value a transfer function's entry `i` is made from: its texel's centre, where
/// the shader's `lookup(tf, x)` (a plain linear sample at `x`) reads it alone, except the first
/// and last entries, which are the curve's values at 0 and 1. A linear sampler holds those from
/// their centres to the table's ends, so values at or beyond the window's ends (all the air
/// clamped to its low end, a ParaView map's values below its first point) read the curve's end
/// values exactly; otherwise a ramp from 0 would give them an opacity of half an entry's step
/// (4.9e-4 per reference step: a veil through 200 mm of air). The price: within the first and
/// last one and a half entries the table bends from the curve by less than one entry's step.
pub(crate) fn entry_value(i: u32) -> f32 {
    match i {
        0 => 0.0,
        i if i + 1 >= TF_WIDTH => 1.0,
        i => texel_centre(i as usize, TF_WIDTH as usize) as f32,
    }
}

/// What a linear sampler reads from `rows` (texel-centred entries, see [`texel_centre`]) at the
/// normalized value `x`: the two nearest entries blended, the end entries held beyond their
/// centres.
pub(crate) fn sample_rows(rows: &[[f32; 4]], x: f32) -> [f32; 4] {
    let last = rows.len().saturating_sub(1);
    let at = (x * rows.len() as f32 - 0.5).clamp(0.0, last as f32);
    let below = (at.floor() as usize).min(last.saturating_sub(1));
    let t = at - below as f32;
    let (a, b) = (rows[below], rows[(below + 1).min(last)]);
    std::array::from_fn(|c| a[c] + (b[c] - a[c]) * t)
}

/// RGBA entries as little-endian `f16` (8 bytes per entry), for an `Rgba16Float` texture
/// (filterable on every adapter, unlike `Rgba32Float`): an 11-bit mantissa, so an opacity of
/// 0.001 is held to 5e-7 where 8 bits rounded it to 0 (and 0.0098 to 0.0118).
pub(crate) fn to_rgba16f(entries: &[[f32; 4]]) -> Vec<u8> {
    entries.iter().flatten().flat_map(|&c| half::f16::from_f32(c).to_le_bytes()).collect()
}

/// What the first and last entries of a transfer function's table stand for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TfDomain {
    /// The low and high ends of the window of the volume it classifies.
    Window,
    /// These data values (lo < hi): Hounsfield units for CT presets, a colormap's own values.
    Data([f32; 2]),
}

/// The Hounsfield range the CT presets are defined over: the 12-bit range scanners store.
pub(crate) const CT_DOMAIN: [f32; 2] = [-1024.0, 3071.0];

/// A transfer function table.
#[derive(Clone, Debug, PartialEq)]
pub struct TransferFunction {
    /// The preset's name, the colormap's `Name`, or the file stem.
    pub(crate) name: String,
    /// `TF_WIDTH` entries over `domain`, entry i made at `entry_value` of it: r, g, b and
    /// straight alpha, each in [0, 1].
    pub rgba: Vec<[f32; 4]>,
    /// What the first and last entries stand for.
    pub domain: TfDomain,
}

impl TransferFunction {
    /// The table over `window` (data units): entry i stands for the value
    /// `lo + entry_value(i) * (hi - lo)`, read from this table as the shader's linear sampler
    /// would (its end entries held beyond their centres). A window-relative function is already over any
    /// window and comes back as it is.
    pub fn over_window(&self, [lo, hi]: [f32; 2]) -> TransferFunction {
        let TfDomain::Data([d0, d1]) = self.domain else { return self.clone() };
        let rgba = (0..TF_WIDTH)
            .map(|i| {
                let value = f64::from(lo) + f64::from(hi - lo) * f64::from(entry_value(i));
                self.sample(((value - f64::from(d0)) / f64::from(d1 - d0)) as f32)
            })
            .collect();
        TransferFunction { name: self.name.clone(), rgba, domain: TfDomain::Window }
    }

    /// What the shader's `lookup` reads at the normalized value `x` (see `texel_centre`).
    pub fn sample(&self, x: f32) -> [f32; 4] {
        sample_rows(&self.rgba, x)
    }

    /// The table as little-endian `f16` RGBA (8 bytes per entry), as it is uploaded.
    pub fn to_rgba16f(&self) -> Vec<u8> {
        to_rgba16f(&self.rgba)
    }
}

/// A colour control point: normalized value, then r, g, b in [0, 1].
pub(crate) type ColorPoint = (f32, [f32; 3]);

/// An opacity control point: normalized value, then opacity in [0, 1].
pub(crate) type OpacityPoint = (f32, f32);

/// The built-in transfer functions: the window-relative ones, then the CT presets in
/// Hounsfield units.
pub const PRESETS: &[&str] = &[
    "grayscale",
    "mr_default",
    "vessel_red",
    "vessel_blue",
    "hot_metal",
    "labels",
    "ct_bone",
    "ct_soft_tissue",
    "ct_lung",
    "ct_angio",
    "ct_cardiac",
    "ct_coronary",
    "ct_muscle",
    "ct_fat",
    "ct_skin",
    "ct_mip",
];

/// Why a transfer function could not be made.
#[derive(Debug)]
#[non_exhaustive]
pub enum TfError {
    /// The name is not one of [`PRESETS`].
    UnknownPreset {
        /// The name asked for.
        name: String,
    },
    /// A colormap file could not be read.
    Io {
        /// The colormap file.
        path: PathBuf,
        /// What the operating system said.
        error: std::io::Error,
    },
    /// A colormap file is not a ParaView colormap; `message` says what is wrong.
    Invalid {
        /// The colormap file.
        path: PathBuf,
        /// What is wrong with it.
        message: String,
    },
}

impl fmt::Display for TfError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TfError::UnknownPreset { name } => {
                write!(f, "unknown transfer function preset `{name}`")?;
                if let Some(close) = did_you_mean(name, PRESETS) {
                    write!(f, " (did you mean `{close}`?)")?;
                }
                write!(f, "; the presets are: {}", PRESETS.join(", "))
            }
            TfError::Io { path, error } => write!(f, "`{}`: cannot read: {error}", path.display()),
            TfError::Invalid { path, message } => write!(f, "`{}`: {message}", path.display()),
        }
    }
}

impl std::error::Error for TfError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            TfError::Io { error, .. } => Some(error),
            _ => None,
        }
    }
}

/// The preset `name` (one of [`PRESETS`]).
pub fn preset(name: &str) -> Result<TransferFunction, TfError> {
    preset_curve(name).map(|c| c.table())
}

/// The control points of preset `name` (one of [`PRESETS`]).
pub fn preset_curve(name: &str) -> Result<TfCurve, TfError> {
    let curve = |color: &[ColorPoint], opacity: &[OpacityPoint], domain| TfCurve {
        name: name.to_string(),
        color: color.to_vec(),
        opacity: opacity.to_vec(),
        domain,
    };
    if let Some((color, opacity)) = ct_preset(name) {
        return Ok(curve(color, opacity, TfDomain::Data(CT_DOMAIN)));
    }
    let (color, opacity): (&[ColorPoint], &[OpacityPoint]) = match name {
        // A grey ramp; opacity grows with the value so dense material hides what is behind it.
        "grayscale" => (&[(0.0, [0.0; 3]), (1.0, [1.0; 3])], &[(0.05, 0.0), (1.0, 0.25)]),
        // Grey to white, transparent below ~0.15 (background noise in MRI), moderate above.
        "mr_default" => (
            &[(0.0, [0.1; 3]), (0.15, [0.35; 3]), (0.6, [0.8, 0.8, 0.78]), (1.0, [1.0; 3])],
            &[(0.15, 0.0), (0.4, 0.03), (0.7, 0.12), (1.0, 0.3)],
        ),
        // Bright structures (above ~0.55 of the window: contrast-filled vessels, a probability
        // map's likely voxels): dark to bright red (or blue), nearly opaque.
        "vessel_red" => (
            &[(0.0, [0.0; 3]), (0.55, [0.5, 0.03, 0.03]), (0.7, [0.9, 0.12, 0.1]), (1.0, [1.0, 0.55, 0.5])],
            &[(0.55, 0.0), (0.62, 0.4), (0.75, 0.75), (1.0, 0.9)],
        ),
        "vessel_blue" => (
            &[(0.0, [0.0; 3]), (0.55, [0.03, 0.08, 0.5]), (0.7, [0.1, 0.3, 0.95]), (1.0, [0.55, 0.75, 1.0])],
            &[(0.55, 0.0), (0.62, 0.4), (0.75, 0.75), (1.0, 0.9)],
        ),
        // Black body colours: black, red, yellow, white.
        "hot_metal" => (
            &[(0.0, [0.0; 3]), (0.35, [0.85, 0.05, 0.0]), (0.7, [1.0, 0.85, 0.0]), (1.0, [1.0; 3])],
            &[(0.05, 0.0), (1.0, 0.3)],
        ),
        "labels" => return Ok(labels::preset()),
        _ => return Err(TfError::UnknownPreset { name: name.to_string() }),
    };
    Ok(curve(color, opacity, TfDomain::Window))
}

/// The control points of the CT presets, in Hounsfield units. Reference levels: air -1000,
/// lung -900 to -500, fat -120 to -60, water 0, soft tissue and blood 20 to 80, contrast-filled
/// vessels 150 to 500, cancellous bone 300 to 700, cortical bone above 700.
#[allow(clippy::type_complexity)]
fn ct_preset(name: &str) -> Option<(&'static [ColorPoint], &'static [OpacityPoint])> {
    Some(match name {
        // Bone only: ivory turning white, nearly opaque; soft tissue and contrast below 180 HU
        // are invisible.
        "ct_bone" => (
            &[
                (-1024.0, [0.0; 3]),
                (180.0, [0.55, 0.45, 0.35]),
                (500.0, [0.92, 0.85, 0.72]),
                (1500.0, [1.0, 1.0, 0.97]),
            ],
            &[(180.0, 0.0), (300.0, 0.4), (600.0, 0.75), (1200.0, 0.9)],
        ),
        // Fat faint yellow, soft tissue reddish beige and see-through, contrast-filled vessels
        // bright red-white, bone white and dense.
        "ct_soft_tissue" => (
            &[
                (-1024.0, [0.0; 3]),
                (-150.0, [0.6, 0.45, 0.25]),
                (-60.0, [0.85, 0.7, 0.4]),
                (20.0, [0.8, 0.38, 0.3]),
                (80.0, [0.95, 0.68, 0.55]),
                (200.0, [1.0, 0.35, 0.25]),
                (400.0, [1.0, 0.75, 0.7]),
                (800.0, [1.0, 1.0, 0.95]),
            ],
            &[
                (-200.0, 0.0),
                (-120.0, 0.004),
                (-60.0, 0.004),
                (0.0, 0.012),
                (80.0, 0.035),
                (150.0, 0.05),
                (220.0, 0.3),
                (400.0, 0.45),
                (1000.0, 0.8),
            ],
        ),
        // Lung parenchyma pink and translucent; air, soft tissue and bone invisible.
        "ct_lung" => (
            &[(-1000.0, [0.35, 0.2, 0.2]), (-800.0, [0.9, 0.6, 0.55]), (-500.0, [1.0, 0.85, 0.8])],
            &[(-950.0, 0.0), (-850.0, 0.03), (-600.0, 0.06), (-450.0, 0.0)],
        ),
        // Angiography (vessels, aortic aneurysms): contrast-filled vessels red, bone white.
        "ct_angio" => (
            &[
                (100.0, [0.6, 0.05, 0.05]),
                (200.0, [0.9, 0.15, 0.1]),
                (400.0, [1.0, 0.6, 0.5]),
                (700.0, [1.0, 1.0, 0.95]),
            ],
            &[(120.0, 0.0), (180.0, 0.4), (300.0, 0.7), (700.0, 0.85)],
        ),
        // Heart: myocardium faint red, contrast-filled chambers bright red, bone white.
        "ct_cardiac" => (
            &[
                (0.0, [0.5, 0.1, 0.1]),
                (80.0, [0.8, 0.3, 0.25]),
                (200.0, [1.0, 0.25, 0.2]),
                (400.0, [1.0, 0.8, 0.7]),
                (800.0, [1.0; 3]),
            ],
            &[(20.0, 0.0), (80.0, 0.02), (150.0, 0.1), (250.0, 0.5), (800.0, 0.8)],
        ),
        // Coronary arteries: only the densest contrast (250-600 HU) orange-red, bone white.
        "ct_coronary" => (
            &[(200.0, [0.8, 0.2, 0.05]), (350.0, [1.0, 0.45, 0.15]), (600.0, [1.0, 0.9, 0.8])],
            &[(220.0, 0.0), (300.0, 0.6), (600.0, 0.9)],
        ),
        // Muscle red and fairly opaque, fat faint yellow, bone white.
        "ct_muscle" => (
            &[(-100.0, [0.8, 0.7, 0.4]), (20.0, [0.75, 0.2, 0.15]), (80.0, [0.9, 0.3, 0.25]), (300.0, [1.0, 0.9, 0.8])],
            &[(-150.0, 0.0), (-80.0, 0.01), (-30.0, 0.0), (20.0, 0.05), (80.0, 0.2), (700.0, 0.7)],
        ),
        // Fat only, yellow.
        "ct_fat" => (
            &[(-150.0, [0.9, 0.75, 0.3]), (-50.0, [1.0, 0.9, 0.5])],
            &[(-200.0, 0.0), (-120.0, 0.15), (-60.0, 0.15), (-30.0, 0.0)],
        ),
        // The body's surface: the step from air to skin, beige and opaque.
        "ct_skin" => (&[(-500.0, [0.8, 0.6, 0.5]), (0.0, [0.95, 0.8, 0.7])], &[(-500.0, 0.0), (-300.0, 0.8)]),
        // For maximum intensity projections: a grey ramp from soft tissue to dense bone.
        "ct_mip" => (&[(-200.0, [0.0; 3]), (1500.0, [1.0; 3])], &[(-200.0, 0.0), (1500.0, 1.0)]),
        _ => return None,
    })
}

/// Distinct colours for the label bins 1..=16 (bin 0 is the transparent background).
const LABEL_COLOURS: [[f32; 3]; 16] = [
    [0.90, 0.10, 0.10],
    [0.15, 0.70, 0.20],
    [0.15, 0.35, 0.95],
    [0.95, 0.85, 0.10],
    [0.80, 0.20, 0.80],
    [0.10, 0.80, 0.85],
    [1.00, 0.55, 0.10],
    [0.50, 0.30, 0.85],
    [0.65, 0.90, 0.20],
    [1.00, 0.55, 0.70],
    [0.10, 0.50, 0.50],
    [0.60, 0.40, 0.20],
    [0.95, 0.95, 0.70],
    [0.50, 0.05, 0.10],
    [0.60, 0.80, 1.00],
    [0.40, 0.40, 0.40],
];

/// A transfer function over data values `domain` from control points in data units.
pub(crate) fn from_data_points(
    name: &str,
    color: &[ColorPoint],
    opacity: &[OpacityPoint],
    domain: [f32; 2],
) -> TransferFunction {
    let [lo, hi] = domain;
    let to_unit = |x: f32| (x - lo) / (hi - lo);
    let color: Vec<ColorPoint> = color.iter().map(|&(x, c)| (to_unit(x), c)).collect();
    let opacity: Vec<OpacityPoint> = opacity.iter().map(|&(x, o)| (to_unit(x), o)).collect();
    TransferFunction { domain: TfDomain::Data(domain), ..from_points(name, &color, &opacity) }
}

/// Builds a window-relative table by piecewise-linear interpolation between control points
/// `(x, value)` over [0, 1] of the window, holding the end values beyond the first and last points. Points need not be sorted;
/// two points at the same x make a step (the later one applies from x on). Without colour points
/// the colour is white; without opacity points the opacity is a linear ramp from 0 to 1.
/// Values are clamped to [0, 1].
pub(crate) fn from_points(name: &str, color: &[ColorPoint], opacity: &[OpacityPoint]) -> TransferFunction {
    let opacity: Vec<(f32, [f32; 1])> = opacity.iter().map(|&(x, o)| (x, [o])).collect();
    let colors = Table::new(color);
    let alphas = Table::new(&opacity);
    let rgba = (0..TF_WIDTH)
        .map(|i| {
            let x = entry_value(i);
            let [r, g, b] = colors.at(x).unwrap_or([1.0; 3]);
            let [a] = alphas.at(x).unwrap_or([x]);
            [r, g, b, a].map(|c| if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) })
        })
        .collect();
    TransferFunction { name: name.to_string(), rgba, domain: TfDomain::Window }
}

/// Control points sorted by x (stably, so steps keep their order), non-finite x dropped.
struct Table<const N: usize> {
    points: Vec<(f32, [f32; N])>,
}

impl<const N: usize> Table<N> {
    fn new(points: &[(f32, [f32; N])]) -> Self {
        let mut points: Vec<_> = points.iter().filter(|p| p.0.is_finite()).copied().collect();
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        Table { points }
    }

    /// The interpolated value at `x`; `None` without points.
    fn at(&self, x: f32) -> Option<[f32; N]> {
        let after = self.points.partition_point(|p| p.0 <= x);
        let (first, last) = (self.points.first()?, self.points.last()?);
        if after == 0 {
            return Some(first.1);
        }
        if after == self.points.len() {
            return Some(last.1);
        }
        let ((x0, v0), (x1, v1)) = (self.points[after - 1], self.points[after]);
        let t = (x - x0) / (x1 - x0);
        Some(std::array::from_fn(|i| v0[i] + (v1[i] - v0[i]) * t))
    }
}

/// Reads a ParaView colormap (`File > Export` in the colour map editor): a JSON array of objects
/// (the first with `RGBPoints` is used) or one object, with `RGBPoints` `[x, r, g, b, ...]` and
/// optionally `Points` `[x, opacity, midpoint, sharpness, ...]` (used as linear `x, opacity`).
/// The points are in data units, as ParaView writes them: the table spans the smallest to the
/// largest x of both lists ([`TfDomain::Data`]), and is resampled over each volume's window
/// when uploaded. Without `Points` the opacity is a linear ramp over the colour points' range.
pub fn from_paraview_json(path: &Path) -> Result<TransferFunction, TfError> {
    paraview_curve(path).map(|c| c.table())
}

/// The control points of a ParaView colormap file (see [`from_paraview_json`]).
pub(crate) fn paraview_curve(path: &Path) -> Result<TfCurve, TfError> {
    let text = std::fs::read_to_string(path).map_err(|error| TfError::Io { path: path.to_path_buf(), error })?;
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    parse_paraview(&text, &stem).map_err(|message| TfError::Invalid { path: path.to_path_buf(), message })
}

/// Parses a ParaView colormap's text; errors are messages for users.
fn parse_paraview(text: &str, fallback_name: &str) -> Result<TfCurve, String> {
    let json: Value = serde_json::from_str(text).map_err(|e| format!("not valid JSON: {e}"))?;
    let colormap = match &json {
        Value::Array(items) => items.iter().find(|item| item.get("RGBPoints").is_some()),
        Value::Object(_) => Some(&json),
        _ => None,
    }
    .ok_or("not a ParaView colormap: expected an object, or an array of objects, with `RGBPoints`")?;
    let rgb = numbers(colormap, "RGBPoints")?.ok_or("the colormap has no `RGBPoints`")?;
    if rgb.is_empty() || rgb.len() % 4 != 0 {
        return Err(format!("`RGBPoints` has {} numbers, expected groups of 4 (x, r, g, b)", rgb.len()));
    }
    let opacity = numbers(colormap, "Points")?;
    if let Some(points) = &opacity
        && (points.is_empty() || points.len() % 4 != 0)
    {
        return Err(format!(
            "`Points` has {} numbers, expected groups of 4 (x, opacity, midpoint, sharpness)",
            points.len()
        ));
    }
    let xs = rgb.chunks_exact(4).chain(opacity.iter().flat_map(|p| p.chunks_exact(4))).map(|p| p[0]);
    let (lo, hi) = xs.fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), x| (lo.min(x), hi.max(x)));
    let color: Vec<ColorPoint> = rgb.chunks_exact(4).map(|p| (p[0], [p[1], p[2], p[3]])).collect();
    let (rgb_lo, rgb_hi) = (
        color.iter().map(|p| p.0).fold(f32::INFINITY, f32::min),
        color.iter().map(|p| p.0).fold(f32::NEG_INFINITY, f32::max),
    );
    let opacity: Vec<OpacityPoint> = match &opacity {
        Some(points) => points.chunks_exact(4).map(|p| (p[0], p[1])).collect(),
        None => vec![(rgb_lo, 0.0), (rgb_hi, 1.0)],
    };
    let name = colormap.get("Name").and_then(Value::as_str).unwrap_or(fallback_name);
    // One x for every point: a step at that value, over a domain of one unit around it.
    let domain = if hi > lo { [lo, hi] } else { [lo - 0.5, lo + 0.5] };
    Ok(TfCurve { name: name.to_string(), color, opacity, domain: TfDomain::Data(domain) })
}

/// The array of finite numbers under `key`, if the key is present.
fn numbers(object: &Value, key: &str) -> Result<Option<Vec<f32>>, String> {
    let Some(value) = object.get(key) else { return Ok(None) };
    let array = value.as_array().ok_or_else(|| format!("`{key}` is not an array of numbers"))?;
    array
        .iter()
        .enumerate()
        .map(|(i, v)| match v.as_f64() {
            Some(n) if n.is_finite() => Ok(n as f32),
            _ => Err(format!("`{key}` entry {i} is not a number: `{v}`")),
        })
        .collect::<Result<_, _>>()
        .map(Some)
}

/// The candidate closest to a mistyped `name`, if any is close: at most one edit (insertion,
/// deletion, substitution or swap of neighbours) per three characters. Shared by the lists of
/// names the runtime accepts (presets, phantoms).
///
/// A swap of neighbouring characters counts as one edit (`strsim`'s optimal string alignment),
/// since swaps are the commonest typo.
pub(crate) fn did_you_mean<'a>(name: &str, candidates: &[&'a str]) -> Option<&'a str> {
    let name = name.to_ascii_lowercase();
    candidates
        .iter()
        .map(|&c| (strsim::osa_distance(&name, c), c))
        .filter(|&(d, c)| d <= (name.len().max(c.len()) / 3).max(1))
        .min_by_key(|&(d, _)| d)
        .map(|(_, c)| c)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The entry nearest the normalized value `x`.
    fn at(tf: &TransferFunction, x: f32) -> [f32; 4] {
        tf.rgba[((x * TF_WIDTH as f32).floor() as usize).min(TF_WIDTH as usize - 1)]
    }

    #[test]
    fn every_preset_is_a_full_table_in_range() {
        for &name in PRESETS {
            let tf = preset(name).unwrap();
            assert_eq!(tf.name, name);
            assert_eq!(tf.rgba.len(), TF_WIDTH as usize, "{name}");
            assert!(tf.rgba.iter().flatten().all(|c| (0.0..=1.0).contains(c)), "{name}");
            assert_eq!(tf.to_rgba16f().len(), 8 * TF_WIDTH as usize);
            assert_eq!(at(&tf, 0.0)[3], 0.0, "{name}: the lowest value is transparent");
        }
    }

    /// The entry of a CT preset for `hu` Hounsfield units.
    fn at_hu(tf: &TransferFunction, hu: f32) -> [f32; 4] {
        assert_eq!(tf.domain, TfDomain::Data(CT_DOMAIN), "{}", tf.name);
        at(tf, (hu - CT_DOMAIN[0]) / (CT_DOMAIN[1] - CT_DOMAIN[0]))
    }

    #[test]
    fn ct_presets_pick_their_tissues_in_hounsfield_units() {
        let bone = preset("ct_bone").unwrap();
        assert_eq!(at_hu(&bone, 60.0)[3], 0.0, "liver is invisible");
        assert_eq!(at_hu(&bone, 150.0)[3], 0.0, "so is contrast below 180 HU");
        assert!(at_hu(&bone, 700.0)[3] > 0.5, "bone is dense");
        let soft = preset("ct_soft_tissue").unwrap();
        let (fat, liver, vessel) = (at_hu(&soft, -100.0), at_hu(&soft, 60.0), at_hu(&soft, 250.0));
        assert!(fat[3] < liver[3] && liver[3] < 0.1 && vessel[3] > 0.2);
        assert!(liver[0] > liver[2], "soft tissue is reddish");
        let lung = preset("ct_lung").unwrap();
        assert!(at_hu(&lung, -700.0)[3] > 0.0 && at_hu(&lung, 40.0)[3] == 0.0 && at_hu(&lung, -1000.0)[3] == 0.0);
        let angio = preset("ct_angio").unwrap();
        assert!(at_hu(&angio, 40.0)[3] == 0.0 && at_hu(&angio, 300.0)[3] > 0.5);
        let v = at_hu(&angio, 250.0);
        assert!(v[0] > 2.0 * v[2], "contrast is red");
        assert!(at_hu(&preset("ct_fat").unwrap(), -100.0)[3] > 0.0);
        assert_eq!(at_hu(&preset("ct_fat").unwrap(), 40.0)[3], 0.0);
        let ct = PRESETS.iter().filter(|p| p.starts_with("ct_")).count();
        assert!(ct >= 10, "{ct} CT presets");
    }

    #[test]
    fn over_window_resamples_data_domains_and_keeps_window_ones() {
        let bone = preset("ct_bone").unwrap();
        // Over a window of [0, 1000] HU, entry i stands for (i + 0.5) / 1024 * 1000 HU.
        let windowed = bone.over_window([0.0, 1000.0]);
        assert_eq!(windowed.domain, TfDomain::Window);
        for hu in [0.0, 250.0, 600.0, 1000.0] {
            let a = at(&windowed, hu / 1000.0);
            let b = at_hu(&bone, hu);
            assert!(a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 0.01), "{hu} HU: {a:?} vs {b:?}");
        }
        // Beyond the domain the end entries hold.
        assert_eq!(bone.over_window([4000.0, 5000.0]).rgba[0], bone.rgba[1023]);
        let grey = preset("grayscale").unwrap();
        assert_eq!(grey.over_window([-5.0, 5.0]), grey);
    }

    #[test]
    fn window_presets_pick_their_levels() {
        let red = preset("vessel_red").unwrap();
        assert_eq!(at(&red, 0.5)[3], 0.0);
        let v = at(&red, 0.65);
        assert!(v[3] > 0.4 && v[0] > 2.0 * v[2]);
        let blue = at(&preset("vessel_blue").unwrap(), 0.65);
        assert!(blue[2] > 2.0 * blue[0]);
        assert_eq!(at(&preset("mr_default").unwrap(), 0.1)[3], 0.0);
    }

    #[test]
    fn labels_are_piecewise_constant() {
        let tf = preset("labels").unwrap();
        assert_eq!(at(&tf, 0.0)[3], 0.0);
        assert_eq!(at(&tf, 0.02)[3], 0.0);
        // Labels 0..=4 normalized by their range: 0, 0.25, 0.5, 0.75, 1.
        let colours: Vec<[f32; 4]> = [0.25, 0.5, 0.75, 1.0].iter().map(|&x| at(&tf, x)).collect();
        for (i, a) in colours.iter().enumerate() {
            assert_eq!(a[3], 0.6);
            assert!(colours[i + 1..].iter().all(|b| a != b), "distinct colours");
        }
        // Constant within a bin: a bin is 64 entries wide.
        assert_eq!(at(&tf, 0.25), at(&tf, 0.25 + 0.02));
        assert_eq!(at(&tf, 1.0)[..3], LABEL_COLOURS[15]);
    }

    #[test]
    fn unknown_preset_suggests() {
        let e = preset("ct_bnoe").unwrap_err().to_string();
        assert!(
            e.starts_with("unknown transfer function preset `ct_bnoe` (did you mean `ct_bone`?); the presets are: ")
        );
        assert!(e.ends_with("ct_skin, ct_mip"), "{e}");
        let e = preset("rainbow").unwrap_err().to_string();
        assert!(!e.contains("did you mean"), "{e}");
    }

    #[test]
    fn from_points_interpolates_sorts_and_clamps() {
        let tf = from_points("t", &[(1.0, [1.0, 0.0, 2.0]), (0.0, [0.0, 1.0, 0.0])], &[(0.5, 0.2), (0.75, f32::NAN)]);
        // Entry i is made at x = (i + 0.5) / 1024, the first at 0 and the last at 1: red is x,
        // green 1 - x, blue 2x clamped.
        for (i, x) in [(0, 0.0f32), (1, 1.5 / 1024.0), (511, 511.5 / 1024.0), (1023, 1.0)] {
            let [r, g, b, _] = tf.rgba[i];
            assert_eq!([r, g, b], [x, 1.0 - x, (2.0 * x).min(1.0)], "entry {i}");
        }
        assert_eq!(tf.rgba[0][3], 0.2);
        assert_eq!(tf.rgba[1023][3], 0.0, "NaN opacity becomes 0");
        let defaults = from_points("d", &[], &[]);
        assert_eq!(defaults.rgba[0], [1.0, 1.0, 1.0, 0.0], "the default ramp is clear at the window's low end");
        assert_eq!(defaults.rgba[1], [1.0, 1.0, 1.0, 1.5 / 1024.0]);
        assert_eq!(defaults.rgba[1023], [1.0; 4]);
        let one = half::f16::from_f32(1.0).to_le_bytes();
        assert_eq!(defaults.to_rgba16f()[8 * 1023..8 * 1023 + 2], one, "f16 little-endian");
    }

    fn write(dir: &tempfile::TempDir, text: &str) -> PathBuf {
        let path = dir.path().join("map.json");
        std::fs::write(&path, text).unwrap();
        path
    }

    #[test]
    fn paraview_with_points() {
        let dir = tempfile::tempdir().unwrap();
        let text = r#"[{"ColorSpace": "RGB", "Name": "Cool",
            "RGBPoints": [-100, 0, 0, 1, 100, 1, 0, 0],
            "Points": [-100, 0, 0.5, 0, 0, 0.5, 0.5, 0, 100, 1, 0.5, 0]}]"#;
        let tf = from_paraview_json(&write(&dir, text)).unwrap();
        assert_eq!(tf.name, "Cool");
        assert_eq!(tf.domain, TfDomain::Data([-100.0, 100.0]));
        assert_eq!(tf.rgba[0], [0.0, 0.0, 1.0, 0.0]);
        assert_eq!(tf.rgba[1023], [1.0, 0.0, 0.0, 1.0]);
        assert!((tf.rgba[511][3] - 0.5).abs() < 0.01);
        // Over a window of [0, 200]: the value 0 (half opaque) is entry 0, 100 and above opaque.
        let windowed = tf.over_window([0.0, 200.0]);
        assert!((windowed.rgba[0][3] - 0.5).abs() < 0.01);
        assert_eq!(windowed.rgba[600], tf.rgba[1023], "beyond the domain its last entry holds");
    }

    #[test]
    fn paraview_points_are_data_units() {
        // A bone colormap from 300 HU on: soft tissue at 40 HU takes the first point's colour
        // and opacity (transparent), as in ParaView, instead of being stretched onto the map.
        let dir = tempfile::tempdir().unwrap();
        let text =
            r#"{"RGBPoints": [300, 0.9, 0.8, 0.7, 1500, 1, 1, 1], "Points": [300, 0, 0.5, 0, 1500, 0.9, 0.5, 0]}"#;
        let tf = from_paraview_json(&write(&dir, text)).unwrap();
        let windowed = tf.over_window([-1000.0, 2000.0]);
        let entry = |hu: f32| at(&windowed, (hu + 1000.0) / 3000.0);
        assert_eq!(entry(40.0)[3], 0.0);
        assert!(entry(1000.0)[3] > 0.5);
    }

    #[test]
    fn paraview_without_points_ramps_opacity() {
        let dir = tempfile::tempdir().unwrap();
        let tf = from_paraview_json(&write(&dir, r#"{"RGBPoints": [0, 0, 0, 0, 0.5, 1, 1, 1]}"#)).unwrap();
        assert_eq!(tf.name, "map");
        assert_eq!(tf.domain, TfDomain::Data([0.0, 0.5]));
        assert_eq!(tf.rgba[0], [0.0; 4]);
        assert_eq!(tf.rgba[1023], [1.0; 4]);
        assert!((tf.rgba[256][3] - 256.5 / 1024.0).abs() < 1e-6);
    }

    #[test]
    fn paraview_errors_name_the_file_and_problem() {
        let dir = tempfile::tempdir().unwrap();
        let cases = [
            ("{not json", "not valid JSON"),
            ("42", "not a ParaView colormap"),
            ("[]", "not a ParaView colormap"),
            (r#"[{"Name": "x"}]"#, "not a ParaView colormap"),
            (r#"{"Name": "x"}"#, "the colormap has no `RGBPoints`"),
            (r#"{"RGBPoints": [0, 1, 1]}"#, "`RGBPoints` has 3 numbers, expected groups of 4"),
            (r#"{"RGBPoints": []}"#, "`RGBPoints` has 0 numbers"),
            (r#"{"RGBPoints": [0, 1, "a", 1]}"#, "`RGBPoints` entry 2 is not a number: `\"a\"`"),
            (r#"{"RGBPoints": "0 1 1 1"}"#, "`RGBPoints` is not an array of numbers"),
            (r#"{"RGBPoints": [0, 1, 1, 1], "Points": [0, 1]}"#, "`Points` has 2 numbers, expected groups of 4"),
        ];
        for (text, expected) in cases {
            let path = write(&dir, text);
            let e = from_paraview_json(&path).unwrap_err().to_string();
            assert!(e.starts_with(&format!("`{}`: ", path.display())), "{e}");
            assert!(e.contains(expected), "{text}: {e}");
        }
        let missing = from_paraview_json(&dir.path().join("none.json")).unwrap_err();
        assert!(matches!(missing, TfError::Io { .. }));
        assert!(missing.to_string().contains("cannot read"));
    }

    #[test]
    fn did_you_mean_allows_one_edit_per_three_characters() {
        assert_eq!(did_you_mean("haed", &["head", "abdomen"]), Some("head"));
        assert_eq!(did_you_mean("ABDOMEN", &["head", "abdomen"]), Some("abdomen"));
        assert_eq!(did_you_mean("abdmn", &["head", "abdomen"]), Some("abdomen"));
        assert_eq!(did_you_mean("xyz", &["head", "abdomen"]), None);
    }
}
