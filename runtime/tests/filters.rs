//! Filter passes on lavapipe (a view's `filters`, composed into the `filter.*` steps): the
//! standard filters against what they promise, computed from the view's picture without
//! filters and from the `geometry_depth` probe, and a user's filter in a standard one's place.

use crate::common;

use std::path::Path;
use vrs_runtime::{ProbeAt, ProbeSpec, SceneRenderer};

/// A transparent volume (the transfer function is clear everywhere) over a coloured background,
/// so a view's picture is its meshes' colour over that background; the meshes follow.
const SCENE: &str = r#"
[render]
compositing = "dvr"
jitter = 0.0
background = [0.2, 0.35, 0.6, 1.0]

[[volume]]
name = "cube"
role = "primary"
path = "cube.nrrd"
window = [0.0, 1000.0]
tf = "clear.json"

[[mesh]]
name = "ball"
shape = "sphere"
centre = [16.0, 16.0, 16.0]
radius = 9.0
color = [0.9, 0.55, 0.1]

[[view]]
name = "3d"
kind = "raycast"
size = [96, 96]
camera = { azimuth = 30.0, elevation = 20.0, distance = 2.2 }
"#;

/// Two boxes that meet in a concave corner (a block standing on a slab), or the block alone.
const BLOCKS: &str = r#"
[[mesh]]
name = "block"
shape = "box"
min = [11.0, 11.0, 12.0]
max = [21.0, 21.0, 24.0]
color = [0.8, 0.8, 0.8]

[[mesh]]
name = "slab"
shape = "box"
min = [2.0, 2.0, 8.0]
max = [30.0, 30.0, 12.0]
color = [0.8, 0.8, 0.8]

[[view]]
name = "3d"
kind = "raycast"
size = [96, 96]
camera = { azimuth = 30.0, elevation = 35.0, distance = 2.2 }
"#;

/// A box beside `SCENE`'s ball, in front of part of it.
const BOX: &str = "\n[[mesh]]\nname = \"box\"\nshape = \"box\"\nmin = [2.0, 2.0, 2.0]\nmax = [9.0, 9.0, 30.0]\ncolor = [0.1, 0.3, 0.9]\n";

/// `SCENE`'s meshes, then `more` (more meshes), then a group `group` of the ball and the filter
/// `filter` after it.
fn with_group(group: &str, filter: &str, more: &str) -> String {
    let meshes = &SCENE[SCENE.find("[[mesh]]").expect("a mesh")..];
    format!("{meshes}{more}\n[[group]]\nname = \"{group}\"\nchildren = [\"ball\", {{ filter = \"{filter}\" }}]\n")
}

/// Writes the scene (`scene` after the volume; `SCENE`'s meshes and view when it is `SCENE`)
/// into `dir` with its volume, its view given `extra` lines, and opens it.
fn open(dir: &Path, scene: &str, extra: &str) -> SceneRenderer {
    let head = SCENE.split("[[mesh]]").next().unwrap_or_default();
    let body = if scene == SCENE { SCENE.trim_start_matches(head) } else { scene };
    let text = format!("{head}{}", body.replace("size = [96, 96]", &format!("size = [96, 96]\n{extra}")));
    common::open_with_clear_cube(dir, &text)
}

fn render(dir: &Path, scene: &str, extra: &str) -> image::RgbaImage {
    open(dir, scene, extra).render_all().expect("render").remove(0).1
}

fn filters(list: &[&str]) -> String {
    let entries: Vec<String> = list.iter().map(|p| format!("{{ path = \"{p}\" }}")).collect();
    format!("filters = [{}]", entries.join(", "))
}

/// The picture is opaque everywhere (the background is), so read-back colours are the
/// premultiplied ones the filters saw.
#[test]
fn luminance_is_rec_709_luma_of_the_picture() {
    let dir = tempfile::tempdir().expect("temp dir");
    let plain = render(dir.path(), SCENE, "");
    let grey = render(dir.path(), SCENE, &filters(&["std::luminance"]));
    let mut worst = 0.0f64;
    for (p, g) in plain.pixels().zip(grey.pixels()) {
        let [r, gr, b, a] = p.0.map(f64::from);
        let y = 0.2126 * r + 0.7152 * gr + 0.0722 * b;
        assert_eq!(a, 255.0, "the picture is opaque");
        assert!(g.0[0] == g.0[1] && g.0[1] == g.0[2], "grey: {:?}", g.0);
        assert_eq!(g.0[3], 255);
        worst = worst.max((f64::from(g.0[0]) - y).abs());
    }
    // The filter reads the 8-bit picture and writes 8 bits: only the last rounding differs.
    assert!(worst <= 0.5 + 1e-3, "largest difference from Rec. 709 luma {worst}/255");
}

