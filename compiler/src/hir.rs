//! The checked program: names resolved, every expression typed, constants folded.
//!
//! The checker builds it from the AST; lowering (and the composer) consume it. Pipeline-function
//! names, state fields and uniforms keep their `$` here: a template is instantiated by the
//! composer, which substitutes names, never by re-checking.
//!
//! A function body never names another function by its [`LibFnId`]: a call names one of the
//! calling function's call sites (`calls`), and only that table holds ids. Bodies are therefore
//! the same in every program that holds the function (the standard library's are checked once
//! per process and shared, [`Arc`]), and renumbering a program's functions touches only the
//! tables.

use std::sync::Arc;

use crate::ast::{AssignOp, BinaryOp, PlacementKind, UnaryOp};
use crate::source::Span;
use crate::types::{Scalar, Type};

/// Index into [`Program::lib_fns`].
pub type LibFnId = usize;
/// Index into a function's `locals`.
pub type LocalId = usize;

/// Every checked function of the modules given to the checker (and of the modules they import).
#[derive(Clone, Debug, Default)]
pub struct Program {
    /// In dependency order: a function's callees come before it.
    pub lib_fns: Vec<LibFn>,
    /// In module order, then source order.
    pub pipelines: Vec<PipelineFn>,
    /// `remove` items, in the same order.
    pub removes: Vec<Remove>,
}

/// A checked library function.
#[derive(Clone, Debug)]
pub struct LibFn {
    pub name: String,
    /// Index of the module (in the loader's graph) that defines it.
    pub module: usize,
    pub doc: Option<String>,
    pub params: Vec<Param>,
    /// `Type::Void` when it returns nothing.
    pub ret: Type,
    pub locals: Vec<Local>,
    pub body: Arc<Block>,
    /// The callee of each call site of the body ([`ExprKind::CallLib::site`]).
    pub calls: Vec<LibFnId>,
    pub span: Span,
}

/// A parameter of a checked library function.
#[derive(Clone, Debug)]
pub struct Param {
    pub name: String,
    pub ty: Type,
    pub span: Span,
}

/// A `let`, `var` or `for` variable.
#[derive(Clone, Debug)]
pub struct Local {
    pub name: String,
    pub ty: Type,
    /// `var` and loop variables are mutable... loop variables only by the loop itself.
    pub mutable: bool,
    pub span: Span,
}

/// A checked pipeline function: its placement, declarations and body.
#[derive(Clone, Debug)]
pub struct PipelineFn {
    pub name: String,
    /// Index of the module (in the loader's graph) that defines it.
    pub module: usize,
    pub doc: Option<String>,
    pub placement: Placement,
    /// The declared state fields, in declaration order; `Expr::State` indexes this list.
    pub state: Vec<StateDecl>,
    /// The declared uniforms, in declaration order; `Expr::Uniform` indexes this list.
    pub uniforms: Vec<UniformDecl>,
    /// The declared library functions.
    pub uses: Vec<LibFnId>,
    pub locals: Vec<Local>,
    pub body: Arc<Block>,
    /// The callee of each call site of the body ([`ExprKind::CallLib::site`]).
    pub calls: Vec<LibFnId>,
    pub span: Span,
}

/// A checked step path.
#[derive(Clone, Debug)]
pub struct Placement {
    pub kind: PlacementKind,
    /// A known step, resolved from a group name for `before`/`after` (see `steps`).
    pub step: crate::steps::Step,
    /// The substep name, possibly with `$`.
    pub substep: Option<String>,
    pub when_active: bool,
    pub span: Span,
}

/// A checked `remove`: the step, and the substep for `remove S[x]`.
#[derive(Clone, Debug)]
pub struct Remove {
    /// Index of the module (in the loader's graph) that holds it.
    pub module: usize,
    pub step: crate::steps::Step,
    pub substep: Option<String>,
    pub when_active: bool,
    pub span: Span,
}

/// A `state` declaration of a pipeline function, with whether the body reads and writes it.
#[derive(Clone, Debug)]
pub struct StateDecl {
    pub name: String,
    pub ty: Type,
    /// `@ray`: lives for the whole ray instead of one sample.
    pub ray: bool,
    pub default: Option<ConstValue>,
    /// Whether the body reads / writes `state.name`.
    pub read: bool,
    pub written: bool,
    /// The first `state.name` of the body that reads it (for data-flow warnings).
    pub first_read: Option<Span>,
    pub span: Span,
}

