//! A generator of well-typed VRS modules, for property tests and fuzzing: constants, library
//! functions and a pipeline function whose bodies use every expression and statement form,
//! with edge-case literals (zero divisors, large shift amounts, values at the ends of i32) so
//! that the checker's constant-evaluation rules are reached, not only the parser.
//!
//! Every choice comes from a [`Choices`] source: a seeded PRNG for the test suite, or the fuzzer's
//! bytes (when they run out every choice is 0, which always picks the simplest form, so every
//! input gives a finite, well-formed module). The output is well typed by construction; it may
//! still break a rule that needs values (`1 / 0`), which is the point: the property is that a
//! module `check` accepts lowers to IR that validates.
//!
//! Public face: [`generate`], which writes a module from a [`Choices`] source, and
//! [`check_clean_validates`], which checks it for that property and gives a [`Verdict`]; the
//! property tests and the fuzz targets call them.

use std::fmt::Write;

/// Where the generator's decisions come from.
pub enum Choices<'a> {
    /// xorshift64* from a seed: deterministic, so a failure names a reproducible seed.
    Seeded(u64),
    /// The fuzzer's bytes, one per decision.
    Bytes(&'a [u8]),
}

impl Choices<'_> {
    /// A number in `0..n` (0 when `n` is 0 or the bytes ran out).
    pub fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            return 0;
        }
        match self {
            Choices::Seeded(state) => {
                // xorshift never leaves 0.
                if *state == 0 {
                    *state = 0x9E37_79B9_7F4A_7C15;
                }
                *state ^= *state >> 12;
                *state ^= *state << 25;
                *state ^= *state >> 27;
                (state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as usize % n
            }
            Choices::Bytes(bytes) => match bytes.split_first() {
                Some((&b, rest)) => {
                    *bytes = rest;
                    b as usize % n
                }
                None => 0,
            },
        }
    }

    fn chance(&mut self, percent: usize) -> bool {
        self.below(100) < percent
    }

    fn pick<'t, T>(&mut self, items: &'t [T]) -> &'t T {
        &items[self.below(items.len())]
    }
}

/// The element scalar of a generated type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Elem {
    F,
    I,
    U,
    B,
}

/// A plain VRS type: a scalar or vector (`size` 1 is a scalar), or a square float matrix.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Ty {
    V(Elem, u8),
    M(u8),
}

impl Ty {
    fn name(self) -> String {
        match self {
            Ty::V(e, 1) => String::from(match e {
                Elem::F => "f32",
                Elem::I => "i32",
                Elem::U => "u32",
                Elem::B => "bool",
            }),
            Ty::V(Elem::B, n) => format!("vec{n}<bool>"),
            Ty::V(e, n) => format!("vec{n}{}", ["f", "i", "u"][e as usize]),
            Ty::M(n) => format!("mat{n}x{n}f"),
        }
    }
}

const ELEMS: [Elem; 4] = [Elem::F, Elem::I, Elem::U, Elem::B];

fn random_type(c: &mut Choices, matrices: bool) -> Ty {
    if matrices && c.chance(8) {
        return Ty::M(2 + c.below(3) as u8);
    }
    let elem = ELEMS[c.below(4)];
    let size = if c.chance(50) { 1 } else { 2 + c.below(3) as u8 };
    Ty::V(elem, size)
}

/// A name in scope and its type.
#[derive(Clone)]
struct Var {
    name: String,
    ty: Ty,
    mutable: bool,
}

/// A library function already generated: callable by later ones.
#[derive(Clone)]
struct Lib {
    name: String,
    params: Vec<Ty>,
    ret: Ty,
}

/// The state of generating one module.
struct Gen<'c, 'a> {
    c: &'c mut Choices<'a>,
    out: String,
    consts: Vec<Var>,
    libs: Vec<Lib>,
    /// Names visible in the body being generated, innermost last.
    scope: Vec<Var>,
    /// Library functions the body may call (all earlier ones in a lib fn; the `use` list in a
    /// pipeline function).
    callable: Vec<Lib>,
    /// `state.NAME` fields of the pipeline function (empty in a lib fn).
    state: Vec<Var>,
    counter: usize,
    loops: u32,
    /// Expression nodes still allowed in the current statement.
    budget: u32,
}

