//! Names: the item scope of each module (its own consts and lib fns plus those of the modules it
//! imports directly), the local scopes of one function body ([`FnCx`]), and written types.

use super::Checker;
use crate::ast::{self, DeclKind, ItemKind};
use crate::diag::{Code, Diagnostic};
use crate::hir;
use crate::source::Span;
use crate::suggest::did_you_mean;
use crate::types::Type;
use rustc_hash::{FxHashMap, FxHashSet};
use std::path::Path;

/// What a module-level name refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum ItemRef {
    /// Index into [`Checker::consts`].
    Const(usize),
    /// Index into [`Checker::libs`].
    Lib(usize),
}

/// Names declared in the pipeline headers of a graph.
#[derive(Default)]
pub(super) struct DeclaredNames {
    /// The written type (and `@ray`) of each state field, to offer the missing declaration in
    /// E0501.
    pub state_hints: FxHashMap<String, (String, bool)>,
    /// Every uniform name, to explain why a lib fn cannot see one.
    pub uniforms: FxHashSet<String>,
}

#[derive(Default)]
pub(super) struct ModuleScope {
    pub names: FxHashMap<String, ItemRef>,
}

/// A library function of some module, with its resolved signature.
pub(super) struct LibInfo {
    pub module: usize,
    /// Index of the item in its module's AST.
    pub item: usize,
    pub name: String,
    pub name_span: Span,
    pub params: Vec<hir::Param>,
    pub ret: Type,
    /// An error of its own (signature, duplicate, recursion): it is left out of the program.
    pub failed: bool,
}

/// A `const` item and its value, computed on first use.
pub(super) struct ConstInfo {
    pub module: usize,
    pub item: usize,
    pub name: String,
    pub state: ConstState,
}

pub(super) enum ConstState {
    Pending,
    /// Being evaluated: a reference now closes a cycle.
    Evaluating,
    /// `None` when it has an error (already reported).
    Done(Option<hir::ConstValue>),
}

/// One module-level name defined in a module, in source order.
struct OwnItem {
    name: String,
    item: ItemRef,
    span: Span,
}

