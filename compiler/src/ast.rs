//! The syntax tree the parser builds. Every node has a [`Span`]; nothing here is resolved or
//! typed yet (see `hir` for the checked form).

use crate::lexer::IntSuffix;
use crate::source::{FileId, Span};

/// A name as written, possibly with the template wildcard `$`.
#[derive(Clone, Debug, PartialEq)]
pub struct Ident {
    pub name: String,
    pub span: Span,
}

impl Ident {
    /// Whether the name holds the template wildcard `$`.
    pub fn is_template(&self) -> bool {
        self.name.contains('$')
    }
}

/// One parsed file.
#[derive(Clone, Debug)]
pub struct Module {
    pub file: FileId,
    pub items: Vec<Item>,
}

/// A top-level item with its doc comment and span.
#[derive(Clone, Debug)]
pub struct Item {
    pub kind: ItemKind,
    /// The `///` doc comment before the item, lines joined with `\n`.
    pub doc: Option<String>,
    pub span: Span,
}

/// What an item is.
#[derive(Clone, Debug)]
pub enum ItemKind {
    Import(Import),
    Const(ConstItem),
    LibFn(LibFn),
    Pipeline(PipelineFn),
    Remove(Remove),
}

/// The target of an `import`: a file path or a standard module.
#[derive(Clone, Debug)]
pub enum Import {
    /// `import "path.vrs";`, relative to the importing file. The string is unescaped.
    Path { path: String, span: Span },
    /// `import std::shading;`
    Std { path: Vec<Ident> },
}

/// `const NAME: T = e;` (the type may be left out).
#[derive(Clone, Debug)]
pub struct ConstItem {
    pub name: Ident,
    pub ty: Option<TypeExpr>,
    pub value: Expr,
}

/// `lib fn NAME(params) -> T { body }` (no return type means it returns nothing).
#[derive(Clone, Debug)]
pub struct LibFn {
    pub name: Ident,
    pub params: Vec<Param>,
    pub ret: Option<TypeExpr>,
    pub body: Block,
}

/// A parameter of a library function: `NAME: TYPE`.
#[derive(Clone, Debug)]
pub struct Param {
    pub name: Ident,
    pub ty: TypeExpr,
    pub span: Span,
}

/// `pipeline NAME PLACEMENT { decls stmts }`
#[derive(Clone, Debug)]
pub struct PipelineFn {
    pub name: Ident,
    pub placement: Placement,
    pub decls: Vec<Decl>,
    pub body: Block,
}

/// `remove STEP_PATH;` (optionally `when active`).
#[derive(Clone, Debug)]
pub struct Remove {
    pub target: StepPath,
    pub when_active: bool,
}

/// How a pipeline function is placed relative to its target step or substep.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PlacementKind {
    In,
    Before,
    After,
    Replace,
}

/// `in|before|after|replace STEP[SUBSTEP] [when active]`.
#[derive(Clone, Debug)]
pub struct Placement {
    pub kind: PlacementKind,
    pub target: StepPath,
    pub when_active: bool,
    pub span: Span,
}

/// `shading.lights`, `classification.additional[gm]`, `compositing`.
#[derive(Clone, Debug)]
pub struct StepPath {
    /// Dotted segments: `["shading", "lights"]`, or one for a group name alone.
    pub segments: Vec<Ident>,
    /// The substep in brackets.
    pub substep: Option<Ident>,
    pub span: Span,
}

impl StepPath {
    /// The dotted step name without the substep: `shading.lights`.
    pub fn step_name(&self) -> String {
        self.segments.iter().map(|s| s.name.as_str()).collect::<Vec<_>>().join(".")
    }
}

/// A declaration in the header of a pipeline function.
#[derive(Clone, Debug)]
pub struct Decl {
    pub kind: DeclKind,
    pub doc: Option<String>,
    pub span: Span,
}

/// A declaration at the top of a pipeline function's body.
#[derive(Clone, Debug)]
pub enum DeclKind {
    /// `@ray? state NAME: T (= e)?;`
    State { ray: bool, name: Ident, ty: TypeExpr, default: Option<Expr> },
    /// `uniform NAME: T (= e)? (in lo .. hi)?;`
    Uniform { name: Ident, ty: TypeExpr, default: Option<Expr>, range: Option<(Expr, Expr)> },
    /// `use a, b;`
    Use { names: Vec<Ident> },
}

