//! Renderer trees on lavapipe: an occlusion group's hidden children show through the first
//! child as the reference's rule says, against the pictures of each child alone.

mod common;

use std::path::Path;
use vrs_runtime::{RenderOptions, SceneRenderer};

/// A transparent volume (32^3 voxels of 1 mm; the transfer function is clear everywhere), so a
/// view's picture is its mesh layer's colour over the black background.
const SCENE: &str = r#"
[render]
compositing = "dvr"
jitter = 0.0
background = [0.0, 0.0, 0.0, 1.0]

[[volume]]
name = "cube"
role = "primary"
path = "cube.nrrd"
window = [0.0, 1000.0]
tf = "clear.json"

[[mesh]]
name = "tissue"
shape = "box"
min = [8.0, 6.0, 6.0]
max = [26.0, 25.0, 25.0]
color = [0.0, 0.3, 1.0]

[[mesh]]
name = "vessel"
shape = "sphere"
centre = [17.0, 15.5, 15.5]
radius = 6.0
color = [1.0, 0.2, 0.0]

[[group]]
name = "liver"
kind = "occlusion"
children = ["tissue", "vessel"]

[[view]]
name = "3d"
kind = "raycast"
size = [64, 64]
camera = { azimuth = 60.0, elevation = 25.0, distance = 2.2 }
"#;

fn render(dir: &Path, scene: &str, picture: &str) -> image::RgbaImage {
    let values = vec![1000.0f32; 32 * 32 * 32];
    let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    common::write_nrrd(&dir.join("cube.nrrd"), "RAS", [32; 3], identity, [0.0; 3], &values);
    let tf =
        r#"[{"Name": "clear", "RGBPoints": [0, 1, 1, 1, 1000, 1, 1, 1], "Points": [0, 0, 0.5, 0, 1000, 0, 0.5, 0]}]"#;
    std::fs::write(dir.join("clear.json"), tf).expect("tf written");
    let path = dir.join("scene.toml");
    let text = scene.replace("size = [64, 64]", &format!("size = [64, 64]\npicture = {picture}"));
    std::fs::write(&path, text).expect("scene written");
    let mut renderer = SceneRenderer::open(common::software_gpu(), &path, RenderOptions::default(), &mut |_, _, _| {})
        .unwrap_or_else(|e| panic!("{e}"));
    renderer.render_all().expect("render").remove(0).1
}

/// The occlusion group against its children alone: where the vessel (wholly inside the
/// tissue) shows, the group's picture is `k vessel + (1 - k) tissue` per channel (both opaque:
/// the rule `k F + (1 - k F.a) C`), elsewhere the tissue's; `k` is the group's hidden opacity.
/// Colours pass through 8-bit images twice, so the tolerance is 3/255.
fn assert_occlusion(dir: &Path, scene: &str, k: f32) {
    let tissue = render(dir, scene, r#"["tissue", "volume"]"#);
    let vessel = render(dir, scene, r#"["vessel", "volume"]"#);
    let group = render(dir, scene, r#"["liver", "volume"]"#);
    let (mut hidden, mut worst) = (0, 0.0f32);
    for ((c, f), got) in tissue.pixels().zip(vessel.pixels()).zip(group.pixels()) {
        let covered = f[0] > 0 || f[1] > 0 || f[2] > 0;
        hidden += usize::from(covered);
        for ch in 0..3 {
            let want = if covered { k * f32::from(f[ch]) + (1.0 - k) * f32::from(c[ch]) } else { f32::from(c[ch]) };
            let off = (f32::from(got[ch]) - want).abs();
            worst = worst.max(off);
            assert!(off <= 3.0, "channel {ch}: {got:?}, want {want} from tissue {c:?} and vessel {f:?} (k = {k})");
        }
    }
    assert!(hidden > 150, "the vessel covers many pixels ({hidden})");
    assert!(tissue != group, "the vessel shows through the tissue");
    eprintln!("k = {k}: {hidden} pixels show the hidden vessel; largest difference {worst}/255");
}

#[test]
fn an_occlusion_group_shows_what_its_first_child_hides_semi_transparently() {
    let dir = tempfile::tempdir().expect("a folder");
    assert_occlusion(dir.path(), SCENE, vrsc::scene::DEFAULT_HIDDEN_OPACITY);
    let thin = SCENE.replace("kind = \"occlusion\"", "kind = \"occlusion\"\nopacity = 0.25");
    assert_occlusion(dir.path(), &thin, 0.25);
}

#[test]
fn an_occlusion_group_with_show_visible_shows_the_hidden_children_whole() {
    let dir = tempfile::tempdir().expect("a folder");
    let visible = SCENE.replace("kind = \"occlusion\"", "kind = \"occlusion\"\nshow = \"visible\"");
    assert_occlusion(dir.path(), &visible, 1.0);
}

/// A depth group is the same picture as its children listed in the view.
#[test]
fn a_depth_group_draws_as_its_children_would() {
    let dir = tempfile::tempdir().expect("a folder");
    let depth = SCENE.replace("kind = \"occlusion\"", "kind = \"depth\"");
    let listed = render(dir.path(), &depth, r#"["tissue", "vessel", "volume"]"#);
    let grouped = render(dir.path(), &depth, r#"["liver", "volume"]"#);
    assert!(listed == grouped, "a depth group draws its children as the view would");
    let tissue = render(dir.path(), &depth, r#"["tissue", "volume"]"#);
    assert!(listed == tissue, "the vessel inside the tissue is hidden");
}
