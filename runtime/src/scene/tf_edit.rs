//! Transfer-function editing: each volume's curve, window and histogram as an editor shows
//! them, and an edited curve put in place by rewriting one table (no pipeline changes), for
//! every view or for one view of its own (a slice view's window/level).

use super::SceneRenderer;
use crate::error::RuntimeError;
use crate::textures::TfTexture;
use crate::tf::TfCurve;

/// A volume of the scene as a transfer-function editor sees it.
#[derive(Clone, Copy, Debug)]
pub struct VolumeStatus<'a> {
    /// Its name in the scene.
    pub name: &'a str,
    /// The data values its texture's [0, 1] stands for: the editor's value axis.
    pub window: [f32; 2],
    /// Voxel counts in equal bins over `window` (voxels outside it in the end bins).
    pub histogram: &'a [u64],
    /// Its transfer function's control points (`None` for a mask).
    pub curve: Option<&'a TfCurve>,
}

impl SceneRenderer {
    /// Every volume, primary first.
    pub fn volumes(&self) -> Vec<VolumeStatus<'_>> {
        self.grids
            .iter()
            .map(|g| VolumeStatus { name: &g.name, window: g.window, histogram: &g.histogram, curve: g.curve.as_ref() })
            .collect()
    }

    /// Gives volume `volume` the transfer function `curve` in every view: its table is
    /// rewritten (and, with empty-space skipping, the occupancy grid rebuilt), nothing else.
    pub fn set_tf_curve(&mut self, volume: &str, curve: TfCurve) -> Result<(), RuntimeError> {
        self.set_transfer_function(volume, &curve.table())?;
        if let Some(grid) = self.grids.iter_mut().find(|g| g.name == volume) {
            grid.curve = Some(curve);
        }
        Ok(())
    }

    /// Gives view `index` a transfer function of its own for volume `volume` (`None`: the
    /// volume's again). Only that view's 1D table changes; the volume's table, its
    /// pre-integration tables and the occupancy grid of empty-space skipping stay the volume's
    /// (a slice view, where window/level is set, skips nothing).
    pub fn set_view_tf_curve(
        &mut self,
        index: usize,
        volume: &str,
        curve: Option<&TfCurve>,
    ) -> Result<(), RuntimeError> {
        let grid = self
            .grids
            .iter()
            .find(|g| g.name == volume)
            .ok_or_else(|| RuntimeError::Invalid(format!("the scene has no volume `{volume}`")))?;
        let binding = super::tf_binding(volume, self.grids.first().is_some_and(|g| g.name == volume));
        let table = curve.map(|c| c.table().over_window(grid.window));
        let view = self.views.get_mut(index).ok_or_else(|| RuntimeError::Invalid(format!("no view {index}")))?;
        let own = view.renderer.own_tfs_mut();
        match (table, own.get(&binding)) {
            (None, _) => {
                own.remove(&binding);
            }
            (Some(table), Some(texture)) => texture.write(&self.gpu, &table),
            (Some(table), None) => {
                let texture = TfTexture::upload(&self.gpu, &table)?;
                own.insert(binding, texture);
            }
        }
        self.resources.content_changed();
        Ok(())
    }
}
