//! The vrsc contender of the peer benchmark (`benches/peers/`): a long-lived process that renders
//! the shaders `vrsc build` wrote (of this vrsc or of another, such as a build from before a
//! change) with this runtime, and times them. The benchmark's driver speaks to it in JSON lines
//! on standard input and output; every answer is one line, `{"error": ...}` on failure.
//!
//! - `{"cmd": "prepare", "volume": {"file": P} | {"phantom": NAME, "size": N}, "window": [lo, hi]
//!   | null, "tf": PRESET, "out": DIR}`: loads the volume as a scene would, writes what the other
//!   contenders render: `DIR/volume.f32` (normalized by the window, x fastest), `DIR/tf.rgba8`
//!   (the transfer function over the window, as uploaded) and answers dims, extent and window.
//! - `{"cmd": "open", "scene": PATH, "size": [w, h], "phantom_size": N, "as": NAME}`: opens the
//!   scene as NAME (`"vrsc"` when left out), in place of the scene of that name; its bricked
//!   volumes stream every brick its views need before it answers.
//! - `{"cmd": "time", "shader": DIR, "view": V, "uniforms": {..}, "frames": N, "warmup": B,
//!   "scene": NAME}`: renders view V of scene NAME (`"vrsc"` when left out) with `DIR/V.wgsl` and
//!   `.json` (with the scene's own shader when `shader` is left out), N frames (after an untimed
//!   one unless `warmup` is false); answers their times in ms, from submit to completion (no
//!   read-back).
//! - `{"cmd": "image", "shader": DIR, "view": V, "uniforms": {..}, "out": PNG, "scene": NAME}`:
//!   one frame, read back and written.
//!
//! Run by the driver as `cargo run --release -p vrs-runtime --example peer_worker`.

use serde_json::{Value, json};
use std::collections::HashMap;
use std::io::{BufRead, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;
use vrs_runtime::{AdapterChoice, Gpu, RenderOptions, SceneRenderer, ViewShader, tf, volume};

struct Worker {
    gpu: Gpu,
    scenes: HashMap<String, OpenScene>,
}

/// A scene the driver opened, by the name it gave.
struct OpenScene {
    renderer: SceneRenderer,
    /// The shader directory view 0 renders with now (`None`: the scene's own).
    current: Option<PathBuf>,
}

fn main() {
    let gpu = match Gpu::headless(AdapterChoice::Software) {
        Ok(gpu) => gpu,
        Err(e) => {
            println!("{}", json!({ "error": format!("no software adapter: {e}") }));
            return;
        }
    };
    eprintln!("peer_worker: adapter {}", gpu.adapter);
    let mut worker = Worker { gpu, scenes: HashMap::new() };
    let stdin = std::io::stdin();
    let mut stdout = std::io::stdout();
    for line in stdin.lock().lines() {
        let Ok(line) = line else { break };
        if line.trim().is_empty() {
            continue;
        }
        let answer = match serde_json::from_str::<Value>(&line) {
            Ok(request) => worker.handle(&request).unwrap_or_else(|e| json!({ "error": e })),
            Err(e) => json!({ "error": format!("not JSON: {e}") }),
        };
        let _ = writeln!(stdout, "{answer}");
        let _ = stdout.flush();
    }
}

fn text<'a>(request: &'a Value, key: &str) -> Result<&'a str, String> {
    request[key].as_str().ok_or_else(|| format!("`{key}` is missing"))
}

/// The name of the scene `request` is about: `key`'s value, `"vrsc"` when left out.
fn scene_name<'a>(request: &'a Value, key: &str) -> &'a str {
    request[key].as_str().unwrap_or("vrsc")
}

impl Worker {
    fn handle(&mut self, request: &Value) -> Result<Value, String> {
        match text(request, "cmd")? {
            "prepare" => prepare(request),
            "open" => self.open(request),
            "time" => self.time(request),
            "image" => self.image(request),
            other => Err(format!("unknown command `{other}`")),
        }
    }

    fn open(&mut self, request: &Value) -> Result<Value, String> {
        let size =
            request["size"].as_array().and_then(|s| Some([s.first()?.as_u64()? as u32, s.get(1)?.as_u64()? as u32]));
        let n = request["phantom_size"].as_u64().unwrap_or(128) as u32;
        let options = RenderOptions { size, phantom_size: [n; 3], ..RenderOptions::default() };
        let path = Path::new(text(request, "scene")?);
        let name = scene_name(request, "as");
        self.scenes.remove(name);
        let mut renderer =
            SceneRenderer::open(self.gpu.clone(), path, options, &mut |_, _, _| {}).map_err(|e| e.to_string())?;
        if renderer.brick_residency().is_some() {
            // Streams every brick the views need: timed frames find them resident.
            renderer.render_all().map_err(|e| e.to_string())?;
        }
        self.scenes.insert(name.to_string(), OpenScene { renderer, current: None });
        Ok(json!({ "ok": true }))
    }

