//! Tests of [`ZarrSource`]: stores written with `zarrs` in a temporary directory, read back a
//! brick at a time and compared with [`PyramidSource`] over the same values (which the pyramid
//! tests check against the voxels themselves).

use std::path::Path;
use std::sync::Arc;

use glam::{Mat4, Vec3};
use serde_json::{Value, json};
use zarrs::array::{Array, ArrayMetadata, Element};
use zarrs::filesystem::FilesystemStore;

use super::*;
use crate::bricks::BrickSource;
use crate::bricks::pyramid::PyramidSource;
use crate::volume::Volume;

/// Integer values that vary along every axis (so averages stay exact in `f32`).
fn value([x, y, z]: [u32; 3]) -> f32 {
    ((x * 7 + y * 3 + z * 11) % 200) as f32
}

/// Values of a grid of `dims` (x fastest).
fn grid(dims: [u32; 3], f: impl Fn([u32; 3]) -> f32) -> Vec<f32> {
    let mut out = Vec::new();
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                out.push(f([x, y, z]));
            }
        }
    }
    out
}

/// Writes an array at `path` of the store in `root` with the metadata `meta` and the values
/// `data` (C order).
fn write_array<T: Element>(root: &Path, path: &str, meta: Value, data: Vec<T>) {
    let store = Arc::new(FilesystemStore::new(root).unwrap());
    let metadata: ArrayMetadata = serde_json::from_value(meta).unwrap();
    let array = Array::new_with_metadata(store, path, metadata).unwrap();
    array.store_metadata().unwrap();
    array.store_array_subset(&array.subset_all(), data).unwrap();
}

/// Zarr v3 metadata: shape and chunks as z, y, x.
fn v3(shape: [u32; 3], chunks: [u32; 3], data_type: &str, codecs: Value) -> Value {
    json!({
        "zarr_format": 3,
        "node_type": "array",
        "shape": shape,
        "data_type": data_type,
        "chunk_grid": { "name": "regular", "configuration": { "chunk_shape": chunks } },
        "chunk_key_encoding": { "name": "default", "configuration": { "separator": "/" } },
        "fill_value": 0,
        "codecs": codecs,
    })
}

fn bytes_gzip() -> Value {
    json!([{ "name": "bytes", "configuration": { "endian": "little" } }, { "name": "gzip", "configuration": { "level": 1 } }])
}

/// Zarr v2 metadata: shape and chunks as z, y, x.
fn v2(shape: [u32; 3], chunks: [u32; 3], dtype: &str, compressor: Value) -> Value {
    json!({
        "zarr_format": 2, "shape": shape, "chunks": chunks, "dtype": dtype, "compressor": compressor,
        "fill_value": 0, "order": "C", "filters": null,
    })
}

fn zyx(d: [u32; 3]) -> [u32; 3] {
    [d[2], d[1], d[0]]
}

/// Every brick of every level of `source`: (level, brick).
fn every_brick(source: &dyn BrickSource) -> Vec<(usize, [u32; 3])> {
    let mut out = Vec::new();
    for (l, level) in source.levels().iter().enumerate() {
        for z in 0..level.bricks[2] {
            for y in 0..level.bricks[1] {
                out.extend((0..level.bricks[0]).map(|x| (l, [x, y, z])));
            }
        }
    }
    out
}

/// Every brick of every level of `source` equals the same brick of `expected`.
fn assert_same_bricks(source: &dyn BrickSource, expected: &dyn BrickSource) {
    assert_eq!(source.levels(), expected.levels());
    for (l, brick) in every_brick(source) {
        let (a, b) = (source.read(l, brick).unwrap(), expected.read(l, brick).unwrap());
        assert!(a == b, "level {l} brick {brick:?} differs");
    }
}

fn reference(dims: [u32; 3], f: impl Fn([u32; 3]) -> f32) -> PyramidSource {
    PyramidSource::from_volume(&Volume::new(dims, Mat4::IDENTITY, grid(dims, f)), Coarsening::Mean)
}

