//! Compile-time evaluation of built-in calls whose arguments are all constant, with WGSL's
//! shader-creation rules: a result that is infinite or NaN, and an argument outside the
//! function's domain (`sqrt(-1.0)`, `log(0.0)`, `clamp(x, 1.0, 0.0)`), are errors.
//!
//! WGSL evaluates such calls when it creates the shader, so a mistake here would reach the GPU
//! driver as a shader that does not compile. The built-ins that naga does not fold
//! (`mix`, `smoothstep`, `reflect`, `faceForward`, `transpose`, `determinant`) and the resource
//! built-ins give [`ConstError::NotConstant`]: they are evaluated at run time, and so are the
//! expressions around them.

use super::consteval::{ConstError, Eval, check_value, finite, make};
use crate::check::rules;
use crate::hir::{Builtin, ConstValue, ScalarValue};
use crate::types::Type;

use ScalarValue as V;

/// The value of `builtin(args)`, for arguments the checker has already accepted.
pub fn eval_builtin(builtin: Builtin, args: &[ConstValue]) -> Eval<ConstValue> {
    let types: Vec<Type> = args.iter().map(|a| a.ty).collect();
    let ty = rules::builtin_result(builtin, &types).map_err(|_| ConstError::NotConstant)?;
    if ty.is_error() {
        return Err(ConstError::NotConstant);
    }
    for arg in args {
        check_value(arg)?;
    }
    use Builtin::*;
    let components = match builtin {
        Abs | Sign | Floor | Ceil | Fract | Round | Trunc | Sqrt | InverseSqrt | Exp | Exp2 | Log | Log2 | Sin
        | Cos | Tan | Asin | Acos | Atan => componentwise(ty, args, |v| unary(builtin, v[0]))?,
        Min | Max | Pow | Atan2 | Step => componentwise(ty, args, |v| binary(builtin, v[0], v[1]))?,
        Clamp => componentwise(ty, args, |v| clamp(v[0], v[1], v[2]))?,
        Select => select(ty, args)?,
        Any | All => vec![any_all(builtin == All, args)?],
        Dot => vec![dot(args)?],
        Cross => cross(args)?,
        Length => vec![V::F32(length(floats(args.first())?.iter().copied())?)],
        Distance => {
            let (a, b) = (floats(args.first())?, floats(args.get(1))?);
            let diff: Eval<Vec<f32>> = a.iter().zip(&b).map(|(x, y)| finite(x - y)).collect();
            vec![V::F32(length(diff?.into_iter())?)]
        }
        Normalize => normalize(args)?,
        Mix | Smoothstep | Reflect | FaceForward | Transpose | Determinant | Sample | Lookup | Dims | Load => {
            return Err(ConstError::NotConstant);
        }
    };
    make(ty, components)
}

/// Applies `op` to the `i`-th component of every argument, for each component of `ty`; a
/// scalar argument stands for all components.
fn componentwise(
    ty: Type,
    args: &[ConstValue],
    op: impl Fn(&[ScalarValue]) -> Eval<ScalarValue>,
) -> Eval<Vec<ScalarValue>> {
    (0..ty.components())
        .map(|i| {
            let picked = args
                .iter()
                .map(|a| match a.components.as_slice() {
                    [single] => Ok(*single),
                    all => all.get(i).copied().ok_or(ConstError::NotConstant),
                })
                .collect::<Eval<Vec<_>>>()?;
            op(&picked)
        })
        .collect()
}

