//! Items (`import`, `const`, `lib fn`, `pipeline`, `remove`) and the module they make.

use super::decl::body;
use super::depth::{Dx, St};
use super::expr::{expression, ident, type_expr, value};
use super::recovery::skip_item;
use super::stmt::{annotation, statements};
use super::{Extra, GrammarError, Rule, Tokens, span_of};
use crate::ast::{
    Block, ConstItem, Import, Item, ItemKind, LibFn, Param, PipelineFn, Placement, PlacementKind, Remove, StepPath,
    TypeExpr,
};
use crate::lexer::Token as T;
use chumsky::prelude::*;

/// A file's items; a broken item is skipped up to the next item keyword outside brackets.
pub(super) fn module<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>() -> impl Parser<'t, I, Vec<Item>, Extra<Er>> {
    let ty = type_expr();
    let expr = expression(ty.clone());
    let statements = statements(expr.clone(), ty.clone());
    let item = choice((
        import(),
        const_item(expr.clone(), ty.clone()),
        lib_fn(ty.clone(), statements.block),
        pipeline(expr, ty, statements.stmt),
        remove(),
    ))
    .map_with(|kind, e| Some(Item { kind, doc: None, span: span_of(e.span()) }))
    .recover_with(via_parser(skip_item()));
    item.repeated().collect::<Vec<Option<Item>>>().map(|items| items.into_iter().flatten().collect())
}

/// `import "path";` or `import std::NAME;`
fn import<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>() -> impl Parser<'t, I, ItemKind, Extra<Er>> + Clone {
    let string = select_ref! { T::Str(path) = e => Import::Path { path: path.clone(), span: span_of(e.span()) } }
        .labelled("string literal");
    let std_path = select_ref! { T::Ident(name) if name == "std" => () }
        .labelled("`std`")
        .ignore_then(just(T::ColonColon).ignore_then(ident()).repeated().at_least(1).collect::<Vec<_>>())
        .map(|path| Import::Std { path });
    just(T::Import).ignore_then(choice((string, std_path))).then_ignore(just(T::Semi)).map(ItemKind::Import)
}

/// `const NAME[: TYPE] = VALUE;`
fn const_item<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    expr: Rule<'t, I, Dx, Er>,
    ty: Rule<'t, I, TypeExpr, Er>,
) -> impl Parser<'t, I, ItemKind, Extra<Er>> + Clone {
    just(T::Const)
        .ignore_then(ident())
        .then(annotation(ty))
        .then_ignore(just(T::Eq))
        .then(value(expr))
        .then_ignore(just(T::Semi))
        .map(|((name, ty), value)| ItemKind::Const(ConstItem { name, ty, value }))
}

/// `lib fn NAME(PARAM: TYPE, ...)[ -> TYPE] { ... }`
fn lib_fn<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    ty: Rule<'t, I, TypeExpr, Er>,
    block: Rule<'t, I, (Block, u32), Er>,
) -> impl Parser<'t, I, ItemKind, Extra<Er>> + Clone {
    let param = ident().then_ignore(just(T::Colon)).then(ty.clone()).map_with(|(name, ty), e| Param {
        name,
        ty,
        span: span_of(e.span()),
    });
    let params = param
        .separated_by(just(T::Comma))
        .allow_trailing()
        .collect::<Vec<_>>()
        .delimited_by(just(T::LParen), just(T::RParen));
    just(T::Lib)
        .ignore_then(just(T::Fn))
        .ignore_then(ident())
        .then(params)
        .then(just(T::Arrow).ignore_then(ty).or_not())
        .then(block)
        .map(|(((name, params), ret), (body, _))| ItemKind::LibFn(LibFn { name, params, ret, body }))
}

/// `pipeline NAME PLACEMENT { ... }`
fn pipeline<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>(
    expr: Rule<'t, I, Dx, Er>,
    ty: Rule<'t, I, TypeExpr, Er>,
    stmt: Rule<'t, I, St, Er>,
) -> impl Parser<'t, I, ItemKind, Extra<Er>> + Clone {
    just(T::Pipeline)
        .ignore_then(ident())
        .then(placement())
        .then(body(expr, ty, stmt))
        .map(|((name, placement), (decls, body))| ItemKind::Pipeline(PipelineFn { name, placement, decls, body }))
}

/// `remove STEP_PATH[ when active];`
fn remove<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>() -> impl Parser<'t, I, ItemKind, Extra<Er>> + Clone {
    just(T::Remove)
        .ignore_then(step_path())
        .then(when_active())
        .then_ignore(just(T::Semi))
        .map(|(target, when_active)| ItemKind::Remove(Remove { target, when_active }))
}

/// `in|before|after|replace STEP_PATH[ when active]`
fn placement<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>() -> impl Parser<'t, I, Placement, Extra<Er>> + Clone {
    choice((
        just(T::In).to(PlacementKind::In),
        just(T::Before).to(PlacementKind::Before),
        just(T::After).to(PlacementKind::After),
        just(T::Replace).to(PlacementKind::Replace),
    ))
    .then(step_path())
    .then(when_active())
    .map_with(|((kind, target), when_active), e| Placement { kind, target, when_active, span: span_of(e.span()) })
}

/// `shading.lights`, `classification.additional[$]`
fn step_path<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>() -> impl Parser<'t, I, StepPath, Extra<Er>> + Clone {
    ident()
        .separated_by(just(T::Dot))
        .at_least(1)
        .collect::<Vec<_>>()
        .then(ident().delimited_by(just(T::LBracket), just(T::RBracket)).or_not())
        .map_with(|(segments, substep), e| StepPath { segments, substep, span: span_of(e.span()) })
}

/// `when active`, optional.
fn when_active<'t, I: Tokens<'t>, Er: GrammarError<'t, I>>() -> impl Parser<'t, I, bool, Extra<Er>> + Clone {
    just(T::When).then(just(T::Active)).or_not().map(|w| w.is_some())
}
