//! The textures, meshes and sampler shared by the views of a scene, which each view binds by
//! name (`crate::bindings`). Its own file so that the bindings and the views both depend on it
//! and not on each other.

use crate::bricks::BrickedVolumes;
use crate::gpu::Gpu;
use crate::mesh_layer::{MeshInstance, pipelines::MeshPipelines};
use crate::textures::{TfTexture, VolumeTexture, linear_sampler};
use std::collections::HashMap;
use std::sync::Arc;

/// Textures shared by the views of a scene, by the uniform name the shaders bind them under
/// (`volume`, `volume_gm`, `tf`, `tf_gm`).
pub struct Resources {
    pub volumes: HashMap<String, Arc<VolumeTexture>>,
    /// Volumes kept in bricks (`crate::bricks`), by the same names.
    pub bricked: BrickedVolumes,
    pub tfs: HashMap<String, Arc<TfTexture>>,
    pub sampler: wgpu::Sampler,
    /// The scene's meshes, which views' mesh layers draw (by index).
    pub meshes: Vec<MeshInstance>,
    /// Counts changes of `meshes`' surfaces (a layer drawn from an older one is drawn again).
    pub mesh_generation: u64,
    /// Made with the first mesh.
    pub mesh_pipelines: Option<MeshPipelines>,
}

impl Resources {
    pub fn new(gpu: &Gpu) -> Resources {
        Resources {
            volumes: HashMap::new(),
            bricked: HashMap::new(),
            tfs: HashMap::new(),
            sampler: linear_sampler(gpu),
            meshes: Vec::new(),
            mesh_generation: 0,
            mesh_pipelines: None,
        }
    }
}