impl Checker<'_> {
    /// Gives every lib fn and const of the graph its id. (Pipeline functions are not in the item
    /// scope: two of one name clash only if they land in the same step, which the composer sees.)
    pub(super) fn collect_items(&mut self) {
        let graph = self.graph;
        for (m, module) in graph.modules.iter().enumerate() {
            for (i, item) in module.ast.items.iter().enumerate() {
                match &item.kind {
                    ItemKind::LibFn(f) => self.libs.push(LibInfo {
                        module: m,
                        item: i,
                        name: f.name.name.clone(),
                        name_span: f.name.span,
                        params: Vec::new(),
                        ret: Type::Error,
                        failed: false,
                    }),
                    ItemKind::Const(c) => self.consts.push(ConstInfo {
                        module: m,
                        item: i,
                        name: c.name.name.clone(),
                        state: ConstState::Pending,
                    }),
                    _ => {}
                }
            }
        }
    }

    /// Builds each module's item scope: own items first, then those of its direct imports.
    pub(super) fn build_scopes(&mut self) {
        let own = self.own_items();
        let graph = self.graph;
        for (m, module) in graph.modules.iter().enumerate() {
            let mut scope = ModuleScope::default();
            let mut spans: FxHashMap<String, (Span, Option<usize>)> = FxHashMap::default();
            for it in own.get(m).into_iter().flatten() {
                if let Some(&(first, _)) = spans.get(&it.name) {
                    self.diags.push(duplicate(&it.name, "name", it.span, first));
                    self.fail_item(it.item);
                    continue;
                }
                spans.insert(it.name.clone(), (it.span, None));
                scope.names.insert(it.name.clone(), it.item);
            }
            for &imported in &module.imports {
                for it in own.get(imported).into_iter().flatten() {
                    match spans.get(&it.name).copied() {
                        None => {
                            spans.insert(it.name.clone(), (it.span, Some(imported)));
                            scope.names.insert(it.name.clone(), it.item);
                        }
                        Some((first, None)) => {
                            let d = self.import_clash_with_local(m, imported, &it.name, first, it.span);
                            self.diags.push(d);
                            if let Some(local) = scope.names.get(&it.name).copied() {
                                self.fail_item(local);
                            }
                        }
                        Some((first, Some(earlier))) if earlier != imported => {
                            let d = self.import_clash(m, earlier, imported, &it.name, first, it.span);
                            self.diags.push(d);
                        }
                        Some(_) => {}
                    }
                }
            }
            self.scopes.push(scope);
        }
    }

    /// The names declared in every pipeline header of the graph, gathered on first use: only
    /// help texts of errors need them.
    pub(super) fn declared_names(&mut self) -> &DeclaredNames {
        let (graph, sources) = (self.graph, self.sources);
        self.declared.get_or_insert_with(|| {
            let mut names = DeclaredNames::default();
            for module in &graph.modules {
                for item in &module.ast.items {
                    let ItemKind::Pipeline(p) = &item.kind else { continue };
                    for d in &p.decls {
                        match &d.kind {
                            DeclKind::State { ray, name, ty, .. } => {
                                let written = sources.snippet(ty.span).to_string();
                                if !written.is_empty() && Type::from_name(&written).is_some() {
                                    names.state_hints.entry(name.name.clone()).or_insert((written, *ray));
                                }
                            }
                            DeclKind::Uniform { name, .. } => {
                                names.uniforms.insert(name.name.clone());
                            }
                            DeclKind::Use { .. } => {}
                        }
                    }
                }
            }
            names
        })
    }

    fn own_items(&self) -> Vec<Vec<OwnItem>> {
        let mut own: Vec<Vec<OwnItem>> = self.graph.modules.iter().map(|_| Vec::new()).collect();
        for (id, lib) in self.libs.iter().enumerate() {
            if let Some(list) = own.get_mut(lib.module) {
                list.push(OwnItem { name: lib.name.clone(), item: ItemRef::Lib(id), span: lib.name_span });
            }
        }
        for (id, c) in self.consts.iter().enumerate() {
            let span = self.const_name_span(id);
            if let Some(list) = own.get_mut(c.module) {
                list.push(OwnItem { name: c.name.clone(), item: ItemRef::Const(id), span });
            }
        }
        for list in &mut own {
            list.retain(|it| !it.name.is_empty());
            list.sort_by_key(|it| it.span.start);
        }
        own
    }

    fn const_name_span(&self, id: usize) -> Span {
        match self.const_item(id) {
            Some(c) => c.name.span,
            None => Span::DUMMY,
        }
    }

    /// The AST of const `id`.
    pub(super) fn const_item(&self, id: usize) -> Option<&ast::ConstItem> {
        let info = self.consts.get(id)?;
        match &self.graph.modules.get(info.module)?.ast.items.get(info.item)?.kind {
            ItemKind::Const(c) => Some(c),
            _ => None,
        }
    }

    /// The AST of lib fn `id`.
    pub(super) fn lib_item(&self, id: usize) -> Option<(&ast::Item, &ast::LibFn)> {
        let info = self.libs.get(id)?;
        let item = self.graph.modules.get(info.module)?.ast.items.get(info.item)?;
        match &item.kind {
            ItemKind::LibFn(f) => Some((item, f)),
            _ => None,
        }
    }

    /// A duplicate lib fn is left out of the program (calls resolve to the first definition).
    fn fail_item(&mut self, item: ItemRef) {
        if let ItemRef::Lib(id) = item
            && let Some(lib) = self.libs.get_mut(id)
        {
            lib.failed = true;
        }
    }

    fn import_clash_with_local(&self, m: usize, imported: usize, name: &str, local: Span, other: Span) -> Diagnostic {
        let from = self.module_name(imported);
        let mut d = Diagnostic::new(
            Code::Duplicate,
            local,
            format!("`{name}` is defined in this module and also imported from `{from}`"),
        )
        .with_label("defined here")
        .with_secondary(other, "also defined here");
        if let Some(span) = self.import_span(m, imported) {
            d = d.with_secondary(span, "imported here");
        }
        d.with_help(format!("rename one of the two definitions of `{name}`"))
    }

    fn import_clash(&self, m: usize, earlier: usize, later: usize, name: &str, first: Span, other: Span) -> Diagnostic {
        let (a, b) = (self.module_name(earlier), self.module_name(later));
        let primary = self.import_span(m, later).unwrap_or(other);
        Diagnostic::new(Code::Duplicate, primary, format!("`{name}` is imported from both `{a}` and `{b}`"))
            .with_label(format!("this import brings a second `{name}`"))
            .with_secondary(first, "first definition")
            .with_secondary(other, "second definition")
            .with_help(format!("rename one of the two definitions of `{name}`"))
    }

    /// The `import` item of module `m` that loaded module `target`, if it can be found again.
    fn import_span(&self, m: usize, target: usize) -> Option<Span> {
        let module = self.graph.modules.get(m)?;
        let target_module = self.graph.modules.get(target)?;
        let target_path = self.sources.file(target_module.file).path.clone();
        let dir = self.sources.file(module.file).path.as_deref().and_then(Path::parent).map(Path::to_path_buf);
        module.ast.items.iter().find_map(|item| match &item.kind {
            ItemKind::Import(ast::Import::Path { path, span }) => {
                let full = dir.as_ref().map_or_else(|| Path::new(path).to_path_buf(), |d| d.join(path));
                let full = full.canonicalize().unwrap_or(full);
                (target_path.as_deref() == Some(full.as_path())).then_some(*span)
            }
            ItemKind::Import(ast::Import::Std { path }) => {
                let name = path.iter().map(|p| p.name.as_str()).collect::<Vec<_>>().join("::");
                let span = path.first().map(|p| p.span)?.to(path.last().map(|p| p.span)?);
                (target_module.std_name.as_deref() == Some(name.as_str())).then_some(span)
            }
            _ => None,
        })
    }

    /// Resolves a written type; reports E0206 and gives [`Type::Error`] for an unknown one.
    pub(super) fn resolve_type(&mut self, t: &ast::TypeExpr) -> Type {
        let found = match t.args.as_slice() {
            [] => Type::from_name(&t.name.name),
            [arg] if arg.args.is_empty() => {
                Type::from_name(&arg.name.name).and_then(|a| Type::from_generic(&t.name.name, a))
            }
            _ => None,
        };
        if let Some(ty) = found {
            return ty;
        }
        if t.name.name.is_empty() {
            return Type::Error; // the parser already reported it
        }
        let written = self.show(t.span);
        let mut d = Diagnostic::new(Code::UnknownType, t.span, format!("unknown type `{written}`"))
            .with_label("not a VRS type");
        if Type::is_generic_name(&t.name.name) && t.args.is_empty() {
            d = d.with_help(format!("give the component type: `{0}f` or `{0}<f32>`", t.name.name));
        } else if let Some(best) = did_you_mean(&t.name.name, type_names().iter().map(String::as_str)) {
            d = d.with_help(format!("did you mean `{best}`?"));
        } else {
            d = d.with_note("types: bool, i32, u32, f32, vecNf/vecNi/vecNu, matCxRf, volume, tf");
        }
        self.diags.push(d);
        Type::Error
    }
}

