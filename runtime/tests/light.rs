//! Light transport on lavapipe, against what it should be analytically: tone mapping (known
//! radiance in, known 8-bit value out), shadow rays (the Beer-Lambert transmittance of a slab
//! of known opacity), and renders of bad input that stay finite.

mod common;

use std::path::{Path, PathBuf};
use vrs_runtime::{ProbeAt, ProbeSpec, RenderOptions, SceneRenderer};

/// Writes `dims` int16 voxels of 1 mm, `value(i, j, k)` each, as a NRRD.
fn write_nrrd(path: &Path, [x, y, z]: [u32; 3], value: impl Fn(u32, u32, u32) -> i16) {
    let mut bytes = format!(
        "NRRD0004\ntype: short\ndimension: 3\nsizes: {x} {y} {z}\nspace directions: (1,0,0) (0,1,0) (0,0,1)\n\
         space origin: (0,0,0)\nendian: little\nencoding: raw\n\n"
    )
    .into_bytes();
    for k in 0..z {
        for j in 0..y {
            for i in 0..x {
                bytes.extend(value(i, j, k).to_le_bytes());
            }
        }
    }
    std::fs::write(path, bytes).expect("volume written");
}

fn open(dir: &Path, scene: &str) -> SceneRenderer {
    let path: PathBuf = dir.join("scene.toml");
    std::fs::write(&path, scene).expect("scene written");
    let options = RenderOptions { phantom_size: [32, 32, 32], ..RenderOptions::default() };
    SceneRenderer::open(common::software_gpu(), &path, options, &mut |_, _, _| {}).unwrap_or_else(|e| panic!("{e}"))
}

/// Overrides the composited colour with the uniform `known` just before exposure.
const KNOWN_RADIANCE: &str = "pipeline known_radiance before ray.finish[expose] {\n    \
    uniform known: vec4f = vec4f(0.0);\n    @ray state accum: vec4f = vec4f(0.0);\n\n    state.accum = known;\n}\n";

/// One opaque pixel of radiance `known` through `tone` (its render keys): its bytes.
fn tone_mapped(tone: &str, known: [f32; 3]) -> [u8; 3] {
    let dir = tempfile::tempdir().expect("a folder");
    std::fs::write(dir.path().join("known.vrs"), KNOWN_RADIANCE).expect("module written");
    let [r, g, b] = known;
    let scene = format!(
        "[render]\ncompositing = \"dvr\"\n{tone}\n\n[[volume]]\nname = \"head\"\nrole = \"primary\"\n\
         phantom = \"head\"\ntf = \"ct_bone\"\n\n[[module]]\npath = \"known.vrs\"\n\n\
         [uniforms]\nknown = [{r}, {g}, {b}, 1.0]\n\n[[view]]\nname = \"3d\"\nkind = \"raycast\"\nsize = [4, 4]\n"
    );
    let mut renderer = open(dir.path(), &scene);
    let image = &renderer.render_all().expect("renders")[0].1;
    let p = image.get_pixel(2, 2);
    assert_eq!(p[3], 255, "{tone}: opaque");
    [p[0], p[1], p[2]]
}

/// Radiance in, 8-bit sRGB out, for each operator: the expected bytes were computed by hand
/// (sRGB encoding of the operator's value, rounded) and are within one step of rounding.
#[test]
fn tone_mapping_maps_known_radiance_to_known_bytes() {
    let cases: [(&str, [f32; 3], [u8; 3]); 5] = [
        // Exposure alone clips at white; sRGB(0.5) = 0.7354 = 188/255.
        ("tone_mapping = \"exposure\"", [0.5, 0.2, 0.05], [188, 124, 63]),
        // One stop more doubles the radiance.
        ("tone_mapping = \"exposure\"\nexposure = 1.0", [0.5, 0.2, 0.05], [255, 170, 89]),
        // Reinhard on luminance L = 1.1765: L_d = L (1 + L / 16) / (1 + L) = 0.5803.
        ("tone_mapping = \"reinhard\"\nwhite_point = 4.0", [2.0, 1.0, 0.5], [253, 186, 136]),
        // At the white point the luminance maps to exactly 1.
        ("tone_mapping = \"reinhard\"\nwhite_point = 2.0", [2.0, 2.0, 2.0], [255, 255, 255]),
        // Narkowicz's ACES fit per channel: 2 -> 0.9132, 1 -> 0.8038, 0.5 -> 0.6163.
        ("tone_mapping = \"aces\"", [2.0, 1.0, 0.5], [245, 232, 206]),
    ];
    for (tone, radiance, want) in cases {
        let got = tone_mapped(tone, radiance);
        let close = got.iter().zip(want).all(|(g, w)| g.abs_diff(w) <= 1);
        assert!(close, "{tone}, radiance {radiance:?}: got {got:?}, want {want:?}");
    }
}