/// Label ids: runs of 0, 3, 7 and 70000 along every axis (odd lengths, so 2x2x2 blocks mix
/// them).
fn label([x, y, z]: [u32; 3]) -> f32 {
    [0.0, 3.0, 7.0, 70000.0][((x / 3 + y / 5 + z / 7) % 4) as usize]
}

/// Every voxel of every brick of every level of `source`, apron included.
fn every_voxel(source: &dyn BrickSource) -> Vec<f32> {
    let mut out = Vec::new();
    for (l, brick) in every_brick(source) {
        match source.read(l, brick).unwrap() {
            BrickData::Constant(v) => out.push(v),
            BrickData::Voxels(v) => out.extend(v),
        }
    }
    out
}

#[test]
fn label_ids_stay_ids_in_every_level() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("labels.zarr");
    let dims = [150, 90, 140];
    let data: Vec<u32> = grid(dims, label).into_iter().map(|v| v as u32).collect();
    write_array(&root, "/", v3(zyx(dims), [40, 30, 50], "uint32", bytes_gzip()), data);
    let ids = [0.0, 3.0, 7.0, 70000.0];
    let only_ids = |source: &dyn BrickSource| every_voxel(source).iter().all(|v| ids.contains(v));
    // Level 1 is read from the array two voxels per axis at a time, level 2 built from it.
    let source = ZarrSource::open(&root).unwrap().coarsened_by(Coarsening::First);
    assert_eq!(source.levels().len(), 3);
    assert!(only_ids(&source), "a coarse level of the store holds a voxel that is no label id");
    let volume = Volume::new(dims, Mat4::IDENTITY, grid(dims, label));
    let in_memory = PyramidSource::from_volume(&volume, Coarsening::First);
    assert!(only_ids(&in_memory), "a coarse level in memory holds a voxel that is no label id");
    // Both take the first voxel of each block: the same bricks.
    assert_same_bricks(&source, &in_memory);
    // Means would not do.
    assert!(!only_ids(&ZarrSource::open(&root).unwrap()));
    assert!(!only_ids(&PyramidSource::from_volume(&volume, Coarsening::Mean)));
}

#[test]
fn a_v3_array_with_unaligned_chunks_reads_back_with_built_levels() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("ct.zarr");
    let dims = [130, 50, 70];
    let data: Vec<u16> = grid(dims, value).into_iter().map(|v| v as u16).collect();
    write_array(&root, "/", v3(zyx(dims), [30, 20, 10], "uint16", bytes_gzip()), data);
    let source = ZarrSource::open(&root).unwrap();
    assert_eq!(source.stored_levels(), 1);
    assert_eq!(source.levels().len(), 3);
    assert_same_bricks(&source, &reference(dims, value));
    assert_eq!(source.grid_to_world(), Mat4::IDENTITY);
    assert!(source.warnings().is_empty());
    let [lo, hi] = source.range();
    assert!(lo >= 0.0 && hi <= 199.0 && lo < hi);
}

#[test]
fn a_v2_float_array_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("f.zarr");
    let dims = [65, 33, 7];
    let f = |p: [u32; 3]| value(p) * 0.5 - 20.0;
    let compressor = json!({ "id": "blosc", "cname": "lz4", "clevel": 5, "shuffle": 1, "blocksize": 0 });
    write_array(&root, "/", v2(zyx(dims), [4, 9, 64], "<f4", compressor), grid(dims, f));
    let source = ZarrSource::open(&root).unwrap();
    assert_same_bricks(&source, &reference(dims, f));
    // Stored voxel (APRON, APRON, APRON) is voxel (0, 0, 0); the aprons before it repeat it.
    let brick = source.read(0, [0, 0, 0]).unwrap();
    const A: u32 = crate::bricks::APRON;
    assert_eq!(brick.at([A, A, A]), f([0, 0, 0]));
    assert_eq!(brick.at([0, 0, 0]), f([0, 0, 0]));
    assert_eq!(brick.at([64 + A, 32 + A, 6 + A]), f([64, 32, 6]));
    assert_eq!(brick.at([64 + A + 1, 40, 60]), f([64, 32, 6]));
}

