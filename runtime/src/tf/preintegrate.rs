//! Pre-integrated classification (Engel, Kraus and Ertl, "High-quality pre-integrated volume
//! rendering using hardware-accelerated pixel shading", 2001): a table that classifies the whole
//! ray segment between two consecutive samples instead of each sample, so thin features of the
//! transfer function (an opaque spike a step jumps over) are not missed.
//!
//! Point sampling classifies a sample of normalized value `v` by `c = lookup(tf, v)`, with the
//! opacity corrected for the step `dt`: `alpha = 1 - (1 - c.a)^(dt / ref_step)`. Written with
//! the extinction per reference step `tau = -ln(1 - a)` that is `alpha = 1 - exp(-tau dt /
//! ref_step)`. A pre-integrated segment from a front value `sf` to a back value `sb`, with the
//! value assumed to vary linearly between them, has the mean extinction
//!
//! `tau_mean = (T(sb) - T(sf)) / (sb - sf)`, `T(v) = ∫0^v tau(u) du`,
//!
//! and the extinction-weighted mean colour
//!
//! `rgb_mean = (K(sb) - K(sf)) / (T(sb) - T(sf))`, `K(v) = ∫0^v tau(u) rgb(u) du`.
//!
//! The shader then composites the segment like one sample: `alpha = 1 - exp(-tau_mean * dt /
//! ref_step)` and premultiplied colour `rgb_mean * alpha` ([`premultiplied`]). The opacity is
//! exact for the linear model; the colour is the standard approximation that neglects
//! self-attenuation within the segment: it weights the colour along the segment by extinction
//! alone, ignoring that the segment's front dims what its back emits, which only matters where
//! the colour varies along a segment that is itself nearly opaque. Neither quantity depends on `dt`, so the table is rebuilt only when the
//! transfer function changes, not when the step does.
//!
//! `tau(u)` and `rgb(u)` are what a linear sampler reads from the transfer function's table at
//! `u`: straight r, g, b, a interpolated between the two nearest entries (each at its texel's
//! centre, [`crate::tf::texel_centre`]; the end entries held from their centres to 0 and 1),
//! then `tau = -ln(1 - a)`. The integrals are taken over [`SUBSTEPS`] sub-intervals of every interval between two
//! entries, the extinction integral exactly (`-ln` of a linear function has a closed-form
//! integral), the colour at each sub-interval's middle; so they match compositing many point
//! samples, also across a one-entry spike, where interpolating `tau` between entries instead of
//! `a` would overestimate the extinction by up to half.

use super::{TransferFunction, texel_centre};

/// The side of a [`PreintegratedTable`] unless the caller picks another.
pub(crate) const DEFAULT_SIZE: u32 = 256;

/// The largest opacity per reference step an entry is taken to have: an opacity of 1 has an
/// infinite extinction, so opacities are capped at `1 - 1e-6` and the extinction per reference
/// step at `-ln(1e-6)` ≈ 13.8 (a step of one reference step then lets 1e-6 of the light
/// through, which no 8- or 16-bit target can tell from opaque).
pub(crate) const MAX_OPACITY: f64 = 1.0 - 1e-6;

/// Sub-intervals per interval between two transfer function entries over which the integrals
/// are taken (8 × 1023 for a full table: the cost stays linear in the table's width).
pub(crate) const SUBSTEPS: usize = 8;

#[cfg(test)]
/// The length (in normalized values) below which [`segment`] point-samples a segment at its
/// middle rather than dividing by the length: the table's diagonal is point-sampled, and its
/// other entries are at least one entry (`1 / size`) long.
pub(crate) const POINT_SEGMENT: f64 = 1e-6;

/// A pre-integrated transfer function table, for an `Rgba16Float` (or `Rgba32Float`) 2D
/// texture, `size` × `size` entries.
///
/// Entry `(x, y)` (column `x`, row `y`, stored at `rgba[y * size + x]`) classifies the segment
/// from the front value `sf = (x + 0.5) / size` to the back value `sb = (y + 0.5) / size`
/// ([`texel_centre`]: each entry stands for the value at its texel's centre, so a shader reads
/// the segment `(sf, sb)` at the texture coordinate `(sf, sb)` itself), as `[r, g, b, tau]`: `rgb_mean` (straight colour, in [0, 1]) and `tau_mean`,
/// the mean extinction per reference step, which is not clamped: it is at least 0 and can
/// exceed 1 (up to about 13.8, see [`MAX_OPACITY`]), which a float texture holds. The diagonal
/// (`sf == sb`) is the point-sampled transfer function: its colour, and `-ln(1 - a)`. The table
/// is symmetric: a segment's mean does not depend on its direction.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct PreintegratedTable {
    /// Entries per side (at least 2).
    pub size: u32,
    /// `size * size` entries `[r_mean, g_mean, b_mean, tau_mean]`, row by row (rows: back value).
    pub rgba: Vec<[f32; 4]>,
}

