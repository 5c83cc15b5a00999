//! Renderer trees: the `[[group]]` tables and each view's `picture` (or the tree its `meshes`,
//! `planes` and `overlay` lists make), checked with spans: names resolve to meshes, groups or
//! slice views (E0713), groups have children (E0720) and contain no cycle (E0721), and a picture
//! lists its volume once with only meshes after it (E0722).
//!
//! Names of children resolve in this order: a mesh, a group, an image (validation refuses a
//! group or image named as a mesh or as each other), then a view. `"volume"` in a `picture` is the view's own volume.

use super::raw::{RawChild, RawGroup, RawLight, RawModule, RawView};
use super::*;

/// The lists of a `[[view]]` table that name nodes, resolved once every view, mesh and group
/// is known.
pub(super) struct ViewLists {
    meshes: Option<Spanned<Vec<Spanned<String>>>>,
    overlay: Option<Spanned<Vec<Spanned<String>>>>,
    planes: Option<Spanned<Vec<Spanned<String>>>>,
    picture: Option<Spanned<Vec<Spanned<String>>>>,
}

impl ViewLists {
    pub(super) fn take(v: &mut RawView) -> ViewLists {
        ViewLists {
            meshes: v.meshes.take(),
            overlay: v.overlay.take(),
            planes: v.planes.take(),
            picture: v.picture.take(),
        }
    }
}

/// What a child's name can name.
struct Names<'a> {
    meshes: &'a [Mesh],
    groups: &'a [Group],
    images: &'a [Image],
    views: &'a [View],
}

/// The name `"volume"` stands for in a `picture`: the view's own volume.
const VOLUME: &str = "volume";

impl Names<'_> {
    fn find(&self, name: &str) -> Option<Node> {
        let mesh = || self.meshes.iter().position(|m| m.name.name == name).map(Node::Mesh);
        let group = || self.groups.iter().position(|g| g.name.name == name).map(Node::Group);
        let image = || self.images.iter().position(|i| i.name.name == name).map(Node::Image);
        let view = || self.views.iter().position(|v| v.name.name == name).map(Node::Plane);
        mesh().or_else(group).or_else(image).or_else(view)
    }

    fn name(&self, node: Node) -> &str {
        match node {
            Node::Mesh(i) => &self.meshes[i].name.name,
            Node::Group(i) => &self.groups[i].name.name,
            Node::Plane(i) => &self.views[i].name.name,
            Node::Image(i) => &self.images[i].name.name,
            Node::Filter(_) => "a filter",
        }
    }
}

