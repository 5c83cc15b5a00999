//! Resources made from the primary volume and its transfer function for the views that read
//! them: the pre-integration tables of `std::preintegrate` (`tf_preint`) and
//! `std::preintegrate_lighting` (`tf_preint_back`) and the light volumes
//! of `std::shadow_volume` (`shadow_volume_NAME`), which shadow groups' meshes read too. Each is
//! made when some view binds it (or its shadow groups read it) and made
//! again when what it was made from changes (the transfer function, a light's direction,
//! `ref_step`); nothing is made for views that do not read it.

use super::{SceneRenderer, SceneView};
use crate::error::RuntimeError;
use crate::geometry;
use crate::light_volume::{LightKey, LightVolumePass, Primary};
use crate::textures::{TfTexture, VolumeTexture};
use crate::tf::{self, TransferFunction, preintegrate::PreintegratedTable};
use crate::uniforms::Value;
use crate::volume_layer::shadowed_lights;
use glam::Vec3;
use std::collections::HashMap;
use std::sync::Arc;
use vrsc::compose::uniform_check::{LIGHT_VOLUME_PREFIX, PREINTEGRATION_TABLE, PREINTEGRATION_WEIGHTS};
use vrsc::scene as vscene;

/// The binding of `std::preintegrate`'s table (the compiler's name: its build checks what the
/// runtime binds); `std::preintegrate_lighting`'s starts with it too.
const PREINTEGRATED: &str = PREINTEGRATION_TABLE;

/// How a pre-integration table is made from the (windowed) transfer function.
type MakeTable = fn(&TransferFunction) -> PreintegratedTable;

/// The pre-integration tables by binding, each with how it is made.
const PREINTEGRATION_TABLES: [(&str, MakeTable); 2] =
    [(PREINTEGRATION_TABLE, PreintegratedTable::new), (PREINTEGRATION_WEIGHTS, PreintegratedTable::segment_weights)];

/// What the derived resources were made from.
#[derive(Default)]
pub(super) struct Derived {
    /// Counts changes of the primary volume and its transfer function.
    pub generation: u64,
    pass: Option<LightVolumePass>,
    /// Each light volume's key, by binding name.
    lights: HashMap<String, LightKey>,
    /// A bricked primary volume's stand-in texture for the light volumes (a level that fits
    /// one texture, `bricked::standin`), with the generation it was made in.
    standin: Option<(u64, Arc<VolumeTexture>)>,
}

/// What `of` names for some view, each once.
fn each_once<'a, I: Iterator<Item = &'a str>>(views: &'a [SceneView], of: impl Fn(&'a SceneView) -> I) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for name in views.iter().flat_map(of) {
        if !out.iter().any(|n| n == name) {
            out.push(name.to_string());
        }
    }
    out
}

/// The names bound by some view that start with `prefix`, each once.
fn bound_with_prefix(views: &[SceneView], prefix: &str) -> Vec<String> {
    each_once(views, |view| {
        let bindings = view.renderer.shader().reflection.bindings.iter();
        bindings.map(|b| b.name.as_str()).filter(|name| name.starts_with(prefix))
    })
}

impl SceneRenderer {
    /// The table and the light volumes, as the views need them now.
    pub(super) fn update_derived(&mut self) -> Result<(), RuntimeError> {
        self.update_preintegration()?;
        self.update_light_volumes()
    }

    /// Makes the pre-integration tables of the primary volume's transfer function that some view
    /// binds, from the function as it is now; drops those none binds.
    fn update_preintegration(&mut self) -> Result<(), RuntimeError> {
        let bound = bound_with_prefix(&self.views, PREINTEGRATED);
        let Some(primary) = self.grids.first().filter(|_| !bound.is_empty()) else {
            for (name, _) in PREINTEGRATION_TABLES {
                self.resources.tfs.remove(name);
            }
            return Ok(());
        };
        let tf = match &primary.curve {
            Some(curve) => curve.table(),
            None => tf::preset(vscene::DEFAULT_TF)?,
        };
        let tf = tf.over_window(primary.window);
        for (name, make) in PREINTEGRATION_TABLES {
            if !bound.iter().any(|b| b == name) {
                self.resources.tfs.remove(name);
                continue;
            }
            let table = make(&tf);
            let bytes = table.to_rgba16f();
            match self.resources.tfs.get(name) {
                Some(texture) => texture.write_table(&self.gpu, &bytes),
                None => {
                    let size = [table.size, table.size];
                    let texture = TfTexture::upload_table(&self.gpu, name, size, &bytes)?;
                    self.resources.tfs.insert(name.into(), Arc::new(texture));
                }
            }
        }
        Ok(())
    }

