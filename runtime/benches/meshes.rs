//! The cost of a view's mesh layer on the software adapter (lavapipe): a 100 k-triangle mesh
//! drawn under shaded DVR, in one run with the variants taking turns round after round. The
//! camera turns a little every frame, so the layer is drawn every frame (as while the user
//! orbits); a variant with the camera still (the layer drawn once and kept) separates the
//! layer's own cost from the rays the mesh ends early. Target: the mesh over plain DVR at most
//! 1.2x at 512^2. A closed mesh's back faces are culled; the same sphere with one triangle
//! missing (open: every face drawn) shows what that saves. The same sphere at opacity 0.5 is
//! peeled into the translucent layers and blended into the rays (std::translucent): turning,
//! the peeling passes draw it five times a frame; still, what is left is the rays' share. Two
//! rows add a filter pass over the mesh's frame: `std::luminance` (a copy of the picture and one
//! pass) and `std::ssao` with `std::edges` (16 and 12 depth reads a pixel).
//!
//! The volume is the MNI152 T1 of `../shared/data` when it is there, else the built-in head
//! phantom (said in the output). Run: `cargo bench -p vrs-runtime --bench meshes`; settings:
//! `VRS_BENCH_SIZE` (512), `VRS_BENCH_ROUNDS` (4), `VRS_BENCH_FRAMES` (2), `VRS_BENCH_TRIANGLES`
//! (100000), `VRS_BENCH_SHADING` (1; 0 for unshaded DVR).

#[path = "timing.rs"]
mod timing;

use std::path::Path;
use std::time::Instant;
use timing::median;
use vrs_runtime::mesh::shapes;
use vrs_runtime::{AdapterChoice, Gpu, RenderOptions, SceneRenderer};

const MNI_T1: &str = "../shared/data/mni152/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz";

fn number(name: &str, default: usize) -> usize {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).filter(|&n| n > 0).unwrap_or(default)
}

/// A binary STL of a sphere of about `triangles` triangles; `open`, without one of them (an
/// open surface: its back faces are drawn, not culled).
fn write_sphere_stl(path: &Path, centre: glam::Vec3, radius: f32, triangles: u32, open: bool) -> usize {
    let side = ((triangles / 2) as f32).sqrt().ceil() as u32;
    let mut mesh = shapes::sphere(centre, radius, side, side).expect("a sphere");
    if open {
        mesh.indices.truncate(mesh.indices.len() - 3);
    }
    let count = mesh.indices.len() / 3;
    let mut bytes = vec![0u8; 80];
    bytes.extend((count as u32).to_le_bytes());
    for tri in mesh.indices.chunks_exact(3) {
        bytes.extend([0u8; 12]);
        for &i in tri {
            bytes.extend(mesh.positions[i as usize].iter().flat_map(|c| c.to_le_bytes()));
        }
        bytes.extend([0u8; 2]);
    }
    std::fs::write(path, bytes).expect("mesh written");
    count
}

/// The scene with the mesh file `mesh` (none: `""`) of `opacity`, shaded with one light or not,
/// its view's `filters` those listed (standard modules).
fn scene(volume: &str, size: u32, (mesh, opacity): (&str, f32), shading: bool, filters: &[&str]) -> String {
    let filters: Vec<String> = filters.iter().map(|f| format!("{{ path = \"std::{f}\" }}")).collect();
    let filters = if filters.is_empty() { String::new() } else { format!("filters = [{}]\n", filters.join(", ")) };
    let mesh = if mesh.is_empty() {
        String::new()
    } else {
        format!("[[mesh]]\nname = \"ball\"\npath = \"{mesh}\"\ncolor = [0.9, 0.7, 0.2]\nopacity = {opacity:?}\n\n")
    };
    format!(
        "[render]\ncompositing = \"dvr\"\nshading = {shading}\njitter = 1.0\n\n\
         [[volume]]\nname = \"t1\"\nrole = \"primary\"\n{volume}\ntf = \"skin.json\"\n\n{mesh}\
         [[view]]\nname = \"3d\"\nkind = \"raycast\"\nsize = [{size}, {size}]\n\
         camera = {{ azimuth = 35.0, elevation = 15.0, distance = 2.4 }}\n{filters}"
    )
}