/// A `uniform` declaration of a pipeline function.
#[derive(Clone, Debug)]
pub struct UniformDecl {
    pub name: String,
    pub ty: Type,
    pub default: Option<ConstValue>,
    /// Slider bounds, per component for vectors and matrices.
    pub range: Option<(ConstValue, ConstValue)>,
    pub doc: Option<String>,
    pub span: Span,
}

/// A compile-time value: a scalar, vector or matrix, components flattened column-major.
#[derive(Clone, Debug, PartialEq)]
pub struct ConstValue {
    pub ty: Type,
    pub components: Vec<ScalarValue>,
}

impl ConstValue {
    /// The value as an index, when it is one integer (`i32` or `u32`); whether it is in range is
    /// the caller's question.
    pub fn as_index(&self) -> Option<i64> {
        match self.components.as_slice() {
            [ScalarValue::I32(i)] => Some(i64::from(*i)),
            [ScalarValue::U32(u)] => Some(i64::from(*u)),
            _ => None,
        }
    }
}

/// One component of a constant value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ScalarValue {
    Bool(bool),
    I32(i32),
    U32(u32),
    F32(f32),
}

impl ScalarValue {
    /// The scalar type of the component.
    pub fn scalar(self) -> Scalar {
        match self {
            ScalarValue::Bool(_) => Scalar::Bool,
            ScalarValue::I32(_) => Scalar::I32,
            ScalarValue::U32(_) => Scalar::U32,
            ScalarValue::F32(_) => Scalar::F32,
        }
    }
}

/// Checked statements.
#[derive(Clone, Debug)]
pub struct Block {
    pub stmts: Vec<Stmt>,
    pub span: Span,
}

/// A checked statement with its span.
#[derive(Clone, Debug)]
pub struct Stmt {
    pub kind: StmtKind,
    pub span: Span,
}

/// What a checked statement is.
#[derive(Clone, Debug)]
pub enum StmtKind {
    /// Initialises a local; `None` for `var x: T;` (zero value).
    Let {
        local: LocalId,
        value: Option<Expr>,
    },
    /// `place op= value`; for compound ops the value has the place's type (or a scalar that
    /// WGSL's vector-scalar rules accept).
    Assign {
        place: Place,
        op: AssignOp,
        value: Expr,
    },
    If {
        cond: Expr,
        then: Block,
        otherwise: Option<Block>,
    },
    /// `for var in start .. end` over i32 or u32.
    For {
        var: LocalId,
        start: Expr,
        end: Expr,
        body: Block,
    },
    Break,
    Continue,
    Return(Option<Expr>),
    /// A call whose value (if any) is dropped.
    Expr(Expr),
    Block(Block),
}

/// Something assignable: a local or state field, then component/swizzle/index accesses.
#[derive(Clone, Debug)]
pub struct Place {
    pub root: PlaceRoot,
    pub path: Vec<Access>,
    /// The type of the whole place.
    pub ty: Type,
    pub span: Span,
}

/// What an assignment or a reference starts from: a local or a state field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlaceRoot {
    Local(LocalId),
    /// Index into the pipeline function's `state`.
    State(usize),
}

/// One step of an access path below a place root.
#[derive(Clone, Debug)]
pub enum Access {
    /// `.x`, `.g`: one vector component.
    Component(u8),
    /// `.xz`: several distinct components, in order (only at the end of a path).
    Swizzle(Vec<u8>),
    /// `[i]` of a vector or matrix column.
    Index(Box<Expr>),
}

/// A checked expression with its type and span.
#[derive(Clone, Debug)]
pub struct Expr {
    pub kind: ExprKind,
    pub ty: Type,
    pub span: Span,
}

impl Expr {
    /// The value of a constant integer index, if the expression is one.
    pub fn const_index(&self) -> Option<i64> {
        match &self.kind {
            ExprKind::Const(v) => v.as_index(),
            _ => None,
        }
    }
}

