//! A view's compiled shader: WGSL text and its reflection, loaded from `vrsc build`'s output
//! or handed over by the compiler; and the pipeline cache keyed by the structural hash.

use crate::error::RuntimeError;
use crate::gpu::Gpu;
use crate::reflection::{Reflection, content_hash};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A view's WGSL and reflection, checked to belong together.
#[derive(Clone, Debug)]
pub struct ViewShader {
    pub wgsl: Arc<str>,
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
    pub hits: u64,
    pub misses: u64,
}

/// Compute pipelines by structural hash: a configuration seen before reuses its pipeline, and a
/// uniform-only change (same hash) never compiles again.
#[derive(Default)]
pub struct PipelineCache {
    pipelines: HashMap<String, Arc<wgpu::ComputePipeline>>,
    stats: PipelineStats,
}

impl PipelineCache {
    pub fn new() -> PipelineCache {
        PipelineCache::default()
    }

    pub fn stats(&self) -> PipelineStats {
        self.stats
    }

    /// The pipeline of `shader`, compiled on first use.
    pub fn get(&mut self, gpu: &Gpu, shader: &ViewShader) -> Result<Arc<wgpu::ComputePipeline>, RuntimeError> {
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

/// Creates the shader module and compute pipeline, turning wgpu's validation errors into values.
fn compile(gpu: &Gpu, shader: &ViewShader) -> Result<wgpu::ComputePipeline, RuntimeError> {
    let view = &shader.reflection.view;
    let scope = gpu.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let module = gpu.device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(view),
        source: wgpu::ShaderSource::Wgsl(shader.wgsl.as_ref().into()),
    });
    let pipeline = gpu.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(view),
        layout: None,
        module: &module,
        entry_point: Some(&shader.reflection.entry_point),
        compilation_options: Default::default(),
        cache: None,
    });
    match pollster::block_on(scope.pop()) {
        Some(error) => Err(RuntimeError::Pipeline { view: view.clone(), message: error.to_string() }),
        None => Ok(pipeline),
    }
}