#[test]
fn other_integer_types_read_as_data_units() {
    let dir = tempfile::tempdir().unwrap();
    let dims = [5, 4, 3];
    let signed = |p: [u32; 3]| value(p) - 100.0;
    for (name, dtype) in [("i16", "<i2"), ("i32", "<i4"), ("f8", "<f8"), ("i1", "|i1")] {
        let root = dir.path().join(name);
        let meta = v2(zyx(dims), [3, 4, 5], dtype, Value::Null);
        let values = grid(dims, signed);
        match name {
            "i16" => write_array(&root, "/", meta, values.iter().map(|&v| v as i16).collect::<Vec<_>>()),
            "i32" => write_array(&root, "/", meta, values.iter().map(|&v| v as i32).collect::<Vec<_>>()),
            "f8" => write_array(&root, "/", meta, values.iter().map(|&v| v as f64).collect::<Vec<_>>()),
            _ => write_array(&root, "/", meta, values.iter().map(|&v| v as i8).collect::<Vec<_>>()),
        }
        let source = ZarrSource::open(&root).unwrap();
        assert_same_bricks(&source, &reference(dims, signed));
    }
}

/// An OME-Zarr v0.5 group (Zarr v3, sharded arrays) of two levels over a `dims` grid.
fn write_ome_v05(root: &Path, dims: [u32; 3], level1: [u32; 3]) {
    std::fs::create_dir_all(root).unwrap();
    let axes: Vec<Value> =
        ["z", "y", "x"].iter().map(|n| json!({ "name": n, "type": "space", "unit": "micrometer" })).collect();
    let datasets = json!([
        { "path": "s0", "coordinateTransformations": [
            { "type": "scale", "scale": [2.0, 0.5, 0.5] }, { "type": "translation", "translation": [10.0, 20.0, 30.0] }] },
        // Level 1's voxels are the box averages of level 0's 2 x 2 x 2: centred half a voxel on.
        { "path": "s1", "coordinateTransformations": [
            { "type": "scale", "scale": [4.0, 1.0, 1.0] }, { "type": "translation", "translation": [11.0, 20.25, 30.25] }] },
    ]);
    let group = json!({
        "zarr_format": 3, "node_type": "group",
        "attributes": { "ome": { "version": "0.5", "multiscales": [{ "axes": axes, "datasets": datasets }] } },
    });
    std::fs::write(root.join("zarr.json"), group.to_string()).unwrap();
    let sharded = json!([{ "name": "sharding_indexed", "configuration": {
        "chunk_shape": [8, 16, 16],
        "codecs": [{ "name": "bytes", "configuration": { "endian": "little" } }, { "name": "zstd", "configuration": { "level": 1, "checksum": false } }],
        "index_codecs": [{ "name": "bytes", "configuration": { "endian": "little" } }, { "name": "crc32c" }],
        "index_location": "end",
    } }]);
    let level0: Vec<u8> = grid(dims, value).into_iter().map(|v| v as u8).collect();
    write_array(root, "/s0", v3(zyx(dims), [16, 32, 48], "uint8", sharded), level0);
    // Level 1 holds its own values (not an average) so the test sees it is read, not built.
    let level1_values: Vec<u8> = grid(level1, |p| value(p) + 1.0).into_iter().map(|v| v as u8).collect();
    write_array(root, "/s1", v3(zyx(level1), [5, 5, 5], "uint8", bytes_gzip()), level1_values);
}