impl PreintegratedTable {
    /// The table of `tf` (over the window it classifies: see [`TransferFunction::over_window`])
    /// with [`DEFAULT_SIZE`] entries per side.
    pub(crate) fn new(tf: &TransferFunction) -> Self {
        Self::with_size(tf, DEFAULT_SIZE)
    }

    /// The table of `tf` with `size` entries per side, in O(size² + the TF's width).
    ///
    /// # Panics
    ///
    /// If `size` is less than 2.
    pub(crate) fn with_size(tf: &TransferFunction, size: u32) -> Self {
        Self::tabulate(tf, size, Integrals::mean)
    }

    /// The segment weights of `tf` for interpolated pre-integrated lighting
    /// (`std::preintegrate_lighting`'s `tf_preint_back`), laid out as the table of [`Self::new`]:
    /// entry `(x, y)` holds, for the segment from `sf` to `sb` with the value running linearly
    /// between them and `s` going from 0 at the front to 1 at the back, the mean of `s`
    /// weighted by each channel's emission `tau(u) rgb(u)` (r, g, b) and by the extinction
    /// `tau(u)` (a). A shader mixes the front sample's light with the back sample's by them:
    /// with the light running linearly along the segment, `∫ tau rgb L ds / ∫ tau rgb ds =
    /// mix(L_front, L_back, w)`. Where a segment emits nothing (and on the diagonal, where its
    /// two ends are one point) the weight is 1/2.
    pub(crate) fn segment_weights(tf: &TransferFunction) -> Self {
        Self::tabulate(tf, DEFAULT_SIZE, Integrals::weights)
    }

    /// A `size` x `size` table of `entry(integrals, front prefix, back prefix, sf, sb)`.
    fn tabulate(
        tf: &TransferFunction,
        size: u32,
        entry: fn(&Integrals, &Prefix, &Prefix, f64, f64) -> [f64; 4],
    ) -> Self {
        assert!(size >= 2, "a pre-integrated table needs at least 2 entries per side, not {size}");
        let integrals = Integrals::new(tf);
        let n = size as usize;
        let values: Vec<f64> = (0..n).map(|i| texel_centre(i, n)).collect();
        let prefix: Vec<Prefix> = values.iter().map(|&v| integrals.prefix_at(v)).collect();
        let mut rgba = Vec::with_capacity(n * n);
        for back in 0..n {
            for front in 0..n {
                let e = entry(&integrals, &prefix[front], &prefix[back], values[front], values[back]);
                rgba.push(e.map(|c| c as f32));
            }
        }
        PreintegratedTable { size, rgba }
    }

    #[cfg(test)]
    /// The entry for the front value's column `front` and the back value's row `back`.
    pub(crate) fn entry(&self, front: u32, back: u32) -> [f32; 4] {
        self.rgba[(back * self.size + front) as usize]
    }

    /// The table as little-endian `f16` RGBA (8 bytes per entry, row by row), for an
    /// `Rgba16Float` texture (filterable everywhere, unlike `Rgba32Float`). Its 11-bit mantissa
    /// keeps `tau` to about 5e-4 of itself.
    pub(crate) fn to_rgba16f(&self) -> Vec<u8> {
        crate::tf::to_rgba16f(&self.rgba)
    }
}

#[cfg(test)]
/// What the shader does with a table entry `[r, g, b, tau]` for a step of `steps_ratio =
/// dt / ref_step` reference steps: `alpha = 1 - exp(-tau * steps_ratio)` and the premultiplied
/// `[r * alpha, g * alpha, b * alpha, alpha]`.
pub(crate) fn premultiplied([r, g, b, tau]: [f32; 4], steps_ratio: f32) -> [f32; 4] {
    let alpha = -(-tau * steps_ratio).exp_m1();
    [r * alpha, g * alpha, b * alpha, alpha]
}

