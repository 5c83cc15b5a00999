//! Probe images: a state field of a view shown as an image (see "Probes" in `docs/reference.md`).
//!
//! The probe variant of a view (composed by `vrsc::compose::probe`) renders a field's value as
//! 32-bit words over several passes of an RGBA8 image (the layout of `std::probe`): pass k < N,
//! for a value of N words, holds word k's bits 31..8 in R, G, B; pass N holds the low bytes of
//! words 0, 1, 2 and pass N + 1 that of word 3. Alpha is 255 where the pixel has a value and 0
//! where it has none. This module turns those passes back into exact values and colours them:
//!
//! - a numeric scalar through viridis, from the smallest value over the image (dark purple) to
//!   the largest (yellow); one value everywhere maps to the middle of the map;
//! - a numeric vector as RGB: components x, y, z in R, G, B (B is 0 for a vec2; a vec4's w is
//!   not drawn, its range is in the legend), all through one linear range: [-m, m] when some
//!   component is negative, else [0, m], m the largest magnitude of a drawn component;
//! - a bool as black (false) and white (true); a bool vector's components as R, G, B of 0 or 255;
//! - no value: transparent black; an infinite or NaN component: magenta, left out of the range.

use image::{Rgba, RgbaImage};
use std::fmt::Write as _;

/// The scalar kind of a probed value's components.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ComponentKind {
    Float,
    Int,
    Uint,
    Bool,
}

impl ComponentKind {
    /// The value a word stands for.
    fn value(self, word: u32) -> f64 {
        match self {
            ComponentKind::Float => f64::from(f32::from_bits(word)),
            ComponentKind::Int => f64::from(word as i32),
            ComponentKind::Uint => f64::from(word),
            ComponentKind::Bool => f64::from(u8::from(word != 0)),
        }
    }
}

/// What a probed field holds: the kind and number (1 to 4) of its components.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ProbeFormat {
    pub(crate) kind: ComponentKind,
    /// How many components each value has: 1 (a scalar) to 4.
    pub components: u32,
}

impl ProbeFormat {
    /// Renders that carry every word: one per word, then one per three words' low bytes.
    pub(crate) fn passes(self) -> u32 {
        self.components + self.components.div_ceil(3)
    }
}

/// How a probe image shows its values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Mapping {
    /// A scalar through viridis, `lo` dark purple to `hi` yellow.
    Colormap { lo: f64, hi: f64 },
    /// A vector's x, y, z as R, G, B, each from `lo` (0) to `hi` (255).
    Rgb { lo: f64, hi: f64 },
    /// false black, true white.
    Boolean,
}

/// The decoded values of a probe: per pixel, row by row, the components or `None`.
#[derive(Clone, Debug, PartialEq)]
pub struct ProbeValues {
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// What each value holds.
    pub format: ProbeFormat,
    /// Row by row, top first: the components (the first `format.components` used), or `None`
    /// where the field was not written (a ray that missed the volume).
    pub pixels: Vec<Option<[f64; 4]>>,
}

impl ProbeValues {
    /// Decodes the passes of a probe (all of one size, `format.passes()` of them).
    pub(crate) fn decode(format: ProbeFormat, passes: &[RgbaImage]) -> Result<ProbeValues, String> {
        let n = format.components as usize;
        if !(1..=4).contains(&n) || passes.len() != format.passes() as usize {
            return Err(format!("a probe of {n} components needs {} passes, got {}", format.passes(), passes.len()));
        }
        let (width, height) = passes[0].dimensions();
        if passes.iter().any(|p| p.dimensions() != (width, height)) {
            return Err("the passes of a probe differ in size".into());
        }
        let pixels = (0..height)
            .flat_map(|y| (0..width).map(move |x| (x, y)))
            .map(|(x, y)| {
                if passes[0].get_pixel(x, y)[3] != 255 {
                    return None;
                }
                let mut components = [0.0; 4];
                for (k, c) in components.iter_mut().enumerate().take(n) {
                    let [r, g, b, _] = passes[k].get_pixel(x, y).0;
                    let low = passes[n + k / 3].get_pixel(x, y)[k % 3];
                    let word = u32::from_be_bytes([r, g, b, low]);
                    *c = format.kind.value(word);
                }
                Some(components)
            })
            .collect();
        Ok(ProbeValues { width, height, format, pixels })
    }

