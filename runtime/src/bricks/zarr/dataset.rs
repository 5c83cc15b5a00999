//! One array of a store, read as a level of a volume: which array axes are x, y and z, the
//! index read on the others (the chosen time point and channel), and its values converted to
//! `f32` data units.

use std::ops::Range;
use std::sync::Arc;

use zarrs::array::data_type::{
    BoolDataType, Float16DataType, Float32DataType, Float64DataType, Int8DataType, Int16DataType, Int32DataType,
    Int64DataType, UInt8DataType, UInt16DataType, UInt32DataType, UInt64DataType,
};
use zarrs::array::{Array, ArrayError, ArraySubsetTraits, DataType, ElementOwned};
use zarrs::storage::ReadableStorageTraits;

use super::ome::{Axis, AxisKind};

/// A store that can be read, local or remote.
pub(super) type Store = dyn ReadableStorageTraits;

/// An array of the store as one level: its spatial axes and the index of every other axis.
pub(super) struct Dataset {
    pub(super) array: Array<Store>,
    /// Its path in the store, for messages (`/` for the root).
    pub(super) path: String,
    dtype: Dtype,
    /// The fill value in data units: what chunks left out of the store hold.
    pub(super) fill: f32,
    /// The array axis of x, y and z.
    space: [usize; 3],
    /// Per array axis, the index read on it when it is not spatial.
    fixed: Vec<Option<u64>>,
    /// Voxels along x, y, z.
    pub(super) dims: [u32; 3],
}

/// The data types read, each converted to `f32` (64-bit integers exactly up to 2^24, as label
/// images use them; `bool` as 0 and 1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Dtype {
    Bool,
    I8,
    I16,
    I32,
    I64,
    U8,
    U16,
    U32,
    U64,
    F16,
    F32,
    F64,
}

/// The index chosen on each non-spatial axis, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct Fixed {
    pub(super) time: Option<u64>,
    pub(super) channel: Option<u64>,
}

impl Dataset {
    /// Opens the array at `path` of `store` whose axes are `axes`, reading `fixed`'s time point
    /// and channel (index 0 of an axis of size 1 when none is chosen).
    pub(super) fn open(store: &Arc<Store>, path: &str, axes: &[Axis], fixed: Fixed) -> Result<Dataset, String> {
        let array = Array::open(store.clone(), &format!("/{path}")).map_err(|e| format!("array `{path}`: {e}"))?;
        Dataset::from_array(array, path, axes, fixed)
    }

    /// [`Dataset::open`] of an array already opened.
    pub(super) fn from_array(array: Array<Store>, path: &str, axes: &[Axis], fixed: Fixed) -> Result<Dataset, String> {
        let shown = if path.is_empty() { "/".to_string() } else { path.to_string() };
        let dtype = Dtype::of(array.data_type()).ok_or_else(|| {
            format!(
                "array `{shown}` has data type {}; volumes are bool, int8/16/32/64, uint8/16/32/64 or float16/32/64",
                array.data_type()
            )
        })?;
        let shape = array.shape().to_vec();
        if shape.len() != axes.len() {
            return Err(format!(
                "array `{shown}` has {} axes ({shape:?}) but the image names {}",
                shape.len(),
                axes.len()
            ));
        }
        let mut space = [usize::MAX; 3];
        let mut chosen = Vec::with_capacity(shape.len());
        for (i, (axis, &n)) in axes.iter().zip(&shape).enumerate() {
            chosen.push(match axis.kind {
                AxisKind::Space(s) => {
                    space[s] = i;
                    if n == 0 || n > u32::MAX as u64 {
                        return Err(format!("array `{shown}` has shape {shape:?}: an axis of {n} voxels"));
                    }
                    None
                }
                AxisKind::Time => Some(pick(&shown, "time point", "time", fixed.time, n)?),
                AxisKind::Channel => Some(pick(&shown, "channel", "channel", fixed.channel, n)?),
            });
        }
        let dims = [0, 1, 2].map(|a| shape[space[a]] as u32);
        let fill = dtype.decode(array.fill_value().as_ne_bytes());
        Ok(Dataset { array, path: shown, dtype, fill, space, fixed: chosen, dims })
    }

    /// The array axis of grid axis `a` (0 x, 1 y, 2 z).
    pub(super) fn space_axis(&self, a: usize) -> usize {
        self.space[a]
    }

    /// The array subset of the box `[lo, hi)` (x, y, z).
    pub(super) fn subset(&self, lo: [u32; 3], hi: [u32; 3]) -> Vec<Range<u64>> {
        let mut ranges: Vec<Range<u64>> = self.fixed.iter().map(|f| f.map_or(0..0, |i| i..i + 1)).collect();
        for a in 0..3 {
            ranges[self.space[a]] = lo[a] as u64..hi[a] as u64;
        }
        ranges
    }

    /// The box `[lo, hi)`'s values in data units, x fastest.
    pub(super) fn read_box(&self, lo: [u32; 3], hi: [u32; 3]) -> Result<Vec<f32>, ArrayError> {
        let values = self.read_f32(&self.subset(lo, hi))?;
        Ok(self.x_fastest(values, [0, 1, 2].map(|a| hi[a] - lo[a])))
    }

