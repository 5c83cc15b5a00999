//! Whole functions: lib-fn signatures, lib-fn bodies (with the "returns on every path" rule)
//! and pipeline functions (placement, header, body, unused declarations).

use super::Checker;
use super::scope::{Binding, FnCx, FnKind, duplicate};
use crate::ast::{self, ItemKind};
use crate::diag::{Code, Diagnostic};
use crate::hir;
use crate::source::Span;
use crate::types::Type;
use std::sync::Arc;

/// A checked lib fn, before the program is assembled (ids are still provisional).
#[derive(Clone)]
pub(super) struct LibOut {
    /// Its `calls` are filled in when the program is assembled, from `calls` here.
    pub hir: hir::LibFn,
    /// Every call site of the body, with the callee's span.
    pub calls: Vec<(usize, Span)>,
    pub failed: bool,
}

/// A checked pipeline function, before the program is assembled.
#[derive(Clone)]
pub(super) struct PipeOut {
    pub module: usize,
    pub name: String,
    pub doc: Option<String>,
    pub placement: Option<hir::Placement>,
    pub state: Vec<hir::StateDecl>,
    pub uniforms: Vec<hir::UniformDecl>,
    pub uses: Vec<usize>,
    pub locals: Vec<hir::Local>,
    pub body: Arc<hir::Block>,
    /// The callee of every call site of the body.
    pub calls: Vec<usize>,
    pub span: Span,
    pub failed: bool,
}

impl Checker<'_> {
    /// Resolves the parameter and return types of every lib fn, before any body is checked.
    pub(super) fn resolve_signatures(&mut self) {
        for id in 0..self.libs.len() {
            if let Some(cached) = self.std.as_ref().and_then(|std| std.signature(id))
                && let Some(lib) = self.libs.get_mut(id)
            {
                lib.params = cached.params.clone();
                lib.ret = cached.ret;
                lib.failed |= cached.failed;
                continue;
            }
            let Some((_, f)) = self.lib_item(id) else { continue };
            let f: &ast::LibFn = f;
            let (params, ret) = (f.params.clone(), f.ret.clone());
            let mut failed = false;
            let mut checked: Vec<hir::Param> = Vec::new();
            for p in &params {
                let ty = self.resolve_type(&p.ty);
                failed |= ty.is_error();
                if let Some(first) = checked.iter().find(|q| q.name == p.name.name) {
                    self.diags.push(duplicate(&p.name.name, "parameter", p.name.span, first.span));
                    failed = true;
                }
                checked.push(hir::Param { name: p.name.name.clone(), ty, span: p.name.span });
            }
            let ret = match &ret {
                None => Type::Void,
                Some(t) => self.return_type(t),
            };
            failed |= ret.is_error();
            if let Some(lib) = self.libs.get_mut(id) {
                lib.params = checked;
                lib.ret = ret;
                lib.failed |= failed;
            }
        }
    }

    fn return_type(&mut self, t: &ast::TypeExpr) -> Type {
        let ty = self.resolve_type(t);
        if !ty.is_resource() {
            return ty;
        }
        self.diags.push(
            Diagnostic::new(Code::ResourceMisuse, t.span, format!("a library function cannot return a `{ty}`"))
                .with_label("not a plain value")
                .with_help(format!("return what you computed from the {ty} instead (e.g. a sampled value)")),
        );
        Type::Error
    }

    /// Checks every lib fn body; the result is indexed by lib fn id.
    pub(super) fn check_lib_fns(&mut self) -> Vec<Option<LibOut>> {
        (0..self.libs.len()).map(|id| self.check_lib_fn(id)).collect()
    }

    fn check_lib_fn(&mut self, id: usize) -> Option<LibOut> {
        let graph = self.graph;
        let info = self.libs.get(id)?;
        if let Some(cached) = self.std.as_ref().and_then(|std| std.lib_fn(id, info.module)) {
            return cached;
        }
        let (module, params, ret, sig_failed) = (info.module, info.params.clone(), info.ret, info.failed);
        let item = graph.modules.get(module)?.ast.items.get(info.item)?;
        let ItemKind::LibFn(lf) = &item.kind else { return None };
        let mut f = FnCx::new(FnKind::Lib, module, &lf.name.name, ret);
        for (i, p) in params.iter().enumerate() {
            let _ = f.declare(&p.name, Binding::Param(i), p.span); // duplicates were reported with the signature
        }
        f.params = params.clone();
        let (body, flow) = self.block(&mut f, &lf.body, false);
        if ret != Type::Void && !ret.is_error() && !flow.returns && !f.too_deep {
            let d = Diagnostic::new(
                Code::MissingReturn,
                lf.name.span,
                format!("`{}` can reach its end without returning a value", lf.name.name),
            )
            .with_label(format!("declared to return {ret}"))
            .with_help(format!("end every path of `{}` with `return ...;` (a {ret})", lf.name.name));
            self.emit(&mut f, d);
        }
        let hir = hir::LibFn {
            name: lf.name.name.clone(),
            module,
            doc: item.doc.clone(),
            params,
            ret,
            locals: f.locals,
            body: Arc::new(body),
            calls: Vec::new(),
            span: item.span,
        };
        Some(LibOut { hir, calls: f.calls, failed: f.failed || sig_failed })
    }

    /// Checks every pipeline function and `remove` item, in module order then source order.
    pub(super) fn check_pipelines(&mut self) -> (Vec<PipeOut>, Vec<hir::Remove>) {
        let graph = self.graph;
        let mut pipes = Vec::new();
        let mut removes = Vec::new();
        for (m, module) in graph.modules.iter().enumerate() {
            if let Some((cached_pipes, cached_removes)) = self.std.as_ref().and_then(|std| std.module_items(m)) {
                pipes.extend(cached_pipes);
                removes.extend(cached_removes);
                continue;
            }
            for item in &module.ast.items {
                match &item.kind {
                    ItemKind::Pipeline(p) => pipes.push(self.check_pipeline(m, item, p)),
                    ItemKind::Remove(r) => removes.extend(self.remove_item(m, r, item.span)),
                    _ => {}
                }
            }
        }
        (pipes, removes)
    }

    fn check_pipeline(&mut self, module: usize, item: &ast::Item, p: &ast::PipelineFn) -> PipeOut {
        let placement = self.placement(&p.placement);
        let mut f = FnCx::new(FnKind::Pipeline, module, &p.name.name, Type::Void);
        let (mut state, uniforms) = self.declarations(&mut f, &p.decls);
        let (body, _) = self.block(&mut f, &p.body, false);
        for (decl, slot) in state.iter_mut().zip(&f.state) {
            decl.read = slot.read;
            decl.written = slot.written;
            decl.first_read = slot.first_read;
        }
        if !f.failed {
            self.unused_warnings(&f, &state, &uniforms);
        }
        PipeOut {
            module,
            name: p.name.name.clone(),
            doc: item.doc.clone(),
            failed: f.failed || placement.is_none() || p.name.name.is_empty(),
            placement,
            state,
            uniforms,
            uses: f.uses.iter().map(|u| u.lib).collect(),
            locals: f.locals,
            body: Arc::new(body),
            calls: f.calls.iter().map(|c| c.0).collect(),
            span: item.span,
        }
    }
}