    /// The components of pixel (x, y), `None` where it has no value.
    pub fn at(&self, x: u32, y: u32) -> Option<&[f64]> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let i = y as usize * self.width as usize + x as usize;
        self.pixels.get(i)?.as_ref().map(|c| &c[..self.format.components as usize])
    }

    /// How many pixels have a value.
    pub fn count(&self) -> usize {
        self.pixels.iter().flatten().count()
    }

    /// A value as its component type prints it (an f32 with the digits that tell it apart).
    fn show(&self, v: f64) -> String {
        match self.format.kind {
            ComponentKind::Float => format!("{}", v as f32),
            _ => format!("{v}"),
        }
    }

    /// Components the image draws: a scalar's one, a vector's first three.
    fn drawn(&self) -> usize {
        (self.format.components as usize).min(3)
    }

    /// Smallest and largest finite value of component `c` over the pixels with a value.
    pub(crate) fn component_range(&self, c: usize) -> Option<(f64, f64)> {
        finite_range(self.pixels.iter().flatten().map(|p| p[c]))
    }

    /// The mapping the image uses (see the module documentation); `None` when no pixel has a
    /// finite value.
    pub(crate) fn mapping(&self) -> Option<Mapping> {
        if self.format.kind == ComponentKind::Bool {
            return Some(Mapping::Boolean);
        }
        let drawn = self.pixels.iter().flatten().flat_map(|p| p[..self.drawn()].iter().copied());
        let (lo, hi) = finite_range(drawn)?;
        if self.format.components == 1 {
            return Some(Mapping::Colormap { lo, hi });
        }
        let m = lo.abs().max(hi.abs());
        Some(Mapping::Rgb { lo: if lo < 0.0 { -m } else { 0.0 }, hi: m })
    }

    /// The image: every pixel coloured by [`ProbeValues::mapping`].
    pub(crate) fn to_image(&self) -> RgbaImage {
        let mapping = self.mapping();
        let drawn = self.drawn();
        let mut image = RgbaImage::new(self.width, self.height);
        for (px, value) in image.pixels_mut().zip(&self.pixels) {
            *px = match (value, mapping) {
                (None, _) | (Some(_), None) => Rgba([0, 0, 0, 0]),
                (Some(v), Some(_)) if v[..drawn].iter().any(|c| !c.is_finite()) => MAGENTA,
                (Some(v), Some(Mapping::Colormap { lo, hi })) => viridis(unit(v[0], lo, hi)),
                (Some(v), Some(Mapping::Rgb { lo, hi })) => {
                    let mut rgb = [0u8; 3];
                    for (channel, &c) in rgb.iter_mut().zip(&v[..drawn]) {
                        *channel = byte(unit(c, lo, hi));
                    }
                    Rgba([rgb[0], rgb[1], rgb[2], 255])
                }
                (Some(v), Some(Mapping::Boolean)) if self.format.components == 1 => {
                    let level = if v[0] != 0.0 { 255 } else { 0 };
                    Rgba([level, level, level, 255])
                }
                (Some(v), Some(Mapping::Boolean)) => {
                    let mut rgb = [0u8; 3];
                    for (channel, &c) in rgb.iter_mut().zip(&v[..drawn]) {
                        *channel = if c != 0.0 { 255 } else { 0 };
                    }
                    Rgba([rgb[0], rgb[1], rgb[2], 255])
                }
            };
        }
        image
    }

    /// One line that says how to read the image: the pixels with a value, the range and the
    /// mapping (and a vec4's w range, which the image does not draw).
    pub(crate) fn legend(&self) -> String {
        let total = self.pixels.len();
        let mut out = format!("{} of {total} pixels have a value", self.count());
        let non_finite = self.pixels.iter().flatten().filter(|v| v[..self.drawn()].iter().any(|c| !c.is_finite()));
        let non_finite = non_finite.count();
        match self.mapping() {
            None => out.push_str("; no finite value to show"),
            Some(Mapping::Colormap { lo, hi }) => {
                let (lo, hi) = (self.show(lo), self.show(hi));
                let _ = write!(out, "; range {lo} .. {hi}; viridis from dark purple ({lo}) to yellow ({hi})");
            }
            Some(Mapping::Rgb { lo, hi }) => {
                let names = ["x", "y", "z"];
                let parts: Vec<String> = (0..self.drawn())
                    .map(|c| {
                        let (a, b) = self.component_range(c).unwrap_or((f64::NAN, f64::NAN));
                        format!("{} {} .. {}", names[c], self.show(a), self.show(b))
                    })
                    .collect();
                let channels = ["R", "G", "B"][..self.drawn()].join(", ");
                let _ = write!(
                    out,
                    "; range {}; {} = {} linearly from {} (0) to {} (255)",
                    parts.join(", "),
                    channels,
                    names[..self.drawn()].join(", "),
                    self.show(lo),
                    self.show(hi)
                );
                if self.format.components == 4
                    && let Some((a, b)) = self.component_range(3)
                {
                    let _ = write!(out, "; w (not drawn) {} .. {}", self.show(a), self.show(b));
                }
            }
            Some(Mapping::Boolean) if self.format.components == 1 => out.push_str("; false black, true white"),
            Some(Mapping::Boolean) => out.push_str("; each component 0 (false) or 255 (true) in R, G, B"),
        }
        if non_finite > 0 {
            let _ = write!(out, "; {non_finite} pixels infinite or NaN (magenta)");
        }
        out.push_str("; transparent: no value");
        out
    }
}