#[test]
fn an_ome_zarr_v05_group_gives_levels_and_spacing() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("cells.ome.zarr");
    let dims = [200, 90, 20];
    write_ome_v05(&root, dims, [100, 45, 10]);
    let source = ZarrSource::open(&root).unwrap();
    assert_eq!(source.stored_levels(), 2);
    assert_eq!(source.levels().len(), 3);
    let expected0 = reference(dims, value);
    let expected1 = reference([100, 45, 10], |p| value(p) + 1.0);
    assert_eq!(source.read(0, [3, 1, 0]).unwrap(), expected0.read(0, [3, 1, 0]).unwrap());
    assert_eq!(source.read(1, [1, 0, 0]).unwrap(), expected1.read(0, [1, 0, 0]).unwrap());
    // Level 2 is averaged from level 1: the pyramid of level 1's values one level up.
    assert_eq!(source.read(2, [0, 0, 0]).unwrap(), expected1.read(1, [0, 0, 0]).unwrap());
    // Micrometres to millimetres; x, y, z from the OME z, y, x order.
    let world = source.grid_to_world().transform_point3(Vec3::new(1.0, 1.0, 1.0));
    let expected = Vec3::new(0.030 + 0.0005, 0.020 + 0.0005, 0.010 + 0.002);
    assert!((world - expected).abs().max_element() < 1e-6, "{world}");
}

#[test]
fn a_level_halved_rounding_down_is_read_with_its_last_voxel_repeated() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("floor.ome.zarr");
    write_ome_v05(&root, [200, 90, 20], [100, 44, 10]);
    let source = ZarrSource::open(&root).unwrap();
    assert_eq!(source.stored_levels(), 2);
    assert_eq!(source.levels()[1].dims, [100, 45, 10]);
    // The level's last row (y = 44) is past the dataset's end: row 43 repeated.
    let expected = reference([100, 44, 10], |p| value(p) + 1.0);
    let (got, want) = (source.read(1, [0, 0, 0]).unwrap(), expected.read(0, [0, 0, 0]).unwrap());
    const A: u32 = crate::bricks::APRON;
    for (x, z) in [(1, 1), (20, 5), (64, 10)] {
        assert_eq!(got.at([x, 44 + A, z]), want.at([x, 43 + A, z]), "{x} {z}");
        assert_eq!(got.at([x, 43 + A, z]), want.at([x, 43 + A, z]), "{x} {z}");
    }
}

/// A test volume: a ball of value `200 + level` in a `dims` grid, empty elsewhere.
fn ball(level: usize, [x, y, z]: [u32; 3]) -> f32 {
    let d = (x as f32 - 20.0).powi(2) + (y as f32 - 20.0).powi(2) + (z as f32 - 20.0).powi(2);
    if d < 100.0 { 200.0 + level as f32 } else { 0.0 }
}

#[test]
fn write_test_zarr_writes_a_sparse_ome_zarr_v04_group() {
    let dir = tempfile::tempdir().unwrap();
    let dims = [300, 140, 70];
    let occupied = |level: usize, min: [u32; 3], _max: [u32; 3]| level > 0 || min.iter().all(|&v| v < 40);
    let root = write_test_zarr(dir.path(), dims, [32, 32, 32], 3, ball, occupied).unwrap();
    let source = ZarrSource::open(&root).unwrap();
    assert_eq!(source.stored_levels(), 3);
    assert_eq!(source.levels().len(), 4);
    let brick = source.read(0, [0, 0, 0]).unwrap();
    assert_eq!(brick.at([21, 21, 21]), 200.0);
    assert_eq!(brick.at([1, 1, 1]), 0.0);
    assert_eq!(source.read(1, [0, 0, 0]).unwrap().at([21, 21, 21]), 201.0);
    // Far from the ball every chunk was left out: constant without reading, and no warning
    // (chunks of the fill value are left out by zarr-python too: empty space, not lost data).
    assert_eq!(source.read(0, [4, 2, 1]).unwrap(), BrickData::Constant(0.0));
    assert!(source.warnings().is_empty(), "{:?}", source.warnings());
    assert_eq!(source.range(), [0.0, 202.0]);
    assert_eq!(source.grid_to_world(), Mat4::IDENTITY);
}

