//! Transfer functions of label volumes (segmentations): entry k of the table is the colour of
//! label id k, read unblended.
//!
//! A label volume's texture is normalized over [`LABEL_WINDOW`], which puts id k at
//! `(k + 0.5) / TF_WIDTH`, the centre of the table's texel k, so `lookup` reads entry k alone
//! (its linear filter blends nothing). Ids from `TF_WIDTH - 1` up are clamped by the
//! normalization and read the last entry. The texture holds `(2k + 1) / 2048` exactly in
//! `R16Float` for every id below `TF_WIDTH`.

use super::{ColorPoint, LABEL_COLOURS, OpacityPoint, TF_WIDTH, TfCurve, TfDomain};

/// The window of a label volume (see the module's comment).
pub(crate) const LABEL_WINDOW: [f32; 2] = [-0.5, TF_WIDTH as f32 - 0.5];

/// The opacity of a label that has no colour of its own: how strongly it tints.
const DEFAULT_OPACITY: f32 = 0.6;

/// The curve of a label volume whose labels `colors` (id, straight RGBA in [0, 1]; an OME-Zarr
/// label image's `image-label.colors`, perhaps none) have colours of their own: id k gets its
/// listed colour, else one of 16 distinct colours in turn (id 0, the background, transparent);
/// the last entry takes the smallest listed id from `TF_WIDTH - 1` up.
pub(crate) fn label_curve(name: &str, colors: &[(u64, [f32; 4])]) -> TfCurve {
    let last = u64::from(TF_WIDTH - 1);
    let listed = |k: u64| -> Option<[f32; 4]> {
        let matching = colors.iter().filter(|c| if k < last { c.0 == k } else { c.0 >= last });
        matching.min_by_key(|c| c.0).map(|c| c.1)
    };
    let rgba = |k: u64| {
        listed(k).unwrap_or_else(|| match k {
            0 => [0.0; 4],
            _ => {
                let [r, g, b] = LABEL_COLOURS[(k as usize - 1) % LABEL_COLOURS.len()];
                [r, g, b, DEFAULT_OPACITY]
            }
        })
    };
    let entries: Vec<[f32; 4]> = (0..=last).map(rgba).collect();
    piecewise_constant(name, &entries)
}

/// The `labels` preset: bin k of 17 centred on k/16 of the window, bin 0 (the background)
/// transparent, bins 1 to 16 the 16 colours in turn. With labels 0..=L (L <= 16) normalized by
/// their range, every label gets its own bin.
pub(super) fn preset() -> TfCurve {
    let colours = LABEL_COLOURS.iter().map(|&[r, g, b]| [r, g, b, DEFAULT_OPACITY]);
    let entries: Vec<[f32; 4]> = std::iter::once([0.0; 4]).chain(colours).collect();
    piecewise_constant("labels", &entries)
}

/// A window-relative curve whose value at `i / (entries.len() - 1)` is `entries[i]` (straight
/// RGBA) and that holds it halfway to each neighbour.
fn piecewise_constant(name: &str, entries: &[[f32; 4]]) -> TfCurve {
    let color: Vec<ColorPoint> = steps(entries, |e| [e[0], e[1], e[2]]);
    let opacity: Vec<OpacityPoint> = steps(entries, |e| [e[3]]).into_iter().map(|(x, [a])| (x, a)).collect();
    TfCurve { name: name.to_string(), color, opacity, domain: TfDomain::Window }
}

/// Control points of a piecewise-constant curve whose value at `i / (entries.len() - 1)` is
/// `part(entries[i])`: a step halfway between two entries wherever
/// the value changes, so runs of one value take two points.
fn steps<const N: usize>(entries: &[[f32; 4]], part: impl Fn(&[f32; 4]) -> [f32; N]) -> Vec<(f32, [f32; N])> {
    let last = (entries.len() - 1) as f32;
    let mut points = vec![(0.0, part(&entries[0]))];
    for (i, pair) in entries.windows(2).enumerate() {
        let (before, after) = (part(&pair[0]), part(&pair[1]));
        if before != after {
            let edge = (i as f32 + 0.5) / last;
            points.extend([(edge, before), (edge, after)]);
        }
    }
    points.push((1.0, part(&entries[entries.len() - 1])));
    points
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table entry the shader's `lookup` reads for label id `k`: the texel whose centre
    /// the normalized value falls in.
    fn entry_of(k: f64) -> usize {
        let [lo, hi] = LABEL_WINDOW.map(f64::from);
        let x = ((k - lo) / (hi - lo)).clamp(0.0, 1.0);
        ((x * f64::from(TF_WIDTH)).floor() as usize).min(TF_WIDTH as usize - 1)
    }

    #[test]
    fn each_id_reads_its_own_entry_at_the_texel_centre() {
        for k in 0..TF_WIDTH {
            let [lo, hi] = LABEL_WINDOW;
            let x = (k as f32 - lo) / (hi - lo);
            assert_eq!(x, (k as f32 + 0.5) / TF_WIDTH as f32, "id {k}");
            assert_eq!(half::f16::from_f32(x).to_f32(), x, "id {k} is exact in the R16Float texture");
            assert_eq!(entry_of(f64::from(k)), k as usize);
        }
        assert_eq!(entry_of(70000.0), TF_WIDTH as usize - 1);
    }

    #[test]
    fn listed_colours_win_and_the_rest_cycle() {
        let red = [1.0, 0.0, 0.0, 1.0];
        let blue = [0.0, 0.0, 1.0, 0.5];
        let yellow = [1.0, 1.0, 0.0, 1.0];
        let table = label_curve("seg", &[(1, red), (3, blue), (70000, yellow), (5000, [0.0; 4])]).table();
        assert_eq!(table.rgba[0], [0.0; 4], "the background is transparent");
        assert_eq!(table.rgba[1], red);
        assert_eq!(table.rgba[3], blue);
        let [r, g, b] = LABEL_COLOURS[1];
        assert_eq!(table.rgba[2], [r, g, b, DEFAULT_OPACITY], "id 2 is unlisted: the second colour");
        let [r, g, b] = LABEL_COLOURS[(40 - 1) % 16];
        assert_eq!(table.rgba[40], [r, g, b, DEFAULT_OPACITY]);
        assert_eq!(table.rgba[TF_WIDTH as usize - 1], [0.0; 4], "the smallest listed id above the table: 5000");
    }

    #[test]
    fn unlisted_volumes_cycle_through_every_entry() {
        let table = label_curve("labels", &[]).table();
        for (k, rgba) in table.rgba.iter().enumerate().skip(1) {
            let [r, g, b] = LABEL_COLOURS[(k - 1) % 16];
            assert_eq!(*rgba, [r, g, b, DEFAULT_OPACITY], "id {k}");
        }
    }
}