impl Cx<'_> {
    /// `[[group]]` tables: their names and kinds, then their children (which may name groups
    /// further down), then the cycles among them; with the filters among their children.
    pub(super) fn groups(
        &mut self,
        raw: Vec<Spanned<RawGroup>>,
        (meshes, images): (&[Mesh], &[Image]),
        views: &[View],
    ) -> (Vec<Group>, Vec<ModuleRef>) {
        let mut groups: Vec<Group> = Vec::new();
        for g in &raw {
            let group = self.group_head(g, (meshes, images, views), &groups);
            groups.push(group);
        }
        let (mut child_spans, mut filters) = (Vec::with_capacity(raw.len()), Vec::new());
        for (i, g) in raw.iter().enumerate() {
            let names = Names { meshes, groups: &groups, images, views };
            let list = g.get_ref().children.get_ref();
            let children = self.group_children(&groups[i], list, &names, &mut filters);
            let listed = list.iter().filter(|c| matches!(c.get_ref(), RawChild::Name(_))).count();
            self.check_child_count(&groups[i], listed, self.span(&g.get_ref().children));
            groups[i].children = children.iter().map(|(node, _)| *node).collect();
            child_spans.push(children.into_iter().map(|(_, span)| span).collect::<Vec<_>>());
        }
        self.check_cycles(&groups, &child_spans);
        (groups, filters)
    }

    /// A group's children, each with its span: the nodes its names name (as [`Cx::nodes`]) and
    /// its filters (added to `filters`), E0723 for a filter first, E0724 for one in an
    /// occlusion or shadow group.
    fn group_children(
        &mut self,
        group: &Group,
        list: &[Spanned<RawChild>],
        names: &Names,
        filters: &mut Vec<ModuleRef>,
    ) -> Vec<(Node, Span)> {
        let mut out = Vec::new();
        for (k, child) in list.iter().enumerate() {
            let span = self.span(child);
            match child.get_ref() {
                RawChild::Name(name) => self.add_node(&mut out, &Spanned::new(child.span(), name.clone()), names, true),
                RawChild::Filter(f) => {
                    let kind = match group.kind {
                        GroupKind::Depth => None,
                        GroupKind::Occlusion { .. } => Some("occlusion"),
                        GroupKind::Shadow { .. } => Some("shadow"),
                    };
                    let name = group.name.name.clone();
                    if let Some(kind) = kind {
                        self.report(span, SceneError::FilterInGroupKind { group: name, kind });
                    } else if k == 0 {
                        self.report(span, SceneError::FilterFirst { group: name });
                    }
                    let range = child.span();
                    let names =
                        |list: &Vec<String>| list.iter().map(|i| Spanned::new(range.clone(), i.clone())).collect();
                    let instances = f.instances.as_ref().map(|list| Spanned::new(range.clone(), names(list)));
                    let raw = RawModule { path: Spanned::new(range.clone(), f.filter.clone()), instances };
                    filters.push(self.module(Spanned::new(child.span(), raw)));
                    out.push((Node::Filter(filters.len() - 1), span));
                }
            }
        }
        out
    }

    /// A group's name, kind, `show` and `opacity`; its children come later.
    fn group_head(
        &mut self,
        g: &Spanned<RawGroup>,
        (meshes, images, views): (&[Mesh], &[Image], &[View]),
        earlier: &[Group],
    ) -> Group {
        let span = self.span(g);
        let g = g.get_ref();
        let name = Ident { name: g.name.get_ref().clone(), span: self.span(&g.name) };
        if self.check_name(&name.name, name.span, "group") {
            let mesh = meshes.iter().find(|m| m.name.name == name.name).map(|m| (m.name.span, "mesh"));
            let group = earlier.iter().find(|o| o.name.name == name.name).map(|o| (o.name.span, "group"));
            let image = || images.iter().find(|i| i.name.name == name.name).map(|i| (i.name.span, "image"));
            if let Some((first, what)) = mesh.or(group).or_else(image) {
                self.report(name.span, Twice::NodeNamed { name: name.name.clone(), first, kind: "group", what });
            }
        }
        let kind = match g.kind.as_ref().map(|k| *k.get_ref()) {
            Some(GroupKindName::Occlusion) => GroupKind::Occlusion { hidden_opacity: self.hidden_opacity(g) },
            Some(GroupKindName::Shadow) => GroupKind::Shadow { light: self.light(g, span, views) },
            _ => GroupKind::Depth,
        };
        self.ignore_keys_of_other_kinds(g, &kind);
        Group { name, kind, children: Vec::new(), span }
    }

    /// W0701 for `show` and `opacity` outside occlusion groups, `light` outside shadow groups.
    fn ignore_keys_of_other_kinds(&mut self, g: &RawGroup, kind: &GroupKind) {
        let (occlusion, shadow) =
            (matches!(kind, GroupKind::Occlusion { .. }), matches!(kind, GroupKind::Shadow { .. }));
        let keys = [
            ("show", g.show.as_ref().map(Spanned::span), occlusion, "it is for occlusion groups"),
            ("opacity", g.opacity.as_ref().map(Spanned::span), occlusion, "it is for occlusion groups"),
            ("light", g.light.as_ref().map(Spanned::span), shadow, "it is for shadow groups"),
        ];
        for (key, range, allowed, why) in keys {
            if let (Some(r), false) = (range, allowed) {
                let span = self.range(r);
                self.ignored_at(span, key, &format!("on this group ({why})"));
            }
        }
    }

    /// A shadow group's light: E0704 without `light`, E0708 for a direction that is none, E0713
    /// for a name no view's `lights` has (straight above, `[0, 0, 1]`, stands in).
    fn light(&mut self, g: &RawGroup, table: Span, views: &[View]) -> ShadowLight {
        const ABOVE: ShadowLight = ShadowLight::Towards([0.0, 0.0, 1.0]);
        let Some(light) = &g.light else {
            self.report(table, Missing::Key { key: "light".into(), table: "a shadow group".into() });
            return ABOVE;
        };
        let span = self.span(light);
        match light.get_ref() {
            RawLight::Towards(v) if v.iter().any(|x| !x.is_finite()) || v.iter().all(|&x| x == 0.0) => {
                self.report(span, ViewRange::LightDirection);
                ABOVE
            }
            RawLight::Towards(v) => ShadowLight::Towards(*v),
            RawLight::Name(name) => {
                let lights = || views.iter().flat_map(|v| &v.render.lights).map(|l| l.name.as_str());
                if lights().any(|l| l == name) {
                    return ShadowLight::Light(Ident { name: name.clone(), span });
                }
                let suggestion = did_you_mean(name, lights()).map(String::from);
                self.report(span, NoSuch::Light { name: name.clone(), suggestion });
                ABOVE
            }
        }
    }

    /// An occlusion group's opacity of what its first child hides: 1 for `show = "visible"`, else
    /// `opacity` (0.5 without it).
    fn hidden_opacity(&mut self, g: &RawGroup) -> f32 {
        let opacity = g.opacity.as_ref().map(|o| {
            let x = *o.get_ref();
            if !(0.0..=1.0).contains(&x) {
                self.report(self.span(o), ViewRange::MeshUnit { key: "opacity" });
            }
            x
        });
        match (g.show.as_ref().map(|s| *s.get_ref()), &g.opacity) {
            (Some(Show::Visible), Some(o)) => {
                self.ignored(o, "opacity", "with `show = \"visible\"` (hidden children show whole)");
                1.0
            }
            (Some(Show::Visible), None) => 1.0,
            _ => opacity.unwrap_or(DEFAULT_HIDDEN_OPACITY),
        }
    }

    /// E0720 for a group with fewer children than its kind needs (`listed` names, found or not).
    fn check_child_count(&mut self, group: &Group, listed: usize, span: Span) {
        let (kind, needs) = match group.kind {
            GroupKind::Depth => ("depth", 1),
            GroupKind::Occlusion { .. } => ("occlusion", 2),
            GroupKind::Shadow { .. } => ("shadow", 1),
        };
        if listed < needs {
            self.report(span, SceneError::TooFewChildren { group: group.name.name.clone(), kind, needs });
        }
    }

    /// E0721 at the child that closes each cycle, once per cycle.
    fn check_cycles(&mut self, groups: &[Group], child_spans: &[Vec<Span>]) {
        let mut reported: Vec<Vec<usize>> = Vec::new();
        for start in 0..groups.len() {
            let Some((cycle, span)) = find_cycle(groups, child_spans, start) else { continue };
            let mut key = cycle.clone();
            key.sort_unstable();
            if reported.contains(&key) {
                continue;
            }
            reported.push(key);
            let mut path: Vec<String> = cycle.iter().map(|&g| groups[g].name.name.clone()).collect();
            path.push(groups[start].name.name.clone());
            self.report(span, SceneError::GroupCycle { path });
        }
    }

    /// The nodes of a list, each with its span; unknown names (E0713) and names listed twice
    /// (E0712) are left out. With `planes_allowed` false (a slice view's list) a slice view or
    /// an image is ignored (W0701): a slice view has no depth to place a plane in.
    fn nodes(&mut self, list: &[Spanned<String>], names: &Names, planes_allowed: bool) -> Vec<(Node, Span)> {
        let mut out: Vec<(Node, Span)> = Vec::new();
        for item in list {
            self.add_node(&mut out, item, names, planes_allowed);
        }
        out
    }

    /// The node `item` names, added to `out` unless it names nothing or is there already (as
    /// [`Cx::nodes`] says).
    fn add_node(&mut self, out: &mut Vec<(Node, Span)>, item: &Spanned<String>, names: &Names, planes_allowed: bool) {
        let span = self.span(item);
        let Some(node) = self.node(item, names) else { return };
        if out.iter().any(|(n, _)| *n == node) {
            self.report(span, listed_twice(node, item.get_ref()));
        } else if node.is_plane() && !planes_allowed {
            self.ignored_at(
                span,
                item.get_ref(),
                "in a slice view's picture (a raycast view shows slice views and images on their planes)",
            );
        } else {
            out.push((node, span));
        }
    }

    /// The node `item` names: E0713 for no such name, E0714 for a raycast view.
    fn node(&mut self, item: &Spanned<String>, names: &Names) -> Option<Node> {
        let span = self.span(item);
        let name = item.get_ref();
        match names.find(name) {
            Some(Node::Plane(i)) if names.views[i].kind.value != ViewKind::Slice => {
                let kind = names.views[i].kind.span;
                self.report(span, SceneError::PlaneNotSlice { name: name.clone(), kind });
                None
            }
            Some(node) => Some(node),
            None => {
                let meshes = names.meshes.iter().map(|m| m.name.name.as_str());
                let groups = names.groups.iter().map(|g| g.name.name.as_str());
                let images = names.images.iter().map(|i| i.name.name.as_str());
                let slices =
                    names.views.iter().filter(|v| v.kind.value == ViewKind::Slice).map(|v| v.name.name.as_str());
                let candidates = meshes.chain(groups).chain(images).chain(slices);
                let suggestion = did_you_mean(name, candidates).map(String::from);
                self.report(span, NoSuch::Node { name: name.clone(), suggestion });
                None
            }
        }
    }

    /// Each view's picture: its `picture` list, or the tree its `meshes` (every mesh without
    /// it), `planes` and `overlay` lists make.
    pub(super) fn pictures(
        &mut self,
        views: &mut [View],
        lists: Vec<ViewLists>,
        (meshes, groups, images): (&[Mesh], &[Group], &[Image]),
    ) {
        for (i, lists) in lists.into_iter().enumerate() {
            let names = Names { meshes, groups, images, views };
            let picture = match &lists.picture {
                Some(picture) => self.picture_list(picture, &lists, &names, views[i].kind.value),
                None => self.picture_of_lists(&lists, &names, views, i),
            };
            views[i].picture = picture;
        }
    }

    /// A view's `picture`: its nodes before `"volume"` and its meshes after it.
    fn picture_list(
        &mut self,
        list: &Spanned<Vec<Spanned<String>>>,
        lists: &ViewLists,
        names: &Names,
        kind: ViewKind,
    ) -> Picture {
        let picture_span = self.span(list);
        for (key, other) in [("meshes", &lists.meshes), ("planes", &lists.planes), ("overlay", &lists.overlay)] {
            if let Some(other) = other {
                self.report(self.span(other), Conflict::PictureAndList { key, picture: picture_span });
            }
        }
        let items = list.get_ref();
        let volume_at = items.iter().position(|i| i.get_ref() == VOLUME);
        if let Some(first) = volume_at {
            for again in items[first + 1..].iter().filter(|i| i.get_ref() == VOLUME) {
                let first = self.span(&items[first]);
                self.report(self.span(again), PictureVolume::Twice { first });
            }
        } else {
            self.report(picture_span, PictureVolume::Missing);
        }
        let split = volume_at.unwrap_or(items.len());
        let under = self.nodes(&items[..split], names, kind == ViewKind::Raycast);
        let after: Vec<Spanned<String>> = items[split..].iter().filter(|i| i.get_ref() != VOLUME).cloned().collect();
        let mut over = Vec::new();
        for (node, span) in self.nodes(&after, names, true) {
            match node {
                Node::Mesh(m) => over.push(m),
                Node::Group(_) | Node::Plane(_) | Node::Image(_) | Node::Filter(_) => {
                    let what = match node {
                        Node::Group(_) => "group",
                        Node::Image(_) => "image",
                        _ => "slice view",
                    };
                    let name = names.name(node).to_string();
                    self.report(span, PictureVolume::AfterIt { name, what });
                }
            }
        }
        Picture { under: under.into_iter().map(|(node, _)| node).collect(), over }
    }

    /// The tree of a view without `picture`: its meshes and planes under its volume, its overlay
    /// over it.
    fn picture_of_lists(&mut self, lists: &ViewLists, names: &Names, views: &[View], index: usize) -> Picture {
        let mut under: Vec<Node> =
            self.view_meshes(lists.meshes.as_ref(), names.meshes).into_iter().map(Node::Mesh).collect();
        if let Some(planes) = &lists.planes {
            under.extend(self.view_planes(views, index, planes).into_iter().map(Node::Plane));
        }
        let over = match &lists.overlay {
            Some(list) => self.view_meshes(Some(list), names.meshes),
            None => Vec::new(),
        };
        Picture { under, over }
    }
}