fn unary(builtin: Builtin, v: ScalarValue) -> Eval<ScalarValue> {
    use Builtin::*;
    let x = match v {
        V::F32(x) => x,
        V::I32(i) => {
            return match builtin {
                Abs => Ok(V::I32(i.wrapping_abs())),
                Sign => Ok(V::I32(i.signum())),
                _ => Err(ConstError::NotConstant),
            };
        }
        V::U32(u) if builtin == Abs => return Ok(V::U32(u)),
        _ => return Err(ConstError::NotConstant),
    };
    let domain = |ok: bool, why: &'static str| if ok { Ok(()) } else { Err(ConstError::Domain(why)) };
    let result = match builtin {
        Abs => x.abs(),
        Sign => {
            if x == 0.0 {
                0.0
            } else {
                x.signum()
            }
        }
        Floor => x.floor(),
        Ceil => x.ceil(),
        Fract => x - x.floor(),
        Round => x.round_ties_even(),
        Trunc => x.trunc(),
        Sqrt => {
            domain(x >= 0.0, "`sqrt` of a negative value")?;
            x.sqrt()
        }
        InverseSqrt => {
            domain(x > 0.0, "`inverseSqrt` of zero or a negative value")?;
            1.0 / x.sqrt()
        }
        Exp => x.exp(),
        Exp2 => x.exp2(),
        Log => {
            domain(x > 0.0, "`log` of zero or a negative value")?;
            x.ln()
        }
        Log2 => {
            domain(x > 0.0, "`log2` of zero or a negative value")?;
            x.log2()
        }
        Sin => x.sin(),
        Cos => x.cos(),
        Tan => x.tan(),
        Asin => {
            domain(x.abs() <= 1.0, "`asin` of a value outside -1 ..= 1")?;
            x.asin()
        }
        Acos => {
            domain(x.abs() <= 1.0, "`acos` of a value outside -1 ..= 1")?;
            x.acos()
        }
        Atan => x.atan(),
        _ => return Err(ConstError::NotConstant),
    };
    finite(result).map(V::F32)
}

fn binary(builtin: Builtin, a: ScalarValue, b: ScalarValue) -> Eval<ScalarValue> {
    use Builtin::*;
    match (builtin, a, b) {
        (Min, V::I32(x), V::I32(y)) => Ok(V::I32(x.min(y))),
        (Max, V::I32(x), V::I32(y)) => Ok(V::I32(x.max(y))),
        (Min, V::U32(x), V::U32(y)) => Ok(V::U32(x.min(y))),
        (Max, V::U32(x), V::U32(y)) => Ok(V::U32(x.max(y))),
        (_, V::F32(x), V::F32(y)) => {
            let result = match builtin {
                Min => x.min(y),
                Max => x.max(y),
                // `atan2(y, x)`: the first argument is the ordinate.
                Atan2 => x.atan2(y),
                Step => {
                    if x <= y {
                        1.0
                    } else {
                        0.0
                    }
                }
                Pow => pow(x, y)?,
                _ => return Err(ConstError::NotConstant),
            };
            finite(result).map(V::F32)
        }
        _ => Err(ConstError::NotConstant),
    }
}

/// WGSL's `pow`: undefined for a negative base, for `0^0`, `1^inf` and `inf^0`.
fn pow(base: f32, exponent: f32) -> Eval<f32> {
    let undefined = base < 0.0
        || (base == 1.0 && exponent.is_infinite())
        || (base.is_infinite() && exponent == 0.0)
        || (base == 0.0 && exponent == 0.0);
    if undefined {
        return Err(ConstError::Domain("`pow` of a negative base, or `pow(0.0, 0.0)`"));
    }
    finite(base.powf(exponent))
}

fn clamp(e: ScalarValue, low: ScalarValue, high: ScalarValue) -> Eval<ScalarValue> {
    const WHY: &str = "`clamp` with `low` greater than `high`";
    match (e, low, high) {
        (V::F32(e), V::F32(l), V::F32(h)) if l <= h => Ok(V::F32(e.clamp(l, h))),
        (V::I32(e), V::I32(l), V::I32(h)) if l <= h => Ok(V::I32(e.clamp(l, h))),
        (V::U32(e), V::U32(l), V::U32(h)) if l <= h => Ok(V::U32(e.clamp(l, h))),
        (V::F32(_), V::F32(l), V::F32(h)) if l.is_nan() || h.is_nan() => Err(ConstError::NotConstant),
        (V::F32(_), V::F32(_), V::F32(_)) | (V::I32(_), V::I32(_), V::I32(_)) | (V::U32(_), V::U32(_), V::U32(_)) => {
            Err(ConstError::Domain(WHY))
        }
        _ => Err(ConstError::NotConstant),
    }
}