/// Generates one module from `choices`.
pub fn generate(choices: &mut Choices) -> String {
    let mut g = Gen {
        c: choices,
        out: String::new(),
        consts: Vec::new(),
        libs: Vec::new(),
        scope: Vec::new(),
        callable: Vec::new(),
        state: Vec::new(),
        counter: 0,
        loops: 0,
        budget: 0,
    };
    g.module();
    g.out
}

impl Gen<'_, '_> {
    fn fresh(&mut self, prefix: &str) -> String {
        self.counter += 1;
        format!("{prefix}{}", self.counter)
    }

    fn module(&mut self) {
        for _ in 0..self.c.below(3) {
            self.const_item();
        }
        for _ in 0..self.c.below(3) {
            self.lib_fn();
        }
        self.pipeline();
    }

    fn const_item(&mut self) {
        let ty = random_type(self.c, true);
        let name = self.fresh("K");
        self.budget = 6;
        let value = self.const_expr(ty, 0);
        let _ = writeln!(self.out, "const {name}: {} = {value};", ty.name());
        self.consts.push(Var { name, ty, mutable: false });
    }

    /// A constant expression: literals, constructors, arithmetic and earlier constants.
    fn const_expr(&mut self, ty: Ty, depth: u32) -> String {
        let saved = std::mem::take(&mut self.scope);
        self.scope = self.consts.clone();
        let callable = std::mem::take(&mut self.callable);
        let state = std::mem::take(&mut self.state);
        let e = self.expr_with(ty, depth, true);
        self.scope = saved;
        self.callable = callable;
        self.state = state;
        e
    }

    fn lib_fn(&mut self) {
        let name = self.fresh("lib");
        let params: Vec<Ty> = (0..self.c.below(4)).map(|_| random_type(self.c, true)).collect();
        let ret = random_type(self.c, true);
        self.scope = self.consts.clone();
        let mut shown = Vec::new();
        for ty in &params {
            let p = self.fresh("p");
            shown.push(format!("{p}: {}", ty.name()));
            self.scope.push(Var { name: p, ty: *ty, mutable: false });
        }
        self.callable = self.libs.clone();
        self.state.clear();
        let _ = writeln!(self.out, "lib fn {name}({}) -> {} {{", shown.join(", "), ret.name());
        self.statements(1, Some(ret));
        self.budget = 8;
        let value = self.expr(ret, 0);
        let _ = writeln!(self.out, "    return {value};\n}}");
        self.libs.push(Lib { name, params, ret });
    }

    fn pipeline(&mut self) {
        let name = self.fresh("pipe");
        let places = ["in start", "after sampling.primary", "before compositing", "in shading.tone", "after ray.setup"];
        let place = *self.c.pick(&places);
        let _ = writeln!(self.out, "pipeline {name} {place} {{");
        self.scope = self.consts.clone();
        self.state.clear();
        for _ in 0..1 + self.c.below(3) {
            let ty = random_type(self.c, true);
            let field = self.fresh("s");
            self.budget = 4;
            let default = self.const_expr(ty, 1);
            let ray = if self.c.chance(30) { "@ray " } else { "" };
            let _ = writeln!(self.out, "    {ray}state {field}: {} = {default};", ty.name());
            self.state.push(Var { name: format!("state.{field}"), ty, mutable: true });
        }
        for _ in 0..self.c.below(3) {
            let ty = random_type(self.c, true);
            let u = self.fresh("u");
            self.budget = 4;
            let default = if self.c.chance(60) { format!(" = {}", self.const_expr(ty, 1)) } else { String::new() };
            let _ = writeln!(self.out, "    uniform {u}: {}{default};", ty.name());
            self.scope.push(Var { name: u, ty, mutable: false });
        }
        self.callable = self.libs.clone();
        if !self.callable.is_empty() {
            let names: Vec<&str> = self.callable.iter().map(|l| l.name.as_str()).collect();
            let _ = writeln!(self.out, "    use {};", names.join(", "));
        }
        self.statements(1, None);
        self.out.push_str("}\n");
    }

    /// A few statements at block depth `depth`; `ret` is the enclosing lib fn's return type.
    fn statements(&mut self, depth: u32, ret: Option<Ty>) {
        let mark = self.scope.len();
        for _ in 0..self.c.below(5) {
            self.statement(depth, ret);
        }
        self.scope.truncate(mark);
    }

    fn line(&mut self, depth: u32, text: &str) {
        for _ in 0..depth {
            self.out.push_str("    ");
        }
        self.out.push_str(text);
        self.out.push('\n');
    }