/// A 16 x 16 x 64 volume of 1 mm voxels: value 1000 in slices 8 to 47 (a slab 40 mm thick), 0
/// elsewhere, under a transfer function of opacity `A` per millimetre from 500 up (the slab's
/// top is halfway between slices 47 and 48, at 47.5 mm). An axial slice inside the slab, lit
/// from superior (+z), reads the shadow ray's transmittance at its one sample.
const SLAB_SCENE: &str = r#"
[render]
compositing = "dvr"
shading = true
lights = ["key"]
shadows = "rays"
step_size = 0.25
jitter = 0.0

[[volume]]
name = "slab"
role = "primary"
path = "slab.nrrd"
window = [0.0, 1000.0]
tf = "slab.json"

[uniforms]
light_dir_key = [0.0, 0.0, 1.0]
ref_step = 1.0
shadow_step_factor = 1.0

[[view]]
name = "axial"
kind = "slice"
axis = "axial"
position = POSITION
size = [8, 8]
"#;

/// The slab's opacity per millimetre: 13/255, which the transfer function's 8-bit table holds
/// exactly (0.05 would be stored as 13/255 all the same).
const A: f64 = 13.0 / 255.0;

/// Shadow rays attenuate as Beer-Lambert says: through L mm of a slab whose opacity per
/// millimetre is A, the transmittance is (1 - A)^L. The ray steps 0.25 mm, so its path in the
/// slab is known to within a step at each end: the tolerance is the transmittance of one step
/// either way, (1 - A)^0.25: 1.3% relative.
#[test]
fn shadow_rays_give_the_beer_lambert_transmittance_of_a_slab() {
    let dir = tempfile::tempdir().expect("a folder");
    write_nrrd(&dir.path().join("slab.nrrd"), [16, 16, 64], |_, _, k| if (8..48).contains(&k) { 1000 } else { 0 });
    let tf = format!(
        r#"[{{"Name": "slab", "RGBPoints": [0, 1, 1, 1, 1000, 1, 1, 1], "Points": [0, 0, 0.5, 0, 499, 0, 0.5, 0, 501, {A}, 0.5, 0, 1000, {A}, 0.5, 0]}}]"#
    );
    std::fs::write(dir.path().join("slab.json"), tf).expect("tf written");
    // Slice positions (the fraction of the grid's box along z) and the path to the slab's top:
    // the plane lies at 64 p - 0.5 mm (voxel centres at whole millimetres).
    for position in [0.625f64, 0.5, 0.25] {
        let plane = 64.0 * position - 0.5;
        let path = 47.5 - plane;
        let mut renderer = open(dir.path(), &SLAB_SCENE.replace("POSITION", &position.to_string()));
        let spec = ProbeSpec { field: "shadow_key".into(), at: Some(ProbeAt::Sample(0)) };
        let probe = renderer.render_probe(0, &spec).expect("the shadow probes");
        let t = probe.values.at(4, 4).expect("the centre has a value")[0];
        let want = (1.0 - A).powf(path);
        let tolerance = want * (1.0 - (1.0 - A).powf(0.25));
        assert!((t - want).abs() <= tolerance, "{path} mm of slab: transmittance {t:.4}, Beer-Lambert {want:.4}");
    }
}
