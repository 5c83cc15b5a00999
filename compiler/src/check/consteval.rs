//! Compile-time evaluation of constant expressions (defaults, ranges, `const` items), with
//! WGSL's semantics; overflow and division by zero are errors, never wrapped silently.
//!
//! Every function first asks [`rules`] for the result type, so the values it builds always have
//! the type the checker gave the expression. Ill-formed inputs (a type that the rules reject, an
//! `Error` type, a component list that does not fit its type) give `NotConstant`, never a panic.

use crate::ast::{BinaryOp, UnaryOp};
use crate::check::rules::{self, ConstructorKind};
use crate::hir::{ConstValue, ScalarValue};
use crate::types::{Scalar, Type};

/// Why a constant expression has no value.
#[derive(Clone, Debug, PartialEq)]
pub enum ConstError {
    /// The result does not fit its type (or is infinite or NaN).
    Overflow,
    DivisionByZero,
    /// A shift by at least the bit width of its operand.
    ShiftTooLarge,
    /// A built-in's argument outside its domain: the text says which (`sqrt` of a negative value).
    Domain(&'static str),
    /// The operation exists at run time but not in constant expressions.
    NotConstant,
}

pub(super) type Eval<T> = Result<T, ConstError>;

pub fn eval_binary(op: BinaryOp, lhs: &ConstValue, rhs: &ConstValue) -> Result<ConstValue, ConstError> {
    let ty = rules::binary_result(op, lhs.ty, rhs.ty).ok_or(ConstError::NotConstant)?;
    check_value(lhs)?;
    check_value(rhs)?;
    let is_matrix = |t: Type| matches!(t, Type::Matrix { .. });
    let is_linear = |t: Type| matches!(t, Type::Matrix { .. } | Type::Vector { .. });
    let linear_algebra =
        op == BinaryOp::Mul && is_linear(lhs.ty) && is_linear(rhs.ty) && (is_matrix(lhs.ty) || is_matrix(rhs.ty));
    let components = if linear_algebra { matrix_product(lhs, rhs)? } else { componentwise(op, lhs, rhs)? };
    make(ty, components)
}

pub fn eval_unary(op: UnaryOp, operand: &ConstValue) -> Result<ConstValue, ConstError> {
    let ty = rules::unary_result(op, operand.ty).ok_or(ConstError::NotConstant)?;
    check_value(operand)?;
    let components = operand.components.iter().map(|&v| scalar_unary(op, v)).collect::<Eval<Vec<_>>>()?;
    make(ty, components)
}

/// `T(args)` for an already checked constructor (construct or convert).
pub fn eval_constructor(target: Type, args: &[ConstValue]) -> Result<ConstValue, ConstError> {
    let types: Vec<Type> = args.iter().map(|a| a.ty).collect();
    let kind = rules::constructor(target, &types).map_err(|_| ConstError::NotConstant)?;
    for arg in args {
        check_value(arg)?;
    }
    let scalar = target.scalar().ok_or(ConstError::NotConstant)?;
    let count = target.components();
    let components = match (kind, args) {
        (_, []) => vec![zero(scalar); count],
        (ConstructorKind::Convert, [arg]) => {
            arg.components.iter().map(|&v| convert(v, scalar)).collect::<Eval<Vec<_>>>()?
        }
        (ConstructorKind::Construct, [arg]) => match arg.components.as_slice() {
            [v] => vec![*v; count],
            _ => return Err(ConstError::NotConstant),
        },
        (ConstructorKind::Construct, _) => args.iter().flat_map(|a| a.components.iter().copied()).collect(),
        (ConstructorKind::Convert, _) => return Err(ConstError::NotConstant),
    };
    make(target, components)
}

/// Component (or swizzle) access of a constant vector.
pub fn eval_swizzle(base: &ConstValue, components: &[u8]) -> Result<ConstValue, ConstError> {
    check_value(base)?;
    let Type::Vector { scalar, .. } = base.ty else {
        return Err(ConstError::NotConstant);
    };
    let ty = match components.len() {
        1 => Type::Scalar(scalar),
        n @ 2..=4 => Type::vec(n as u8, scalar),
        _ => return Err(ConstError::NotConstant),
    };
    let picked = components
        .iter()
        .map(|&i| base.components.get(i as usize).copied().ok_or(ConstError::NotConstant))
        .collect::<Eval<Vec<_>>>()?;
    make(ty, picked)
}

/// A value of `ty`, after checking that the components fit it.
pub(super) fn make(ty: Type, components: Vec<ScalarValue>) -> Eval<ConstValue> {
    let value = ConstValue { ty, components };
    check_value(&value)?;
    Ok(value)
}

/// Whether a value is well formed: one component of the element type per component of its type.
pub(super) fn check_value(value: &ConstValue) -> Eval<()> {
    let scalar = value.ty.scalar().ok_or(ConstError::NotConstant)?;
    let fits = value.components.len() == value.ty.components() && value.components.iter().all(|c| c.scalar() == scalar);
    if fits { Ok(()) } else { Err(ConstError::NotConstant) }
}

/// The zero value of a scalar type.
fn zero(scalar: Scalar) -> ScalarValue {
    match scalar {
        Scalar::Bool => ScalarValue::Bool(false),
        Scalar::I32 => ScalarValue::I32(0),
        Scalar::U32 => ScalarValue::U32(0),
        Scalar::F32 => ScalarValue::F32(0.0),
    }
}

/// Applies `op` component by component; a one-component operand (a scalar) is splatted.
fn componentwise(op: BinaryOp, lhs: &ConstValue, rhs: &ConstValue) -> Eval<Vec<ScalarValue>> {
    let (l, r) = (&lhs.components, &rhs.components);
    let n = l.len().max(r.len());
    let at = |values: &[ScalarValue], i: usize| match values {
        [single] => Ok(*single),
        _ => values.get(i).copied().ok_or(ConstError::NotConstant),
    };
    (0..n).map(|i| scalar_binary(op, at(l, i)?, at(r, i)?)).collect()
}

/// Columns and rows of a product operand; a vector is a column on the right, a row on the left.
fn product_shape(ty: Type, left: bool) -> Eval<(usize, usize)> {
    match ty {
        Type::Matrix { cols, rows } => Ok((cols as usize, rows as usize)),
        Type::Vector { size, .. } if left => Ok((size as usize, 1)),
        Type::Vector { size, .. } => Ok((1, size as usize)),
        _ => Err(ConstError::NotConstant),
    }
}

/// `A * B` for matrices and vectors, all column-major: `(k x r) * (c x k) = (c x r)`.
fn matrix_product(lhs: &ConstValue, rhs: &ConstValue) -> Eval<Vec<ScalarValue>> {
    let (k, rows) = product_shape(lhs.ty, true)?;
    let (cols, k2) = product_shape(rhs.ty, false)?;
    if k != k2 {
        return Err(ConstError::NotConstant);
    }
    let (a, b) = (floats(lhs)?, floats(rhs)?);
    let get = |v: &[f32], i: usize| v.get(i).copied().ok_or(ConstError::NotConstant);
    let mut out = Vec::with_capacity(cols * rows);
    for j in 0..cols {
        for i in 0..rows {
            let mut sum = 0.0f32;
            for l in 0..k {
                sum += get(&a, l * rows + i)? * get(&b, j * k + l)?;
            }
            out.push(ScalarValue::F32(finite(sum)?));
        }
    }
    Ok(out)
}

fn floats(value: &ConstValue) -> Eval<Vec<f32>> {
    let float = |v: &ScalarValue| match v {
        ScalarValue::F32(x) => Ok(*x),
        _ => Err(ConstError::NotConstant),
    };
    value.components.iter().map(float).collect()
}

/// An f32 result: infinity or NaN is an overflow (a shader-creation error in WGSL).
pub(super) fn finite(x: f32) -> Eval<f32> {
    if x.is_finite() { Ok(x) } else { Err(ConstError::Overflow) }
}

fn scalar_binary(op: BinaryOp, lhs: ScalarValue, rhs: ScalarValue) -> Eval<ScalarValue> {
    use ScalarValue as V;
    match (lhs, rhs) {
        (V::I32(a), V::U32(b)) => shift_i32(op, a, b),
        (V::U32(a), V::U32(b)) if matches!(op, BinaryOp::Shl | BinaryOp::Shr) => shift_u32(op, a, b),
        (V::I32(a), V::I32(b)) => int(op, a, b),
        (V::U32(a), V::U32(b)) => int(op, a, b),
        (V::F32(a), V::F32(b)) => float(op, a, b),
        (V::Bool(a), V::Bool(b)) => logical(op, a, b),
        _ => Err(ConstError::NotConstant),
    }
}

/// `< <= > >= == !=` on any ordered values; other operators are not comparisons.
fn compare<T: PartialOrd>(op: BinaryOp, a: T, b: T) -> Eval<ScalarValue> {
    use BinaryOp::*;
    let result = match op {
        Lt => a < b,
        Le => a <= b,
        Gt => a > b,
        Ge => a >= b,
        Eq => a == b,
        Ne => a != b,
        _ => return Err(ConstError::NotConstant),
    };
    Ok(ScalarValue::Bool(result))
}

/// A checked integer result: `None` is an overflow.
fn checked<T>(result: Option<T>, wrap: fn(T) -> ScalarValue) -> Eval<ScalarValue> {
    result.map(wrap).ok_or(ConstError::Overflow)
}

/// The integer types WGSL folds (`i32`, `u32`): the checked operations of each, and how its
/// value is stored.
trait ConstInt:
    Copy + PartialOrd + std::ops::BitAnd<Output = Self> + std::ops::BitOr<Output = Self> + std::ops::BitXor<Output = Self>
{
    const ZERO: Self;
    fn wrap(self) -> ScalarValue;
    fn checked_add(self, b: Self) -> Option<Self>;
    fn checked_sub(self, b: Self) -> Option<Self>;
    fn checked_mul(self, b: Self) -> Option<Self>;
    fn checked_div(self, b: Self) -> Option<Self>;
    fn checked_rem(self, b: Self) -> Option<Self>;
}

macro_rules! const_int {
    ($ty:ty, $variant:ident) => {
        impl ConstInt for $ty {
            const ZERO: Self = 0;
            fn wrap(self) -> ScalarValue {
                ScalarValue::$variant(self)
            }
            fn checked_add(self, b: Self) -> Option<Self> {
                <$ty>::checked_add(self, b)
            }
            fn checked_sub(self, b: Self) -> Option<Self> {
                <$ty>::checked_sub(self, b)
            }
            fn checked_mul(self, b: Self) -> Option<Self> {
                <$ty>::checked_mul(self, b)
            }
            fn checked_div(self, b: Self) -> Option<Self> {
                <$ty>::checked_div(self, b)
            }
            fn checked_rem(self, b: Self) -> Option<Self> {
                <$ty>::checked_rem(self, b)
            }
        }
    };
}

const_int!(i32, I32);
const_int!(u32, U32);

/// An integer operator on two values of one integer type (shifts aside).
fn int<T: ConstInt>(op: BinaryOp, a: T, b: T) -> Eval<ScalarValue> {
    use BinaryOp::*;
    let w = T::wrap;
    match op {
        Add => checked(a.checked_add(b), w),
        Sub => checked(a.checked_sub(b), w),
        Mul => checked(a.checked_mul(b), w),
        Div | Rem if b == T::ZERO => Err(ConstError::DivisionByZero),
        Div => checked(a.checked_div(b), w),
        Rem => checked(a.checked_rem(b), w),
        BitAnd => Ok(w(a & b)),
        BitOr => Ok(w(a | b)),
        BitXor => Ok(w(a ^ b)),
        _ => compare(op, a, b),
    }
}

/// WGSL's constant shifts: the amount must be below 32, and `<<` must not lose bits (for i32,
/// the bits shifted out and the sign bit of the result must all agree).
fn shift_i32(op: BinaryOp, a: i32, b: u32) -> Eval<ScalarValue> {
    let w = ScalarValue::I32;
    match op {
        _ if b >= 32 => Err(ConstError::ShiftTooLarge),
        BinaryOp::Shl => {
            let shifted = a.checked_shl(b).ok_or(ConstError::Overflow)?;
            checked(shifted.checked_shr(b).filter(|&back| back == a).map(|_| shifted), w)
        }
        BinaryOp::Shr => checked(a.checked_shr(b), w),
        _ => Err(ConstError::NotConstant),
    }
}

fn shift_u32(op: BinaryOp, a: u32, b: u32) -> Eval<ScalarValue> {
    let w = ScalarValue::U32;
    match op {
        _ if b >= 32 => Err(ConstError::ShiftTooLarge),
        BinaryOp::Shl => {
            let shifted = a.checked_shl(b).ok_or(ConstError::Overflow)?;
            checked(shifted.checked_shr(b).filter(|&back| back == a).map(|_| shifted), w)
        }
        BinaryOp::Shr => checked(a.checked_shr(b), w),
        _ => Err(ConstError::NotConstant),
    }
}

fn float(op: BinaryOp, a: f32, b: f32) -> Eval<ScalarValue> {
    use BinaryOp::*;
    let result = match op {
        Add => a + b,
        Sub => a - b,
        Mul => a * b,
        Div | Rem if b == 0.0 => return Err(ConstError::DivisionByZero),
        Div => a / b,
        // Rust's `%` truncates like WGSL's: `a - b * trunc(a / b)`.
        Rem => a % b,
        _ => return compare(op, a, b),
    };
    finite(result).map(ScalarValue::F32)
}

fn logical(op: BinaryOp, a: bool, b: bool) -> Eval<ScalarValue> {
    use BinaryOp::*;
    match op {
        And | BitAnd => Ok(ScalarValue::Bool(a && b)),
        Or | BitOr => Ok(ScalarValue::Bool(a || b)),
        Eq | Ne => compare(op, a, b),
        _ => Err(ConstError::NotConstant),
    }
}

fn scalar_unary(op: UnaryOp, value: ScalarValue) -> Eval<ScalarValue> {
    use ScalarValue as V;
    match (op, value) {
        (UnaryOp::Neg, V::I32(x)) => checked(x.checked_neg(), V::I32),
        (UnaryOp::Neg, V::F32(x)) => Ok(V::F32(-x)),
        (UnaryOp::Not, V::Bool(b)) => Ok(V::Bool(!b)),
        _ => Err(ConstError::NotConstant),
    }
}

/// WGSL's scalar value conversion: bool gives 0 or 1 and non-zero gives `true`; i32 and u32
/// reinterpret their bits (`u32(-1i)` is 4294967295); f32 to an integer truncates toward zero
/// and must fit (else overflow).
fn convert(value: ScalarValue, to: Scalar) -> Eval<ScalarValue> {
    use ScalarValue as V;
    Ok(match (value, to) {
        (v, s) if v.scalar() == s => v,
        (V::Bool(b), s) => from_bool(b, s),
        (v, Scalar::Bool) => V::Bool(v != zero(v.scalar())),
        (V::I32(x), Scalar::U32) => V::U32(x as u32),
        (V::U32(x), Scalar::I32) => V::I32(x as i32),
        (V::I32(x), Scalar::F32) => V::F32(x as f32),
        (V::U32(x), Scalar::F32) => V::F32(x as f32),
        (V::F32(x), Scalar::I32) => V::I32(float_to_int(x, -2147483648.0, 2147483648.0)? as i32),
        (V::F32(x), Scalar::U32) => V::U32(float_to_int(x, 0.0, 4294967296.0)? as u32),
        _ => return Err(ConstError::NotConstant),
    })
}

fn from_bool(b: bool, to: Scalar) -> ScalarValue {
    match to {
        Scalar::Bool => ScalarValue::Bool(b),
        Scalar::I32 => ScalarValue::I32(b as i32),
        Scalar::U32 => ScalarValue::U32(b as u32),
        Scalar::F32 => ScalarValue::F32(if b { 1.0 } else { 0.0 }),
    }
}

/// `x` truncated toward zero, if it lies in `[min, end)`.
fn float_to_int(x: f32, min: f64, end: f64) -> Eval<f64> {
    let t = f64::from(x).trunc();
    if t >= min && t < end { Ok(t) } else { Err(ConstError::Overflow) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ScalarValue::{Bool, F32, I32, U32};

    fn value(ty: &str, components: &[ScalarValue]) -> ConstValue {
        ConstValue { ty: Type::from_name(ty).unwrap_or(Type::Error), components: components.to_vec() }
    }

    fn f(x: f32) -> ConstValue {
        value("f32", &[F32(x)])
    }

    fn i(x: i32) -> ConstValue {
        value("i32", &[I32(x)])
    }

    fn u(x: u32) -> ConstValue {
        value("u32", &[U32(x)])
    }

    fn vf(xs: &[f32]) -> ConstValue {
        let components: Vec<ScalarValue> = xs.iter().map(|&x| F32(x)).collect();
        value(&format!("vec{}f", xs.len()), &components)
    }

    #[test]
    #[allow(clippy::approx_constant)] // `3.14` is the literal under test, not an approximation of π.
    fn float_arithmetic() {
        assert_eq!(eval_binary(BinaryOp::Mul, &f(2.0), &f(3.14)), Ok(f(2.0 * 3.14)));
        assert_eq!(eval_binary(BinaryOp::Mul, &f(3e38), &f(10.0)), Err(ConstError::Overflow));
        assert_eq!(eval_binary(BinaryOp::Div, &f(1.0), &f(0.0)), Err(ConstError::DivisionByZero));
        assert_eq!(eval_binary(BinaryOp::Rem, &f(-7.5), &f(2.0)), Ok(f(-1.5)));
        assert_eq!(eval_binary(BinaryOp::Lt, &f(1.0), &f(2.0)), Ok(value("bool", &[Bool(true)])));
    }

    #[test]
    fn integer_arithmetic() {
        assert_eq!(eval_binary(BinaryOp::Add, &i(i32::MAX), &i(1)), Err(ConstError::Overflow));
        assert_eq!(eval_binary(BinaryOp::Div, &i(1), &i(0)), Err(ConstError::DivisionByZero));
        assert_eq!(eval_binary(BinaryOp::Rem, &u(1), &u(0)), Err(ConstError::DivisionByZero));
        assert_eq!(eval_binary(BinaryOp::Div, &i(i32::MIN), &i(-1)), Err(ConstError::Overflow));
        assert_eq!(eval_binary(BinaryOp::Sub, &u(0), &u(1)), Err(ConstError::Overflow));
        assert_eq!(eval_binary(BinaryOp::Rem, &i(-7), &i(2)), Ok(i(-1)));
        assert_eq!(eval_binary(BinaryOp::BitXor, &u(6), &u(3)), Ok(u(5)));
        assert_eq!(eval_binary(BinaryOp::Add, &i(1), &f(1.0)), Err(ConstError::NotConstant));
    }

    #[test]
    fn shifts() {
        assert_eq!(eval_binary(BinaryOp::Shl, &i(1), &u(4)), Ok(i(16)));
        assert_eq!(eval_binary(BinaryOp::Shr, &i(-16), &u(2)), Ok(i(-4)));
        assert_eq!(eval_binary(BinaryOp::Shr, &u(0x8000_0000), &u(31)), Ok(u(1)));
        assert_eq!(eval_binary(BinaryOp::Shl, &u(1), &u(32)), Err(ConstError::ShiftTooLarge));
        assert_eq!(eval_binary(BinaryOp::Shr, &i(1), &u(40)), Err(ConstError::ShiftTooLarge));
        assert_eq!(eval_binary(BinaryOp::Shl, &u(3), &u(31)), Err(ConstError::Overflow));
        assert_eq!(eval_binary(BinaryOp::Shl, &i(1), &u(31)), Err(ConstError::Overflow));
        assert_eq!(eval_binary(BinaryOp::Shl, &i(-1), &u(31)), Ok(i(i32::MIN)));
    }

    #[test]
    fn vectors_and_logic() {
        assert_eq!(eval_unary(UnaryOp::Neg, &vf(&[0.5, 0.5, 0.5])), Ok(vf(&[-0.5, -0.5, -0.5])));
        assert_eq!(eval_binary(BinaryOp::Mul, &f(2.0), &vf(&[1.0, 2.0])), Ok(vf(&[2.0, 4.0])));
        assert_eq!(eval_binary(BinaryOp::Sub, &vf(&[1.0, 2.0]), &f(1.0)), Ok(vf(&[0.0, 1.0])));
        let cmp = eval_binary(BinaryOp::Eq, &vf(&[1.0, 2.0]), &vf(&[1.0, 3.0]));
        assert_eq!(cmp.map(|v| v.components), Ok(vec![Bool(true), Bool(false)]));
        let t = value("bool", &[Bool(true)]);
        let fl = value("bool", &[Bool(false)]);
        assert_eq!(eval_binary(BinaryOp::And, &t, &fl), Ok(fl.clone()));
        assert_eq!(eval_binary(BinaryOp::BitOr, &t, &fl), Ok(t.clone()));
        assert_eq!(eval_unary(UnaryOp::Not, &t), Ok(fl));
        assert_eq!(eval_unary(UnaryOp::Neg, &i(i32::MIN)), Err(ConstError::Overflow));
        assert_eq!(eval_unary(UnaryOp::Neg, &u(1)), Err(ConstError::NotConstant));
    }

    #[test]
    fn matrices() {
        // Columns (1, 2) and (3, 4): [[1, 3], [2, 4]] in row notation.
        let m = value("mat2x2f", &[F32(1.0), F32(2.0), F32(3.0), F32(4.0)]);
        assert_eq!(eval_binary(BinaryOp::Mul, &m, &vf(&[1.0, 1.0])), Ok(vf(&[4.0, 6.0])));
        assert_eq!(eval_binary(BinaryOp::Mul, &vf(&[1.0, 1.0]), &m), Ok(vf(&[3.0, 7.0])));
        let squared = value("mat2x2f", &[F32(7.0), F32(10.0), F32(15.0), F32(22.0)]);
        assert_eq!(eval_binary(BinaryOp::Mul, &m, &m), Ok(squared));
        let doubled = value("mat2x2f", &[F32(2.0), F32(4.0), F32(6.0), F32(8.0)]);
        assert_eq!(eval_binary(BinaryOp::Add, &m, &m), Ok(doubled.clone()));
        assert_eq!(eval_binary(BinaryOp::Mul, &f(2.0), &m), Ok(doubled));
        // mat2x3f (two columns of 3) * mat3x2f gives mat3x3f.
        let a = value("mat2x3f", &[F32(1.0), F32(0.0), F32(0.0), F32(0.0), F32(1.0), F32(0.0)]);
        let b = value("mat3x2f", &[F32(1.0), F32(2.0), F32(3.0), F32(4.0), F32(5.0), F32(6.0)]);
        let product = eval_binary(BinaryOp::Mul, &a, &b);
        let want = [1.0, 2.0, 0.0, 3.0, 4.0, 0.0, 5.0, 6.0, 0.0].map(F32);
        assert_eq!(product, Ok(value("mat3x3f", &want)));
    }

    #[test]
    fn constructors() {
        let v3 = vf(&[1.0, 2.0, 3.0]);
        assert_eq!(eval_constructor(Type::vec(4, Scalar::F32), &[v3.clone(), f(4.0)]), Ok(vf(&[1.0, 2.0, 3.0, 4.0])));
        assert_eq!(eval_constructor(Type::vec(3, Scalar::F32), &[f(0.5)]), Ok(vf(&[0.5, 0.5, 0.5])));
        assert_eq!(eval_constructor(Type::vec(2, Scalar::F32), &[]), Ok(vf(&[0.0, 0.0])));
        assert_eq!(eval_constructor(Type::vec(4, Scalar::F32), &[vf(&[1.0, 2.0])]), Err(ConstError::NotConstant));
        let mat = eval_constructor(Type::Matrix { cols: 3, rows: 3 }, &[v3.clone(), v3.clone(), v3.clone()]);
        let scalars: Vec<ConstValue> = (0..9).map(|k| f([1.0, 2.0, 3.0][k % 3])).collect();
        assert_eq!(mat, eval_constructor(Type::Matrix { cols: 3, rows: 3 }, &scalars));
        assert_eq!(mat.map(|m| m.components.len()), Ok(9));
    }

    #[test]
    fn conversions() {
        assert_eq!(eval_constructor(Type::U32, &[i(-1)]), Ok(u(4294967295)));
        assert_eq!(eval_constructor(Type::I32, &[u(u32::MAX)]), Ok(i(-1)));
        assert_eq!(eval_constructor(Type::I32, &[f(-2.7)]), Ok(i(-2)));
        assert_eq!(eval_constructor(Type::U32, &[f(-0.5)]), Ok(u(0)));
        assert_eq!(eval_constructor(Type::U32, &[f(-1.0)]), Err(ConstError::Overflow));
        assert_eq!(eval_constructor(Type::I32, &[f(3e9)]), Err(ConstError::Overflow));
        assert_eq!(eval_constructor(Type::F32, &[value("bool", &[Bool(true)])]), Ok(f(1.0)));
        assert_eq!(eval_constructor(Type::BOOL, &[f(-0.0)]), Ok(value("bool", &[Bool(false)])));
        assert_eq!(eval_constructor(Type::BOOL, &[i(7)]), Ok(value("bool", &[Bool(true)])));
        let v3i = value("vec3i", &[I32(1), I32(-2), I32(3)]);
        assert_eq!(eval_constructor(Type::vec(3, Scalar::F32), &[v3i]), Ok(vf(&[1.0, -2.0, 3.0])));
    }

    #[test]
    fn swizzles() {
        let v = vf(&[1.0, 2.0, 3.0, 4.0]);
        assert_eq!(eval_swizzle(&v, &[2]), Ok(f(3.0)));
        assert_eq!(eval_swizzle(&v, &[3, 0]), Ok(vf(&[4.0, 1.0])));
        assert_eq!(eval_swizzle(&vf(&[1.0, 2.0]), &[2]), Err(ConstError::NotConstant));
        assert_eq!(eval_swizzle(&v, &[]), Err(ConstError::NotConstant));
        assert_eq!(eval_swizzle(&f(1.0), &[0]), Err(ConstError::NotConstant));
    }

    #[test]
    fn malformed_values_never_panic() {
        let short = value("vec3f", &[F32(1.0)]);
        assert_eq!(eval_binary(BinaryOp::Add, &short, &short), Err(ConstError::NotConstant));
        assert_eq!(eval_unary(UnaryOp::Neg, &short), Err(ConstError::NotConstant));
        assert_eq!(eval_swizzle(&short, &[1]), Err(ConstError::NotConstant));
        let error = ConstValue { ty: Type::Error, components: vec![] };
        assert_eq!(eval_binary(BinaryOp::Add, &error, &f(1.0)), Err(ConstError::NotConstant));
        assert_eq!(eval_constructor(Type::F32, &[error]), Err(ConstError::NotConstant));
        assert_eq!(eval_constructor(Type::Volume, &[]), Err(ConstError::NotConstant));
    }
}