#[test]
fn the_depth_buffer_view_equals_the_geometry_depth_probe() {
    let dir = tempfile::tempdir().expect("temp dir");
    let shown = render(dir.path(), SCENE, &filters(&["std::show_depth"]));
    let mut renderer = open(dir.path(), SCENE, &filters(&["std::show_depth"]));
    let probe = renderer.render_probe(0, &ProbeSpec::of("geometry_depth")).expect("probe");
    let (mut worst, mut covered) = (0.0f64, 0);
    for (x, y, pixel) in shown.enumerate_pixels() {
        let depth = probe.values.at(x, y).expect("a @ray field has a value everywhere")[0];
        covered += usize::from(depth < 1.0);
        worst = worst.max((f64::from(pixel.0[0]) / 255.0 - depth).abs());
    }
    assert!(covered > 1000, "the ball covers {covered} pixels");
    assert!(worst <= 0.5 / 255.0 + 1e-6, "largest difference {worst} (8-bit grey against the exact depth)");
}

/// A user's module takes `std::luminance`'s place in `filter.apply` (`replace`): the picture is
/// inverted instead; and `filter_mix = 0` shows the picture as it was.
#[test]
fn a_user_filter_replaces_a_standard_one() {
    let dir = tempfile::tempdir().expect("temp dir");
    let invert = "/// Inverts the premultiplied colour.\n\
        pipeline invert replace filter.apply[luminance] {\n    state color: vec4f;\n\
        \n    state.color = vec4f(vec3f(state.color.a) - state.color.rgb, state.color.a);\n}\n";
    std::fs::write(dir.path().join("invert.vrs"), invert).expect("module written");
    let plain = render(dir.path(), SCENE, "");
    let inverted = render(dir.path(), SCENE, &filters(&["std::luminance", "invert.vrs"]));
    for (p, i) in plain.pixels().zip(inverted.pixels()) {
        assert_eq!([255 - p.0[0], 255 - p.0[1], 255 - p.0[2], 255], i.0);
    }
    let mut renderer = open(dir.path(), SCENE, &filters(&["std::luminance", "invert.vrs"]));
    renderer.set_uniform("filter_mix", 0.0f32).expect("the filter pass reads filter_mix");
    assert_eq!(renderer.render_all().expect("render").remove(0).1, plain, "filter_mix 0 is the picture");
}

/// Lines along the ball's silhouette, where a pixel of the ball has a neighbour without it;
/// none on its smooth inside (the sphere's facets fold by 5.6 degrees, far below the threshold),
/// nothing outside.
#[test]
fn edges_outline_the_silhouette_and_leave_smooth_surfaces() {
    let dir = tempfile::tempdir().expect("temp dir");
    let plain = render(dir.path(), SCENE, "");
    let lined = render(dir.path(), SCENE, &filters(&["std::edges"]));
    let mut renderer = open(dir.path(), SCENE, "");
    let probe = renderer.render_probe(0, &ProbeSpec::of("geometry_depth")).expect("probe");
    let (w, h) = plain.dimensions();
    let covered = |x: i64, y: i64| {
        let inside = (0..i64::from(w)).contains(&x) && (0..i64::from(h)).contains(&y);
        !inside || probe.values.at(x as u32, y as u32).is_some_and(|d| d[0] < 1.0)
    };
    let distance_to_outside =
        |x: i64, y: i64| (1..4).find(|&r| (-r..=r).any(|dy| (-r..=r).any(|dx| !covered(x + dx, y + dy)))).unwrap_or(4);
    let (mut silhouette, mut inside) = (0, 0);
    for (x, y, pixel) in lined.enumerate_pixels() {
        let (xi, yi) = (i64::from(x), i64::from(y));
        let before = plain.get_pixel(x, y).0;
        if !covered(xi, yi) {
            assert_eq!(pixel.0, before, "({x}, {y}) is outside the ball");
        } else if [(1, 0), (-1, 0), (0, 1), (0, -1)].iter().any(|(dx, dy)| !covered(xi + dx, yi + dy)) {
            assert_eq!(pixel.0, [0, 0, 0, 255], "({x}, {y}) is on the silhouette");
            silhouette += 1;
        } else if distance_to_outside(xi, yi) >= 4 {
            assert_eq!(pixel.0, before, "({x}, {y}) is inside the smooth surface");
            inside += 1;
        }
    }
    assert!(silhouette > 100 && inside > 1000, "{silhouette} silhouette and {inside} inner pixels");
}