/// Every type name VRS knows, for suggestions.
fn type_names() -> Vec<String> {
    let mut names: Vec<String> = ["bool", "i32", "u32", "f32", "volume", "tf"].map(String::from).to_vec();
    for n in 2..=4 {
        for s in ["f", "i", "u"] {
            names.push(format!("vec{n}{s}"));
        }
        for r in 2..=4 {
            names.push(format!("mat{n}x{r}f"));
        }
    }
    names
}

/// E0203 at the later definition, pointing at the earlier one.
pub(super) fn duplicate(name: &str, what: &str, later: Span, earlier: Span) -> Diagnostic {
    Diagnostic::new(Code::Duplicate, later, format!("{what} `{name}` is defined twice in the same scope"))
        .with_label("second definition")
        .with_secondary(earlier, "first defined here")
        .with_help(format!("rename one of them, or remove one definition of `{name}`"))
}

/// What kind of function a [`FnCx`] checks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum FnKind {
    Lib,
    Pipeline,
    /// A constant expression: a `const` item, a default or a range bound.
    Const,
}

/// What a local name refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Binding {
    Local(hir::LocalId),
    Param(usize),
    Uniform(usize),
}

/// How a local was introduced, for the assignment rules.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum LocalKind {
    Let,
    Var,
    Loop,
}

pub(super) struct UniformSlot {
    pub name: String,
    pub ty: Type,
    pub read: bool,
}

pub(super) struct StateSlot {
    pub name: String,
    pub ty: Type,
    pub read: bool,
    pub written: bool,
    /// The first `state.NAME` of the body that reads the field.
    pub first_read: Option<Span>,
}

/// One name of a `use` list.
pub(super) struct UseSlot {
    pub lib: usize,
    pub span: Span,
    pub called: bool,
}