#[cfg(test)]
/// The premultiplied rgba of one segment from the front value `sf` to the back value `sb`
/// (normalized, clamped to [0, 1]) of `steps_ratio = dt / ref_step` reference steps, by the
/// table's formula at these exact values: a table's entry off the diagonal is `segment` at its
/// grid values. A segment shorter than [`POINT_SEGMENT`] is point-sampled at its middle, as
/// the table's diagonal is. Builds the integrals each call: for tests and checks; the renderer
/// uses a [`PreintegratedTable`].
pub(crate) fn segment(tf: &TransferFunction, sf: f32, sb: f32, steps_ratio: f32) -> [f32; 4] {
    let integrals = Integrals::new(tf);
    let (sf, sb) = ((sf as f64).clamp(0.0, 1.0), (sb as f64).clamp(0.0, 1.0));
    let mean = if (sb - sf).abs() < POINT_SEGMENT {
        integrals.point(0.5 * (sf + sb))
    } else {
        integrals.mean(&integrals.prefix_at(sf), &integrals.prefix_at(sb), sf, sb)
    };
    premultiplied(mean.map(|c| c as f32), steps_ratio)
}

/// The prefix integrals at one value `v`: `[T, K_r, K_g, K_b]` (`T(v) = ∫0^v tau(u) du`,
/// `K(v) = ∫0^v tau(u) rgb(u) du`) and their first moments `[M_T, M_r, M_g, M_b]` (the same
/// integrands times `u`), which weigh where along a segment its extinction and emission lie.
type Prefix = [f64; 8];

/// The prefix integrals of a transfer function, in `f64` (differences of prefixes lose what
/// the prefixes hold beyond the difference).
struct Integrals {
    /// The entries, at least 2, each at its texel's centre: r, g, b in [0, 1], a in [0,
    /// MAX_OPACITY].
    entries: Vec<[f64; 4]>,
    /// The [`Prefix`] at the `SUBSTEPS * (entries - 1) + 1` sub-interval bounds between the
    /// first entry's centre and the last one's (the first: the integral of the first entry held
    /// from 0 to its centre).
    prefix: Vec<Prefix>,
}

impl Integrals {
    fn new(tf: &TransferFunction) -> Self {
        let sanitize = |[r, g, b, a]: [f32; 4]| {
            let unit = |c: f32| if c.is_nan() { 0.0 } else { (c as f64).clamp(0.0, 1.0) };
            [unit(r), unit(g), unit(b), unit(a).min(MAX_OPACITY)]
        };
        let mut entries: Vec<[f64; 4]> = tf.rgba.iter().map(|&c| sanitize(c)).collect();
        // An empty table is transparent; one entry stands for every value.
        match entries.len() {
            0 => entries = vec![[0.0; 4]; 2],
            1 => entries.push(entries[0]),
            _ => {}
        }
        let n = entries.len();
        let intervals = SUBSTEPS * (n - 1);
        // Entries are 1 / n apart in value: each sub-interval is a SUBSTEPS-th of that.
        let width = 1.0 / (n * SUBSTEPS) as f64;
        let mut prefix = Vec::with_capacity(intervals + 1);
        let mut sum = held(entries[0], 0.0, texel_centre(0, n));
        prefix.push(sum);
        for (i, pair) in entries.windows(2).enumerate() {
            let (e0, e1) = (pair[0], pair[1]);
            let at = |t: f64, c: usize| e0[c] + (e1[c] - e0[c]) * t;
            for k in 0..SUBSTEPS {
                let (t0, t1) = (k as f64 / SUBSTEPS as f64, (k + 1) as f64 / SUBSTEPS as f64);
                let extinction = width * mean_neg_ln(1.0 - at(t0, 3), 1.0 - at(t1, 3));
                let mid = 0.5 * (t0 + t1);
                // The sub-interval's middle, in values.
                let u = (i as f64 + 0.5 + mid) / n as f64;
                let emitted = [1.0, at(mid, 0), at(mid, 1), at(mid, 2)];
                for c in 0..4 {
                    sum[c] += extinction * emitted[c];
                    sum[c + 4] += extinction * emitted[c] * u;
                }
                prefix.push(sum);
            }
        }
        Integrals { entries, prefix }
    }