/// `select(f, t, cond)`: `t` where `cond` holds, component by component for a vector condition.
fn select(ty: Type, args: &[ConstValue]) -> Eval<Vec<ScalarValue>> {
    let [f, t, cond] = args else { return Err(ConstError::NotConstant) };
    componentwise(ty, &[f.clone(), t.clone(), cond.clone()], |v| match v[2] {
        V::Bool(true) => Ok(v[1]),
        V::Bool(false) => Ok(v[0]),
        _ => Err(ConstError::NotConstant),
    })
}

fn any_all(all: bool, args: &[ConstValue]) -> Eval<ScalarValue> {
    let values = args.first().ok_or(ConstError::NotConstant)?;
    let bools = values
        .components
        .iter()
        .map(|c| match c {
            V::Bool(b) => Ok(*b),
            _ => Err(ConstError::NotConstant),
        })
        .collect::<Eval<Vec<bool>>>()?;
    Ok(V::Bool(if all { bools.iter().all(|&b| b) } else { bools.iter().any(|&b| b) }))
}

fn dot(args: &[ConstValue]) -> Eval<ScalarValue> {
    let [a, b] = args else { return Err(ConstError::NotConstant) };
    let pairs = a.components.iter().zip(&b.components);
    match a.components.first() {
        Some(V::F32(_)) => {
            let (x, y) = (floats(Some(a))?, floats(Some(b))?);
            let sum = x.iter().zip(&y).try_fold(0.0f32, |acc, (p, q)| finite(acc + finite(p * q)?))?;
            Ok(V::F32(sum))
        }
        Some(V::I32(_)) => pairs
            .map(|pair| match pair {
                (V::I32(p), V::I32(q)) => p.checked_mul(*q).ok_or(ConstError::Overflow),
                _ => Err(ConstError::NotConstant),
            })
            .try_fold(0i32, |acc, term| acc.checked_add(term?).ok_or(ConstError::Overflow))
            .map(V::I32),
        Some(V::U32(_)) => pairs
            .map(|pair| match pair {
                (V::U32(p), V::U32(q)) => p.checked_mul(*q).ok_or(ConstError::Overflow),
                _ => Err(ConstError::NotConstant),
            })
            .try_fold(0u32, |acc, term| acc.checked_add(term?).ok_or(ConstError::Overflow))
            .map(V::U32),
        _ => Err(ConstError::NotConstant),
    }
}

fn cross(args: &[ConstValue]) -> Eval<Vec<ScalarValue>> {
    let (a, b) = (floats(args.first())?, floats(args.get(1))?);
    let ([a0, a1, a2], [b0, b1, b2]) = (a.as_slice(), b.as_slice()) else { return Err(ConstError::NotConstant) };
    [a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0].into_iter().map(|x| finite(x).map(V::F32)).collect()
}

fn length(components: impl Iterator<Item = f32>) -> Eval<f32> {
    let sum = components.map(|x| x * x).sum::<f32>();
    finite(sum.sqrt())
}

fn normalize(args: &[ConstValue]) -> Eval<Vec<ScalarValue>> {
    let v = floats(args.first())?;
    let len = length(v.iter().copied())?;
    if len == 0.0 {
        return Err(ConstError::Domain("`normalize` of a zero vector"));
    }
    v.iter().map(|x| finite(x / len).map(V::F32)).collect()
}