    fn statement(&mut self, depth: u32, ret: Option<Ty>) {
        self.budget = 12;
        let nested = depth < 4;
        match self.c.below(9) {
            0 | 1 => {
                let ty = random_type(self.c, true);
                let value = self.expr(ty, 0);
                let name = self.fresh("v");
                let mutable = self.c.chance(50);
                let text = if mutable {
                    format!("var {name}: {} = {value};", ty.name())
                } else {
                    format!("let {name} = {value};")
                };
                self.line(depth, &text);
                self.scope.push(Var { name, ty, mutable });
            }
            2 | 3 => self.assignment(depth),
            4 if nested => {
                let cond = self.expr(Ty::V(Elem::B, 1), 0);
                self.line(depth, &format!("if {cond} {{"));
                self.statements(depth + 1, ret);
                if self.c.chance(50) {
                    self.line(depth, "} else {");
                    self.statements(depth + 1, ret);
                }
                self.line(depth, "}");
            }
            5 if nested => {
                let elem = if self.c.chance(50) { Elem::I } else { Elem::U };
                let suffix = if elem == Elem::I { "i" } else { "u" };
                let (lo, hi) = (self.c.below(3), self.c.below(5));
                let var = self.fresh("i");
                self.line(depth, &format!("for {var} in {lo}{suffix} .. {hi}{suffix} {{"));
                self.scope.push(Var { name: var, ty: Ty::V(elem, 1), mutable: false });
                self.loops += 1;
                self.statements(depth + 1, ret);
                self.loops -= 1;
                self.scope.pop();
                self.line(depth, "}");
            }
            6 if self.loops > 0 => {
                let cond = self.expr(Ty::V(Elem::B, 1), 0);
                let jump = if self.c.chance(50) { "break" } else { "continue" };
                self.line(depth, &format!("if {cond} {{ {jump}; }}"));
            }
            7 if self.c.chance(20) => match ret {
                Some(ty) => {
                    let value = self.expr(ty, 0);
                    let cond = self.expr(Ty::V(Elem::B, 1), 0);
                    self.line(depth, &format!("if {cond} {{ return {value}; }}"));
                }
                None => {
                    let cond = self.expr(Ty::V(Elem::B, 1), 0);
                    self.line(depth, &format!("if {cond} {{ return; }}"));
                }
            },
            _ => self.assignment(depth),
        }
    }

    fn assignment(&mut self, depth: u32) {
        let targets: Vec<Var> = self.scope.iter().chain(&self.state).filter(|v| v.mutable).cloned().collect();
        if targets.is_empty() {
            return;
        }
        let target = self.c.pick(&targets).clone();
        let (place, ty) = match target.ty {
            Ty::V(e, n) if n > 1 && self.c.chance(30) => {
                let k = self.c.below(n as usize);
                (format!("{}.{}", target.name, ["x", "y", "z", "w"][k]), Ty::V(e, 1))
            }
            ty => (target.name.clone(), ty),
        };
        let numeric = matches!(ty, Ty::V(e, _) if e != Elem::B);
        let op = if numeric && self.c.chance(40) { *self.c.pick(&["+=", "-=", "*=", "/="]) } else { "=" };
        let op = if op == "*=" && matches!(ty, Ty::M(_)) { "=" } else { op };
        let value = self.expr(ty, 0);
        self.line(depth, &format!("{place} {op} {value};"));
    }

    fn expr(&mut self, ty: Ty, depth: u32) -> String {
        self.expr_with(ty, depth, false)
    }

    /// An expression of type `ty`; `constant` restricts it to constant expressions.
    fn expr_with(&mut self, ty: Ty, depth: u32, constant: bool) -> String {
        if self.budget == 0 || depth > 5 {
            return self.leaf(ty);
        }
        self.budget -= 1;
        let forms = if constant { 5 } else { 9 };
        match (ty, self.c.below(forms)) {
            (_, 0) => self.leaf(ty),
            (Ty::V(Elem::B, 1), 1 | 2) => self.comparison(depth, constant),
            (Ty::V(e, _), 1 | 2) => self.arithmetic(ty, e, depth, constant),
            (Ty::M(n), 1 | 2) => {
                let (a, b) = (self.expr_with(ty, depth + 1, constant), self.expr_with(ty, depth + 1, constant));
                let op = if constant { "+" } else { *self.c.pick(&["+", "-", "*"]) };
                let _ = n;
                format!("({a} {op} {b})")
            }
            (_, 3) => self.constructor(ty, depth, constant),
            (Ty::V(e, n), 4) => self.access(e, n, depth, constant),
            (_, 5 | 6) => self.builtin(ty, depth),
            (Ty::V(Elem::F, n), 7) if n > 1 => {
                let m = self.expr(Ty::M(n), depth + 1);
                let v = self.expr(ty, depth + 1);
                if self.c.chance(50) { format!("({m} * {v})") } else { format!("({v} * {m})") }
            }
            _ => self.call(ty, depth),
        }
    }

