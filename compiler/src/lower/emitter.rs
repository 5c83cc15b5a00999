//! The emit discipline, shared by lowering and the composer's entry point.
//!
//! naga evaluates an expression only where an `Emit` statement covers it, except for the
//! expressions it evaluates on its own (literals, constants, arguments, variable pointers, call
//! results: [`is_pre_emitted`]). An [`Emitter`] appends expressions to a function's arena and
//! keeps the runs of them that still need an `Emit`; before the next statement it pushes one
//! `Emit` per run ([`Emitter::push`]), and at the end of a block whatever is left
//! ([`Emitter::flush`]). It is naga's own `proc::Emitter` (start, then finish before a
//! statement) with the start kept for the caller, so that no expression can be left out.

use naga::{Arena, Block, Expression, Handle, Span, Statement};
use std::ops::Range;

/// Whether naga evaluates `expr` without an `Emit` (and the WGSL writer prints it inline).
pub(crate) fn is_pre_emitted(expr: &Expression) -> bool {
    expr.needs_pre_emit() || matches!(expr, Expression::CallResult(_))
}

/// Appends expressions and turns runs of them into `Emit` statements before each statement.
#[derive(Debug, Default)]
pub(crate) struct Emitter {
    /// Start of the run of expressions appended since the last pre-emitted one, not yet in
    /// `pending`.
    open: Option<u32>,
    /// Runs of appended expressions that need an `Emit` before the next statement.
    pending: Vec<Range<u32>>,
}

impl Emitter {
    /// Appends `expr` to `exprs`. A pre-emitted expression ends the current run; every other
    /// expression joins one.
    pub(crate) fn append(&mut self, exprs: &mut Arena<Expression>, expr: Expression, span: Span) -> Handle<Expression> {
        let len = exprs.len() as u32;
        if is_pre_emitted(&expr) {
            self.close_run(len);
        } else if self.open.is_none() {
            self.open = Some(len);
        }
        exprs.append(expr, span)
    }

    fn close_run(&mut self, end: u32) {
        if let Some(start) = self.open.take()
            && start < end
        {
            self.pending.push(start..end);
        }
    }

    /// Pushes an `Emit` for every run appended since the last flush, each with the span of the
    /// expressions it covers.
    pub(crate) fn flush(&mut self, exprs: &Arena<Expression>, block: &mut Block) {
        self.close_run(exprs.len() as u32);
        for range in self.pending.drain(..) {
            let range = naga::Range::from_index_range(range, exprs);
            let span = Span::total_span(range.clone().map(|h| exprs.get_span(h)));
            block.push(Statement::Emit(range), span);
        }
    }

    /// Pushes `stmt` after the `Emit`s it needs.
    pub(crate) fn push(&mut self, exprs: &Arena<Expression>, block: &mut Block, stmt: Statement, span: Span) {
        self.flush(exprs, block);
        block.push(stmt, span);
    }
}