    /// The [`Prefix`] at `v` in [0, 1]: the end entries held before the first centre and after
    /// the last, linear between the sub-interval bounds in between.
    fn prefix_at(&self, v: f64) -> Prefix {
        let n = self.entries.len();
        let (first, last) = (texel_centre(0, n), texel_centre(n - 1, n));
        let v = v.clamp(0.0, 1.0);
        if v <= first {
            return held(self.entries[0], 0.0, v);
        }
        let end = self.prefix[self.prefix.len() - 1];
        if v >= last {
            let tail = held(self.entries[n - 1], last, v);
            return std::array::from_fn(|c| end[c] + tail[c]);
        }
        at_coordinate(&self.prefix, (v - first) / (last - first) * (self.prefix.len() - 1) as f64)
    }

    /// The point-sampled `[r, g, b, tau]` at `v`: the entries interpolated as a linear sampler
    /// does, then `tau = -ln(1 - a)`.
    fn point(&self, v: f64) -> [f64; 4] {
        let n = self.entries.len() as f64;
        let [r, g, b, a] = at_coordinate(&self.entries, v.clamp(0.0, 1.0) * n - 0.5);
        [r, g, b, -(-a).ln_1p()]
    }

    /// `[rgb_mean, tau_mean]` of the segment from `sf` to `sb` from the prefixes there: the
    /// point-sampled function where they are equal, the colour at the middle where the segment
    /// is transparent.
    fn mean(&self, front: &Prefix, back: &Prefix, sf: f64, sb: f64) -> [f64; 4] {
        if sf == sb {
            return self.point(sf);
        }
        let extinction = back[0] - front[0];
        let tau = (extinction / (sb - sf)).max(0.0);
        if negligible(extinction, front[0], back[0]) {
            let [r, g, b, _] = self.point(0.5 * (sf + sb));
            return [r, g, b, tau];
        }
        let colour = |c: usize| ((back[c] - front[c]) / extinction).clamp(0.0, 1.0);
        [colour(1), colour(2), colour(3), tau]
    }

    /// The segment weights `[w_r, w_g, w_b, w_tau]` of the segment from `sf` to `sb` (see
    /// [`PreintegratedTable::segment_weights`]): `(M - sf I) / ((sb - sf) I)` for each integral
    /// `I` and its moment `M` over the segment, 1/2 where `I` vanishes.
    fn weights(&self, front: &Prefix, back: &Prefix, sf: f64, sb: f64) -> [f64; 4] {
        if sf == sb {
            return [0.5; 4];
        }
        let weight = |c: usize| {
            let integral = back[c] - front[c];
            if negligible(integral, front[c], back[c]) {
                return 0.5;
            }
            let moment = back[c + 4] - front[c + 4];
            ((moment - sf * integral) / ((sb - sf) * integral)).clamp(0.0, 1.0)
        };
        [weight(1), weight(2), weight(3), weight(0)]
    }
}

/// Whether the difference `d` of two prefixes `p` and `q` is rounding noise: prefixes only grow,
/// and are equal where the transfer function is transparent (the segment is invisible then).
fn negligible(d: f64, p: f64, q: f64) -> bool {
    d.abs() <= 1e-12 * (1.0 + p.abs().max(q.abs()))
}

/// The mean of `-ln(b)` over an interval where `b` goes linearly from `p` to `q` (both in
/// [1 - MAX_OPACITY, 1]): `∫ -ln b db / (q - p) = [b - b ln b]_p^q / (q - p)`.
fn mean_neg_ln(p: f64, q: f64) -> f64 {
    let d = q - p;
    if d.abs() < 1e-8 {
        // Rounding would spoil the closed form; the middle's value is within d² / (24 p²) of
        // it, 4e-6 even at the cap.
        -(0.5 * (p + q)).ln()
    } else {
        (q - q * q.ln() - p + p * p.ln()) / d
    }
}

/// `rows` (at least two) at the fractional row `at` (clamped to the rows), linearly between
/// neighbours.
fn at_coordinate<const N: usize>(rows: &[[f64; N]], at: f64) -> [f64; N] {
    let last = rows.len() - 1;
    let at = at.clamp(0.0, last as f64);
    let below = (at.floor() as usize).min(last - 1);
    let t = at - below as f64;
    let (r0, r1) = (rows[below], rows[below + 1]);
    std::array::from_fn(|c| r0[c] + (r1[c] - r0[c]) * t)
}