/// Times `frames` frames of view 0 (after one untimed frame), turning the camera by `turn`
/// degrees before each.
fn frame_times(scene: &mut SceneRenderer, frames: usize, turn: f32) -> Vec<f64> {
    let mut times = Vec::with_capacity(frames);
    for i in 0..=frames {
        if let Some(camera) = scene.views_mut()[0].camera.as_mut() {
            camera.azimuth += turn;
        }
        let mut encoder = scene.gpu().device.create_command_encoder(&Default::default());
        let start = Instant::now();
        scene.encode_view(0, &mut encoder).expect("encode");
        scene.gpu().queue.submit([encoder.finish()]);
        scene.gpu().wait();
        if i > 0 {
            times.push(start.elapsed().as_secs_f64() * 1e3);
        }
    }
    times
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mni = root.join(MNI_T1);
    let (volume, centre) = if mni.exists() {
        println!("volume: the MNI152 T1 (197 x 233 x 189)");
        (format!("path = {:?}", mni.display().to_string()), glam::Vec3::new(0.0, -18.0, 18.0))
    } else {
        println!("volume: the head phantom (128^3; {} is absent)", mni.display());
        ("phantom = \"head\"".to_string(), glam::Vec3::ZERO)
    };
    let (size, rounds, frames) =
        (number("VRS_BENCH_SIZE", 512) as u32, number("VRS_BENCH_ROUNDS", 4), number("VRS_BENCH_FRAMES", 2));
    let shading = std::env::var("VRS_BENCH_SHADING").map_or(true, |v| v != "0" && v != "false");
    let gpu = Gpu::headless(AdapterChoice::Software).expect("the software adapter");
    let dir = tempfile::tempdir().expect("a folder");
    std::fs::copy(root.join("examples/light/skin.json"), dir.path().join("skin.json")).expect("the example's tf");
    let wanted = number("VRS_BENCH_TRIANGLES", 100_000) as u32;
    let triangles = write_sphere_stl(&dir.path().join("ball.stl"), centre, 25.0, wanted, false);
    write_sphere_stl(&dir.path().join("open.stl"), centre, 25.0, wanted, true);
    println!(
        "adapter: {}, {size}x{size}, {rounds} rounds of {frames} frames, a mesh of {triangles} triangles",
        gpu.adapter
    );
    // (name, mesh file and its opacity, degrees the camera turns per frame, filters)
    let none: &[&str] = &[];
    let variants = [
        ("DVR", ("", 1.0), 0.05, none),
        ("DVR + mesh, camera turning", ("ball.stl", 1.0), 0.05, none),
        ("DVR + mesh, camera still", ("ball.stl", 1.0), 0.0, none),
        ("DVR + open mesh, camera turning", ("open.stl", 1.0), 0.05, none),
        ("DVR + translucent mesh, turning", ("ball.stl", 0.5), 0.05, none),
        ("DVR + translucent mesh, still", ("ball.stl", 0.5), 0.0, none),
        ("DVR + mesh + luminance, turning", ("ball.stl", 1.0), 0.05, &["luminance"][..]),
        ("DVR + mesh + SSAO, edges, turning", ("ball.stl", 1.0), 0.05, &["ssao", "edges"][..]),
    ];
    let mut renderers: Vec<SceneRenderer> = variants
        .iter()
        .enumerate()
        .map(|(i, &(_, mesh, _, filters))| {
            let path = dir.path().join(format!("scene{i}.toml"));
            std::fs::write(&path, scene(&volume, size, mesh, shading, filters)).expect("scene written");
            SceneRenderer::open(gpu.clone(), &path, RenderOptions::default(), &mut |_, _, _| {}).expect("opens")
        })
        .collect();
    let mut times = vec![Vec::new(); variants.len()];
    for _ in 0..rounds {
        for ((renderer, times), &(_, _, turn, _)) in renderers.iter_mut().zip(&mut times).zip(&variants) {
            times.extend(frame_times(renderer, frames, turn));
        }
    }
    let medians: Vec<f64> = times.into_iter().map(median).collect();
    for ((name, _, _, _), ms) in variants.iter().zip(&medians) {
        println!("{name:<30} {ms:8.1} ms");
    }
    println!("mesh (drawn every frame) over DVR: {:.3}x (target <= 1.2)", medians[1] / medians[0]);
    println!("the mesh layer's own share:        {:.3}x (turning over still)", medians[1] / medians[2]);
    println!("an open mesh (no culling) over DVR: {:.3}x", medians[3] / medians[0]);
    println!(
        "translucent (peeled) over DVR:      {:.3}x, camera still {:.3}x",
        medians[4] / medians[0],
        medians[5] / medians[0]
    );
    println!(
        "a filter pass over the mesh's frame:  luminance {:.3}x, SSAO and edges {:.3}x",
        medians[6] / medians[1],
        medians[7] / medians[1]
    );
}