    /// The scene `request` names with view 0 rendering its shader (or the scene's own) and its
    /// uniforms.
    fn ready(&mut self, request: &Value) -> Result<&mut SceneRenderer, String> {
        let name = scene_name(request, "scene");
        let open = self.scenes.get_mut(name).ok_or_else(|| format!("no scene `{name}` is open"))?;
        if let Some(dir) = request["shader"].as_str().map(PathBuf::from)
            && open.current.as_ref() != Some(&dir)
        {
            let shader = ViewShader::load_view(&dir, text(request, "view")?).map_err(|e| e.to_string())?;
            open.renderer.replace_shader(0, shader).map_err(|e| e.to_string())?;
            open.current = Some(dir);
        }
        let scene = &mut open.renderer;
        // A new shader starts from its reflection's defaults: the scene's values again.
        if let Some(uniforms) = request["uniforms"].as_object() {
            let renderer = &mut scene.views_mut()[0].renderer;
            for (name, value) in uniforms {
                if !renderer.has_uniform(name) {
                    continue;
                }
                let result = match value {
                    Value::Number(n) if n.is_u64() && name == "max_samples" => {
                        renderer.set_uniform(name, n.as_u64().unwrap_or(0) as u32)
                    }
                    Value::Number(n) => renderer.set_uniform(name, n.as_f64().unwrap_or(0.0) as f32),
                    _ => continue,
                };
                result.map_err(|e| e.to_string())?;
            }
        }
        Ok(scene)
    }

    fn time(&mut self, request: &Value) -> Result<Value, String> {
        let frames = request["frames"].as_u64().unwrap_or(2) as usize;
        let warmup = usize::from(request["warmup"].as_bool().unwrap_or(true));
        let scene = self.ready(request)?;
        let mut times = Vec::with_capacity(frames);
        for i in (1 - warmup)..=frames {
            let mut encoder = scene.gpu().device.create_command_encoder(&Default::default());
            scene.encode_view(0, &mut encoder).map_err(|e| e.to_string())?;
            let start = Instant::now();
            scene.gpu().queue.submit([encoder.finish()]);
            scene.gpu().wait();
            if i > 0 {
                times.push(start.elapsed().as_secs_f64() * 1e3);
            }
        }
        Ok(json!({ "ms": times }))
    }

    fn image(&mut self, request: &Value) -> Result<Value, String> {
        let out = PathBuf::from(text(request, "out")?);
        let scene = self.ready(request)?;
        let images = scene.render_all().map_err(|e| e.to_string())?;
        let (_, image) = images.first().ok_or("the scene has no views")?;
        image.save(&out).map_err(|e| format!("{}: {e}", out.display()))?;
        Ok(json!({ "ok": true }))
    }
}

/// Loads the volume and writes the normalized samples and the transfer-function table.
fn prepare(request: &Value) -> Result<Value, String> {
    let spec = &request["volume"];
    let data = if let Some(file) = spec["file"].as_str() {
        volume::load(Path::new(file), &mut |_, _| {}).map_err(|e| e.to_string())?
    } else {
        let name = spec["phantom"].as_str().ok_or("`volume` needs `file` or `phantom`")?;
        let n = spec["size"].as_u64().unwrap_or(128) as u32;
        volume::phantom::phantom(name, [n; 3]).map_err(|e| e.to_string())?
    };
    // A preset's name, or a ParaView colormap file (`.json`).
    let tf_name = text(request, "tf")?;
    let table =
        if tf_name.ends_with(".json") { tf::from_paraview_json(Path::new(tf_name)) } else { tf::preset(tf_name) };
    let table = table.map_err(|e| e.to_string())?;
    let window = match request["window"].as_array() {
        Some(w) => [w[0].as_f64().unwrap_or(0.0) as f32, w[1].as_f64().unwrap_or(1.0) as f32],
        None => match table.domain {
            tf::TfDomain::Data(domain) => domain,
            _ => volume::auto_window(&data),
        },
    };
    let out = PathBuf::from(text(request, "out")?);
    std::fs::create_dir_all(&out).map_err(|e| e.to_string())?;
    let mut samples = Vec::with_capacity(data.voxel_count() as usize * 4);
    data.for_each_normalized(Some(window), 0..data.voxel_count() as usize, |t| {
        samples.extend_from_slice(&half::f16::from_f32(t).to_f32().to_le_bytes())
    });
    std::fs::write(out.join("volume.f32"), samples).map_err(|e| e.to_string())?;
    // The table as the GPU holds it: half floats, written as f32 for the peers.
    let entries = table.over_window(window).rgba;
    let rounded = entries.iter().flatten().flat_map(|&c| half::f16::from_f32(c).to_f32().to_le_bytes());
    std::fs::write(out.join("tf.f32"), rounded.collect::<Vec<u8>>()).map_err(|e| e.to_string())?;
    use vrs_runtime::geometry::{PatientBox, volume_to_world};
    let extent = PatientBox::of(volume_to_world(data.dims, data.grid_to_world)).size();
    Ok(json!({ "dims": data.dims, "extent": extent.to_array(), "window": window }))
}