    /// A literal (often at an edge of its type) or a name of type `ty`.
    fn leaf(&mut self, ty: Ty) -> String {
        let names: Vec<String> =
            self.scope.iter().chain(&self.state).filter(|v| v.ty == ty).map(|v| v.name.clone()).collect();
        if !names.is_empty() && self.c.chance(60) {
            return self.c.pick(&names).clone();
        }
        self.literal(ty)
    }

    fn literal(&mut self, ty: Ty) -> String {
        match ty {
            Ty::V(e, 1) => self.scalar_literal(e),
            Ty::V(e, n) => {
                let parts: Vec<String> = (0..n).map(|_| self.scalar_literal(e)).collect();
                if self.c.chance(30) {
                    format!("{}({})", ty.name(), parts[0])
                } else {
                    format!("{}({})", ty.name(), parts.join(", "))
                }
            }
            Ty::M(n) => {
                let parts: Vec<String> = (0..n * n).map(|_| self.scalar_literal(Elem::F)).collect();
                format!("{}({})", ty.name(), parts.join(", "))
            }
        }
    }

    fn scalar_literal(&mut self, e: Elem) -> String {
        let edge = self.c.chance(8);
        match e {
            Elem::F if edge => {
                self.c.pick(&["0.0", "-0.0", "3.4e38", "-3.4e38", "1e-45", "1e30", "-1.0", "2.0"]).to_string()
            }
            Elem::F => format!("{}.{}", self.c.below(10), self.c.below(100)),
            Elem::I if edge => self.c.pick(&["0i", "-1i", "2147483647i", "-2147483648", "31i", "65536i"]).to_string(),
            Elem::I => format!("{}i", self.c.below(20) as i64 - 5),
            Elem::U if edge => self.c.pick(&["0u", "4294967295u", "31u", "32u", "40u", "65536u"]).to_string(),
            Elem::U => format!("{}u", self.c.below(20)),
            Elem::B => self.c.pick(&["true", "false"]).to_string(),
        }
    }

    fn arithmetic(&mut self, ty: Ty, e: Elem, depth: u32, constant: bool) -> String {
        let Ty::V(_, n) = ty else { return self.leaf(ty) };
        if e == Elem::B {
            let op = *self.c.pick(&["&", "|"]);
            let (a, b) = (self.expr_with(ty, depth + 1, constant), self.expr_with(ty, depth + 1, constant));
            return format!("({a} {op} {b})");
        }
        let mut ops = vec!["+", "-", "*", "/", "%"];
        if e != Elem::F {
            ops.extend(["&", "|", "^", "<<", ">>"]);
        }
        let op = *self.c.pick(&ops);
        if op == "<<" || op == ">>" {
            let a = self.expr_with(ty, depth + 1, constant);
            let b = self.expr_with(Ty::V(Elem::U, n), depth + 1, constant);
            return format!("({a} {op} {b})");
        }
        // WGSL mixes a vector with a scalar of its element type in arithmetic.
        let scalar_side = n > 1 && ["+", "-", "*", "/", "%"].contains(&op) && self.c.chance(25);
        let a = self.expr_with(ty, depth + 1, constant);
        let b = if scalar_side {
            self.expr_with(Ty::V(e, 1), depth + 1, constant)
        } else {
            self.expr_with(ty, depth + 1, constant)
        };
        if e == Elem::I && self.c.chance(10) {
            return format!("(-({a}) {op} {b})");
        }
        format!("({a} {op} {b})")
    }

    fn comparison(&mut self, depth: u32, constant: bool) -> String {
        match self.c.below(3) {
            0 => {
                let e = [Elem::F, Elem::I, Elem::U][self.c.below(3)];
                let op = *self.c.pick(&["<", "<=", ">", ">=", "==", "!="]);
                let (a, b) = (
                    self.expr_with(Ty::V(e, 1), depth + 1, constant),
                    self.expr_with(Ty::V(e, 1), depth + 1, constant),
                );
                format!("({a} {op} {b})")
            }
            1 => {
                let op = *self.c.pick(&["&&", "||"]);
                let b1 = Ty::V(Elem::B, 1);
                let (a, b) = (self.expr_with(b1, depth + 1, constant), self.expr_with(b1, depth + 1, constant));
                format!("({a} {op} {b})")
            }
            _ => format!("!{}", self.expr_with(Ty::V(Elem::B, 1), depth + 1, constant)),
        }
    }

