//! Lowering tests on hand-built HIR: every module must validate, print as WGSL, and that WGSL
//! must parse and validate again.

use super::*;
use crate::ast::{AssignOp, BinaryOp, PlacementKind, UnaryOp};
use crate::diag::Code;
use crate::hir::*;
use crate::source::{SourceMap, Span};
use crate::steps::Step;
use crate::types::{Scalar, Type};
use std::sync::Arc;

const F32: Type = Type::F32;
const I32: Type = Type::I32;
const BOOL: Type = Type::BOOL;

fn vf(n: u8) -> Type {
    Type::vec(n, Scalar::F32)
}

fn mat(c: u8, r: u8) -> Type {
    Type::Matrix { cols: c, rows: r }
}

/// Builds HIR nodes with distinct spans inside the one test file. The calls built since the
/// last function go into the next function's call-site table.
struct H {
    next: u32,
    calls: Vec<LibFnId>,
}

impl H {
    fn new() -> H {
        H { next: 10, calls: Vec::new() }
    }

    fn span(&mut self) -> Span {
        self.next += 3;
        Span::new(self.next, self.next + 2)
    }

    fn e(&mut self, kind: ExprKind, ty: Type) -> Expr {
        Expr { kind, ty, span: self.span() }
    }

    fn cnst(&mut self, ty: Type, components: Vec<ScalarValue>) -> Expr {
        self.e(ExprKind::Const(ConstValue { ty, components }), ty)
    }

    fn f(&mut self, v: f32) -> Expr {
        self.cnst(F32, vec![ScalarValue::F32(v)])
    }

    fn i(&mut self, v: i32) -> Expr {
        self.cnst(I32, vec![ScalarValue::I32(v)])
    }

    fn local(&mut self, id: LocalId, ty: Type) -> Expr {
        self.e(ExprKind::Local(id), ty)
    }

    fn param(&mut self, i: usize, ty: Type) -> Expr {
        self.e(ExprKind::Param(i), ty)
    }

    fn uniform(&mut self, i: usize, ty: Type) -> Expr {
        self.e(ExprKind::Uniform(i), ty)
    }

    fn state(&mut self, i: usize, ty: Type) -> Expr {
        self.e(ExprKind::State(i), ty)
    }

    fn bin(&mut self, op: BinaryOp, lhs: Expr, rhs: Expr, ty: Type) -> Expr {
        self.e(ExprKind::Binary { op, lhs: Box::new(lhs), rhs: Box::new(rhs) }, ty)
    }

    fn builtin(&mut self, builtin: Builtin, args: Vec<Expr>, ty: Type) -> Expr {
        self.e(ExprKind::CallBuiltin { builtin, args }, ty)
    }

    fn call(&mut self, func: LibFnId, args: Vec<Expr>, ty: Type) -> Expr {
        let site = self.calls.len();
        self.calls.push(func);
        self.e(ExprKind::CallLib { site, args }, ty)
    }

    fn construct(&mut self, ty: Type, args: Vec<Expr>) -> Expr {
        self.e(ExprKind::Construct { args }, ty)
    }

    fn convert(&mut self, ty: Type, arg: Expr) -> Expr {
        self.e(ExprKind::Convert { arg: Box::new(arg) }, ty)
    }

    fn swz(&mut self, base: Expr, components: &[u8], ty: Type) -> Expr {
        self.e(ExprKind::Swizzle { base: Box::new(base), components: components.to_vec() }, ty)
    }

    fn index(&mut self, base: Expr, index: Expr, ty: Type) -> Expr {
        self.e(ExprKind::Index { base: Box::new(base), index: Box::new(index) }, ty)
    }

    fn s(&mut self, kind: StmtKind) -> Stmt {
        Stmt { kind, span: self.span() }
    }

    fn block(&mut self, stmts: Vec<Stmt>) -> Block {
        Block { stmts, span: self.span() }
    }

    fn let_(&mut self, local: LocalId, value: Option<Expr>) -> Stmt {
        self.s(StmtKind::Let { local, value })
    }

    fn assign(&mut self, root: PlaceRoot, path: Vec<Access>, ty: Type, op: AssignOp, value: Expr) -> Stmt {
        let place = Place { root, path, ty, span: self.span() };
        self.s(StmtKind::Assign { place, op, value })
    }

    fn ret(&mut self, value: Option<Expr>) -> Stmt {
        self.s(StmtKind::Return(value))
    }

