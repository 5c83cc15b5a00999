//! A volume's samples as the file stores them: one vector per sample type, so a 16-bit CT
//! takes 2 bytes per voxel in memory, not 4. Values in data units are `stored * slope +
//! intercept` ([`Scaling`]); the GPU upload and the occupancy grid convert chunk by chunk.

use std::collections::TryReserveError;
use std::ops::Range;

use super::ScalarType;

/// Stored samples, x fastest, then y, then z. `f64` files are kept as `f32` (the GPU samples
/// half floats; `f32` keeps every value a half float can tell apart).
#[derive(Clone, PartialEq)]
pub enum Samples {
    /// Unsigned 8-bit samples.
    U8(Vec<u8>),
    /// Signed 8-bit samples.
    I8(Vec<i8>),
    /// Unsigned 16-bit samples.
    U16(Vec<u16>),
    /// Signed 16-bit samples.
    I16(Vec<i16>),
    /// Unsigned 32-bit samples.
    U32(Vec<u32>),
    /// Signed 32-bit samples.
    I32(Vec<i32>),
    /// Float samples (`f32`, or `f64` narrowed).
    F32(Vec<f32>),
}

/// Calls `$body` with `$v` bound to the vector inside a [`Samples`], whatever its type.
macro_rules! with_samples {
    ($samples:expr, $v:ident => $body:expr) => {
        match $samples {
            Samples::U8($v) => $body,
            Samples::I8($v) => $body,
            Samples::U16($v) => $body,
            Samples::I16($v) => $body,
            Samples::U32($v) => $body,
            Samples::I32($v) => $body,
            Samples::F32($v) => $body,
        }
    };
}

/// A sample type that converts to `f32` (exactly for 8- and 16-bit integers).
trait Sample: Copy {
    fn to_f32(self) -> f32;
}

macro_rules! sample {
    ($($t:ty),*) => { $(impl Sample for $t { fn to_f32(self) -> f32 { self as f32 } })* };
}
sample!(u8, i8, u16, i16, u32, i32, f32);

impl Samples {
    /// The number of samples.
    pub(crate) fn len(&self) -> usize {
        with_samples!(self, v => v.len())
    }

    /// Bytes per sample in memory.
    pub(crate) fn sample_bytes(&self) -> usize {
        match self {
            Samples::U8(_) | Samples::I8(_) => 1,
            Samples::U16(_) | Samples::I16(_) => 2,
            Samples::U32(_) | Samples::I32(_) | Samples::F32(_) => 4,
        }
    }

    /// Stored sample `i` as `f32`; `None` beyond the end.
    pub(crate) fn get(&self, i: usize) -> Option<f32> {
        with_samples!(self, v => v.get(i).map(|&s| s.to_f32()))
    }

    /// Calls `f` with each stored sample of `range` as `f32`, in order (one type dispatch per
    /// call, not per sample).
    pub(crate) fn for_each(&self, range: Range<usize>, mut f: impl FnMut(f32)) {
        with_samples!(self, v => v[range].iter().for_each(|&s| f(s.to_f32())))
    }

    #[cfg(test)]
    /// Every stored sample as `f32` (a full copy: for tests and small volumes).
    pub(crate) fn to_f32(&self) -> Vec<f32> {
        let mut out = Vec::with_capacity(self.len());
        self.for_each(0..self.len(), |s| out.push(s));
        out
    }

    /// Minimum and maximum of the finite stored samples, `None` when there are none.
    pub(crate) fn finite_range(&self) -> Option<[f32; 2]> {
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        self.for_each(0..self.len(), |s| {
            if s.is_finite() {
                lo = lo.min(s);
                hi = hi.max(s);
            }
        });
        (lo <= hi).then_some([lo, hi])
    }
}

/// Stored samples to data units: `value = stored * slope + intercept` (NIfTI `scl_slope` and
/// `scl_inter`, DICOM Rescale Slope and Intercept).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scaling {
    pub(crate) slope: f32,
    pub(crate) intercept: f32,
}

impl Scaling {
    /// Stored values are data values.
    pub const IDENTITY: Scaling = Scaling { slope: 1.0, intercept: 0.0 };

    /// The data value of a stored sample.
    pub(crate) fn apply(self, stored: f32) -> f32 {
        stored * self.slope + self.intercept
    }

    /// The data range of samples whose stored range is `stored` (`[0, 0]` without finite
    /// samples, or when scaling overflows).
    pub(crate) fn range(self, stored: Option<[f32; 2]>) -> [f32; 2] {
        match stored {
            Some([lo, hi]) => {
                let (a, b) = (self.apply(lo), self.apply(hi));
                if a.is_finite() && b.is_finite() { [a.min(b), a.max(b)] } else { [0.0, 0.0] }
            }
            None => [0.0, 0.0],
        }
    }
}