    /// A constructor or conversion giving `ty`.
    fn constructor(&mut self, ty: Ty, depth: u32, constant: bool) -> String {
        match ty {
            Ty::V(_, 1) => {
                let from = ELEMS[self.c.below(4)];
                format!("{}({})", ty.name(), self.expr_with(Ty::V(from, 1), depth + 1, constant))
            }
            Ty::V(e, n) => match self.c.below(3) {
                0 => format!("{}({})", ty.name(), self.expr_with(Ty::V(e, 1), depth + 1, constant)),
                1 => {
                    let from = ELEMS[self.c.below(4)];
                    format!("{}({})", ty.name(), self.expr_with(Ty::V(from, n), depth + 1, constant))
                }
                _ => {
                    let first = if n > 2 && self.c.chance(50) { 2 } else { 1 };
                    let head = self.expr_with(Ty::V(e, first), depth + 1, constant);
                    let tail: Vec<String> =
                        (first..n).map(|_| self.expr_with(Ty::V(e, 1), depth + 1, constant)).collect();
                    format!("{}({head}, {})", ty.name(), tail.join(", "))
                }
            },
            Ty::M(n) => {
                let columns: Vec<String> =
                    (0..n).map(|_| self.expr_with(Ty::V(Elem::F, n), depth + 1, constant)).collect();
                format!("{}({})", ty.name(), columns.join(", "))
            }
        }
    }

    /// A swizzle, component or index of a wider vector of element `e`.
    fn access(&mut self, e: Elem, n: u8, depth: u32, constant: bool) -> String {
        let width = (n.max(2) + self.c.below(2) as u8).min(4);
        let base = self.expr_with(Ty::V(e, width), depth + 1, constant);
        if n == 1 && self.c.chance(40) {
            // Now and then one past the end, to reach E0313.
            let end = if self.c.chance(5) { width as usize + 1 } else { width as usize };
            let index = if self.c.chance(60) {
                format!("{}", self.c.below(end))
            } else {
                format!("({} % {width}u)", self.expr_with(Ty::V(Elem::U, 1), depth + 1, constant))
            };
            return format!("{base}[{index}]");
        }
        let letters: String = (0..n).map(|_| ["x", "y", "z", "w"][self.c.below(width as usize)]).collect();
        format!("{base}.{letters}")
    }

    fn builtin(&mut self, ty: Ty, depth: u32) -> String {
        let d = depth + 1;
        match ty {
            Ty::V(Elem::F, n) => {
                let one = [
                    "abs",
                    "floor",
                    "ceil",
                    "fract",
                    "round",
                    "trunc",
                    "sqrt",
                    "inverseSqrt",
                    "exp",
                    "exp2",
                    "log",
                    "log2",
                    "sin",
                    "cos",
                    "tan",
                    "asin",
                    "acos",
                    "atan",
                    "sign",
                ];
                match self.c.below(6) {
                    0 | 1 => {
                        let f = *self.c.pick(&one);
                        format!("{f}({})", self.expr(ty, d))
                    }
                    2 => {
                        let f = *self.c.pick(&["min", "max", "pow", "atan2", "step"]);
                        format!("{f}({}, {})", self.expr(ty, d), self.expr(ty, d))
                    }
                    3 if self.c.chance(40) => self.clamp(ty, d),
                    3 => {
                        let f = *self.c.pick(&["mix", "smoothstep"]);
                        format!("{f}({}, {}, {})", self.expr(ty, d), self.expr(ty, d), self.expr(ty, d))
                    }
                    4 if n == 1 => {
                        let m = 2 + self.c.below(3) as u8;
                        let v = Ty::V(Elem::F, m);
                        match self.c.below(4) {
                            0 => format!("dot({}, {})", self.expr(v, d), self.expr(v, d)),
                            1 => format!("length({})", self.expr(v, d)),
                            2 => format!("distance({}, {})", self.expr(v, d), self.expr(v, d)),
                            _ => format!("determinant({})", self.expr(Ty::M(m), d)),
                        }
                    }
                    4 if n == 3 => {
                        let f = *self.c.pick(&["cross", "reflect"]);
                        format!("{f}({}, {})", self.expr(ty, d), self.expr(ty, d))
                    }
                    4 => format!("normalize({})", self.expr(ty, d)),
                    _ => self.select(ty, n, d),
                }
            }
            Ty::V(Elem::B, 1) => {
                let n = 2 + self.c.below(3) as u8;
                let f = *self.c.pick(&["any", "all"]);
                format!("{f}({})", self.expr(Ty::V(Elem::B, n), d))
            }
            Ty::V(e, n) if e != Elem::B => match self.c.below(4) {
                0 => format!("abs({})", self.expr(ty, d)),
                1 => {
                    let f = *self.c.pick(&["min", "max"]);
                    format!("{f}({}, {})", self.expr(ty, d), self.expr(ty, d))
                }
                2 => self.clamp(ty, d),
                _ if n == 1 => {
                    let m = 2 + self.c.below(3) as u8;
                    format!("dot({}, {})", self.expr(Ty::V(e, m), d), self.expr(Ty::V(e, m), d))
                }
                _ => self.select(ty, n, d),
            },
            Ty::M(n) => format!("transpose({})", self.expr(Ty::M(n), d)),
            Ty::V(_, n) => self.select(ty, n, d),
        }
    }