    fn if_(&mut self, cond: Expr, then: Vec<Stmt>, otherwise: Option<Vec<Stmt>>) -> Stmt {
        let then = self.block(then);
        let otherwise = otherwise.map(|o| self.block(o));
        self.s(StmtKind::If { cond, then, otherwise })
    }

    fn local_decl(&mut self, name: &str, ty: Type, mutable: bool) -> Local {
        Local { name: name.into(), ty, mutable, span: self.span() }
    }

    fn lib(&mut self, name: &str, params: &[(&str, Type)], ret: Type, locals: Vec<Local>, body: Vec<Stmt>) -> LibFn {
        let params = params.iter().map(|&(n, ty)| Param { name: n.into(), ty, span: self.span() }).collect();
        let body = Arc::new(self.block(body));
        let calls = std::mem::take(&mut self.calls);
        LibFn { name: name.into(), module: 0, doc: None, params, ret, locals, body, calls, span: self.span() }
    }

    #[allow(clippy::too_many_arguments)]
    fn pipe(
        &mut self,
        name: &str,
        state: &[(&str, Type)],
        uniforms: &[(&str, Type)],
        uses: Vec<LibFnId>,
        locals: Vec<Local>,
        body: Vec<Stmt>,
    ) -> PipelineFn {
        let placement = Placement {
            kind: PlacementKind::In,
            step: Step::CompositingAlpha,
            substep: None,
            when_active: false,
            span: self.span(),
        };
        let state = state
            .iter()
            .map(|&(n, ty)| StateDecl {
                name: n.into(),
                ty,
                ray: false,
                default: None,
                read: true,
                written: true,
                first_read: None,
                span: self.span(),
            })
            .collect();
        let uniforms = uniforms
            .iter()
            .map(|&(n, ty)| UniformDecl {
                name: n.into(),
                ty,
                default: None,
                range: None,
                doc: None,
                span: self.span(),
            })
            .collect();
        let body = Arc::new(self.block(body));
        PipelineFn {
            name: name.into(),
            module: 0,
            doc: None,
            placement,
            state,
            uniforms,
            uses,
            locals,
            body,
            calls: std::mem::take(&mut self.calls),
            span: self.span(),
        }
    }
}

fn sources() -> SourceMap {
    let mut map = SourceMap::new();
    map.add("test.vrs", None, " ".repeat(100_000));
    map
}

fn validator() -> naga::valid::Validator {
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty())
}

/// Lowers, validates, writes WGSL, parses and validates that again; returns the WGSL.
fn roundtrip(program: &Program) -> String {
    let (module, info) = match lower_standalone(program, &sources()) {
        Ok(ok) => ok,
        Err(d) => panic!("lowering failed: {d:#?}"),
    };
    let text = write_wgsl(&module, &info).expect("WGSL writer");
    let reparsed = match naga::front::wgsl::parse_str(&text) {
        Ok(m) => m,
        Err(e) => panic!("{}\n{text}", e.emit_to_string(&text)),
    };
    if let Err(e) = validator().validate(&reparsed) {
        panic!("{e:?}\n{text}");
    }
    text
}

fn assert_contains(text: &str, needles: &[&str]) {
    for n in needles {
        assert!(text.contains(n), "missing `{n}` in:\n{text}");
    }
}

#[test]
fn names_are_mangled() {
    assert_eq!(emitted_name("color_$"), "color_T");
    assert_eq!(emitted_name("plane_$_a"), "plane_T_a");
    assert_eq!(emitted_name("$"), "_T");
    assert_eq!(emitted_name("plain"), "plain");
    assert_eq!(emitted_name("_"), "unnamed");
    assert_eq!(host_type(Type::vec(3, Scalar::Bool)), Type::vec(3, Scalar::U32));
}