/// The opacity of what an occlusion group's first child hides, without `opacity`.
pub const DEFAULT_HIDDEN_OPACITY: f32 = 0.5;

/// E0712 for `node` listed twice in one list.
fn listed_twice(node: Node, name: &str) -> Twice {
    let name = name.to_string();
    match node {
        Node::Mesh(_) => Twice::MeshListed { name },
        Node::Group(_) | Node::Image(_) | Node::Filter(_) => Twice::NodeListed { name },
        Node::Plane(_) => Twice::ViewListed { name },
    }
}

/// A cycle through group `start`: the groups on the way (from `start`) and the span of the
/// child that leads back to it.
fn find_cycle(groups: &[Group], child_spans: &[Vec<Span>], start: usize) -> Option<(Vec<usize>, Span)> {
    // Depth first, with the path kept; groups already explored without reaching `start` are
    // not entered again, so the search is linear in the tree.
    let mut path = vec![start];
    let mut next = vec![0usize];
    let mut done = vec![false; groups.len()];
    while let Some(&g) = path.last() {
        let k = next[next.len() - 1];
        let Some(&child) = groups[g].children.get(k) else {
            done[g] = true;
            path.pop();
            next.pop();
            continue;
        };
        *next.last_mut()? += 1;
        let Node::Group(c) = child else { continue };
        if c == start {
            return Some((path, child_spans[g][k]));
        }
        if !done[c] && !path.contains(&c) {
            path.push(c);
            next.push(0);
        }
    }
    None
}