#[test]
fn missing_chunks_are_the_fill_value_without_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let dims = [128, 64, 64];
    // Only the chunks of x < 64 are written.
    let root = write_test_zarr(dir.path(), dims, [64, 64, 64], 1, |_, _| 7.0, |_, min, _| min[0] < 64).unwrap();
    let source = ZarrSource::open(&root).unwrap();
    // Brick 1's interior lies in the missing chunk, its apron in the written one.
    let brick = source.read(0, [1, 0, 0]).unwrap();
    assert_eq!(brick.at([0, 5, 5]), 7.0);
    assert_eq!(brick.at([5, 5, 5]), 0.0);
    assert!(source.warnings().is_empty(), "{:?}", source.warnings());
}

#[test]
fn a_shape_far_larger_than_the_chunks_on_disk_reads_as_holes() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("huge.zarr");
    write_array(&root, "/", v2([10, 10, 10], [10, 10, 10], "<u2", Value::Null), vec![5u16; 1000]);
    // The metadata now claims 4096 x 4096 x 1024 voxels (32 GiB), of which one chunk exists.
    let meta = v2([1024, 4096, 4096], [10, 10, 10], "<u2", Value::Null);
    std::fs::write(root.join(".zarray"), meta.to_string()).unwrap();
    let source = ZarrSource::open(&root).unwrap();
    assert_eq!(source.levels()[0].dims, [4096, 4096, 1024]);
    assert_eq!(source.read(0, [0, 0, 0]).unwrap().at([3, 3, 3]), 5.0);
    assert_eq!(source.read(0, [20, 20, 10]).unwrap(), BrickData::Constant(0.0));
    // The coarsest level is built from the level below, which is mostly holes: still cheap.
    let top = source.levels().len() - 1;
    assert!(matches!(source.read(top, [0, 0, 0]).unwrap(), BrickData::Voxels(_)));
    assert!(source.warnings().is_empty());
}

#[test]
fn absurd_shapes_and_types_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let huge = dir.path().join("huge.zarr");
    write_array(&huge, "/", v2([2, 2, 2], [2, 2, 2], "<u2", Value::Null), vec![0u16; 8]);
    let meta = v2([1 << 20, 1 << 20, 1 << 20], [64, 64, 64], "<u2", Value::Null);
    std::fs::write(huge.join(".zarray"), meta.to_string()).unwrap();
    let error = ZarrSource::open(&huge).err().unwrap().0;
    assert!(error.contains("bricks") && error.contains("16777216"), "{error}");

    let strings = dir.path().join("s.zarr");
    std::fs::create_dir_all(&strings).unwrap();
    let mut meta = v3([2, 2, 2], [2, 2, 2], "string", json!([{ "name": "vlen-utf8" }]));
    meta["fill_value"] = json!("");
    std::fs::write(strings.join("zarr.json"), meta.to_string()).unwrap();
    let error = ZarrSource::open(&strings).err().unwrap().0;
    assert!(error.starts_with("s.zarr: ") && error.contains("string"), "{error}");

    let zero = dir.path().join("zero.zarr");
    std::fs::create_dir_all(&zero).unwrap();
    std::fs::write(zero.join(".zarray"), v2([0, 4, 4], [1, 4, 4], "<u2", Value::Null).to_string()).unwrap();
    assert!(ZarrSource::open(&zero).is_err());
    std::fs::write(zero.join(".zarray"), v2([4, 4, 4], [0, 4, 4], "<u2", Value::Null).to_string()).unwrap();
    assert!(ZarrSource::open(&zero).is_err());
}

/// Sets the fill value of array metadata.
trait WithFill {
    fn with_fill(self, fill: impl Into<Value>) -> Value;
}

impl WithFill for Value {
    fn with_fill(mut self, fill: impl Into<Value>) -> Value {
        self["fill_value"] = fill.into();
        self
    }
}