fn floats(value: Option<&ConstValue>) -> Eval<Vec<f32>> {
    let value = value.ok_or(ConstError::NotConstant)?;
    value
        .components
        .iter()
        .map(|c| match c {
            V::F32(x) => Ok(*x),
            _ => Err(ConstError::NotConstant),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::Scalar;

    fn f(x: f32) -> ConstValue {
        ConstValue { ty: Type::F32, components: vec![V::F32(x)] }
    }

    fn i(x: i32) -> ConstValue {
        ConstValue { ty: Type::I32, components: vec![V::I32(x)] }
    }

    fn vf(xs: &[f32]) -> ConstValue {
        ConstValue { ty: Type::vec(xs.len() as u8, Scalar::F32), components: xs.iter().map(|&x| V::F32(x)).collect() }
    }

    #[test]
    fn domains_are_errors() {
        assert!(matches!(eval_builtin(Builtin::Sqrt, &[f(-1.0)]), Err(ConstError::Domain(_))));
        assert!(matches!(eval_builtin(Builtin::Log, &[f(0.0)]), Err(ConstError::Domain(_))));
        assert!(matches!(eval_builtin(Builtin::Log2, &[f(-2.0)]), Err(ConstError::Domain(_))));
        assert!(matches!(eval_builtin(Builtin::Asin, &[f(1.5)]), Err(ConstError::Domain(_))));
        assert!(matches!(eval_builtin(Builtin::InverseSqrt, &[f(0.0)]), Err(ConstError::Domain(_))));
        assert!(matches!(eval_builtin(Builtin::Pow, &[f(0.0), f(0.0)]), Err(ConstError::Domain(_))));
        assert!(matches!(eval_builtin(Builtin::Clamp, &[f(0.5), f(1.0), f(0.0)]), Err(ConstError::Domain(_))));
        assert!(matches!(eval_builtin(Builtin::Normalize, &[vf(&[0.0, 0.0])]), Err(ConstError::Domain(_))));
    }

    #[test]
    fn overflows_are_errors() {
        assert_eq!(eval_builtin(Builtin::Exp, &[f(100.0)]), Err(ConstError::Overflow));
        assert_eq!(eval_builtin(Builtin::Pow, &[f(10.0), f(50.0)]), Err(ConstError::Overflow));
        let big = ConstValue { ty: Type::vec(2, Scalar::I32), components: vec![V::I32(65536), V::I32(1)] };
        assert_eq!(eval_builtin(Builtin::Dot, &[big.clone(), big]), Err(ConstError::Overflow));
        assert_eq!(eval_builtin(Builtin::Length, &[vf(&[3e38, 3e38])]), Err(ConstError::Overflow));
    }

    #[test]
    fn values() {
        assert_eq!(eval_builtin(Builtin::Sqrt, &[f(4.0)]), Ok(f(2.0)));
        assert_eq!(eval_builtin(Builtin::Abs, &[i(i32::MIN)]), Ok(i(i32::MIN)));
        assert_eq!(eval_builtin(Builtin::Round, &[f(2.5)]), Ok(f(2.0)));
        assert_eq!(eval_builtin(Builtin::Fract, &[f(-0.25)]), Ok(f(0.75)));
        assert_eq!(eval_builtin(Builtin::Clamp, &[vf(&[2.0, -1.0]), f(0.0), f(1.0)]), Err(ConstError::NotConstant));
        assert_eq!(
            eval_builtin(Builtin::Clamp, &[vf(&[2.0, -1.0]), vf(&[0.0, 0.0]), vf(&[1.0, 1.0])]),
            Ok(vf(&[1.0, 0.0]))
        );
        assert_eq!(eval_builtin(Builtin::Length, &[vf(&[3.0, 4.0])]), Ok(f(5.0)));
        assert_eq!(
            eval_builtin(Builtin::Cross, &[vf(&[1.0, 0.0, 0.0]), vf(&[0.0, 1.0, 0.0])]),
            Ok(vf(&[0.0, 0.0, 1.0]))
        );
        assert_eq!(eval_builtin(Builtin::Normalize, &[vf(&[0.0, 2.0])]), Ok(vf(&[0.0, 1.0])));
        let t = ConstValue { ty: Type::BOOL, components: vec![V::Bool(true)] };
        assert_eq!(eval_builtin(Builtin::Select, &[f(1.0), f(2.0), t]), Ok(f(2.0)));
        assert_eq!(eval_builtin(Builtin::Mix, &[f(1.0), f(2.0), f(0.5)]), Err(ConstError::NotConstant));
    }
}
