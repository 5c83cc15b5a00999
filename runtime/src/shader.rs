//! A view's compiled shader: WGSL text and its reflection, loaded from `vrsc build`'s output
//! or handed over by the compiler; and the pipeline cache keyed by the structural hash.

use crate::bindings;
use crate::error::RuntimeError;
use crate::gpu::Gpu;
use crate::reflection::{Reflection, content_hash};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A view's WGSL and reflection, checked to belong together.
#[derive(Clone, Debug)]
pub struct ViewShader {
    /// The compute shader's source.
    pub wgsl: Arc<str>,
    /// Its bindings, uniforms and state fields, as the compiler described them.
    pub reflection: Arc<Reflection>,
}

impl ViewShader {
    /// Loads `DIR/VIEW.wgsl` and `DIR/VIEW.json` as `vrsc build` writes them.
    pub fn load(wgsl_path: &Path, json_path: &Path) -> Result<ViewShader, RuntimeError> {
        let read = |path: &Path| {
            std::fs::read_to_string(path).map_err(|error| RuntimeError::Io { path: path.to_path_buf(), error })
        };
        let wgsl = read(wgsl_path)?;
        let reflection = Reflection::from_json(&read(json_path)?)
            .map_err(|message| RuntimeError::Shader { path: json_path.to_path_buf(), message })?;
        ViewShader::new(wgsl, reflection, json_path)
    }

    /// Pairs WGSL with its reflection; refuses a pair whose `wgsl_hash` does not match (a stale
    /// `.json` beside a rebuilt `.wgsl`, or the other way round). `origin` names them in errors.
    pub fn new(wgsl: String, reflection: Reflection, origin: &Path) -> Result<ViewShader, RuntimeError> {
        let actual = content_hash(&wgsl);
        if actual != reflection.wgsl_hash {
            return Err(RuntimeError::Shader {
                path: origin.to_path_buf(),
                message: format!(
                    "the reflection describes WGSL with hash {}, but the WGSL beside it hashes to {actual}: \
                     rebuild both with `vrsc build`",
                    reflection.wgsl_hash
                ),
            });
        }
        Ok(ViewShader { wgsl: wgsl.into(), reflection: Arc::new(reflection) })
    }

    /// The shader of view `view` in a folder written by `vrsc build`.
    pub fn load_view(dir: &Path, view: &str) -> Result<ViewShader, RuntimeError> {
        let file = |ext: &str| -> PathBuf { dir.join(format!("{view}.{ext}")) };
        ViewShader::load(&file("wgsl"), &file("json"))
    }
}

/// How often [`PipelineCache`] reused a pipeline.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PipelineStats {
    pub(crate) hits: u64,
    /// Pipelines compiled because none with that structural hash was cached.
    pub misses: u64,
}

/// A view's compute pipeline and the bind-group layouts it was made with, one per group, both
/// from the shader's reflection (`crate::bindings`).
pub struct ViewPipeline {
    pub(crate) pipeline: wgpu::ComputePipeline,
    pub(crate) groups: Vec<wgpu::BindGroupLayout>,
}

/// Compute pipelines by structural hash: a configuration seen before reuses its pipeline, and a
/// uniform-only change (same hash) never compiles again. The hash covers the WGSL and the
/// bindings, so equal keys have equal layouts.
#[derive(Default)]
pub struct PipelineCache {
    pipelines: HashMap<String, Arc<ViewPipeline>>,
    stats: PipelineStats,
}

impl PipelineCache {
    /// An empty cache.
    pub fn new() -> PipelineCache {
        PipelineCache::default()
    }

    pub(crate) fn stats(&self) -> PipelineStats {
        self.stats
    }

    /// The pipeline of `shader`, compiled on first use.
    pub fn get(&mut self, gpu: &Gpu, shader: &ViewShader) -> Result<Arc<ViewPipeline>, RuntimeError> {
        let key = &shader.reflection.structural_hash;
        if let Some(pipeline) = self.pipelines.get(key) {
            self.stats.hits += 1;
            return Ok(pipeline.clone());
        }
        self.stats.misses += 1;
        let pipeline = Arc::new(compile(gpu, shader)?);
        self.pipelines.insert(key.clone(), pipeline.clone());
        Ok(pipeline)
    }
}

/// Creates the shader module, the layouts of its reflected bindings and the compute pipeline,
/// turning wgpu's errors into values.
fn compile(gpu: &Gpu, shader: &ViewShader) -> Result<ViewPipeline, RuntimeError> {
    let reflection = &shader.reflection;
    let view = &reflection.view;
    let made = gpu.capture(&format!("the shader of view `{view}`"), || {
        let module = gpu.device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(view),
            source: wgpu::ShaderSource::Wgsl(shader.wgsl.as_ref().into()),
        });
        let groups: Vec<wgpu::BindGroupLayout> = (0..bindings::group_count(reflection))
            .map(|group| {
                gpu.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some(view),
                    entries: &bindings::layout_entries(reflection, group),
                })
            })
            .collect();
        let layout = gpu.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(view),
            bind_group_layouts: &groups.iter().map(Some).collect::<Vec<_>>(),
            immediate_size: 0,
        });
        let pipeline = gpu.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(view),
            layout: Some(&layout),
            module: &module,
            entry_point: Some(&reflection.entry_point),
            compilation_options: Default::default(),
            cache: None,
        });
        ViewPipeline { pipeline, groups }
    });
    made.map_err(|fault| RuntimeError::Pipeline { view: view.clone(), message: fault.message })
}