/// lib fn shade(c: vec3f, n: i32) -> vec4f {
///     var acc: f32 = 0.0;
///     let base = vec4f(c * 2.0, 1.0);
///     for i in 0 .. n {
///         if i == 3 { continue; }
///         if f32(i) > base.x { break; }
///         var k: f32;
///         k += 1.0;
///         acc += base.y * 0.5 + k;
///     }
///     var v = vec3f(0.5);
///     v.xz = base.zw;
///     v.y += acc;
///     v -= 1.0;
///     v.zx *= 2.0;
///     if acc > 1.0 && !(acc > 5.0) { return vec4f(v, acc); } else { return vec4f(v.zyx, 0.0); }
/// }
#[test]
fn lib_fn_with_loops_swizzles_and_returns() {
    let mut h = H::new();
    let locals = vec![
        h.local_decl("acc", F32, true),
        h.local_decl("base", vf(4), false),
        h.local_decl("i", I32, true),
        h.local_decl("v", vf(3), true),
        h.local_decl("k", F32, true),
    ];
    let mut body = Vec::new();
    let zero = h.f(0.0);
    body.push(h.let_(0, Some(zero)));
    let c = h.param(0, vf(3));
    let two = h.f(2.0);
    let c2 = h.bin(BinaryOp::Mul, c, two, vf(3));
    let one = h.f(1.0);
    let base = h.construct(vf(4), vec![c2, one]);
    body.push(h.let_(1, Some(base)));
    // for body
    let mut fb = Vec::new();
    let i = h.local(2, I32);
    let three = h.i(3);
    let eq = h.bin(BinaryOp::Eq, i, three, BOOL);
    let cont = h.s(StmtKind::Continue);
    fb.push(h.if_(eq, vec![cont], None));
    let i = h.local(2, I32);
    let fi = h.convert(F32, i);
    let b = h.local(1, vf(4));
    let bx = h.swz(b, &[0], F32);
    let gt = h.bin(BinaryOp::Gt, fi, bx, BOOL);
    let brk = h.s(StmtKind::Break);
    fb.push(h.if_(gt, vec![brk], None));
    fb.push(h.let_(4, None));
    let one = h.f(1.0);
    fb.push(h.assign(PlaceRoot::Local(4), vec![], F32, AssignOp::Add, one));
    let b = h.local(1, vf(4));
    let by = h.swz(b, &[1], F32);
    let half = h.f(0.5);
    let m = h.bin(BinaryOp::Mul, by, half, F32);
    let k = h.local(4, F32);
    let m = h.bin(BinaryOp::Add, m, k, F32);
    fb.push(h.assign(PlaceRoot::Local(0), vec![], F32, AssignOp::Add, m));
    let start = h.i(0);
    let end = h.param(1, I32);
    let fbody = h.block(fb);
    body.push(h.s(StmtKind::For { var: 2, start, end, body: fbody }));
    // v
    let half = h.f(0.5);
    let v = h.construct(vf(3), vec![half]);
    body.push(h.let_(3, Some(v)));
    let b = h.local(1, vf(4));
    let bzw = h.swz(b, &[2, 3], vf(2));
    body.push(h.assign(PlaceRoot::Local(3), vec![Access::Swizzle(vec![0, 2])], vf(2), AssignOp::Assign, bzw));
    let acc = h.local(0, F32);
    body.push(h.assign(PlaceRoot::Local(3), vec![Access::Component(1)], F32, AssignOp::Add, acc));
    let one = h.f(1.0);
    body.push(h.assign(PlaceRoot::Local(3), vec![], vf(3), AssignOp::Sub, one));
    let two = h.f(2.0);
    body.push(h.assign(PlaceRoot::Local(3), vec![Access::Swizzle(vec![2, 0])], vf(2), AssignOp::Mul, two));
    // if / else
    let acc = h.local(0, F32);
    let one = h.f(1.0);
    let c1 = h.bin(BinaryOp::Gt, acc, one, BOOL);
    let acc = h.local(0, F32);
    let five = h.f(5.0);
    let c2 = h.bin(BinaryOp::Gt, acc, five, BOOL);
    let c2 = h.e(ExprKind::Unary { op: UnaryOp::Not, operand: Box::new(c2) }, BOOL);
    let cond = h.bin(BinaryOp::And, c1, c2, BOOL);
    let v = h.local(3, vf(3));
    let acc = h.local(0, F32);
    let r1 = h.construct(vf(4), vec![v, acc]);
    let r1 = h.ret(Some(r1));
    let v = h.local(3, vf(3));
    let vzyx = h.swz(v, &[2, 1, 0], vf(3));
    let zero = h.f(0.0);
    let r2 = h.construct(vf(4), vec![vzyx, zero]);
    let r2 = h.ret(Some(r2));
    body.push(h.if_(cond, vec![r1], Some(vec![r2])));
    let f = h.lib("shade", &[("c", vf(3)), ("n", I32)], vf(4), locals, body);
    let program = Program { lib_fns: vec![f], ..Default::default() };
    let text = roundtrip(&program);
    assert_contains(
        &text,
        &[
            "fn shade(c: vec3<f32>, n: i32) -> vec4<f32> {",
            "var acc: f32 = 0f;",
            "let base = vec4<f32>((c * 2f), 1f);",
            "loop {",
            "if (_e",
            "break;",
            "continue;",
            "continuing {",
            "i = (_e",
            "v = vec3(0.5f);",
            "v = vec3<f32>(_e37.x, _e38.y, _e37.y);",
            "k = f32();",
            "return vec4<f32>(",
        ],
    );
    // The loop bound is evaluated once, before the loop: `n` is an argument, and the start is
    // the literal initialiser of `i` (declared outside any loop).
    assert_contains(&text, &["var i: i32 = 0i;", ">= n)"]);
}