/// Ambient occlusion leaves a convex block (every neighbour lies on or below the pixel's tangent
/// plane) all but unchanged, and darkens the concave corner where the block stands on a slab;
/// it never brightens. On the block, the tangent planes of the few pixels where two creases
/// meet are estimated tilted: at most 1% of its pixels change, by at most 10/255.
#[test]
fn ssao_darkens_concave_corners_only() {
    let dir = tempfile::tempdir().expect("temp dir");
    let convex = BLOCKS.split("[[mesh]]\nname = \"slab\"").next().unwrap_or_default().to_string()
        + &BLOCKS[BLOCKS.find("[[view]]").unwrap_or(0)..];
    let plain = render(dir.path(), &convex, "");
    let occluded = render(dir.path(), &convex, &filters(&["std::ssao"]));
    let background = plain.get_pixel(0, 0).0;
    let block = plain.pixels().filter(|p| p.0 != background).count();
    let changes: Vec<u8> =
        plain.pixels().zip(occluded.pixels()).map(|(a, b)| a.0[0].abs_diff(b.0[0])).filter(|&d| d > 1).collect();
    let largest = changes.iter().max().copied().unwrap_or(0);
    assert!(block > 1000, "the block covers {block} pixels");
    assert!(
        changes.len() * 100 <= block && largest <= 10,
        "a convex block is occluded at {} of {block} pixels, by up to {largest}/255",
        changes.len()
    );
    let plain = render(dir.path(), BLOCKS, "");
    let occluded = render(dir.path(), BLOCKS, &filters(&["std::ssao"]));
    let mut darker = 0;
    for (a, b) in plain.pixels().zip(occluded.pixels()) {
        assert!(b.0[0] <= a.0[0], "ambient occlusion never brightens");
        darker += usize::from(a.0[0] - b.0[0] > 8);
    }
    assert!(darker > 30, "the corner darkens ({darker} pixels by more than 8/255)");
}

/// A field of the filter pass is probed at `filter.finish`: `picture_color` is the picture the
/// pass read, exactly (8-bit values as floats); a sample of it is refused.
#[test]
fn a_probe_reads_a_field_of_the_filter_pass() {
    let dir = tempfile::tempdir().expect("temp dir");
    let plain = render(dir.path(), SCENE, "");
    let mut renderer = open(dir.path(), SCENE, &filters(&["std::luminance"]));
    let probe = renderer.render_probe(0, &ProbeSpec::of("picture_color")).expect("probe");
    assert!(probe.legend().contains("filter pass at filter.finish"), "{}", probe.legend());
    for (x, y, pixel) in plain.enumerate_pixels() {
        let value = probe.values.at(x, y).expect("every pixel has its colour");
        let read: Vec<f64> = value.iter().map(|v| v * 255.0).collect();
        let want: Vec<f64> = pixel.0.iter().map(|&c| f64::from(c)).collect();
        assert!(read.iter().zip(&want).all(|(r, w)| (r - w).abs() < 1e-3), "({x}, {y}): {read:?} for {want:?}");
    }
    let at_sample = ProbeSpec { field: "picture_color".into(), at: Some(ProbeAt::Sample(0)) };
    let refused = renderer.render_probe(0, &at_sample).err().map(|e| e.to_string()).unwrap_or_default();
    assert!(refused.contains("filter.finish"), "{refused}");
}