/// Marks a pixel whose value is infinite or NaN.
const MAGENTA: Rgba<u8> = Rgba([255, 0, 255, 255]);

fn finite_range(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    values.filter(|v| v.is_finite()).fold(None, |range, v| match range {
        None => Some((v, v)),
        Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
    })
}

/// `v` in [lo, hi] as [0, 1]; the middle when the range is one value.
fn unit(v: f64, lo: f64, hi: f64) -> f64 {
    if hi > lo { ((v - lo) / (hi - lo)).clamp(0.0, 1.0) } else { 0.5 }
}

fn byte(x: f64) -> u8 {
    (x * 255.0).round().clamp(0.0, 255.0) as u8
}

/// matplotlib's viridis at 0, 1/4, 1/2, 3/4 and 1 (sRGB), interpolated linearly between them.
const VIRIDIS_STOPS: [[u8; 3]; 5] = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];

/// The colour of `x` in [0, 1] on viridis.
pub(crate) fn viridis(x: f64) -> Rgba<u8> {
    let scaled = x.clamp(0.0, 1.0) * (VIRIDIS_STOPS.len() - 1) as f64;
    let i = (scaled.floor() as usize).min(VIRIDIS_STOPS.len() - 2);
    let f = scaled - i as f64;
    let (a, b) = (VIRIDIS_STOPS[i], VIRIDIS_STOPS[i + 1]);
    let mix = |c: usize| (f64::from(a[c]) + (f64::from(b[c]) - f64::from(a[c])) * f).round() as u8;
    Rgba([mix(0), mix(1), mix(2), 255])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The passes the probe variant would render for `values` (one pixel each, `None` = no
    /// value), built from the words as `std::probe` lays them out.
    fn passes(format: ProbeFormat, values: &[Option<[u32; 4]>]) -> Vec<RgbaImage> {
        let n = format.components as usize;
        (0..format.passes() as usize)
            .map(|pass| {
                let mut image = RgbaImage::new(values.len() as u32, 1);
                for (x, value) in values.iter().enumerate() {
                    let px = match value {
                        None => Rgba([0, 0, 0, 0]),
                        Some(words) if pass < n => {
                            let [r, g, b, _] = words[pass].to_be_bytes();
                            Rgba([r, g, b, 255])
                        }
                        Some(words) => {
                            let low = |k: usize| words.get(k).map_or(0, |w| w.to_be_bytes()[3]);
                            let first = (pass - n) * 3;
                            Rgba([low(first), low(first + 1), low(first + 2), 255])
                        }
                    };
                    image.put_pixel(x as u32, 0, px);
                }
                image
            })
            .collect()
    }

    #[test]
    fn floats_come_back_exactly() {
        let format = ProbeFormat { kind: ComponentKind::Float, components: 3 };
        let v = [-1.5e-7f32, 3.25, 1234567.9];
        let words = [v[0].to_bits(), v[1].to_bits(), v[2].to_bits(), 0];
        let decoded = ProbeValues::decode(format, &passes(format, &[Some(words), None])).expect("decodes");
        assert_eq!(decoded.at(0, 0), Some(&[f64::from(v[0]), f64::from(v[1]), f64::from(v[2])][..]));
        assert_eq!(decoded.at(1, 0), None);
        assert_eq!(decoded.count(), 1);
    }

    #[test]
    fn a_vec4_uses_two_low_byte_passes() {
        let format = ProbeFormat { kind: ComponentKind::Int, components: 4 };
        assert_eq!(format.passes(), 6);
        let words = [(-7i32) as u32, 0x0102_0304, 255, 0xdead_beef];
        let decoded = ProbeValues::decode(format, &passes(format, &[Some(words)])).expect("decodes");
        let want = [-7.0, f64::from(0x0102_0304), 255.0, f64::from(0xdead_beefu32 as i32)];
        assert_eq!(decoded.at(0, 0), Some(&want[..]));
    }

    #[test]
    fn scalars_span_the_colormap() {
        let format = ProbeFormat { kind: ComponentKind::Float, components: 1 };
        let values: Vec<Option<[u32; 4]>> =
            [1.0f32, 3.0, 2.0].iter().map(|v| Some([v.to_bits(), 0, 0, 0])).chain([None]).collect();
        let decoded = ProbeValues::decode(format, &passes(format, &values)).expect("decodes");
        assert_eq!(decoded.mapping(), Some(Mapping::Colormap { lo: 1.0, hi: 3.0 }));
        let image = decoded.to_image();
        assert_eq!(*image.get_pixel(0, 0), viridis(0.0));
        assert_eq!(*image.get_pixel(1, 0), viridis(1.0));
        assert_eq!(*image.get_pixel(2, 0), Rgba([33, 145, 140, 255]));
        assert_eq!(image.get_pixel(3, 0)[3], 0);
        assert!(decoded.legend().contains("range 1 .. 3"), "{}", decoded.legend());
    }

    #[test]
    fn signed_vectors_map_zero_to_the_middle() {
        let format = ProbeFormat { kind: ComponentKind::Float, components: 3 };
        let words = |v: [f32; 3]| Some([v[0].to_bits(), v[1].to_bits(), v[2].to_bits(), 0]);
        let values = [words([-2.0, 0.0, 1.0]), words([2.0, 0.5, 0.0])];
        let decoded = ProbeValues::decode(format, &passes(format, &values)).expect("decodes");
        assert_eq!(decoded.mapping(), Some(Mapping::Rgb { lo: -2.0, hi: 2.0 }));
        let image = decoded.to_image();
        assert_eq!(*image.get_pixel(0, 0), Rgba([0, 128, 191, 255]));
        assert_eq!(*image.get_pixel(1, 0), Rgba([255, 159, 128, 255]));
    }

    #[test]
    fn booleans_are_black_and_white() {
        let format = ProbeFormat { kind: ComponentKind::Bool, components: 1 };
        let decoded =
            ProbeValues::decode(format, &passes(format, &[Some([1, 0, 0, 0]), Some([0; 4])])).expect("decodes");
        let image = decoded.to_image();
        assert_eq!(*image.get_pixel(0, 0), Rgba([255, 255, 255, 255]));
        assert_eq!(*image.get_pixel(1, 0), Rgba([0, 0, 0, 255]));
    }

    #[test]
    fn non_finite_values_are_magenta_and_outside_the_range() {
        let format = ProbeFormat { kind: ComponentKind::Float, components: 1 };
        let values = [Some([f32::INFINITY.to_bits(), 0, 0, 0]), Some([0.25f32.to_bits(), 0, 0, 0])];
        let decoded = ProbeValues::decode(format, &passes(format, &values)).expect("decodes");
        assert_eq!(decoded.mapping(), Some(Mapping::Colormap { lo: 0.25, hi: 0.25 }));
        assert_eq!(*decoded.to_image().get_pixel(0, 0), MAGENTA);
        assert!(decoded.legend().contains("1 pixels infinite or NaN"));
    }
}
