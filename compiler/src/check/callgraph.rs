//! The call graph of lib fns: recursion (E0402, found as strongly connected components), then
//! the [`hir::Program`]: functions that checked cleanly and whose callees did too, lib fns in
//! callee-before-caller order, with the call-site tables renumbered to their place in that
//! order (bodies are left as they are: they name call sites, not functions).
//!
//! Every walk here is iterative: a generated program may chain thousands of functions.

use super::Checker;
use super::func::{LibOut, PipeOut};
use crate::diag::{Code, Diagnostic};
use crate::hir;
use rustc_hash::FxHashSet;
use std::collections::VecDeque;

/// The distinct lib fns `lib` calls directly, in order of first call.
fn callees(lib: &Option<LibOut>, n: usize) -> Vec<usize> {
    let mut out: Vec<usize> = Vec::new();
    for &(c, _) in lib.iter().flat_map(|l| &l.calls) {
        if c < n && !out.contains(&c) {
            out.push(c);
        }
    }
    out
}

impl Checker<'_> {
    /// E0402 once per cycle, at the call in the cycle's last function (in source order) that
    /// closes it; every function of the cycle is left out of the program.
    pub(super) fn check_recursion(&mut self, libs: &mut [Option<LibOut>]) {
        let n = libs.len();
        let edges: Vec<Vec<usize>> = libs.iter().map(|l| callees(l, n)).collect();
        for scc in strongly_connected(&edges) {
            let self_call = scc.len() == 1 && scc.iter().all(|&v| edges.get(v).is_some_and(|e| e.contains(&v)));
            if scc.len() < 2 && !self_call {
                continue;
            }
            let members: FxHashSet<usize> = scc.iter().copied().collect();
            let closer = scc.iter().copied().max().unwrap_or(0);
            let call = libs
                .get(closer)
                .and_then(Option::as_ref)
                .and_then(|l| l.calls.iter().find(|(c, _)| members.contains(c)));
            if let Some(&(callee, span)) = call {
                let chain = self.cycle_names(&edges, &members, closer, callee);
                let name = self.libs.get(closer).map_or("", |l| l.name.as_str());
                let mut d =
                    Diagnostic::new(Code::Recursion, span, format!("`{name}` is recursive: {}", chain.join(" -> ")))
                        .with_label("this call closes the cycle");
                for &other in scc.iter().filter(|&&v| v != closer) {
                    if let Some(l) = self.libs.get(other) {
                        d = d.with_secondary(l.name_span, format!("`{}` is part of the cycle", l.name));
                    }
                }
                self.diags.push(
                    d.with_note("VRS has no recursion: GPU shaders have no call stack")
                        .with_help("rewrite the computation with a `for` loop"),
                );
            }
            for v in scc {
                if let Some(Some(l)) = libs.get_mut(v) {
                    l.failed = true;
                }
            }
        }
    }

    /// The names along the cycle `closer -> callee -> ... -> closer`.
    fn cycle_names(
        &self,
        edges: &[Vec<usize>],
        members: &FxHashSet<usize>,
        closer: usize,
        callee: usize,
    ) -> Vec<String> {
        let mut prev: Vec<Option<usize>> = vec![None; edges.len()];
        let mut queue = VecDeque::from([callee]);
        let mut seen = FxHashSet::from_iter([callee]);
        while let Some(v) = queue.pop_front() {
            if v == closer {
                break;
            }
            for &w in edges.get(v).into_iter().flatten() {
                if members.contains(&w) && seen.insert(w) {
                    prev[w] = Some(v);
                    queue.push_back(w);
                }
            }
        }
        let mut path = vec![closer];
        let mut at = closer;
        while at != callee {
            match prev.get(at).copied().flatten() {
                Some(p) if path.len() <= edges.len() => {
                    path.push(p);
                    at = p;
                }
                _ => break,
            }
        }
        path.push(closer);
        path.reverse();
        // path is now closer, callee, ..., closer (reversed back-pointers from closer).
        path.iter().map(|&v| self.libs.get(v).map_or(String::new(), |l| l.name.clone())).collect()
    }
}