/// lib fn classify(v: volume, t: tf, p: vec3f) -> vec4f {
///     let d = dims(v);
///     let s = sample(v, p + vec3f(1.0) / vec3f(d));
///     return lookup(t, s);
/// }
/// pipeline classify_p {
///     uniform vol: volume; uniform tfn: tf; uniform gain: f32;
///     state pos: vec3f; state color: vec4f; use classify;
///     state.color = classify(vol, tfn, state.pos) * gain;
/// }
#[test]
fn volumes_and_transfer_functions() {
    let mut h = H::new();
    let locals = vec![h.local_decl("d", Type::vec(3, Scalar::U32), false), h.local_decl("s", F32, false)];
    let v = h.param(0, Type::Volume);
    let dims = h.builtin(Builtin::Dims, vec![v], Type::vec(3, Scalar::U32));
    let s1 = h.let_(0, Some(dims));
    let p = h.param(2, vf(3));
    let one = h.cnst(vf(3), vec![ScalarValue::F32(1.0); 3]);
    let d = h.local(0, Type::vec(3, Scalar::U32));
    let df = h.convert(vf(3), d);
    let q = h.bin(BinaryOp::Div, one, df, vf(3));
    let p = h.bin(BinaryOp::Add, p, q, vf(3));
    let v = h.param(0, Type::Volume);
    let sample = h.builtin(Builtin::Sample, vec![v, p], F32);
    let s2 = h.let_(1, Some(sample));
    let t = h.param(1, Type::Tf);
    let s = h.local(1, F32);
    let lookup = h.builtin(Builtin::Lookup, vec![t, s], vf(4));
    let s3 = h.ret(Some(lookup));
    let f = h.lib("classify", &[("v", Type::Volume), ("t", Type::Tf), ("p", vf(3))], vf(4), locals, vec![s1, s2, s3]);

    let vol = h.uniform(0, Type::Volume);
    let tfn = h.uniform(1, Type::Tf);
    let pos = h.state(0, vf(3));
    let call = h.call(0, vec![vol, tfn, pos], vf(4));
    let gain = h.uniform(2, F32);
    let value = h.bin(BinaryOp::Mul, call, gain, vf(4));
    let st = h.assign(PlaceRoot::State(1), vec![], vf(4), AssignOp::Assign, value);
    let p = h.pipe(
        "classify_p",
        &[("pos", vf(3)), ("color", vf(4))],
        &[("vol", Type::Volume), ("tfn", Type::Tf), ("gain", F32)],
        vec![0],
        vec![],
        vec![st],
    );
    let program = Program { lib_fns: vec![f], pipelines: vec![p], removes: vec![] };
    let text = roundtrip(&program);
    assert_contains(
        &text,
        &[
            "fn classify(v: texture_3d<f32>, v_sampler: sampler, t: texture_2d<f32>, t_sampler: sampler, p: vec3<f32>) -> vec4<f32>",
            "textureDimensions(v)",
            "textureSampleLevel(v, v_sampler, (p + (vec3(1f) / vec3<f32>(d))), 0.0);",
            "let s = _e11.x;",
            "textureSampleLevel(t, t_sampler, vec2<f32>(s, 0.5f), 0.0)",
            "struct State_classify_p {\n    pos: vec3<f32>,\n    color: vec4<f32>,\n}",
            "struct Uniforms_classify_p {\n    gain: f32,\n}",
            "@group(0) @binding(0) \nvar<uniform> uniforms_classify_p: Uniforms_classify_p;",
            "@group(0) @binding(1) \nvar vol: texture_3d<f32>;",
            "@group(0) @binding(2) \nvar vol_sampler: sampler;",
            "@group(0) @binding(3) \nvar tfn: texture_2d<f32>;",
            "@group(0) @binding(4) \nvar tfn_sampler: sampler;",
            "fn classify_p(state: ptr<function, State_classify_p>) {",
            "classify(vol, vol_sampler, tfn, tfn_sampler, _e",
            "uniforms_classify_p.gain",
            "(*state).color = ",
        ],
    );
}