    /// `clamp(e, low, high)`, almost always with `low <= high` (`min` and `max` of two values).
    fn clamp(&mut self, ty: Ty, depth: u32) -> String {
        let (e, a, b) = (self.expr(ty, depth), self.expr(ty, depth), self.expr(ty, depth));
        if self.c.chance(5) {
            return format!("clamp({e}, {a}, {b})");
        }
        format!("clamp({e}, min({a}, {b}), max({a}, {b}))")
    }

    fn select(&mut self, ty: Ty, n: u8, depth: u32) -> String {
        let cond = if n > 1 && self.c.chance(50) { Ty::V(Elem::B, n) } else { Ty::V(Elem::B, 1) };
        format!("select({}, {}, {})", self.expr(ty, depth), self.expr(ty, depth), self.expr(cond, depth))
    }

    /// A call of a callable library function returning `ty`, else a leaf.
    fn call(&mut self, ty: Ty, depth: u32) -> String {
        let fitting: Vec<Lib> = self.callable.iter().filter(|l| l.ret == ty).cloned().collect();
        if fitting.is_empty() {
            return self.leaf(ty);
        }
        let lib = self.c.pick(&fitting).clone();
        let args: Vec<String> = lib.params.iter().map(|&p| self.expr(p, depth + 1)).collect();
        format!("{}({})", lib.name, args.join(", "))
    }
}

/// What [`check_clean_validates`] found for a module that keeps the promise.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// `check` reported errors: nothing more is promised.
    Rejected,
    /// `check` accepted it, and it lowered, validated and round-tripped through naga's WGSL
    /// front end.
    Validated,
}

/// The checker's promise, for one module given as text: when `check` reports no error, lowering
/// succeeds (no E0901), and the WGSL it writes is accepted by naga's WGSL front end and validator
/// (what wgpu runs when it creates the shader). `Err` describes a broken promise.
pub fn check_clean_validates(text: &str) -> Result<Verdict, String> {
    let mut checked = crate::driver::check_source("generated.vrs", text, None);
    if checked.diags.has_errors() {
        return Ok(Verdict::Rejected);
    }
    let Some(wgsl) = checked.emit_standalone_wgsl() else {
        let diags = checked.diags.sorted();
        return Err(crate::diag::render_plain(&diags, &checked.sources));
    };
    let module = naga::front::wgsl::parse_str(&wgsl)
        .map_err(|e| format!("WGSL front end: {}\n{wgsl}", e.emit_to_string(&wgsl)))?;
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::empty())
        .validate(&module)
        .map_err(|e| format!("WGSL validation: {e:?}\n{wgsl}"))?;
    Ok(Verdict::Validated)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exhausted_bytes_give_a_small_module() {
        let text = generate(&mut Choices::Bytes(&[]));
        assert!(text.contains("pipeline pipe1 in start {"), "{text}");
    }

    #[test]
    fn seeds_are_deterministic() {
        assert_eq!(generate(&mut Choices::Seeded(7)), generate(&mut Choices::Seeded(7)));
        assert_ne!(generate(&mut Choices::Seeded(7)), generate(&mut Choices::Seeded(8)));
    }
}
