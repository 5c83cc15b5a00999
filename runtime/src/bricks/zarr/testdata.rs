//! A test and benchmark helper: sparse OME-Zarr stores written with `zarrs`.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde_json::{Value, json};
use zarrs::array::{Array, ArrayMetadata};
use zarrs::filesystem::FilesystemStore;

use super::super::BrickError;
use super::super::lazy_levels::{box_index, sub};

/// Writes an OME-Zarr (v0.4-style: Zarr v2 arrays, `multiscales` in `.zattrs`) group of uint16
/// arrays into `dir/test.ome.zarr` and returns its path: `levels` levels (level `l` has `dims`
/// halved `l` times, rounding up) of 1 mm voxels at level 0, chunks of `chunk` voxels (x, y, z)
/// compressed with zstd. A test and benchmark helper.
///
/// `value(level, voxel)` gives each voxel (rounded and clamped to uint16). It is only called for
/// the chunks `occupied(level, min, max)` says may hold non-zero data (`min` the chunk's first
/// voxel, `max` one past its last, both x, y, z); the others, and chunks that come out all zero,
/// are not written (the fill value 0), so a huge sparse volume is cheap to write. Chunks are
/// written by 2 threads.
pub fn write_test_zarr(
    dir: &Path,
    dims: [u32; 3],
    chunk: [u32; 3],
    levels: usize,
    value: impl Fn(usize, [u32; 3]) -> f32 + Sync,
    occupied: impl Fn(usize, [u32; 3], [u32; 3]) -> bool + Sync,
) -> Result<PathBuf, BrickError> {
    let fail = |m: String| BrickError(format!("write_test_zarr: {m}"));
    if dims.contains(&0) || chunk.contains(&0) || levels == 0 {
        return Err(fail(format!("dims {dims:?}, chunk {chunk:?} and {levels} levels must be non-zero")));
    }
    let root = dir.join("test.ome.zarr");
    std::fs::create_dir_all(&root).map_err(|e| fail(format!("{}: {e}", root.display())))?;
    let write =
        |name: &str, v: Value| std::fs::write(root.join(name), v.to_string()).map_err(|e| fail(format!("{name}: {e}")));
    write(".zgroup", json!({ "zarr_format": 2 }))?;
    let datasets: Vec<Value> = (0..levels)
        .map(|l| {
            let s = (1u64 << l) as f64;
            json!({ "path": l.to_string(), "coordinateTransformations": [{ "type": "scale", "scale": [s, s, s] }] })
        })
        .collect();
    let axes: Vec<Value> =
        ["z", "y", "x"].iter().map(|n| json!({ "name": n, "type": "space", "unit": "millimeter" })).collect();
    write(
        ".zattrs",
        json!({ "multiscales": [{ "version": "0.4", "name": "test", "axes": axes, "datasets": datasets }] }),
    )?;
    let store = Arc::new(FilesystemStore::new(&root).map_err(|e| fail(e.to_string()))?);
    for level in 0..levels {
        let ldims = dims.map(|n| n.div_ceil(1 << level.min(31)).max(1));
        write_test_level(&store, level, ldims, chunk, &value, &occupied).map_err(fail)?;
    }
    Ok(root)
}

/// One level of [`write_test_zarr`].
fn write_test_level(
    store: &Arc<FilesystemStore>,
    level: usize,
    dims: [u32; 3],
    chunk: [u32; 3],
    value: &(impl Fn(usize, [u32; 3]) -> f32 + Sync),
    occupied: &(impl Fn(usize, [u32; 3], [u32; 3]) -> bool + Sync),
) -> Result<(), String> {
    let metadata: ArrayMetadata = serde_json::from_value(json!({
        "zarr_format": 2,
        "shape": [dims[2], dims[1], dims[0]],
        "chunks": [chunk[2], chunk[1], chunk[0]],
        "dtype": "<u2",
        "compressor": { "id": "zstd", "level": 1 },
        "fill_value": 0,
        "order": "C",
        "filters": null,
        "dimension_separator": "/",
    }))
    .map_err(|e| e.to_string())?;
    let array = Array::new_with_metadata(store.clone(), &format!("/{level}"), metadata).map_err(|e| e.to_string())?;
    array.store_metadata().map_err(|e| e.to_string())?;
    let grid = [0, 1, 2].map(|a| dims[a].div_ceil(chunk[a]));
    let total = grid.iter().map(|&n| n as u64).product::<u64>();
    let write_one = |i: u64| -> Result<(), String> {
        let c = [i % grid[0] as u64, (i / grid[0] as u64) % grid[1] as u64, i / (grid[0] as u64 * grid[1] as u64)]
            .map(|v| v as u32);
        let min = [0, 1, 2].map(|a| c[a] * chunk[a]);
        let max = [0, 1, 2].map(|a| (min[a] + chunk[a]).min(dims[a]));
        if !occupied(level, min, max) {
            return Ok(());
        }
        // A v2 chunk is whole even past the array's end: the rest stays the fill value 0.
        let mut data = vec![0u16; chunk.iter().map(|&n| n as usize).product()];
        for z in min[2]..max[2] {
            for y in min[1]..max[1] {
                for x in min[0]..max[0] {
                    let v = value(level, [x, y, z]).round().clamp(0.0, u16::MAX as f32) as u16;
                    data[box_index(sub([x, y, z], min), chunk)] = v;
                }
            }
        }
        if data.iter().all(|&v| v == 0) {
            return Ok(());
        }
        let index = [c[2] as u64, c[1] as u64, c[0] as u64];
        array.store_chunk(&index, data).map_err(|e| format!("chunk {index:?} of level {level}: {e}"))
    };
    std::thread::scope(|s| {
        let workers: Vec<_> = (0..2u64)
            .map(|t| {
                let write_one = &write_one;
                s.spawn(move || (t..total).step_by(2).try_for_each(write_one))
            })
            .collect();
        workers.into_iter().try_for_each(|w| w.join().map_err(|_| "a writer thread panicked".to_string())?)
    })
}