/// pipeline fade {
///     uniform opacity: f32; uniform enabled: bool; uniform tint: vec3f;
///     state color: vec4f; state hit: bool;
///     if enabled { state.color.a = state.color.a * opacity; state.color.rgb *= tint; return; }
///     state.hit = any(vec3<bool>(...)) ; state.color[i] = 0.0 for a dynamic i
/// }
#[test]
fn pipeline_fn_reads_uniforms_and_writes_state_components() {
    let mut h = H::new();
    let locals = vec![h.local_decl("j", I32, false)];
    let enabled = h.uniform(1, BOOL);
    let a = h.state(0, vf(4));
    let a = h.swz(a, &[3], F32);
    let opacity = h.uniform(0, F32);
    let prod = h.bin(BinaryOp::Mul, a, opacity, F32);
    let s1 = h.assign(PlaceRoot::State(0), vec![Access::Component(3)], F32, AssignOp::Assign, prod);
    let tint = h.uniform(2, vf(3));
    let s2 = h.assign(PlaceRoot::State(0), vec![Access::Swizzle(vec![0, 1, 2])], vf(3), AssignOp::Mul, tint);
    let r = h.ret(None);
    let if_ = h.if_(enabled, vec![s1, s2, r], None);
    let bools = h.cnst(
        Type::vec(3, Scalar::Bool),
        vec![ScalarValue::Bool(true), ScalarValue::Bool(false), ScalarValue::Bool(true)],
    );
    let any = h.builtin(Builtin::Any, vec![bools], BOOL);
    let s3 = h.assign(PlaceRoot::State(1), vec![], BOOL, AssignOp::Assign, any);
    let two = h.i(2);
    let s4 = h.let_(0, Some(two));
    let j = h.local(0, I32);
    let zero = h.f(0.0);
    let s5 = h.assign(PlaceRoot::State(0), vec![Access::Index(Box::new(j))], F32, AssignOp::Assign, zero);
    let p = h.pipe(
        "fade",
        &[("color", vf(4)), ("hit", BOOL)],
        &[("opacity", F32), ("enabled", BOOL), ("tint", vf(3))],
        vec![],
        locals,
        vec![if_, s3, s4, s5],
    );
    let program = Program { pipelines: vec![p], ..Default::default() };
    let text = roundtrip(&program);
    assert_contains(
        &text,
        &[
            "struct Uniforms_fade {\n    opacity: f32,\n    enabled: u32,\n    tint: vec3<f32>,\n}",
            "fn fade(state: ptr<function, State_fade>) {",
            "bool(_e",
            "(*state).color.w = ",
            "uniforms_fade.opacity",
            "(*state).color = vec4<f32>(",
            "(*state).hit = any(",
            "(*state).color[2i] = 0f;",
            "return;",
        ],
    );
}