/// Everything known while checking one function body (or one constant expression).
pub(super) struct FnCx {
    pub kind: FnKind,
    pub module: usize,
    /// The function's name, for messages.
    pub name: String,
    /// A lib fn's return type; `Void` for pipelines and constants.
    pub ret: Type,
    /// Innermost last. Scope 0 holds parameters or uniforms and the body's top-level names.
    scopes: Vec<FxHashMap<String, (Binding, Span)>>,
    pub locals: Vec<hir::Local>,
    pub local_kinds: Vec<LocalKind>,
    pub params: Vec<hir::Param>,
    pub uniforms: Vec<UniformSlot>,
    pub state: Vec<StateSlot>,
    pub uses: Vec<UseSlot>,
    /// Every call site of a lib fn (`hir::ExprKind::CallLib::site` indexes it), with the
    /// callee's span (for the recursion error).
    pub calls: Vec<(usize, Span)>,
    /// Enclosing `for` loops.
    pub loops: u32,
    pub failed: bool,
    /// E0105 was reported for this function already.
    pub too_deep: bool,
    /// The parser dropped a statement of this body: it may have declared names, so unknown
    /// names after it are not reported again.
    pub lost_statement: bool,
    /// Missing names already reported in this function (`state.F`, names, `use`s): a missing
    /// declaration is one mistake however often it is used.
    pub reported: FxHashSet<String>,
    /// `let` locals whose value WGSL sees as a constant at every use (see `constfold`).
    pub inlined_lets: FxHashMap<hir::LocalId, hir::ConstValue>,
    /// The value of each `let` bound to a constant or a constructor: naga's validator looks
    /// through such a `let` for a zero divisor or a too-large shift amount.
    pub let_values: FxHashMap<hir::LocalId, hir::Expr>,
}

impl FnCx {
    pub fn new(kind: FnKind, module: usize, name: &str, ret: Type) -> FnCx {
        FnCx {
            kind,
            module,
            name: name.to_string(),
            ret,
            scopes: vec![FxHashMap::default()],
            locals: Vec::new(),
            local_kinds: Vec::new(),
            params: Vec::new(),
            uniforms: Vec::new(),
            state: Vec::new(),
            uses: Vec::new(),
            calls: Vec::new(),
            loops: 0,
            failed: false,
            too_deep: false,
            lost_statement: false,
            reported: FxHashSet::default(),
            inlined_lets: FxHashMap::default(),
            let_values: FxHashMap::default(),
        }
    }

    /// The placeholder for an expression with an error: the function is marked failed, so this
    /// never reaches lowering.
    pub fn poison(&mut self, span: Span) -> hir::Expr {
        self.failed = true;
        let kind = hir::ExprKind::Const(hir::ConstValue { ty: Type::Error, components: Vec::new() });
        hir::Expr { kind, ty: Type::Error, span }
    }

    pub fn push_scope(&mut self) {
        self.scopes.push(FxHashMap::default());
    }

    pub fn pop_scope(&mut self) {
        if self.scopes.len() > 1 {
            self.scopes.pop();
        }
    }

    /// The innermost binding of `name`, with the span of its declaration.
    pub fn lookup(&self, name: &str) -> Option<(Binding, Span)> {
        self.scopes.iter().rev().find_map(|s| s.get(name).copied())
    }

    /// Declares `name` in the innermost scope; `Err` holds the span of an earlier declaration
    /// of the same name in that scope.
    pub fn declare(&mut self, name: &str, binding: Binding, span: Span) -> Result<(), Span> {
        let Some(scope) = self.scopes.last_mut() else { return Ok(()) };
        if let Some(&(_, earlier)) = scope.get(name) {
            return Err(earlier);
        }
        scope.insert(name.to_string(), (binding, span));
        Ok(())
    }

    /// Adds a local variable (not yet visible: see [`FnCx::declare`]).
    pub fn add_local(&mut self, name: &str, ty: Type, kind: LocalKind, span: Span) -> hir::LocalId {
        // Loop variables are mutable for lowering (the loop increments them), not for the user.
        let mutable = kind != LocalKind::Let;
        self.locals.push(hir::Local { name: name.to_string(), ty, mutable, span });
        self.local_kinds.push(kind);
        self.locals.len() - 1
    }

    /// True the first time `key` is seen: report it then, stay quiet afterwards.
    pub fn first_report(&mut self, key: String) -> bool {
        self.reported.insert(key)
    }

    /// Every local name visible now, for suggestions.
    pub fn visible_names(&self) -> Vec<String> {
        self.scopes.iter().flat_map(|s| s.keys().cloned()).collect()
    }
}