#[test]
fn labels_in_64_bits_and_flags_read_as_numbers() {
    let dir = tempfile::tempdir().unwrap();
    let labels = dir.path().join("i64.zarr");
    let dims = [5, 4, 3];
    let ids = |p: [u32; 3]| if p[0] > 2 { 70000.0 } else { p[1] as f32 };
    write_array(
        &labels,
        "/",
        v3(zyx(dims), [3, 4, 5], "uint64", bytes_gzip()),
        grid(dims, ids).iter().map(|&v| v as u64).collect::<Vec<_>>(),
    );
    let source = ZarrSource::open(&labels).unwrap();
    assert_eq!(source.read(0, [0, 0, 0]).unwrap(), reference(dims, ids).read(0, [0, 0, 0]).unwrap());
    let flags = dir.path().join("bool.zarr");
    let on = |p: [u32; 3]| (p[0] == p[1]) as u8 as f32;
    let meta = v3(zyx(dims), [3, 4, 5], "bool", json!([{ "name": "bytes" }])).with_fill(false);
    write_array(&flags, "/", meta, grid(dims, on).iter().map(|&v| v > 0.0).collect::<Vec<_>>());
    let source = ZarrSource::open(&flags).unwrap();
    assert_eq!(source.read(0, [0, 0, 0]).unwrap(), reference(dims, on).read(0, [0, 0, 0]).unwrap());
    assert_eq!(source.range(), [0.0, 1.0]);
}

#[test]
fn a_channel_is_chosen_and_more_than_one_without_a_choice_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let one = dir.path().join("c1.zarr");
    let meta = |c: u32| {
        let mut m = v2([3, 4, 5], [3, 4, 5], "<u2", Value::Null);
        m["shape"] = json!([1, c, 3, 4, 5]);
        m["chunks"] = json!([1, 1, 3, 4, 5]);
        m
    };
    write_array(&one, "/", meta(1), grid([5, 4, 3], value).iter().map(|&v| v as u16).collect::<Vec<_>>());
    let source = ZarrSource::open(&one).unwrap();
    assert_eq!(source.levels()[0].dims, [5, 4, 3]);
    assert_eq!(source.read(0, [0, 0, 0]).unwrap(), reference([5, 4, 3], value).read(0, [0, 0, 0]).unwrap());
    let two = dir.path().join("c2.zarr");
    let values: Vec<u16> =
        (0..2).flat_map(|c| grid([5, 4, 3], move |p| value(p) + c as f32)).map(|v| v as u16).collect();
    write_array(&two, "/", meta(2), values);
    let error = ZarrSource::open(&two).err().unwrap().0;
    assert!(error.contains("has 2 channels: choose one with `channel = 0` to `channel = 1`"), "{error}");
    let second = ZarrSelection { channel: Some(Choice::Index(1)), ..ZarrSelection::default() };
    let location = StoreLocation::Path(two.clone());
    let source = ZarrSource::open_at(&location, &second, 1 << 20).unwrap();
    let expected = reference([5, 4, 3], |p| value(p) + 1.0);
    assert_eq!(source.read(0, [0, 0, 0]).unwrap(), expected.read(0, [0, 0, 0]).unwrap());
    let third = ZarrSelection { channel: Some(Choice::Index(2)), ..ZarrSelection::default() };
    let error = ZarrSource::open_at(&location, &third, 1 << 20).err().unwrap().0;
    assert!(error.contains("`channel = 2` is not one"), "{error}");
}

#[test]
fn a_corrupt_chunk_is_an_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path().join("broken.zarr");
    let dims = [40, 40, 40];
    let data: Vec<u16> = grid(dims, value).into_iter().map(|v| v as u16 + 1).collect();
    write_array(&root, "/", v3(zyx(dims), [20, 20, 20], "uint16", bytes_gzip()), data);
    std::fs::write(root.join("c/1/0/1"), b"not gzip at all").unwrap();
    let source = ZarrSource::open(&root).unwrap();
    let error = source.read(0, [0, 0, 0]).unwrap_err().0;
    assert!(error.contains("chunk `c/1/0/1`"), "{error}");
    // A chunk of the wrong size (valid gzip of too few bytes) is refused as well.
    let mut short = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    std::io::Write::write_all(&mut short, &[1u8; 10]).unwrap();
    std::fs::write(root.join("c/1/0/1"), short.finish().unwrap()).unwrap();
    let error = source.read(0, [0, 0, 0]).unwrap_err().0;
    assert!(error.contains("chunk `c/1/0/1`"), "{error}");
}