impl Samples {
    /// An empty vector for samples of `ty` with room for `reserve` of them (`f64` samples are
    /// kept as `f32`).
    pub(super) fn with_capacity(ty: ScalarType, reserve: usize) -> Result<Samples, TryReserveError> {
        fn vec<T>(reserve: usize) -> Result<Vec<T>, TryReserveError> {
            let mut v = Vec::new();
            v.try_reserve_exact(reserve)?;
            Ok(v)
        }
        Ok(match ty {
            ScalarType::U8 => Samples::U8(vec(reserve)?),
            ScalarType::I8 => Samples::I8(vec(reserve)?),
            ScalarType::U16 => Samples::U16(vec(reserve)?),
            ScalarType::I16 => Samples::I16(vec(reserve)?),
            ScalarType::U32 => Samples::U32(vec(reserve)?),
            ScalarType::I32 => Samples::I32(vec(reserve)?),
            ScalarType::F32 | ScalarType::F64 => Samples::F32(vec(reserve)?),
        })
    }

    /// An empty vector of `other`'s type with room for `reserve` samples.
    pub(super) fn empty_like(other: &Samples, reserve: usize) -> Result<Samples, TryReserveError> {
        let ty = match other {
            Samples::U8(_) => ScalarType::U8,
            Samples::I8(_) => ScalarType::I8,
            Samples::U16(_) => ScalarType::U16,
            Samples::I16(_) => ScalarType::I16,
            Samples::U32(_) => ScalarType::U32,
            Samples::I32(_) => ScalarType::I32,
            Samples::F32(_) => ScalarType::F32,
        };
        Samples::with_capacity(ty, reserve)
    }

    /// Removes every sample, keeping the capacity.
    pub(super) fn clear(&mut self) {
        with_samples!(self, v => v.clear())
    }

    /// Appends `other`'s samples; an error when they are of another type.
    pub(super) fn append(&mut self, other: &Samples) -> Result<(), String> {
        match (self, other) {
            (Samples::U8(a), Samples::U8(b)) => a.extend_from_slice(b),
            (Samples::I8(a), Samples::I8(b)) => a.extend_from_slice(b),
            (Samples::U16(a), Samples::U16(b)) => a.extend_from_slice(b),
            (Samples::I16(a), Samples::I16(b)) => a.extend_from_slice(b),
            (Samples::U32(a), Samples::U32(b)) => a.extend_from_slice(b),
            (Samples::I32(a), Samples::I32(b)) => a.extend_from_slice(b),
            (Samples::F32(a), Samples::F32(b)) => a.extend_from_slice(b),
            (a, b) => {
                return Err(format!(
                    "samples of {} bytes follow samples of {} bytes: the volume changes its sample type",
                    b.sample_bytes(),
                    a.sample_bytes()
                ));
            }
        }
        Ok(())
    }

    /// Makes room for `additional` more samples, doubling the capacity as a `Vec` would but
    /// never past `limit` samples in all, so a volume whose size is known ends with no slack.
    pub(super) fn reserve_up_to(&mut self, additional: usize, limit: usize) -> Result<(), TryReserveError> {
        with_samples!(self, v => {
            let needed = v.len() + additional;
            if needed > v.capacity() {
                let target = needed.max(v.capacity().saturating_mul(2).min(limit));
                v.try_reserve_exact(target - v.len())?;
            }
            Ok(())
        })
    }

    /// Appends the samples in `bytes` (a whole number of them, of type `ty`, in the given byte
    /// order). `self` must come from [`Samples::with_capacity`] with the same `ty`.
    pub(super) fn extend_decoded(&mut self, ty: ScalarType, bytes: &[u8], big_endian: bool) {
        macro_rules! convert {
            ($v:expr, $t:ty, $n:literal, $map:expr) => {{
                let (samples, _) = bytes.as_chunks::<$n>();
                if big_endian {
                    $v.extend(samples.iter().map(|&s| $map(<$t>::from_be_bytes(s))));
                } else {
                    $v.extend(samples.iter().map(|&s| $map(<$t>::from_le_bytes(s))));
                }
            }};
        }
        match (ty, self) {
            (ScalarType::U8, Samples::U8(v)) => v.extend_from_slice(bytes),
            (ScalarType::I8, Samples::I8(v)) => v.extend(bytes.iter().map(|&b| b as i8)),
            (ScalarType::U16, Samples::U16(v)) => convert!(v, u16, 2, |s| s),
            (ScalarType::I16, Samples::I16(v)) => convert!(v, i16, 2, |s| s),
            (ScalarType::U32, Samples::U32(v)) => convert!(v, u32, 4, |s| s),
            (ScalarType::I32, Samples::I32(v)) => convert!(v, i32, 4, |s| s),
            (ScalarType::F32, Samples::F32(v)) => convert!(v, f32, 4, |s| s),
            (ScalarType::F64, Samples::F32(v)) => convert!(v, f64, 8, |s| s as f32),
            (ty, samples) => unreachable!("{ty:?} samples decoded into a vector of {} bytes", samples.sample_bytes()),
        }
    }
}
