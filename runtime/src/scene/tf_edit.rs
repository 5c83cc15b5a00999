//! Transfer-function editing: each volume's curve, window and histogram as an editor shows
//! them, and an edited curve put in place by rewriting one table (no pipeline changes).

use super::SceneRenderer;
use crate::error::RuntimeError;
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
}