#[test]
fn broken_metadata_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nothing.zarr");
    assert!(ZarrSource::open(&missing).err().unwrap().0.contains("not a directory"));
    std::fs::create_dir_all(&missing).unwrap();
    assert!(ZarrSource::open(&missing).err().unwrap().0.contains("not a Zarr store"));
    std::fs::write(missing.join("zarr.json"), "{ not json").unwrap();
    assert!(ZarrSource::open(&missing).err().unwrap().0.contains("zarr.json: not valid JSON"));
    std::fs::write(missing.join("zarr.json"), r#"{"zarr_format": 3, "node_type": "group"}"#).unwrap();
    assert!(ZarrSource::open(&missing).err().unwrap().0.contains("multiscales"));
    std::fs::write(missing.join("zarr.json"), r#"{"zarr_format": 3, "node_type": "array", "shape": "x"}"#).unwrap();
    assert!(ZarrSource::open(&missing).err().unwrap().0.starts_with("nothing.zarr: array `/`"));
}

#[test]
fn a_source_is_send_and_sync() {
    fn check<T: Send + Sync>() {}
    check::<ZarrSource>();
    check::<PyramidSource>();
}

/// A 2048 x 2048 x 1024 sparse store (a ball of radius 100 voxels), as the residency tests use:
/// written, opened and its coarse levels read, with and without stored coarse levels. Prints
/// the times; run with `--ignored --nocapture`.
#[test]
#[ignore = "slow in debug builds: writes and reads a 2048 x 2048 x 1024 sparse store"]
fn a_large_sparse_store_is_cheap() {
    let dims = [2048, 2048, 1024];
    let centre = [1024.0f32, 1024.0, 512.0];
    let inside = move |level: usize, p: [u32; 3]| {
        let s = (1u32 << level) as f32;
        let d: f32 = (0..3).map(|a| (p[a] as f32 * s - centre[a]).powi(2)).sum();
        if d < 100.0 * 100.0 { 1000.0 } else { 0.0 }
    };
    let near = move |level: usize, min: [u32; 3], max: [u32; 3]| {
        let s = (1u32 << level) as f32;
        // The distance from the centre to the chunk's box, in level-0 voxels.
        let d: f32 = (0..3).map(|a| (centre[a] - centre[a].clamp(min[a] as f32 * s, max[a] as f32 * s)).powi(2)).sum();
        d < 101.0 * 101.0
    };
    for levels in [6, 1] {
        let dir = tempfile::tempdir().unwrap();
        let t = std::time::Instant::now();
        let root = write_test_zarr(dir.path(), dims, [64, 64, 64], levels, inside, near).unwrap();
        let written = t.elapsed();
        let t = std::time::Instant::now();
        let source = ZarrSource::open(&root).unwrap();
        let opened = t.elapsed();
        let t = std::time::Instant::now();
        let mut voxel_bricks = 0;
        for l in 3..source.levels().len() {
            let b = source.levels()[l].bricks;
            for z in 0..b[2] {
                for y in 0..b[1] {
                    for x in 0..b[0] {
                        voxel_bricks += matches!(source.read(l, [x, y, z]).unwrap(), BrickData::Voxels(_)) as u32;
                    }
                }
            }
        }
        println!(
            "{levels} stored levels: write {written:?}, open {opened:?}, levels 3.. read in {:?} ({voxel_bricks} bricks of voxels), range {:?}",
            t.elapsed(),
            source.range()
        );
        assert!(voxel_bricks > 0);
    }
}