/// lib fn xf(m: mat4x4f, p: vec3f, k: i32) -> vec3f {
///     let q = m * vec4f(p, 1.0);
///     let r = mat3x3f(1, 0, 0, 0, 1, 0, 0, 0, 1);
///     var col = r[k];
///     col += m[k].xyz + mat2x2f-constant[1].xyy;
///     return transpose(r) * col * q.w + vec3f(determinant(r));
/// }
#[test]
fn matrices() {
    let mut h = H::new();
    let locals =
        vec![h.local_decl("q", vf(4), false), h.local_decl("r", mat(3, 3), false), h.local_decl("col", vf(3), true)];
    let m = h.param(0, mat(4, 4));
    let p = h.param(1, vf(3));
    let one = h.f(1.0);
    let p4 = h.construct(vf(4), vec![p, one]);
    let q = h.bin(BinaryOp::Mul, m, p4, vf(4));
    let s1 = h.let_(0, Some(q));
    let scalars = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0].iter().map(|&v| h.f(v)).collect();
    let r = h.construct(mat(3, 3), scalars);
    let s2 = h.let_(1, Some(r));
    let r = h.local(1, mat(3, 3));
    let k = h.param(2, I32);
    let rk = h.index(r, k, vf(3));
    let s3 = h.let_(2, Some(rk));
    let m = h.param(0, mat(4, 4));
    let k = h.param(2, I32);
    let mk = h.index(m, k, vf(4));
    let mk = h.swz(mk, &[0, 1, 2], vf(3));
    let c = h.cnst(
        mat(2, 2),
        vec![ScalarValue::F32(1.0), ScalarValue::F32(2.0), ScalarValue::F32(3.0), ScalarValue::F32(4.0)],
    );
    let one = h.i(1);
    let c1 = h.index(c, one, vf(2));
    let c1 = h.swz(c1, &[0, 1, 1], vf(3));
    let sum = h.bin(BinaryOp::Add, mk, c1, vf(3));
    let s4 = h.assign(PlaceRoot::Local(2), vec![], vf(3), AssignOp::Add, sum);
    let r = h.local(1, mat(3, 3));
    let rt = h.builtin(Builtin::Transpose, vec![r], mat(3, 3));
    let col = h.local(2, vf(3));
    let prod = h.bin(BinaryOp::Mul, rt, col, vf(3));
    let q = h.local(0, vf(4));
    let qw = h.swz(q, &[3], F32);
    let prod = h.bin(BinaryOp::Mul, prod, qw, vf(3));
    let r = h.local(1, mat(3, 3));
    let det = h.builtin(Builtin::Determinant, vec![r], F32);
    let det = h.construct(vf(3), vec![det]);
    let sum = h.bin(BinaryOp::Add, prod, det, vf(3));
    let s5 = h.ret(Some(sum));
    let f = h.lib("xf", &[("m", mat(4, 4)), ("p", vf(3)), ("k", I32)], vf(3), locals, vec![s1, s2, s3, s4, s5]);
    let program = Program { lib_fns: vec![f], ..Default::default() };
    let text = roundtrip(&program);
    assert_contains(
        &text,
        &[
            "let q = (m * vec4<f32>(p, 1f));",
            "mat3x3<f32>(vec3<f32>(1f, 0f, 0f), vec3<f32>(0f, 1f, 0f), vec3<f32>(0f, 0f, 1f))",
            "mat2x2<f32>(vec2<f32>(1f, 2f), vec2<f32>(3f, 4f))[1]",
            "transpose(r)",
            "determinant(r)",
        ],
    );
}

/// c(x) = x * x; b(x) = c(x) + 1; a(x) = b(c(x)); two `f`s from two modules; a template name;
/// a function returning nothing called as a statement; a pipeline function calling the chain.
#[test]
fn call_chains_and_names() {
    let mut h = H::new();
    let x = h.param(0, F32);
    let x2 = h.param(0, F32);
    let sq = h.bin(BinaryOp::Mul, x, x2, F32);
    let r = h.ret(Some(sq));
    let c = h.lib("c", &[("x", F32)], F32, vec![], vec![r]);
    let x = h.param(0, F32);
    let cx = h.call(0, vec![x], F32);
    let one = h.f(1.0);
    let sum = h.bin(BinaryOp::Add, cx, one, F32);
    let r = h.ret(Some(sum));
    let b = h.lib("b", &[("x", F32)], F32, vec![], vec![r]);
    let x = h.param(0, F32);
    let cx = h.call(0, vec![x], F32);
    let bcx = h.call(1, vec![cx], F32);
    let r = h.ret(Some(bcx));
    let a = h.lib("a", &[("x", F32)], F32, vec![], vec![r]);
    let one = h.f(1.0);
    let r = h.ret(Some(one));
    let f0 = h.lib("f", &[], F32, vec![], vec![r]);
    let two = h.f(2.0);
    let r = h.ret(Some(two));
    let mut f1 = h.lib("f", &[], F32, vec![], vec![r]);
    f1.module = 1;
    let r = h.ret(None);
    let noop = h.lib("noop_$", &[("x", F32)], Type::Void, vec![], vec![r]);

    let t = h.state(0, F32);
    let a_t = h.call(2, vec![t], F32);
    let f0c = h.call(3, vec![], F32);
    let f1c = h.call(4, vec![], F32);
    let s = h.bin(BinaryOp::Add, a_t, f0c, F32);
    let s = h.bin(BinaryOp::Sub, s, f1c, F32);
    let st = h.assign(PlaceRoot::State(0), vec![], F32, AssignOp::Assign, s);
    let t = h.state(0, F32);
    let call = h.call(5, vec![t], Type::Void);
    let call = h.s(StmtKind::Expr(call));
    let p = h.pipe("shade_$", &[("t_$", F32)], &[], vec![2, 3, 4, 5], vec![], vec![st, call]);
    let program = Program { lib_fns: vec![c, b, a, f0, f1, noop], pipelines: vec![p], removes: vec![] };
    let text = roundtrip(&program);
    assert_contains(
        &text,
        &[
            "fn c(x: f32) -> f32 {",
            "fn b(x_1: f32) -> f32 {",
            "fn a(x_2: f32) -> f32 {",
            "fn f() -> f32 {",
            "fn m1_f() -> f32 {",
            "fn noop_T(x_3: f32) {",
            "struct State_shade_T {\n    t_T: f32,\n}",
            "fn shade_T(state: ptr<function, State_shade_T>) {",
            "noop_T(",
        ],
    );
    // Callees come before callers.
    let pos = |s: &str| text.find(s).unwrap_or(usize::MAX);
    assert!(pos("fn c(") < pos("fn b(") && pos("fn b(") < pos("fn a(") && pos("fn a(") < pos("fn shade_T("));
}