/// A type as written: `f32`, `vec3f`, `vec3<f32>`, `mat4x4<f32>`, `volume`.
#[derive(Clone, Debug, PartialEq)]
pub struct TypeExpr {
    pub name: Ident,
    /// Template arguments: `vec3<f32>` has one.
    pub args: Vec<TypeExpr>,
    pub span: Span,
}

/// `{ statements }`.
#[derive(Clone, Debug)]
pub struct Block {
    pub stmts: Vec<Stmt>,
    pub span: Span,
}

/// A statement with its span.
#[derive(Clone, Debug)]
pub struct Stmt {
    pub kind: StmtKind,
    pub span: Span,
}

/// `=`, `+=`, `-=`, `*=`, `/=`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum AssignOp {
    Assign,
    Add,
    Sub,
    Mul,
    Div,
}

/// What a statement is.
#[derive(Clone, Debug)]
pub enum StmtKind {
    /// `let x (: T)? = e;` (`mutable: false`) or `var x (: T)? (= e)?;` (`mutable: true`).
    Let {
        mutable: bool,
        name: Ident,
        ty: Option<TypeExpr>,
        value: Option<Expr>,
    },
    /// `target op e;`: the target is a name, `state.f`, or field/swizzle/index access on one.
    Assign {
        target: Expr,
        op: AssignOp,
        value: Expr,
    },
    /// `if c { } else ...`: an `else if` is an `else` block holding one `If` statement.
    If {
        cond: Expr,
        then: Block,
        otherwise: Option<Block>,
    },
    /// `for i in a .. b { }`
    For {
        var: Ident,
        start: Expr,
        end: Expr,
        body: Block,
    },
    Break,
    Continue,
    Return(Option<Expr>),
    /// A call as a statement.
    Expr(Expr),
    /// A nested `{ }` block.
    Block(Block),
    /// What the parser skipped while recovering from a reported error.
    Error,
}

/// `-` and `!`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum UnaryOp {
    Neg,
    Not,
}

/// The binary operators, WGSL's.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BinaryOp {
    Mul,
    Div,
    Rem,
    Add,
    Sub,
    Shl,
    Shr,
    Lt,
    Le,
    Gt,
    Ge,
    Eq,
    Ne,
    BitAnd,
    BitXor,
    BitOr,
    And,
    Or,
}

impl BinaryOp {
    /// The operator as written.
    pub fn symbol(self) -> &'static str {
        use BinaryOp::*;
        match self {
            Mul => "*",
            Div => "/",
            Rem => "%",
            Add => "+",
            Sub => "-",
            Shl => "<<",
            Shr => ">>",
            Lt => "<",
            Le => "<=",
            Gt => ">",
            Ge => ">=",
            Eq => "==",
            Ne => "!=",
            BitAnd => "&",
            BitXor => "^",
            BitOr => "|",
            And => "&&",
            Or => "||",
        }
    }
}

/// An expression with its span.
#[derive(Clone, Debug)]
pub struct Expr {
    pub kind: ExprKind,
    pub span: Span,
}

/// What an expression is.
#[derive(Clone, Debug)]
pub enum ExprKind {
    /// An integer literal; `None` when it did not fit in 64 bits (already reported).
    Int {
        value: Option<u64>,
        suffix: Option<IntSuffix>,
    },
    /// A float literal; `suffixed` for an explicit `f`.
    Float {
        value: f64,
        suffixed: bool,
    },
    Bool(bool),
    /// A plain name: local, parameter, constant or uniform.
    Name(Ident),
    /// `state.field`
    State(Ident),
    /// `base.member`: a swizzle or vector component.
    Member {
        base: Box<Expr>,
        member: Ident,
    },
    /// `base[index]`
    Index {
        base: Box<Expr>,
        index: Box<Expr>,
    },
    /// A call or type constructor: `f(a)`, `vec3f(x)`, `vec3<f32>(x)`.
    Call {
        callee: Ident,
        generics: Vec<TypeExpr>,
        args: Vec<Expr>,
    },
    Unary {
        op: UnaryOp,
        operand: Box<Expr>,
    },
    Binary {
        op: BinaryOp,
        lhs: Box<Expr>,
        rhs: Box<Expr>,
    },
    /// Input the parser or lexer already reported; checks skip it silently.
    Error,
}