/// What a checked expression is.
#[derive(Clone, Debug)]
pub enum ExprKind {
    /// A literal or a folded constant.
    Const(ConstValue),
    Local(LocalId),
    Param(usize),
    /// Index into the pipeline function's `uniforms`.
    Uniform(usize),
    /// Index into the pipeline function's `state`.
    State(usize),
    CallLib {
        /// Index into the calling function's `calls`.
        site: usize,
        args: Vec<Expr>,
    },
    CallBuiltin {
        builtin: Builtin,
        args: Vec<Expr>,
    },
    /// A type constructor: `vec4f(rgb, 1.0)`, `vec3f(0.5)` (splat), `mat3x3f(...)`, `f32()`.
    Construct {
        args: Vec<Expr>,
    },
    /// `f32(i)`, `vec3f(v_int)`: a conversion of a value of the same shape.
    Convert {
        arg: Box<Expr>,
    },
    Unary {
        op: UnaryOp,
        operand: Box<Expr>,
    },
    /// Operand types follow WGSL: equal types, or vector-scalar mixing, or matrix products.
    Binary {
        op: BinaryOp,
        lhs: Box<Expr>,
        rhs: Box<Expr>,
    },
    /// `.xyz`: components of a vector (one component gives a scalar).
    Swizzle {
        base: Box<Expr>,
        components: Vec<u8>,
    },
    /// `v[i]`, `m[i]`.
    Index {
        base: Box<Expr>,
        index: Box<Expr>,
    },
}

/// Declares [`Builtin`] from one table of variants, VRS names and argument counts, so that the
/// enum, its list, its names and its arities cannot drift apart.
macro_rules! builtins {
    ($($(#[$doc:meta])* $variant:ident = $name:literal / $arity:literal,)*) => {
        /// The built-in functions of section 3 of the language spec.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        pub enum Builtin {
            $($(#[$doc])* $variant,)*
        }

        impl Builtin {
            /// Every built-in with the name it is called by in VRS, in declaration order.
            pub const ALL: &[(Builtin, &str)] = &[$((Builtin::$variant, $name),)*];

            /// The name the built-in is called by in VRS.
            pub fn name(self) -> &'static str {
                match self {
                    $(Builtin::$variant => $name,)*
                }
            }

            /// How many arguments the built-in takes (WGSL's overloads of each have one count).
            pub fn arity(self) -> usize {
                match self {
                    $(Builtin::$variant => $arity,)*
                }
            }

            /// The built-in called `name`, if any.
            pub fn by_name(name: &str) -> Option<Builtin> {
                match name {
                    $($name => Some(Builtin::$variant),)*
                    _ => None,
                }
            }
        }
    };
}

builtins! {
    Abs = "abs" / 1,
    Min = "min" / 2,
    Max = "max" / 2,
    Clamp = "clamp" / 3,
    Mix = "mix" / 3,
    Step = "step" / 2,
    Smoothstep = "smoothstep" / 3,
    Sign = "sign" / 1,
    Floor = "floor" / 1,
    Ceil = "ceil" / 1,
    Fract = "fract" / 1,
    Round = "round" / 1,
    Trunc = "trunc" / 1,
    Sqrt = "sqrt" / 1,
    InverseSqrt = "inverseSqrt" / 1,
    Pow = "pow" / 2,
    Exp = "exp" / 1,
    Exp2 = "exp2" / 1,
    Log = "log" / 1,
    Log2 = "log2" / 1,
    Sin = "sin" / 1,
    Cos = "cos" / 1,
    Tan = "tan" / 1,
    Asin = "asin" / 1,
    Acos = "acos" / 1,
    Atan = "atan" / 1,
    Atan2 = "atan2" / 2,
    Dot = "dot" / 2,
    Cross = "cross" / 2,
    Length = "length" / 1,
    Distance = "distance" / 2,
    Normalize = "normalize" / 1,
    Reflect = "reflect" / 2,
    FaceForward = "faceForward" / 3,
    Transpose = "transpose" / 1,
    Determinant = "determinant" / 1,
    Select = "select" / 3,
    Any = "any" / 1,
    All = "all" / 1,
    /// `sample(v: volume, p: vec3f) -> f32`
    Sample = "sample" / 2,
    /// `lookup(t: tf, x: f32) -> vec4f`
    Lookup = "lookup" / 2,
    /// `dims(v: volume) -> vec3u`
    Dims = "dims" / 1,
}

/// A constant as VRS source: `1.0`, `vec3f(0.5, 0.5, 0.5)`.
pub fn show_const(v: &ConstValue) -> String {
    let parts: Vec<String> = v
        .components
        .iter()
        .map(|c| match c {
            ScalarValue::Bool(b) => b.to_string(),
            ScalarValue::I32(i) => i.to_string(),
            ScalarValue::U32(u) => format!("{u}u"),
            ScalarValue::F32(x) => format!("{x:?}"),
        })
        .collect();
    match v.ty {
        Type::Scalar(_) => parts.join(", "),
        _ => format!("{}({})", v.ty, parts.join(", ")),
    }
}