/// The composer's use: one State struct and one uniform block shared by two pipeline functions;
/// a field omitted from the struct has its writes dropped.
#[test]
fn shared_environment_and_omitted_fields() {
    let mut h = H::new();
    let gain = h.uniform(0, F32);
    let s1 = h.assign(PlaceRoot::State(0), vec![], F32, AssignOp::Mul, gain);
    let one = h.f(1.0);
    let s2 = h.assign(PlaceRoot::State(1), vec![Access::Component(0)], F32, AssignOp::Assign, one);
    let p1 = h.pipe("first", &[("value", F32), ("unused", vf(4))], &[("gain", F32)], vec![], vec![], vec![s1, s2]);
    let v = h.state(0, F32);
    let s3 = h.assign(PlaceRoot::State(0), vec![], F32, AssignOp::Add, v);
    let p2 = h.pipe("second", &[("value", F32)], &[("flag", BOOL)], vec![], vec![], vec![s3]);
    let program = Program { pipelines: vec![p1, p2], ..Default::default() };

    let mut b = ModuleBuilder::new();
    let state = b.add_struct("State", &[("value".into(), F32), ("pos".into(), vf(3))], Span::DUMMY).unwrap();
    let binding = ResourceBinding { group: 0, binding: 0 };
    let block = b
        .add_uniform_block("Uniforms", "uniforms", &[("flag".into(), BOOL), ("gain".into(), F32)], binding, Span::DUMMY)
        .unwrap();
    let env1 = PipelineEnv {
        state_type: state,
        state_members: vec![Some(0), None],
        uniforms: vec![UniformAccess::Member { block, index: 1 }],
    };
    let env2 = PipelineEnv {
        state_type: state,
        state_members: vec![Some(0)],
        uniforms: vec![UniformAccess::Member { block, index: 0 }],
    };
    b.lower_pipeline_fn(&program, &program.pipelines[0], "first", &env1).unwrap();
    b.lower_pipeline_fn(&program, &program.pipelines[1], "second", &env2).unwrap();
    let layout = b.struct_layout(state).unwrap();
    assert_eq!(layout.size, 32);
    assert_eq!(layout.members.iter().map(|m| m.offset).collect::<Vec<_>>(), vec![0, 16]);
    let module = b.finish();
    let info = validate(&module, &sources(), Span::DUMMY).unwrap();
    let text = write_wgsl(&module, &info).unwrap();
    assert_contains(&text, &["fn first(state: ptr<function, State>) {", "fn second(state_1: ptr<function, State>) {"]);
    assert!(!text.contains("unused"), "{text}");
    naga::front::wgsl::parse_str(&text).unwrap();
}

