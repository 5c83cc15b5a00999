//! The textures, meshes and sampler shared by the views of a scene, which each view binds by
//! name (`crate::bindings`). Its own file so that the bindings and the views both depend on it
//! and not on each other.

use crate::bricks::BrickedVolumes;
use crate::error::RuntimeError;
use crate::gpu::Gpu;
use crate::mesh_layer::{MeshInstance, pipelines::MeshPipelines};
use crate::textures::{TfTexture, VolumeTexture, linear_sampler};
use crate::tf::TransferFunction;
use crate::volume::Volume;
use std::collections::HashMap;
use std::sync::Arc;

/// Textures shared by the views of a scene, by the uniform name the shaders bind them under
/// (`volume`, `volume_gm`, `tf`, `tf_gm`).
pub struct Resources {
    pub(crate) volumes: HashMap<String, Arc<VolumeTexture>>,
    /// Volumes kept in bricks (`crate::bricks`), by the same names.
    pub(crate) bricked: BrickedVolumes,
    pub(crate) tfs: HashMap<String, Arc<TfTexture>>,
    pub(crate) sampler: wgpu::Sampler,
    /// The scene's meshes, which views' mesh layers draw (by index).
    pub(crate) meshes: Vec<MeshInstance>,
    /// Counts changes of `meshes`' surfaces (a layer drawn from an older one is drawn again).
    mesh_generation: u64,
    /// Made with the first mesh.
    pub(crate) mesh_pipelines: Option<MeshPipelines>,
    /// What the content is at: a fresh value at every change of a texture, table, brick or
    /// mesh (`content_generation`), so a progressive view's history made before it is cleared.
    content: u64,
}

impl Resources {
    /// No textures or meshes yet, and the linear sampler every view binds.
    pub fn new(gpu: &Gpu) -> Resources {
        Resources {
            volumes: HashMap::new(),
            bricked: HashMap::new(),
            tfs: HashMap::new(),
            sampler: linear_sampler(gpu),
            meshes: Vec::new(),
            mesh_generation: 0,
            mesh_pipelines: None,
            content: content_generation(),
        }
    }

    /// Uploads `volume` as the 3D texture views bind as `binding` (`volume`, `volume_gm`, ...),
    /// mapping `window` (data units; without one, the volume's value range) to [0, 1].
    pub fn bind_volume(
        &mut self,
        gpu: &Gpu,
        binding: &str,
        volume: &Volume,
        window: Option<[f32; 2]>,
    ) -> Result<(), RuntimeError> {
        let texture = VolumeTexture::upload(gpu, binding, volume, window)?;
        self.volumes.insert(binding.to_string(), Arc::new(texture));
        self.content_changed();
        Ok(())
    }

    /// Uploads `tf` as the transfer function views bind as `binding` (`tf`, `tf_gm`, ...).
    pub fn bind_tf(&mut self, gpu: &Gpu, binding: &str, tf: &TransferFunction) -> Result<(), RuntimeError> {
        self.tfs.insert(binding.to_string(), Arc::new(TfTexture::upload(gpu, tf)?));
        self.content_changed();
        Ok(())
    }

    /// How many times `meshes`' surfaces have changed: a mesh layer drawn at an older generation
    /// is drawn again.
    pub(crate) fn mesh_generation(&self) -> u64 {
        self.mesh_generation
    }

    /// Records that `meshes`' surfaces changed (every mesh layer is drawn again).
    pub(crate) fn meshes_changed(&mut self) {
        self.mesh_generation += 1;
        self.content_changed();
    }

    /// What the shared content is at (see `content_changed`).
    pub(crate) fn content(&self) -> u64 {
        self.content
    }

    /// Records that something views render from changed in place (a table rewritten, bricks
    /// uploaded): progressive views start their histories again.
    pub(crate) fn content_changed(&mut self) {
        self.content = content_generation();
    }
}

/// A fresh value of the content generation: every change of what views render from (a transfer
/// function written, bricks uploaded, volumes loaded) takes one, so a progressive view's history
/// made before it is never taken for one made after (values are unique across renderers).
fn content_generation() -> u64 {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
    NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}