/// Tarjan's algorithm, iteratively: the strongly connected components of a graph.
fn strongly_connected(edges: &[Vec<usize>]) -> Vec<Vec<usize>> {
    let n = edges.len();
    let mut index = vec![usize::MAX; n];
    let mut low = vec![0; n];
    let mut on_stack = vec![false; n];
    let mut stack = Vec::new();
    let mut next = 0;
    let mut out = Vec::new();
    for root in 0..n {
        if index[root] != usize::MAX {
            continue;
        }
        let mut work: Vec<(usize, usize)> = vec![(root, 0)];
        index[root] = next;
        low[root] = next;
        next += 1;
        stack.push(root);
        on_stack[root] = true;
        while let Some(top) = work.last_mut() {
            let (v, k) = *top;
            if let Some(&w) = edges[v].get(k) {
                top.1 += 1;
                if index[w] == usize::MAX {
                    index[w] = next;
                    low[w] = next;
                    next += 1;
                    stack.push(w);
                    on_stack[w] = true;
                    work.push((w, 0));
                } else if on_stack[w] {
                    low[v] = low[v].min(index[w]);
                }
                continue;
            }
            work.pop();
            if let Some(&(parent, _)) = work.last() {
                low[parent] = low[parent].min(low[v]);
            }
            if low[v] == index[v] {
                let mut scc = Vec::new();
                while let Some(w) = stack.pop() {
                    on_stack[w] = false;
                    scc.push(w);
                    if w == v {
                        break;
                    }
                }
                out.push(scc);
            }
        }
    }
    out
}

/// The lib fns to keep, callees before callers: those that checked cleanly and whose callees
/// are all kept.
fn kept_in_order(edges: &[Vec<usize>], clean: &[bool]) -> Vec<usize> {
    #[derive(Clone, Copy, PartialEq)]
    enum Mark {
        New,
        Open,
        Kept,
        Dropped,
    }
    let n = edges.len();
    let mut mark = vec![Mark::New; n];
    let mut order = Vec::new();
    for root in 0..n {
        if mark[root] != Mark::New {
            continue;
        }
        mark[root] = Mark::Open;
        let mut work: Vec<(usize, usize)> = vec![(root, 0)];
        while let Some(top) = work.last_mut() {
            let (v, k) = *top;
            if let Some(&w) = edges[v].get(k) {
                top.1 += 1;
                if mark[w] == Mark::New {
                    mark[w] = Mark::Open;
                    work.push((w, 0));
                }
                continue;
            }
            work.pop();
            let keep = clean.get(v).copied().unwrap_or(false) && edges[v].iter().all(|&c| mark[c] == Mark::Kept);
            mark[v] = if keep { Mark::Kept } else { Mark::Dropped };
            if keep {
                order.push(v);
            }
        }
    }
    order
}

/// Builds the program from what checked cleanly.
pub(super) fn assemble(libs: Vec<Option<LibOut>>, pipes: Vec<PipeOut>, removes: Vec<hir::Remove>) -> hir::Program {
    let n = libs.len();
    let edges: Vec<Vec<usize>> = libs.iter().map(|l| callees(l, n)).collect();
    let clean: Vec<bool> = libs.iter().map(|l| l.as_ref().is_some_and(|l| !l.failed)).collect();
    let order = kept_in_order(&edges, &clean);
    let mut new_id: Vec<Option<usize>> = vec![None; n];
    for (i, &id) in order.iter().enumerate() {
        new_id[id] = Some(i);
    }
    let renumber = |id: usize| new_id.get(id).copied().flatten();
    // A kept function's callees are kept (`kept_in_order`), so no site is left unresolved.
    let site = |id: usize| renumber(id).unwrap_or(usize::MAX);
    let mut slots = libs;
    let mut lib_fns = Vec::new();
    for &id in &order {
        let Some(out) = slots.get_mut(id).and_then(Option::take) else { continue };
        let mut f = out.hir;
        f.calls = out.calls.iter().map(|&(c, _)| site(c)).collect();
        lib_fns.push(f);
    }
    let mut pipelines = Vec::new();
    for p in pipes {
        if p.failed || !p.uses.iter().chain(&p.calls).all(|&c| renumber(c).is_some()) {
            continue;
        }
        let Some(placement) = p.placement else { continue };
        pipelines.push(hir::PipelineFn {
            name: p.name,
            module: p.module,
            doc: p.doc,
            placement,
            state: p.state,
            uniforms: p.uniforms,
            uses: p.uses.iter().filter_map(|&u| renumber(u)).collect(),
            locals: p.locals,
            body: p.body,
            calls: p.calls.iter().map(|&c| site(c)).collect(),
            span: p.span,
        });
    }
    hir::Program { lib_fns, pipelines, removes }
}