#[test]
fn malformed_hir_is_an_internal_error() {
    // lib fn bad(x: f32) -> f32 { return x + 1i; }: a mismatch the checker would have caught.
    let mut h = H::new();
    let x = h.param(0, F32);
    let one = h.i(1);
    let sum = h.bin(BinaryOp::Add, x, one, F32);
    let bad_span = sum.span;
    let r = h.ret(Some(sum));
    let f = h.lib("bad", &[("x", F32)], F32, vec![], vec![r]);
    let program = Program { lib_fns: vec![f], ..Default::default() };
    let d = lower_standalone(&program, &sources()).unwrap_err();
    assert_eq!(d.code, Code::Internal);
    assert_eq!(d.span, bad_span, "{d:#?}");
    assert!(d.message.contains("did not validate"), "{}", d.message);

    // A local that does not exist.
    let mut h = H::new();
    let x = h.local(7, F32);
    let r = h.ret(Some(x));
    let f = h.lib("bad", &[], F32, vec![], vec![r]);
    let program = Program { lib_fns: vec![f], ..Default::default() };
    let d = lower_standalone(&program, &sources()).unwrap_err();
    assert_eq!(d.code, Code::Internal);

    // A library function that can end without returning.
    let mut h = H::new();
    let t = h.cnst(BOOL, vec![ScalarValue::Bool(true)]);
    let one = h.f(1.0);
    let r = h.ret(Some(one));
    let if_ = h.if_(t, vec![r], None);
    let f = h.lib("bad", &[], F32, vec![], vec![if_]);
    let program = Program { lib_fns: vec![f], ..Default::default() };
    assert_eq!(lower_standalone(&program, &sources()).unwrap_err().code, Code::Internal);

    // Recursion, a state read in a library function, a resource used as a value, a call of a
    // function that does not exist.
    let mut h = H::new();
    let call = h.call(0, vec![], F32);
    let r = h.ret(Some(call));
    let rec = h.lib("rec", &[], F32, vec![], vec![r]);
    let st = h.state(0, F32);
    let r = h.ret(Some(st));
    let state = h.lib("state", &[], F32, vec![], vec![r]);
    let v = h.param(0, Type::Volume);
    let r = h.ret(Some(v));
    let res = h.lib("res", &[("v", Type::Volume)], F32, vec![], vec![r]);
    let call = h.call(42, vec![], F32);
    let r = h.ret(Some(call));
    let missing = h.lib("missing", &[], F32, vec![], vec![r]);
    for f in [rec, state, res, missing] {
        let program = Program { lib_fns: vec![f], ..Default::default() };
        assert_eq!(lower_standalone(&program, &sources()).unwrap_err().code, Code::Internal);
    }
}

#[test]
fn uniform_block_of_every_plain_type() {
    let types = [
        F32,
        vf(3),
        BOOL,
        Type::vec(2, Scalar::Bool),
        mat(3, 2),
        Type::U32,
        mat(2, 2),
        vf(2),
        mat(4, 3),
        Type::vec(4, Scalar::I32),
        mat(3, 3),
        I32,
    ];
    let members: Vec<(String, Type)> = types.iter().enumerate().map(|(i, &t)| (format!("u{i}x"), t)).collect();
    let mut b = ModuleBuilder::new();
    let block = b
        .add_uniform_block("Uniforms", "uniforms", &members, ResourceBinding { group: 0, binding: 0 }, Span::DUMMY)
        .unwrap();
    let ty = b.module.global_variables[block].ty;
    let layout = b.struct_layout(ty).unwrap();
    let offsets: Vec<u32> = layout.members.iter().map(|m| m.offset).collect();
    assert_eq!(offsets, vec![0, 16, 28, 32, 40, 64, 72, 88, 96, 160, 176, 224]);
    assert_eq!(layout.size, 240);
    let module = b.finish();
    let info = validate(&module, &sources(), Span::DUMMY).unwrap();
    let text = write_wgsl(&module, &info).unwrap();
    // naga's WGSL front end lays the struct out the same way.
    let reparsed = naga::front::wgsl::parse_str(&text).unwrap();
    let (_, t) = reparsed.types.iter().find(|(_, t)| t.name.as_deref() == Some("Uniforms")).unwrap();
    let naga::TypeInner::Struct { members, span } = &t.inner else { panic!() };
    assert_eq!(members.iter().map(|m| m.offset).collect::<Vec<_>>(), offsets);
    assert_eq!(*span, 240);
}

/// `vrsc emit` makes one struct per pipeline function: laying out the arena after each made
/// lowering quadratic (a 10 MB module took 24 s). Structs of types already laid out need no
/// new pass.
#[test]
fn structs_of_known_types_need_no_new_layout_pass() {
    let mut b = ModuleBuilder::new();
    let members = [("a".to_string(), Type::F32), ("b".to_string(), vf(3))];
    for i in 0..200 {
        b.add_struct(&format!("S{i}"), &members, Span::DUMMY).expect("a struct");
    }
    assert_eq!(b.layout_passes, 1);
    let last = b.add_struct("Last", &members, Span::DUMMY).expect("a struct");
    let layout = b.struct_layout(last).expect("a layout");
    assert_eq!((layout.size, b.layout_passes), (32, 2));
}