/// The [`Prefix`] increments of the constant entry `[r, g, b, a]` held over the values from
/// `from` to `to`.
fn held([r, g, b, a]: [f64; 4], from: f64, to: f64) -> Prefix {
    let tau = -(-a).ln_1p();
    let (length, moment) = (to - from, 0.5 * (to * to - from * from));
    let emitted = [tau, tau * r, tau * g, tau * b];
    std::array::from_fn(|c| if c < 4 { emitted[c] * length } else { emitted[c - 4] * moment })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tf::{TF_WIDTH, TfDomain, from_points, preset};

    fn table_of(rgba: Vec<[f32; 4]>) -> TransferFunction {
        TransferFunction { name: "test".into(), rgba, domain: TfDomain::Window }
    }

    /// What a linear sampler reads from `tf` at `v`, written apart from the code under test.
    fn lookup(tf: &TransferFunction, v: f64) -> [f64; 4] {
        let last = tf.rgba.len() - 1;
        // Entry i at (i + 0.5) / n; the end entries held beyond.
        let x = (v.clamp(0.0, 1.0) * tf.rgba.len() as f64 - 0.5).clamp(0.0, last as f64);
        let i = (x as usize).min(last - 1);
        let t = x - i as f64;
        std::array::from_fn(|c| tf.rgba[i][c] as f64 * (1.0 - t) + tf.rgba[i + 1][c] as f64 * t)
    }

    fn extinction(a: f64) -> f64 {
        -(1.0 - a.min(MAX_OPACITY)).ln()
    }

    fn assert_finite(table: &PreintegratedTable, what: &str) {
        assert_eq!(table.rgba.len(), (table.size * table.size) as usize, "{what}");
        for (i, e) in table.rgba.iter().enumerate() {
            assert!(e.iter().all(|c| c.is_finite()), "{what}: entry {i} {e:?}");
            assert!(e[..3].iter().all(|c| (0.0..=1.0).contains(c)), "{what}: entry {i} {e:?}");
            assert!((0.0..=14.0).contains(&e[3]), "{what}: entry {i} {e:?}");
        }
    }

    /// A small deterministic PRNG (xorshift64), values in [0, 1).
    struct XorShift(u64);

    impl XorShift {
        fn next(&mut self) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    #[test]
    fn constant_tf_gives_its_point_value_everywhere() {
        let colour = [0.2, 0.6, 0.9, 0.3];
        let table = PreintegratedTable::new(&table_of(vec![colour; TF_WIDTH as usize]));
        assert_eq!(table.size, DEFAULT_SIZE);
        assert_eq!(table.rgba.len(), 256 * 256);
        let tau = -(1.0f32 - 0.3).ln();
        for (i, e) in table.rgba.iter().enumerate() {
            assert!(e[..3].iter().zip(&colour).all(|(a, b)| (a - b).abs() < 1e-6), "entry {i}: {e:?}");
            assert!((e[3] - tau).abs() < 1e-6, "entry {i}: {e:?} vs tau {tau}");
        }
        let bytes = table.to_rgba16f();
        assert_eq!(bytes.len(), 8 * 256 * 256);
        let tau16 = half::f16::from_le_bytes([bytes[6], bytes[7]]).to_f32();
        assert!((tau16 - tau).abs() < 1e-3, "{tau16}");
        // A step of one reference step is the entry's own opacity.
        let [r, _, _, alpha] = premultiplied(table.entry(10, 200), 1.0);
        assert!((alpha - 0.3).abs() < 1e-6 && (r - 0.2 * 0.3).abs() < 1e-6, "{alpha} {r}");
    }

    #[test]
    fn diagonal_is_the_point_sampled_tf() {
        let tfs = [
            preset("ct_soft_tissue").unwrap().over_window([-300.0, 900.0]),
            preset("vessel_red").unwrap(),
            from_points("steep", &[(0.0, [0.0, 0.3, 1.0]), (1.0, [1.0, 0.7, 0.0])], &[(0.4, 0.0), (0.41, 1.0)]),
        ];
        for tf in &tfs {
            // 256 puts few table values on TF entries, 100 and 1500 fewer still.
            for size in [256, 100, 1500] {
                let table = PreintegratedTable::with_size(tf, size);
                for i in 0..size {
                    let point = lookup(tf, texel_centre(i as usize, size as usize));
                    let expected = [point[0], point[1], point[2], extinction(point[3])];
                    let e = table.entry(i, i);
                    assert!(
                        e.iter().zip(&expected).all(|(&a, &b)| (a as f64 - b).abs() < 1e-4),
                        "{} size {size} entry {i}: {e:?} vs {expected:?}",
                        tf.name
                    );
                }
            }
        }
    }

    #[test]
    fn table_is_symmetric() {
        let tf = preset("ct_angio").unwrap().over_window([0.0, 800.0]);
        let table = PreintegratedTable::new(&tf);
        let mut differing = 0;
        for front in 0..table.size {
            for back in 0..front {
                let (a, b) = (table.entry(front, back), table.entry(back, front));
                assert_eq!(a, b, "({front}, {back})");
                differing += usize::from(a != table.entry(front, front));
            }
        }
        assert!(differing > 1000, "the table is not constant: {differing} entries differ from the diagonal");
    }

    #[test]
    fn segment_across_a_thin_spike_sees_it() {
        // Transparent but for one entry of opacity 0.9 in the middle.
        let mut rgba = vec![[1.0, 0.5, 0.25, 0.0]; TF_WIDTH as usize];
        rgba[511][3] = 0.9;
        let tf = table_of(rgba);
        let table = PreintegratedTable::new(&tf);
        // Point sampling at the segment's ends sees nothing.
        assert_eq!(lookup(&tf, 0.0)[3], 0.0);
        assert_eq!(lookup(&tf, 1.0)[3], 0.0);
        assert_eq!(table.entry(0, 0)[3], 0.0);
        assert_eq!(table.entry(255, 255)[3], 0.0);
        // The segment from 0 to 1 of `steps_ratio` reference steps, as `samples` point samples
        // along the linear ramp (at the middles of equal parts), composited front to back.
        let composited = |samples: usize, steps_ratio: f64| {
            let transmittance: f64 = (0..samples)
                .map(|k| (1.0 - lookup(&tf, (k as f64 + 0.5) / samples as f64)[3]).powf(steps_ratio / samples as f64))
                .product();
            1.0 - transmittance
        };
        for steps_ratio in [1.0, 100.0] {
            let [r, g, b, alpha] = segment(&tf, 0.0, 1.0, steps_ratio as f32);
            assert!(alpha > 0.0);
            // Both are the integral of -ln(1 - a(v)) over the spike's tent (a linear from 0 to
            // 0.9 and back over one entry on each side): the table's exact (closed form per
            // sub-interval), the samples' by the midpoint rule, with only 8 samples across the
            // tent, whose sides are convex (-ln(1 - a) curves up towards a = 0.9) and whose tip
            // is a kink; the samples underestimate it by 2.4% (measured), so 3% of the
            // opacity. The opacity is what matters here: with one colour the no-self-
            // attenuation approximation changes nothing. (Interpolating tau rather than a
            // between entries would be 55% above.)
            let reference = composited(4096, steps_ratio);
            assert!((alpha as f64 - reference).abs() < 0.03 * reference, "{steps_ratio}: {alpha} vs {reference}");
            // 16 times as many samples converge on the table's value: measured 1e-4 apart.
            let fine = composited(65536, steps_ratio);
            assert!((alpha as f64 - fine).abs() < 1e-3 * fine, "{steps_ratio}: {alpha} vs {fine}");
            // One colour: premultiplied, it is that colour times the opacity.
            assert!((r - alpha).abs() < 1e-6 && (g - 0.5 * alpha).abs() < 1e-6 && (b - 0.25 * alpha).abs() < 1e-6);
            // The table's corner is the segment between its entries' values, either way round.
            let (first, last) = (texel_centre(0, 256) as f32, texel_centre(255, 256) as f32);
            let between = segment(&tf, first, last, steps_ratio as f32)[3];
            for (front, back) in [(0, 255), (255, 0)] {
                let corner = premultiplied(table.entry(front, back), steps_ratio as f32);
                assert!((corner[3] - between).abs() < 1e-6 * between.max(1e-3), "{corner:?} vs {between}");
            }
        }
        // A segment that ends before the spike sees nothing.
        assert_eq!(segment(&tf, 0.0, 0.45, 100.0)[3], 0.0);
    }

    #[test]
    fn colour_is_the_extinction_weighted_mean() {
        // Red below the middle, blue above, equally opaque: the mean over 0..1 is half of each.
        let half_and_half: Vec<[f32; 4]> =
            (0..TF_WIDTH).map(|i| if i < TF_WIDTH / 2 { [1.0, 0.0, 0.0, 0.2] } else { [0.0, 0.0, 1.0, 0.2] }).collect();
        let e = PreintegratedTable::new(&table_of(half_and_half)).entry(0, 255);
        assert!((e[0] - 0.5).abs() < 1e-3 && e[1] == 0.0 && (e[2] - 0.5).abs() < 1e-3, "{e:?}");
        // A transparent red half adds nothing: the mean is the opaque half's blue.
        let transparent_red: Vec<[f32; 4]> =
            (0..TF_WIDTH).map(|i| if i < TF_WIDTH / 2 { [1.0, 0.0, 0.0, 0.0] } else { [0.0, 0.0, 1.0, 0.5] }).collect();
        let table = PreintegratedTable::new(&table_of(transparent_red));
        let e = table.entry(0, 255);
        assert!(e[0] < 1e-3 && e[2] > 0.999, "{e:?}");
        // Over the transparent half alone the colour is the TF's at the middle, and tau is 0.
        let e = table.entry(0, 100);
        assert_eq!(e, [1.0, 0.0, 0.0, 0.0]);
    }

    #[test]
    fn degenerate_tfs_have_no_nan() {
        let cases = [
            ("empty", vec![]),
            ("one entry", vec![[0.3, 0.4, 0.5, 0.6]]),
            ("two entries", vec![[0.0, 0.0, 0.0, 0.0], [1.0, 1.0, 1.0, 1.0]]),
            ("opaque", vec![[1.0; 4]; TF_WIDTH as usize]),
            ("NaN", vec![[f32::NAN; 4]; 3]),
        ];
        for (what, rgba) in cases {
            let tf = table_of(rgba);
            for size in [2, 3, 256] {
                assert_finite(&PreintegratedTable::with_size(&tf, size), what);
            }
            for (sf, sb) in [(0.0, 0.0), (0.0, 1.0), (0.3, 0.3 + 1e-7), (1.0, 0.5)] {
                let s = segment(&tf, sf, sb, 2.0);
                assert!(s.iter().all(|c| c.is_finite()), "{what} ({sf}, {sb}): {s:?}");
            }
        }
        // One entry is a constant TF.
        let one = PreintegratedTable::with_size(&table_of(vec![[0.3, 0.4, 0.5, 0.6]]), 16);
        let tau = -(0.4f32).ln();
        assert!(one.rgba.iter().all(|e| (e[2] - 0.5).abs() < 1e-6 && (e[3] - tau).abs() < 1e-5), "{one:?}");
        // Opaque: the capped extinction, -ln(1e-6).
        let opaque = PreintegratedTable::with_size(&table_of(vec![[1.0; 4]; TF_WIDTH as usize]), 8);
        assert!(opaque.rgba.iter().all(|e| (e[3] - 13.8155).abs() < 1e-3), "{:?}", opaque.rgba[1]);
        // Transparent everywhere: opacity exactly 0, colour the TF's.
        let mut random = XorShift(7);
        let clear: Vec<[f32; 4]> = (0..TF_WIDTH).map(|_| [random.next(), random.next(), random.next(), 0.0]).collect();
        let table = PreintegratedTable::new(&table_of(clear));
        assert_finite(&table, "transparent");
        assert!(table.rgba.iter().all(|e| e[3] == 0.0));
    }

    #[test]
    fn random_tfs_have_no_nan_or_inf() {
        let mut random = XorShift(0x9e37_79b9_7f4a_7c15);
        for round in 0..12 {
            let width = [TF_WIDTH as usize, 2, 3, 37][round % 4];
            let rgba: Vec<[f32; 4]> = (0..width)
                .map(|_| {
                    let a = match random.next() {
                        x if x < 0.2 => 0.0,
                        x if x < 0.3 => 1.0,
                        x if x < 0.4 => 1.0 - 1e-7,
                        _ => random.next().powi(3),
                    };
                    [random.next(), random.next(), random.next(), a]
                })
                .collect();
            let tf = table_of(rgba);
            let size = [256, 2, 17, 300][(round / 4) % 4];
            let table = PreintegratedTable::with_size(&tf, size);
            assert_finite(&table, &format!("round {round}"));
            // Off the diagonal the table is `segment` at the grid's values.
            for _ in 0..20 {
                let (front, back) = ((random.next() * size as f32) as u32, (random.next() * size as f32) as u32);
                if front == back {
                    continue;
                }
                let value = |i: u32| texel_centre(i as usize, size as usize) as f32;
                let expected = segment(&tf, value(front), value(back), 0.5);
                let got = premultiplied(table.entry(front, back), 0.5);
                assert!(
                    got.iter().zip(&expected).all(|(a, b)| (a - b).abs() < 1e-4),
                    "round {round} ({front}, {back}): {got:?} vs {expected:?}"
                );
            }
        }
    }

    /// The segment weights by brute force: the segment from `sf` to `sb` in `steps` point
    /// samples of what a linear sampler reads, each weighted by its emission (per channel) or
    /// extinction, averaging `s` from 0 (front) to 1 (back).
    fn weights_by_sampling(tf: &TransferFunction, sf: f64, sb: f64, steps: usize) -> [f64; 4] {
        let (mut sum, mut weighted) = ([0.0f64; 4], [0.0f64; 4]);
        for k in 0..steps {
            let s = (k as f64 + 0.5) / steps as f64;
            let [r, g, b, a] = lookup(tf, sf + (sb - sf) * s);
            let tau = extinction(a);
            for (c, w) in [tau * r, tau * g, tau * b, tau].into_iter().enumerate() {
                sum[c] += w;
                weighted[c] += w * s;
            }
        }
        std::array::from_fn(|c| if sum[c] > 1e-12 { weighted[c] / sum[c] } else { 0.5 })
    }

    #[test]
    fn segment_weights_are_where_a_segment_emits_on_average() {
        let tfs = [
            preset("ct_soft_tissue").unwrap().over_window([-300.0, 900.0]),
            from_points("steep", &[(0.0, [0.0, 0.3, 1.0]), (1.0, [1.0, 0.7, 0.0])], &[(0.4, 0.0), (0.41, 1.0)]),
            from_points("ramp", &[(0.0, [1.0, 0.0, 0.0]), (1.0, [0.0, 0.0, 1.0])], &[(0.0, 0.0), (1.0, 0.5)]),
        ];
        let mut rng = XorShift(0x5eed);
        for tf in &tfs {
            let table = PreintegratedTable::segment_weights(tf);
            assert_finite(&table, &tf.name);
            for _ in 0..300 {
                let (front, back) = ((rng.next() * 256.0) as u32 % 256, (rng.next() * 256.0) as u32 % 256);
                let (sf, sb) = (texel_centre(front as usize, 256), texel_centre(back as usize, 256));
                let e = table.entry(front, back);
                if front == back {
                    assert_eq!(e, [0.5; 4], "{} diagonal {front}", tf.name);
                    continue;
                }
                let expected = weights_by_sampling(tf, sf, sb, 20_000);
                assert!(
                    e.iter().zip(&expected).all(|(&a, &b)| (a as f64 - b).abs() < 2e-3),
                    "{} ({front}, {back}): {e:?} vs {expected:?}",
                    tf.name
                );
            }
        }
    }

    #[test]
    fn a_segment_entering_an_opaque_range_is_weighted_towards_that_end() {
        // Transparent below 0.5, uniform above: the emission of a segment from 0.25 to 0.75 lies
        // in its back half, evenly, so its mean position is 3/4 (1/4 running the other way).
        let tf = from_points(
            "step",
            &[(0.0, [1.0; 3]), (1.0, [1.0; 3])],
            &[(0.0, 0.0), (0.4999, 0.0), (0.5, 0.3), (1.0, 0.3)],
        );
        let table = PreintegratedTable::segment_weights(&tf);
        let (lo, hi) = (63, 191); // the entries at 0.25 and 0.75 (texel centres 0.248 and 0.748)
        for c in 0..4 {
            assert!((table.entry(lo, hi)[c] - 0.75).abs() < 0.01, "{:?}", table.entry(lo, hi));
            assert!((table.entry(hi, lo)[c] - 0.25).abs() < 0.01, "{:?}", table.entry(hi, lo));
        }
        // A uniform segment emits evenly: its mean position is the middle.
        let uniform = table.entry(140, 250);
        assert!(uniform.iter().all(|w| (w - 0.5).abs() < 1e-3), "{uniform:?}");
    }
}