    /// Writes the pre-integration tables that exist again for the primary's new transfer
    /// function `tf` (over its window).
    pub(super) fn rewrite_preintegration(&self, tf: &TransferFunction) {
        for (name, make) in PREINTEGRATION_TABLES {
            if let Some(texture) = self.resources.tfs.get(name) {
                texture.write_table(&self.gpu, &make(tf).to_rgba16f());
            }
        }
    }

    /// Computes the light volume of every light some view needs one of (reads, or its shadow
    /// groups' meshes do: `volume_layer::shadowed_lights`), whose light direction,
    /// `ref_step` or transfer function changed since it was computed (a few compares when
    /// nothing did: called before every frame).
    pub(super) fn update_light_volumes(&mut self) -> Result<(), RuntimeError> {
        for light in each_once(&self.views, |view| shadowed_lights(view.renderer.shader())) {
            let key = self.light_key(&light);
            let name = format!("{LIGHT_VOLUME_PREFIX}{light}");
            if self.derived.lights.get(&name) == Some(&key) && self.resources.volumes.contains_key(&name) {
                continue;
            }
            let texture = self.compute_light_volume(&key)?;
            self.resources.volumes.insert(name.clone(), Arc::new(texture));
            self.derived.lights.insert(name, key);
        }
        Ok(())
    }

    /// What light `light`'s volume depends on, from the first view that reads its direction.
    fn light_key(&self, light: &str) -> LightKey {
        let uniform = |name: &str| self.views.iter().find_map(|v| v.renderer.uniforms().get(name));
        let direction = match uniform(&format!("light_dir_{light}")) {
            Some(Value::Float(v)) if v.len() == 3 => Vec3::new(v[0], v[1], v[2]),
            _ => Vec3::ZERO,
        };
        let ref_step = match uniform("ref_step") {
            Some(Value::Float(v)) if v.len() == 1 => v[0],
            _ => 1.0,
        };
        LightKey { direction, ref_step, generation: self.derived.generation }
    }

    fn compute_light_volume(&mut self, key: &LightKey) -> Result<crate::textures::VolumeTexture, RuntimeError> {
        let missing = |what: &str| RuntimeError::Invalid(format!("a light volume needs the primary {what}"));
        let grid = self.grids.first().ok_or_else(|| missing("volume"))?;
        let volume_to_world = geometry::volume_to_world(grid.dims, grid.grid_to_world);
        if self.derived.pass.is_none() {
            self.derived.pass = Some(LightVolumePass::new(&self.gpu)?);
        }
        let texture = match self.resources.volumes.get("volume") {
            Some(texture) => texture.clone(),
            None => self.primary_standin()?,
        };
        let pass = self.derived.pass.as_ref().ok_or_else(|| missing("pass"))?;
        let primary = Primary {
            texture: &texture,
            tf: self.resources.tfs.get("tf").ok_or_else(|| missing("transfer function"))?,
            sampler: &self.resources.sampler,
            volume_to_world,
        };
        pass.compute(&self.gpu, &primary, key)
    }

    /// The texture that stands in for a bricked primary volume in the light volumes: its finest
    /// level of at most 256^3 voxels, normalized by its window; made once per generation.
    fn primary_standin(&mut self) -> Result<Arc<VolumeTexture>, RuntimeError> {
        let generation = self.derived.generation;
        if let Some((made, texture)) = &self.derived.standin
            && *made == generation
        {
            return Ok(texture.clone());
        }
        let missing = || RuntimeError::Invalid("a light volume needs the primary volume".into());
        let bricked = self.resources.bricked.get("volume").ok_or_else(missing)?;
        let window = self.grids.first().ok_or_else(missing)?.window;
        let volume = super::bricked::standin(bricked.source().as_ref())?;
        let texture = Arc::new(VolumeTexture::upload(&self.gpu, "primary stand-in", &volume, Some(window))?);
        self.derived.standin = Some((generation, texture.clone()));
        Ok(texture)
    }
}