/// The fields of a filter in a group are probed as `GROUP-K.FIELD`, read from the group's part
/// right after the filter, whatever lies in front of it in the picture (a box outside the
/// group): `picture_color` is the ball's part as drawn (the ball's pixels as a view of the ball
/// alone shows them, transparent where it is not), `color` its Rec. 709 grey.
#[test]
fn a_probe_reads_a_field_of_a_filter_in_a_group() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = with_group("grey", "std::luminance", BOX);
    let ball = render(dir.path(), &scene, r#"picture = ["ball", "volume"]"#);
    let nothing = render(dir.path(), &scene, r#"picture = ["volume"]"#);
    let mut renderer = open(dir.path(), &scene, r#"picture = ["grey", "box", "volume"]"#);
    let fields = renderer.probe_fields(0).expect("fields");
    assert!(fields.iter().any(|f| f.name == "grey-2.picture_color"), "{fields:?}");
    let part = renderer.render_probe(0, &ProbeSpec::of("grey-2.picture_color")).expect("probe");
    assert!(part.legend().contains("filter of the tree at filter.finish"), "{}", part.legend());
    let grey = renderer.render_probe(0, &ProbeSpec::of("grey-2.color")).expect("probe");
    let (mut inside, mut outside) = (0, 0);
    for ((x, y, b), n) in ball.enumerate_pixels().zip(nothing.pixels()) {
        let drawn = part.values.at(x, y).expect("a filter's field has a value at every pixel");
        let filtered = grey.values.at(x, y).expect("a filter's field has a value at every pixel");
        if b == n {
            assert_eq!(drawn, &[0.0; 4][..], "({x}, {y}): the ball is not here");
            outside += 1;
            continue;
        }
        let want = b.0.map(|c| f64::from(c) / 255.0);
        assert!(drawn.iter().zip(&want).all(|(d, w)| (d - w).abs() < 1e-6), "({x}, {y}): {drawn:?} for {want:?}");
        let y709 = 0.2126 * want[0] + 0.7152 * want[1] + 0.0722 * want[2];
        assert!(filtered[..3].iter().all(|c| (c - y709).abs() < 1e-5) && filtered[3] == want[3], "{filtered:?}");
        inside += 1;
    }
    assert!(inside > 1000 && outside > 1000, "{inside} pixels of the ball, {outside} without it");
}

/// Depth is written only where colour is: a filter in a group that clears its part's colour
/// (a user's filter) clears the part's depth with it, so the volume's rays no longer end at the
/// ball (the `geometry_depth` probe is 1 everywhere, as without the ball).
#[test]
fn a_filter_that_clears_colour_clears_depth_with_it() {
    let dir = tempfile::tempdir().expect("temp dir");
    let erase = "/// Clears the part.\npipeline erase in filter.apply {\n    state color: vec4f;\n\n    state.color = vec4f(0.0);\n}\n";
    std::fs::write(dir.path().join("erase.vrs"), erase).expect("module written");
    let scene = with_group("gone", "erase.vrs", "");
    let mut shown = open(dir.path(), &scene, r#"picture = ["ball", "volume"]"#);
    let drawn = shown.render_probe(0, &ProbeSpec::of("geometry_depth")).expect("probe");
    let covered = drawn.values.pixels.iter().flatten().filter(|d| d[0] < 1.0).count();
    assert!(covered > 1000, "the ball covers {covered} pixels");
    let mut erased = open(dir.path(), &scene, r#"picture = ["gone", "volume"]"#);
    let depth = erased.render_probe(0, &ProbeSpec::of("geometry_depth")).expect("probe");
    let left = depth.values.pixels.iter().flatten().filter(|d| d[0] < 1.0).count();
    assert_eq!(left, 0, "pixels that kept the cleared ball's depth");
}

/// A filter among a group's children filters the picture of the children before it, and only
/// that: the ball in a group with `std::luminance` turns grey (Rec. 709 luma of its colour
/// without the filter, within 1/255: the group's image is 8-bit before the filter and after
/// it), while a box outside the group and the background stay exactly as they were.
#[test]
fn a_filter_in_a_group_filters_the_children_before_it_only() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = with_group("grey", "std::luminance", BOX);
    let with = |picture: &str| format!("picture = {picture}");
    let plain = render(dir.path(), &scene, &with(r#"["ball", "box", "volume"]"#));
    let no_ball = render(dir.path(), &scene, &with(r#"["box", "volume"]"#));
    let grouped = render(dir.path(), &scene, &with(r#"["grey", "box", "volume"]"#));
    let (mut ball, mut rest, mut worst) = (0, 0, 0.0f64);
    for ((p, n), g) in plain.pixels().zip(no_ball.pixels()).zip(grouped.pixels()) {
        if p == n {
            assert_eq!(p, g, "a pixel without the ball changed");
            rest += 1;
            continue;
        }
        let [r, gr, b, _] = p.0.map(f64::from);
        let y = 0.2126 * r + 0.7152 * gr + 0.0722 * b;
        assert!(g.0[0].abs_diff(g.0[1]) <= 1 && g.0[1].abs_diff(g.0[2]) <= 1, "grey: {:?}", g.0);
        worst = worst.max((f64::from(g.0[1]) - y).abs());
        ball += 1;
    }
    assert!(ball > 1000 && rest > 1000, "{ball} pixels of the ball, {rest} others");
    assert!(worst <= 1.0 + 1e-3, "largest difference from Rec. 709 luma {worst}/255");
    // A probe reads the mesh layer as the view does: the ball's colour there is grey too.
    let mut renderer = open(dir.path(), &scene, &with(r#"["grey", "box", "volume"]"#));
    let probe = renderer.render_probe(0, &ProbeSpec::of("geometry_color")).expect("probe");
    let mut grey = 0;
    for ((x, y, p), n) in plain.enumerate_pixels().zip(no_ball.pixels()) {
        let c = probe.values.at(x, y).expect("a @ray field has a value everywhere");
        if p != n && c[3] > 0.99 {
            assert!((c[0] - c[1]).abs() < 1.5 / 255.0 && (c[1] - c[2]).abs() < 1.5 / 255.0, "{c:?}");
            grey += 1;
        }
    }
    assert!(grey > 1000, "{grey} grey pixels of the probe");
}
