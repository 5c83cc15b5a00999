//! The segment march of bricked volumes: variants of a view's sample functions that read each
//! bricked volume's current segment (`NAME_sample_in_segment`) instead of its full lookup, for
//! the entry point's inner sample loop (`compose::entry`).
//!
//! A variant is the function with every call of a full lookup outside a loop turned into a call
//! of the segment read, and every call of a function that makes such a call turned into a call
//! of that function's variant. Calls inside loops keep the full lookup: a loop in a sample
//! function walks away from the sample (a shadow ray, an iso surface's refinement), where the
//! segment would miss on every step. Functions with nothing to turn keep their handle, so a
//! variant costs nothing where no bricked volume is read.

use std::collections::HashMap;

use naga::{Expression as E, Handle, Statement as S};

use crate::lower::{BrickedFns, SegmentFns};

/// The variants of the sample functions and what the entry point calls around them.
pub struct SegmentVariants {
    /// Each bricked volume's segment functions.
    pub volumes: Vec<SegmentFns>,
    /// Variants of the entry plan's `samples`, `contributing` and `sample_end`, in their order.
    pub samples: Vec<Handle<naga::Function>>,
    pub contributing: Vec<Handle<naga::Function>>,
    pub sample_end: Vec<Handle<naga::Function>>,
    /// In each of `samples`, `contributing` and `sample_end`: after how many of its functions
    /// the entry point asks whether the sample read outside a segment (one past the last that
    /// reads one), `None` where none does. Asked right after the read, a sample that missed
    /// runs no more than it must before it is taken back.
    pub checks: [Option<usize>; 3],
    /// The `State` members a sample that read outside a segment is taken back in: the `@ray`
    /// fields written by the functions that run before its last check (the view sets them
    /// after `variants`, from [`SegmentVariants::run_before_last_check`]).
    pub saved: Vec<u32>,
}

impl SegmentVariants {
    /// How many functions of each group run up to the last check, in the order of `checks`:
    /// every function of the groups before the last that checks, and that group's up to its
    /// check. What they write is what a taken-back sample must restore.
    pub fn run_before_last_check(&self) -> [usize; 3] {
        let lengths = [self.samples.len(), self.contributing.len(), self.sample_end.len()];
        let last = self.checks.iter().rposition(Option::is_some);
        std::array::from_fn(|g| match last {
            Some(l) if g < l => lengths[g],
            Some(l) if g == l => self.checks[l].unwrap_or(0),
            _ => 0,
        })
    }
}

/// The variants of `samples`, `contributing` and `sample_end` in `module` for the bricked
/// volumes `bricked`; `None` when no volume has a segment march or no function reads one
/// outside a loop (the entry point then keeps its single sample loop).
pub fn variants(
    module: &mut naga::Module,
    bricked: &[BrickedFns],
    [samples, contributing, sample_end]: [&[Handle<naga::Function>]; 3],
) -> Option<SegmentVariants> {
    let volumes: Vec<SegmentFns> = bricked.iter().filter_map(|b| b.segment).collect();
    let reads: HashMap<_, _> = bricked.iter().filter_map(|b| Some((b.sample, b.segment?.sample))).collect();
    if reads.is_empty() {
        return None;
    }
    let mut rewriter = Rewriter { module, variants: reads };
    let mut variant_of =
        |fns: &[Handle<naga::Function>]| -> Vec<_> { fns.iter().map(|&f| rewriter.variant(f)).collect() };
    let variants = [variant_of(samples), variant_of(contributing), variant_of(sample_end)];
    let originals = [samples, contributing, sample_end];
    let checks: [Option<usize>; 3] = std::array::from_fn(|g| {
        variants[g].iter().zip(originals[g]).rposition(|(variant, original)| variant != original).map(|k| k + 1)
    });
    let [samples, contributing, sample_end] = variants;
    checks.iter().any(Option::is_some).then_some(SegmentVariants {
        samples,
        contributing,
        sample_end,
        volumes,
        checks,
        saved: Vec::new(),
    })
}

/// The calls of a function that were turned: whether any was, and the call results whose
/// expression must name the new callee.
#[derive(Default)]
struct Turned {
    any: bool,
    results: Vec<(Handle<E>, Handle<naga::Function>)>,
}

/// Makes variants, remembering each function's (a full lookup's variant is its segment read; a
/// function with nothing to turn is its own).
struct Rewriter<'m> {
    module: &'m mut naga::Module,
    variants: HashMap<Handle<naga::Function>, Handle<naga::Function>>,
}

impl Rewriter<'_> {
    /// The variant of `function`, made (after the variants it calls, which naga wants declared
    /// before their callers) when it has calls to turn.
    fn variant(&mut self, function: Handle<naga::Function>) -> Handle<naga::Function> {
        if let Some(&known) = self.variants.get(&function) {
            return known;
        }
        let mut copy = self.module.functions[function].clone();
        let mut turned = Turned::default();
        let mut body = std::mem::take(&mut copy.body);
        self.turn_calls(&mut body, false, &mut turned);
        let variant = if !turned.any {
            function
        } else {
            copy.body = body;
            for (result, callee) in turned.results {
                copy.expressions[result] = E::CallResult(callee);
            }
            copy.name = copy.name.map(|n| format!("{n}_in_segment"));
            let span = self.module.functions.get_span(function);
            self.module.functions.append(copy, span)
        };
        self.variants.insert(function, variant);
        variant
    }

    /// Turns the calls in `block` (inside a loop when `in_loop`), noting each call result whose
    /// callee changed.
    fn turn_calls(&mut self, block: &mut naga::Block, in_loop: bool, turned: &mut Turned) {
        for statement in block.iter_mut() {
            match statement {
                S::Call { function, result, .. } if !in_loop => {
                    let variant = self.variant(*function);
                    if variant != *function {
                        *function = variant;
                        turned.any = true;
                        turned.results.extend(result.map(|r| (r, variant)));
                    }
                }
                S::Block(inner) => self.turn_calls(inner, in_loop, turned),
                S::If { accept, reject, .. } => {
                    self.turn_calls(accept, in_loop, turned);
                    self.turn_calls(reject, in_loop, turned);
                }
                S::Switch { cases, .. } => {
                    for case in cases {
                        self.turn_calls(&mut case.body, in_loop, turned);
                    }
                }
                S::Loop { body, continuing, .. } => {
                    self.turn_calls(body, true, turned);
                    self.turn_calls(continuing, true, turned);
                }
                _ => {}
            }
        }
    }
}
