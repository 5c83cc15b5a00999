//! The standard modules, checked once per process.
//!
//! A standard module's checked functions depend only on that module and the standard modules
//! it imports, never on the user's modules, and every [`SourceMap`] holds the standard files at
//! the same offsets. So the checker checks the whole standard library once, keeps each module's
//! lib fns, pipeline functions and `remove` items, and every later run copies them into its own
//! graph ([`StdReuse`]) instead of checking them again: only the ids of lib fns and modules
//! differ from graph to graph, and bodies hold neither (they are shared, not copied).
//!
//! What depends on which modules a graph holds is still done per graph: item scopes (for the
//! user's modules), conflicts between declarations, recursion and the program's assembly.

use super::Checker;
use super::func::{LibOut, PipeOut};
use super::scope::LibInfo;
use crate::diag::Diagnostics;
use crate::hir;
use crate::loader::{Loader, ModuleGraph};
use crate::source::SourceMap;
use crate::stdlib;
use std::sync::OnceLock;

/// The checked items of every standard module, by [`stdlib::index`].
pub(super) struct StdChecked {
    modules: Vec<StdModule>,
    /// How many lib fns the standard library has (ids of the cached run are below this).
    lib_count: usize,
}

/// One standard module, checked.
#[derive(Default)]
struct StdModule {
    /// The id (in the cached run) of its first lib fn; the others follow in source order.
    first_lib: usize,
    /// Its lib fns in source order: signature and checked body (ids of the cached run).
    libs: Vec<(LibInfo, Option<LibOut>)>,
    pipes: Vec<PipeOut>,
    removes: Vec<hir::Remove>,
}

/// The [`stdlib::index`] of each module of `graph` that is a standard module.
fn std_indices(graph: &ModuleGraph) -> Vec<Option<usize>> {
    graph.modules.iter().map(|m| m.std_name.as_deref().and_then(stdlib::index)).collect()
}

/// The standard library checked once, or `None` if it does not check without a diagnostic (a
/// broken standard library is then checked, and reported, in every run).
pub(super) fn std_checked() -> Option<&'static StdChecked> {
    static CHECKED: OnceLock<Option<StdChecked>> = OnceLock::new();
    CHECKED.get_or_init(check_std).as_ref()
}

fn check_std() -> Option<StdChecked> {
    let mut sources = SourceMap::new();
    let mut diags = Diagnostics::new();
    let graph = {
        let mut loader = Loader::new(&mut sources, &mut diags);
        for name in stdlib::names() {
            loader.load_root_std(name)?;
        }
        loader.finish()
    };
    let std_index: Vec<usize> = std_indices(&graph).into_iter().collect::<Option<_>>()?;
    // Conflicts between declarations are left out: two standard modules that never share a view
    // may declare a field differently; each graph checks the conflicts of the modules it holds.
    let mut cx = Checker::new(&graph, &sources, &mut diags);
    cx.collect_items();
    let checked = cx.check_items(false);
    let infos = std::mem::take(&mut cx.libs);
    drop(cx);
    if !diags.is_empty() {
        return None;
    }
    let mut modules: Vec<StdModule> = stdlib::names().map(|_| StdModule::default()).collect();
    let lib_count = infos.len();
    for (id, (info, out)) in infos.into_iter().zip(checked.libs).enumerate() {
        let module = modules.get_mut(*std_index.get(info.module)?)?;
        if module.libs.is_empty() {
            module.first_lib = id;
        }
        module.libs.push((info, out));
    }
    for pipe in checked.pipes {
        modules.get_mut(*std_index.get(pipe.module)?)?.pipes.push(pipe);
    }
    for remove in checked.removes {
        modules.get_mut(*std_index.get(remove.module)?)?.removes.push(remove);
    }
    Some(StdChecked { modules, lib_count })
}

/// How one graph reuses the cached standard modules.
pub(super) struct StdReuse {
    cache: &'static StdChecked,
    /// For each module of the graph: its [`stdlib::index`] when it is a standard module.
    module_std: Vec<Option<usize>>,
    /// Cached lib fn id → the same function's id in this graph.
    lib_ids: Vec<Option<usize>>,
    /// This graph's lib fn id → (standard module, position among its lib fns), for standard ones.
    lib_keys: Vec<Option<(usize, usize)>>,
}

impl StdReuse {
    /// Matches the graph's standard modules and lib fns (`libs`, in the checker's id order)
    /// with the cached ones; `None` when they differ (the graph is then checked in full).
    pub(super) fn new(cache: &'static StdChecked, graph: &ModuleGraph, libs: &[LibInfo]) -> Option<StdReuse> {
        let module_std = std_indices(graph);
        let mut lib_ids = vec![None; cache.lib_count];
        let mut lib_keys = vec![None; libs.len()];
        let mut next_in_module: Vec<usize> = vec![0; graph.modules.len()];
        for (id, lib) in libs.iter().enumerate() {
            let Some(s) = module_std.get(lib.module).copied().flatten() else { continue };
            let k = next_in_module[lib.module];
            next_in_module[lib.module] += 1;
            let module = cache.modules.get(s)?;
            let (cached, _) = module.libs.get(k)?;
            if cached.name != lib.name {
                return None;
            }
            *lib_ids.get_mut(module.first_lib + k)? = Some(id);
            lib_keys[id] = Some((s, k));
        }
        Some(StdReuse { cache, module_std, lib_ids, lib_keys })
    }

    /// Whether module `m` of the graph is a cached standard module.
    pub(super) fn has_module(&self, m: usize) -> bool {
        self.module_std.get(m).is_some_and(Option::is_some)
    }

    fn lib(&self, id: usize) -> Option<&'static (LibInfo, Option<LibOut>)> {
        let (s, k) = self.lib_keys.get(id).copied().flatten()?;
        self.cache.modules.get(s)?.libs.get(k)
    }

    /// The cached signature of lib fn `id` of the graph: (parameters, return type, failed).
    pub(super) fn signature(&self, id: usize) -> Option<&'static LibInfo> {
        self.lib(id).map(|(info, _)| info)
    }

    /// The cached lib fn `id`, its call sites renumbered for this graph (the body is shared).
    /// `None` inside means it did not check (never the case for a clean standard library).
    pub(super) fn lib_fn(&self, id: usize, module: usize) -> Option<Option<LibOut>> {
        let (_, out) = self.lib(id)?;
        Some(out.as_ref().map(|out| {
            let mut out = out.clone();
            out.hir.module = module;
            for (callee, _) in &mut out.calls {
                *callee = self.renumber(*callee);
            }
            out
        }))
    }

    /// The pipeline functions and `remove` items of module `m`, renumbered for this graph (the
    /// bodies are shared).
    pub(super) fn module_items(&self, m: usize) -> Option<(Vec<PipeOut>, Vec<hir::Remove>)> {
        let s = self.module_std.get(m).copied().flatten()?;
        let module = self.cache.modules.get(s)?;
        let pipes = module
            .pipes
            .iter()
            .map(|p| {
                let mut p = p.clone();
                p.module = m;
                p.uses.iter_mut().chain(&mut p.calls).for_each(|id| *id = self.renumber(*id));
                p
            })
            .collect();
        let removes = module.removes.iter().map(|r| hir::Remove { module: m, ..r.clone() }).collect();
        Some((pipes, removes))
    }

    fn renumber(&self, cached: usize) -> usize {
        self.lib_ids.get(cached).copied().flatten().unwrap_or(usize::MAX)
    }
}