    /// The values of the subset `subset` (any box of the array) in data units, C order.
    pub(super) fn read_f32(&self, subset: &dyn ArraySubsetTraits) -> Result<Vec<f32>, ArrayError> {
        fn get<T: ElementOwned + Copy>(
            array: &Array<Store>,
            subset: &dyn ArraySubsetTraits,
            f: impl Fn(T) -> f32,
        ) -> Result<Vec<f32>, ArrayError> {
            Ok(array.retrieve_array_subset::<Vec<T>>(subset)?.into_iter().map(f).collect())
        }
        let a = &self.array;
        match self.dtype {
            Dtype::Bool => get(a, subset, |v: bool| v as u8 as f32),
            Dtype::I8 => get(a, subset, |v: i8| v as f32),
            Dtype::I16 => get(a, subset, |v: i16| v as f32),
            Dtype::I32 => get(a, subset, |v: i32| v as f32),
            Dtype::I64 => get(a, subset, |v: i64| v as f32),
            Dtype::U8 => get(a, subset, |v: u8| v as f32),
            Dtype::U16 => get(a, subset, |v: u16| v as f32),
            Dtype::U32 => get(a, subset, |v: u32| v as f32),
            Dtype::U64 => get(a, subset, |v: u64| v as f32),
            Dtype::F16 => get(a, subset, |v: half::f16| v.to_f32()),
            Dtype::F32 => get(a, subset, |v: f32| v),
            Dtype::F64 => get(a, subset, |v: f64| v as f32),
        }
    }

    /// C-order values of a box of `size` (x, y, z) reordered x fastest (already so when the
    /// array's last three axes are z, y, x).
    fn x_fastest(&self, values: Vec<f32>, size: [u32; 3]) -> Vec<f32> {
        let n = self.fixed.len();
        if self.space == [n - 1, n - 2, n - 3] {
            return values;
        }
        // C-order strides of the box over the array's axes (non-spatial axes have extent 1).
        let mut extent = vec![1u64; n];
        for a in 0..3 {
            extent[self.space[a]] = size[a] as u64;
        }
        let mut stride = vec![1u64; n];
        for i in (0..n.saturating_sub(1)).rev() {
            stride[i] = stride[i + 1] * extent[i + 1];
        }
        let [sx, sy, sz] = [0, 1, 2].map(|a| stride[self.space[a]] as usize);
        let mut out = Vec::with_capacity(values.len());
        for z in 0..size[2] as usize {
            for y in 0..size[1] as usize {
                out.extend((0..size[0] as usize).map(|x| values[x * sx + y * sy + z * sz]));
            }
        }
        out
    }
}

/// The index `chosen` of a non-spatial axis of `n` entries: 0 when it has one, an error that
/// says how to choose when it has more or the choice is out of range.
fn pick(array: &str, what: &str, key: &str, chosen: Option<u64>, n: u64) -> Result<u64, String> {
    match chosen {
        Some(i) if i < n => Ok(i),
        Some(i) => {
            Err(format!("array `{array}` has {n} {what}s (0 to {}); `{key} = {i}` is not one", n.saturating_sub(1)))
        }
        None if n == 1 => Ok(0),
        None => Err(format!(
            "array `{array}` has {n} {what}s: choose one with `{key} = 0` to `{key} = {}` in the [[volume]] table",
            n - 1
        )),
    }
}

impl Dtype {
    fn of(d: &DataType) -> Option<Dtype> {
        Some(if d.is::<BoolDataType>() {
            Dtype::Bool
        } else if d.is::<Int8DataType>() {
            Dtype::I8
        } else if d.is::<Int16DataType>() {
            Dtype::I16
        } else if d.is::<Int32DataType>() {
            Dtype::I32
        } else if d.is::<Int64DataType>() {
            Dtype::I64
        } else if d.is::<UInt8DataType>() {
            Dtype::U8
        } else if d.is::<UInt16DataType>() {
            Dtype::U16
        } else if d.is::<UInt32DataType>() {
            Dtype::U32
        } else if d.is::<UInt64DataType>() {
            Dtype::U64
        } else if d.is::<Float16DataType>() {
            Dtype::F16
        } else if d.is::<Float32DataType>() {
            Dtype::F32
        } else if d.is::<Float64DataType>() {
            Dtype::F64
        } else {
            return None;
        })
    }

    /// A value of this type from its native-endian bytes (0 when they do not fit).
    fn decode(self, b: &[u8]) -> f32 {
        fn arr<const N: usize>(b: &[u8]) -> Option<[u8; N]> {
            b.try_into().ok()
        }
        let v = match self {
            Dtype::Bool => arr::<1>(b).map(|a| (a[0] != 0) as u8 as f32),
            Dtype::I8 => arr::<1>(b).map(|a| i8::from_ne_bytes(a) as f32),
            Dtype::I16 => arr::<2>(b).map(|a| i16::from_ne_bytes(a) as f32),
            Dtype::I32 => arr::<4>(b).map(|a| i32::from_ne_bytes(a) as f32),
            Dtype::I64 => arr::<8>(b).map(|a| i64::from_ne_bytes(a) as f32),
            Dtype::U8 => arr::<1>(b).map(|a| a[0] as f32),
            Dtype::U16 => arr::<2>(b).map(|a| u16::from_ne_bytes(a) as f32),
            Dtype::U32 => arr::<4>(b).map(|a| u32::from_ne_bytes(a) as f32),
            Dtype::U64 => arr::<8>(b).map(|a| u64::from_ne_bytes(a) as f32),
            Dtype::F16 => arr::<2>(b).map(|a| half::f16::from_ne_bytes(a).to_f32()),
            Dtype::F32 => arr::<4>(b).map(f32::from_ne_bytes),
            Dtype::F64 => arr::<8>(b).map(|a| f64::from_ne_bytes(a) as f32),
        };
        v.unwrap_or(0.0)
    }
}
