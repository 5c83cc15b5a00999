//! Validation: what serde cannot check (names, ranges, one primary volume, keys that need each
//! other), building the typed [`Scene`].

use super::raw::*;
use super::*;
use crate::lexer::is_identifier;

// ---------------------------------------------------------------------------------------------
// Validation.

pub(super) struct Cx<'a> {
    pub(super) text: &'a str,
    pub(super) base: u32,
    pub(super) dir: &'a Path,
    pub(super) errors: Vec<Diagnostic>,
    pub(super) warnings: Vec<Diagnostic>,
}

impl Cx<'_> {
    pub(super) fn range(&self, r: Range<usize>) -> Span {
        let len = self.text.len();
        let (start, end) = (r.start.min(len), r.end.min(len));
        Span::new(self.base + start as u32, self.base + end.max(start) as u32)
    }

    pub(super) fn span<T>(&self, s: &Spanned<T>) -> Span {
        self.range(s.span())
    }

    /// Reports the mistake `e` at `span`.
    pub(super) fn report(&mut self, span: Span, e: impl Into<SceneError>) {
        self.errors.push(e.into().at(span));
    }

    /// `value` with its span.
    pub(super) fn located<T: Copy>(&self, value: &Option<Spanned<T>>) -> Option<Located<T>> {
        value.as_ref().map(|v| Located { value: *v.get_ref(), span: self.span(v) })
    }

    /// A volume's value window from `window`, or from `level` and `width` (never both).
    pub(super) fn window(
        &mut self,
        window: &Option<Spanned<[f32; 2]>>,
        level: &Option<Spanned<f32>>,
        width: &Option<Spanned<f32>>,
    ) -> Option<Located<[f32; 2]>> {
        let located = match (window, level, width) {
            (Some(w), None, None) => Located { value: *w.get_ref(), span: self.span(w) },
            (None, Some(l), Some(w)) => {
                let (level, width) = (*l.get_ref(), *w.get_ref());
                let span = self.span(w);
                if width.is_nan() || width <= 0.0 {
                    self.report(span, RenderRange::WindowWidth { width });
                    return None;
                }
                Located { value: [level - width / 2.0, level + width / 2.0], span }
            }
            (None, None, None) => return None,
            (Some(w), _, _) => {
                self.report(self.span(w), Conflict::WindowAndLevel);
                return None;
            }
            (None, Some(l), None) => {
                self.report(self.span(l), Missing::LevelNeedsWidth);
                return None;
            }
            (None, None, Some(w)) => {
                self.report(self.span(w), Missing::WidthNeedsLevel);
                return None;
            }
        };
        let [lo, hi] = located.value;
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            self.report(located.span, RenderRange::WindowOrder { lo, hi });
            return None;
        }
        Some(located)
    }

    pub(super) fn ignored<T>(&mut self, value: &Spanned<T>, key: &str, why: &str) {
        let span = self.span(value);
        self.ignored_at(span, key, why);
    }

    pub(super) fn ignored_at(&mut self, span: Span, key: &str, why: &str) {
        self.warnings.push(
            Diagnostic::new(Code::SceneIgnored, span, format!("`{key}` has no effect {why}"))
                .with_label("ignored")
                .with_help(format!("remove `{key}`")),
        );
    }

    /// `[render] memory` and `host_memory`: sizes like `"512 MiB"` or `"2 GiB"`.
    fn memory(&mut self, raw: Option<&Spanned<RawRender>>) -> Memory {
        let mut memory = Memory::default();
        let Some(r) = raw.map(Spanned::get_ref) else { return memory };
        for (key, value, out) in
            [("memory", &r.memory, &mut memory.gpu), ("host_memory", &r.host_memory, &mut memory.host)]
        {
            let Some(value) = value else { continue };
            match parse_bytes(value.get_ref()) {
                Some(bytes) if bytes >= MIN_MEMORY => *out = bytes,
                _ => self.report(self.span(value), SceneError::Memory { key }),
            }
        }
        memory
    }

    pub(super) fn scene(&mut self, raw: RawScene) -> Scene {
        let shared = raw.render.clone();
        let memory = self.memory(raw.render.as_ref());
        let render = self.render(raw.render);
        let volumes = self.volumes(raw.volumes, &memory);
        let modules = raw.modules.into_iter().map(|m| self.module(m)).collect();
        let uniforms = self.uniforms(raw.uniforms, &render);
        let meshes = self.meshes(raw.meshes, &volumes);
        let (mut views, lists) = self.views(raw.views, shared.as_ref(), &render);
        let images = self.images(raw.images, &meshes);
        let (groups, tree_filters) = self.groups(raw.groups, (&meshes, &images), &views);
        self.pictures(&mut views, lists, (&meshes, &groups, &images));
        let dir = self.dir.to_path_buf();
        Scene { render, volumes, modules, uniforms, views, meshes, groups, images, tree_filters, memory, dir }
    }

    /// `[render]`: each key, or its default, checked in the table's order.
    pub(super) fn render(&mut self, raw: Option<Spanned<RawRender>>) -> Render {
        let (table, r) = match raw {
            Some(r) => (self.span(&r), r.into_inner()),
            None => (Span::new(self.base, self.base), RawRender::default()),
        };
        let compositing = self.located(&r.compositing).unwrap_or(Located { value: Compositing::Dvr, span: table });
        let iso_value = self.iso_value(&r.iso_value, &compositing);
        let shading = r.shading.as_ref().is_some_and(|s| *s.get_ref());
        let lights = self.lights(&r, shading, table);
        let boundary = r.boundary.as_ref().is_some_and(|b| *b.get_ref());
        let tone = r.tone.as_ref().is_some_and(|t| *t.get_ref());
        if let Some(t) = &r.tone
            && tone
            && !shading
        {
            self.report(self.span(t), Missing::ToneNeedsShading);
        }
        let ambient_occlusion = r.ambient_occlusion.as_ref().is_some_and(|a| *a.get_ref());
        if let Some(a) = &r.ambient_occlusion
            && ambient_occlusion
            && !shading
        {
            self.report(self.span(a), Missing::OcclusionNeedsShading);
        }
        let (step_size, max_samples) = (self.located(&r.step_size), self.located(&r.max_samples));
        let (jitter, background) = (self.located(&r.jitter), self.located(&r.background));
        self.check_sampling(&step_size, &max_samples, &jitter, &background);
        let light = self.light_settings(&r, compositing.value, shading, lights.is_empty());
        let traced = compositing.value == Compositing::Pathtrace;
        if traced {
            self.ignored_by_path_tracing(&r);
        }
        // On by default wherever skipping is exact; MinIP and average read every sample: they
        // never skip.
        let exact = matches!(compositing.value, Compositing::Dvr | Compositing::Mip | Compositing::Iso);
        let empty_space_skipping = r.empty_space_skipping.as_ref().map_or(exact, |skip| *skip.get_ref());
        Render {
            compositing,
            iso_value,
            shading,
            lights,
            boundary: boundary && !traced,
            tone: tone && !traced,
            empty_space_skipping,
            step_size,
            max_samples,
            jitter,
            background,
            tone_mapping: light.tone_mapping,
            exposure: light.exposure,
            auto_exposure: light.auto_exposure,
            white_point: light.white_point,
            preintegration: light.preintegration,
            shadows: if traced { Shadows::Off } else { light.shadows },
            ambient_occlusion: ambient_occlusion && !traced,
        }
    }

    /// The keys path tracing has no use for: its lights always cast shadow rays, its scattered
    /// light is its ambient occlusion, and tone shading and boundary enhancement would change
    /// a collision after the free flight chose it.
    fn ignored_by_path_tracing(&mut self, r: &RawRender) {
        let why = "with `compositing = \"pathtrace\"`";
        if let Some(s) = r.shadows.as_ref().filter(|s| *s.get_ref() != Shadows::Off) {
            self.ignored(s, "shadows", "with `compositing = \"pathtrace\"`: its lights always cast shadow rays");
        }
        for (value, key) in [(&r.ambient_occlusion, "ambient_occlusion"), (&r.tone, "tone"), (&r.boundary, "boundary")]
        {
            if let Some(v) = value.as_ref().filter(|v| *v.get_ref()) {
                self.ignored(v, key, why);
            }
        }
    }

    /// `iso_value`: needed by iso-surface compositing, ignored by the others.
    fn iso_value(&mut self, raw: &Option<Spanned<f32>>, compositing: &Located<Compositing>) -> Option<Located<f32>> {
        let iso = compositing.value == Compositing::Iso;
        let Some(value) = raw else {
            if iso {
                self.report(compositing.span, Missing::IsoValue);
            }
            return None;
        };
        if !iso {
            self.ignored(value, "iso_value", "unless compositing is \"iso\"");
            return None;
        }
        let located = Located { value: *value.get_ref(), span: self.span(value) };
        if !located.value.is_finite() {
            self.report(located.span, RenderRange::IsoValue);
        }
        Some(located)
    }

    /// `lights`: the named lights with shading (the key light when none are named), none
    /// without.
    fn lights(&mut self, r: &RawRender, shading: bool, table: Span) -> Vec<Ident> {
        match &r.lights {
            Some(list) if !shading => {
                self.ignored(list, "lights", "without `shading = true`");
                Vec::new()
            }
            Some(list) => self.names(list.get_ref(), "light"),
            None if shading => {
                let span = r.shading.as_ref().map_or(table, |s| self.span(s));
                vec![Ident { name: DEFAULT_LIGHT.into(), span }]
            }
            None => Vec::new(),
        }
    }

    /// The ranges of the sampling keys: `step_size`, `max_samples`, `jitter`, `background`.
    fn check_sampling(
        &mut self,
        step_size: &Option<Located<f32>>,
        max_samples: &Option<Located<u32>>,
        jitter: &Option<Located<f32>>,
        background: &Option<Located<[f32; 4]>>,
    ) {
        if let Some(s) = step_size
            && !(s.value > 0.0 && s.value.is_finite())
        {
            self.report(s.span, RenderRange::StepSize);
        }
        if let Some(m) = max_samples
            && !(1..=MAX_SAMPLES_LIMIT).contains(&m.value)
        {
            self.report(m.span, RenderRange::MaxSamples);
        }
        if let Some(j) = jitter
            && !(0.0..=1.0).contains(&j.value)
        {
            self.report(j.span, RenderRange::Jitter);
        }
        if let Some(b) = background
            && !b.value.iter().all(|c| (0.0..=1.0).contains(c))
        {
            self.report(b.span, RenderRange::Background);
        }
    }

    /// The keys of light transport: tone mapping and its values, pre-integration, shadows.
    fn light_settings(&mut self, r: &RawRender, compositing: Compositing, shading: bool, no_lights: bool) -> Light {
        let tone_mapping = r.tone_mapping.as_ref().map_or(ToneMapping::Off, |t| *t.get_ref());
        let mut exposure = self.located(&r.exposure);
        if let Some(e) = &exposure {
            if tone_mapping == ToneMapping::Off {
                self.ignored_at(e.span, "exposure", "without `tone_mapping`");
                exposure = None;
            } else if !e.value.is_finite() {
                self.report(e.span, RenderRange::Exposure);
            }
        }
        let mut auto_exposure = false;
        if let Some(a) = &r.auto_exposure
            && *a.get_ref()
        {
            match tone_mapping {
                ToneMapping::Off => self.ignored(a, "auto_exposure", "without `tone_mapping`"),
                _ => auto_exposure = true,
            }
        }
        let mut white_point = self.located(&r.white_point);
        if let Some(w) = &white_point {
            if tone_mapping != ToneMapping::Reinhard {
                self.ignored_at(w.span, "white_point", "unless `tone_mapping = \"reinhard\"`");
                white_point = None;
            } else if !(w.value > 0.0 && w.value.is_finite()) {
                self.report(w.span, RenderRange::WhitePoint);
            }
        }
        let preintegration = self.preintegration(&r.preintegration, compositing, shading);
        let shadows = self.shadows(&r.shadows, shading, no_lights);
        Light { tone_mapping, exposure, auto_exposure, white_point, preintegration, shadows }
    }

    /// `preintegration`: DVR only; its lighting needs shading (without, the segment is still
    /// classified).
    fn preintegration(
        &mut self,
        raw: &Option<Spanned<Preintegration>>,
        mode: Compositing,
        shading: bool,
    ) -> Preintegration {
        let Some(p) = raw else { return Preintegration::Off };
        let asked = *p.get_ref();
        if asked == Preintegration::Off {
            return asked;
        }
        if mode != Compositing::Dvr {
            self.ignored(p, "preintegration", "unless compositing is \"dvr\"");
            return Preintegration::Off;
        }
        if asked == Preintegration::Lighting && !shading {
            let span = self.span(p);
            self.warnings.push(
                Diagnostic::new(
                    Code::SceneIgnored,
                    span,
                    "`preintegration = \"lighting\"` lights nothing without shading: the segments are classified only",
                )
                .with_label("its lighting is ignored")
                .with_help("turn `shading` on, or write `preintegration = true`"),
            );
            return Preintegration::Classification;
        }
        asked
    }

    /// `shadows`: they need shading, and have no effect without lights.
    fn shadows(&mut self, raw: &Option<Spanned<Shadows>>, shading: bool, no_lights: bool) -> Shadows {
        let Some(s) = raw else { return Shadows::Off };
        let (shadows, span) = (*s.get_ref(), self.span(s));
        if shadows == Shadows::Off {
            return shadows;
        }
        if !shading {
            self.report(span, Missing::ShadowsNeedShading);
        } else if no_lights {
            self.ignored_at(span, "shadows", "without lights");
            return Shadows::Off;
        }
        shadows
    }

    /// Checks a list of instance-like names: identifiers, not keywords, no duplicates.
    pub(super) fn names(&mut self, list: &[Spanned<String>], what: &str) -> Vec<Ident> {
        let mut out: Vec<Ident> = Vec::new();
        for item in list {
            let span = self.span(item);
            let name = item.get_ref().clone();
            if !self.check_name(&name, span, what) {
                continue;
            }
            if let Some(earlier) = out.iter().find(|i| i.name == name) {
                self.report(span, Twice::Listed { what: what.to_string(), name, first: earlier.span });
                continue;
            }
            out.push(Ident { name, span });
        }
        out
    }

    /// Reports a name that is not an identifier or is a keyword; returns whether it is fine.
    /// Instance names (volumes, lights, meshes, module instances) report E0607, uniforms E0711.
    pub(super) fn check_name(&mut self, name: &str, span: Span, what: &str) -> bool {
        let (what, name) = (what.to_string(), name.to_string());
        if !is_identifier(&name) {
            self.report(span, BadName::NotIdentifier { what, name });
            false
        } else if crate::lexer::is_keyword(&name) {
            self.report(span, BadName::Keyword { what, name });
            false
        } else {
            true
        }
    }

    /// `[[volume]]` tables: each key, or its default, checked in the table's order.
    pub(super) fn volumes(&mut self, raw: Vec<Spanned<RawVolume>>, memory: &Memory) -> Vec<Volume> {
        let mut out: Vec<Volume> = Vec::new();
        for v in raw {
            let span = self.span(&v);
            let v = v.into_inner();
            let name = Ident { name: v.name.get_ref().clone(), span: self.span(&v.name) };
            if self.check_name(&name.name, name.span, "volume") {
                self.check_unique_name(&out, &name, "second volume with this name");
            }
            let role = self.role(&v.role, &out);
            let source = self.volume_source(v.path, v.phantom, &name, span);
            let fallback = self.fallback(v.fallback, &source);
            let (tf_one, tf_list) = split_tf(v.tf);
            let tf = self.volume_tf(tf_one.as_ref(), role.value);
            let window = self.window(&v.window, &v.level, &v.width);
            let bricks = self.located(&v.bricks);
            let bricked = bricks.as_ref().map_or_else(|| outgrows_a_texture(&source, memory), |b| b.value);
            let lookup = self.lookup(v.lookup.as_ref(), bricked);
            let labels = self.labels(v.labels.as_ref(), role.value, window.as_ref().map(|w| w.span));
            let (channel, channels) = split_channels(v.channel);
            let zarr = self.zarr_keys(&source, v.multiscale, channel, v.time);
            let volume =
                Volume { name, role, source, fallback, tf, window, bricks, bricked, lookup, labels, zarr, span };
            self.push_volume(&mut out, volume, channels, tf_list);
        }
        if !out.iter().any(|v| v.role.value == Role::Primary) {
            let span = out.first().map_or(Span::new(self.base, self.base), |v| v.role.span);
            self.report(span, NoTable::Primary { no_volumes: out.is_empty() });
        }
        out
    }

    /// A volume's `role`: one volume is primary.
    fn role(&mut self, raw: &Spanned<Role>, earlier: &[Volume]) -> Located<Role> {
        let role = Located { value: *raw.get_ref(), span: self.span(raw) };
        if role.value == Role::Primary
            && let Some(first) = earlier.iter().find(|o| o.role.value == Role::Primary)
        {
            self.report(role.span, SceneError::SecondPrimary { first: first.role.span });
        }
        role
    }

    /// A volume's data: `path` or `phantom`.
    fn volume_source(
        &mut self,
        path: Option<Spanned<String>>,
        phantom: Option<Spanned<String>>,
        name: &Ident,
        table: Span,
    ) -> VolumeSource {
        match (path, phantom) {
            (Some(path), None) => self.volume_path(&path),
            (None, Some(p)) => VolumeSource::Phantom(self.phantom_name(p)),
            (Some(path), Some(p)) => {
                self.report(self.span(&p), Conflict::PathAndPhantom { path: self.span(&path) });
                VolumeSource::File(self.file_ref(&path, "path"))
            }
            (None, None) => {
                self.report(name.span, Missing::VolumeData { volume: name.name.clone() });
                VolumeSource::Phantom(Located { value: String::new(), span: table })
            }
        }
    }

    /// A phantom's name (`phantom` or `fallback`): an identifier.
    fn phantom_name(&mut self, raw: Spanned<String>) -> Located<String> {
        let span = self.span(&raw);
        if !is_identifier(raw.get_ref()) {
            self.report(span, BadName::Phantom { name: raw.get_ref().clone() });
        }
        Located { value: raw.into_inner(), span }
    }

    /// A volume's `fallback` phantom, for a file that is missing.
    fn fallback(&mut self, raw: Option<Spanned<String>>, source: &VolumeSource) -> Option<Located<String>> {
        let f = raw?;
        match source {
            VolumeSource::Phantom(_) => self.ignored(&f, "fallback", "on a volume that is a phantom"),
            VolumeSource::Url(_) => {
                self.ignored(&f, "fallback", "on a remote store (an unreachable server is an error)")
            }
            VolumeSource::File(_) => return Some(self.phantom_name(f)),
        }
        None
    }

    /// A volume's transfer function: its own, or the default of its role (none for a mask).
    fn volume_tf(&mut self, tf: Option<&Spanned<String>>, role: Role) -> Option<TfRef> {
        match (tf, role) {
            (Some(tf), Role::Mask) => {
                self.ignored(tf, "tf", "on a mask volume");
                None
            }
            (Some(tf), _) => Some(self.tf_ref(tf)),
            (None, Role::Mask) => None,
            (None, Role::Tag) => Some(TfRef::Preset(Located { value: DEFAULT_TAG_TF.into(), span: Span::DUMMY })),
            (None, _) => Some(TfRef::Preset(Located { value: DEFAULT_TF.into(), span: Span::DUMMY })),
        }
    }

    /// A volume's own `lookup`, for a bricked volume.
    fn lookup(&mut self, raw: Option<&Spanned<String>>, bricked: bool) -> Option<FileRef> {
        let path = raw?;
        if !bricked {
            self.ignored(path, "lookup", "on a volume kept in one texture (`bricks = true` keeps it in bricks)");
            return None;
        }
        Some(self.file_ref(path, "lookup"))
    }

    /// A volume's `labels`, for a tag volume (its window is then the ids', so `window` has no
    /// effect beside `labels = true`).
    fn labels(&mut self, raw: Option<&Spanned<bool>>, role: Role, window: Option<Span>) -> Option<Located<bool>> {
        let labels = raw?;
        if role != Role::Tag {
            self.ignored(labels, "labels", "on a volume whose role is not `tag`");
            return None;
        }
        if let Some(window) = window.filter(|_| *labels.get_ref()) {
            self.ignored_at(
                window,
                "window",
                "beside `labels = true` (label id k reads entry k of the transfer function)",
            );
        }
        Some(Located { value: *labels.get_ref(), span: self.span(labels) })
    }

    /// Adds `volume` to `out`, or one volume per channel for a channel list.
    fn push_volume(
        &mut self,
        out: &mut Vec<Volume>,
        volume: Volume,
        channels: Option<ChannelList>,
        tfs: Option<TfList>,
    ) {
        match channels {
            Some((_, list_span)) if !is_store(&volume.source) => {
                let span = self.range(list_span);
                self.ignored_at(span, "channel", "on a volume that is not a Zarr store");
                out.push(volume);
            }
            Some((list, list_span)) => {
                for each in self.channels(volume, list, list_span, tfs) {
                    self.check_unique_name(
                        out,
                        &each.name,
                        "a channel's volume, named after the table and the channel's place",
                    );
                    out.push(each);
                }
            }
            None => {
                if let Some((_, tf_span)) = tfs {
                    self.report(self.range(tf_span), Missing::TfListNeedsChannels);
                }
                out.push(volume);
            }
        }
    }

    pub(super) fn tf_ref(&mut self, tf: &Spanned<String>) -> TfRef {
        let span = self.span(tf);
        let value = tf.get_ref();
        if value.is_empty() {
            self.report(span, Empty::Tf);
        }
        if is_identifier(value) || value.is_empty() {
            TfRef::Preset(Located { value: value.clone(), span })
        } else {
            TfRef::File(self.file_ref(tf, "tf"))
        }
    }

    /// A volume's `path`: a file or folder relative to the scene, or the URL of a remote Zarr
    /// store (`http://` and `https://` only: another scheme is an error here, at build).
    fn volume_path(&mut self, path: &Spanned<String>) -> VolumeSource {
        let given = path.get_ref();
        if !is_url(given) {
            return VolumeSource::File(self.file_ref(path, "path"));
        }
        let span = self.span(path);
        let scheme = given.split_once("://").map_or("", |(s, _)| s).to_ascii_lowercase();
        if scheme != "http" && scheme != "https" {
            self.report(span, SceneError::UrlScheme { scheme });
        }
        VolumeSource::Url(Located { value: given.clone(), span })
    }

    /// `channel = [A, B, ...]`: one volume per channel of the store, as napari's `channel_axis`
    /// shows them: named `NAME_0`, `NAME_1`, ... in the list's order, the first with the
    /// table's role and the others `additional` (all with the table's role when it is not
    /// `primary`), each with its own transfer function when `tf` is a list of as many.
    fn channels(
        &mut self,
        volume: Volume,
        list: Vec<RawEntry>,
        list_span: Range<usize>,
        tfs: Option<TfList>,
    ) -> Vec<Volume> {
        let span = self.range(list_span.clone());
        if list.is_empty() {
            self.report(span, Empty::Channels);
            return vec![volume];
        }
        if let Some((tfs, tf_span)) = &tfs
            && tfs.len() != list.len()
        {
            let tf_span = self.range(tf_span.clone());
            self.report(tf_span, SceneError::TfCount { tfs: tfs.len(), channels: list.len(), list: span });
        }
        let mut out = Vec::with_capacity(list.len());
        for (i, entry) in list.into_iter().enumerate() {
            let mut each = volume.clone();
            each.name = Ident { name: format!("{}_{i}", volume.name.name), span: volume.name.span };
            if i > 0 && volume.role.value == Role::Primary {
                each.role = Located { value: Role::Additional, span: volume.role.span };
            }
            let chosen = Spanned::new(list_span.clone(), entry);
            each.zarr = self.zarr_keys(&volume.source, None, Some(chosen), None);
            each.zarr.multiscale = volume.zarr.multiscale.clone();
            each.zarr.time = volume.zarr.time.clone();
            if let Some((tfs, tf_span)) = &tfs
                && let Some(tf) = tfs.get(i)
                && volume.role.value != Role::Mask
            {
                each.tf = Some(self.tf_ref(&Spanned::new(tf_span.clone(), tf.clone())));
            }
            out.push(each);
        }
        out
    }

    /// E0607 when a volume takes the name of an earlier one (`label` says how it got it).
    fn check_unique_name(&mut self, earlier: &[Volume], name: &Ident, label: &'static str) {
        if let Some(first) = earlier.iter().find(|o| o.name.name == name.name) {
            self.report(name.span, Twice::VolumeNamed { name: name.name.clone(), first: first.name.span, label });
        }
    }

    /// `multiscale`, `channel` and `time`: for a Zarr store only, indices not negative.
    fn zarr_keys(
        &mut self,
        source: &VolumeSource,
        multiscale: Option<Spanned<RawEntry>>,
        channel: Option<Spanned<RawEntry>>,
        time: Option<Spanned<i64>>,
    ) -> ZarrKeys {
        let is_store = is_store(source);
        let entry = |cx: &mut Self, value: Option<Spanned<RawEntry>>, key: &str| -> Option<Located<Entry>> {
            let value = value?;
            let span = cx.span(&value);
            if !is_store {
                cx.ignored_at(span, key, "on a volume that is not a Zarr store");
                return None;
            }
            match value.into_inner() {
                RawEntry::Index(i) if i < 0 => {
                    cx.report(span, RenderRange::NegativeIndex { key: key.to_string(), index: i });
                    None
                }
                RawEntry::Index(i) => Some(Located { value: Entry::Index(i as u64), span }),
                RawEntry::Name(n) => Some(Located { value: Entry::Name(n), span }),
            }
        };
        let multiscale = entry(self, multiscale, "multiscale");
        let channel = entry(self, channel, "channel");
        let time = entry(self, time.map(|t| Spanned::new(t.span(), RawEntry::Index(t.into_inner()))), "time");
        let time = time.and_then(|t| match t.value {
            Entry::Index(i) => Some(Located { value: i, span: t.span }),
            Entry::Name(_) => None,
        });
        ZarrKeys { multiscale, channel, time }
    }

    pub(super) fn file_ref(&mut self, path: &Spanned<String>, key: &str) -> FileRef {
        let span = self.span(path);
        let given = path.get_ref().clone();
        if given.trim().is_empty() {
            self.report(span, Empty::Path { key: key.to_string() });
        }
        let resolved = self.dir.join(&given);
        FileRef { given, resolved, span }
    }

    pub(super) fn module(&mut self, raw: Spanned<RawModule>) -> ModuleRef {
        let span = self.span(&raw);
        let m = raw.into_inner();
        let path_span = self.span(&m.path);
        let source = match m.path.get_ref().strip_prefix("std::") {
            Some(name) => {
                if !is_identifier(name) {
                    self.report(path_span, BadName::StdModule { name: name.to_string() });
                }
                ModuleSource::Std(Located { value: name.to_string(), span: path_span })
            }
            None => ModuleSource::File(self.file_ref(&m.path, "path")),
        };
        let instances = m.instances.map(|list| {
            if list.get_ref().is_empty() {
                self.report(self.span(&list), Empty::Instances);
            }
            self.names(list.get_ref(), "instance")
        });
        ModuleRef { source, instances, span }
    }

    pub(super) fn uniforms(
        &mut self,
        raw: BTreeMap<Spanned<String>, Spanned<UniformValue>>,
        render: &Render,
    ) -> BTreeMap<String, UniformSetting> {
        let mut out = BTreeMap::new();
        let mut entries: Vec<_> = raw.into_iter().collect();
        entries.sort_by_key(|(k, _)| k.span().start);
        for (key, value) in entries {
            let name_span = self.span(&key);
            let span = self.span(&value);
            let name = key.into_inner();
            if !self.check_name(&name, name_span, "uniform") {
                continue;
            }
            if RENDER_UNIFORMS.contains(&name.as_str()) {
                let set_in_render = match name.as_str() {
                    "iso_value" => render.iso_value.as_ref().map(|v| v.span),
                    "step_size" => render.step_size.as_ref().map(|v| v.span),
                    "max_samples" => render.max_samples.as_ref().map(|v| v.span),
                    "jitter" => render.jitter.as_ref().map(|v| v.span),
                    _ => render.background.as_ref().map(|v| v.span),
                };
                if let Some(earlier) = set_in_render {
                    self.report(name_span, Conflict::RenderAndUniforms { name, render: earlier });
                    continue;
                }
            }
            let value = value.into_inner();
            if let Some(problem) = value.problem(0) {
                self.report(span, WrongType::Uniform { name, problem });
                continue;
            }
            out.insert(name, UniformSetting { value, name_span, span });
        }
        out
    }

    /// `[[view]]` tables: each key, or its default, checked in the table's order; the lists
    /// that name meshes, groups and other views are returned for [`Cx::pictures`].
    pub(super) fn views(
        &mut self,
        raw: Vec<Spanned<RawView>>,
        shared: Option<&Spanned<RawRender>>,
        render: &Render,
    ) -> (Vec<View>, Vec<ViewLists>) {
        if raw.is_empty() {
            self.report(Span::new(self.base, self.base), NoTable::View);
        }
        let mut out: Vec<View> = Vec::new();
        let mut lists = Vec::new();
        for v in raw {
            let span = self.span(&v);
            let mut v = v.into_inner();
            lists.push(ViewLists::take(&mut v));
            let name = self.view_name(&v.name, &out);
            let kind = self.located(&v.kind).unwrap_or(Located { value: ViewKind::Raycast, span: name.span });
            let size = self.view_size(&v.size);
            let mut view = View {
                name,
                kind,
                size,
                camera: DEFAULT_CAMERA,
                axis: None,
                position: DEFAULT_SLICE_POSITION,
                slab: 0.0,
                convention: Convention::default(),
                render: match &v.render {
                    Some(own) => self.view_render(shared, own),
                    None => render.clone(),
                },
                modules: Vec::new(),
                filters: Vec::new(),
                picture: Picture::default(),
                span,
            };
            match view.kind.value {
                ViewKind::Raycast => self.raycast_keys(&v, &mut view),
                ViewKind::Slice => self.slice_keys(&v, &mut view),
            }
            view.modules = v.modules.into_iter().map(|m| self.module(m)).collect();
            view.filters = v.filters.into_iter().map(|m| self.module(m)).collect();
            out.push(view);
        }
        (out, lists)
    }

    /// A view's `name`: a plain file name, given to one view only.
    fn view_name(&mut self, raw: &Spanned<String>, earlier: &[View]) -> Ident {
        let name = Ident { name: raw.get_ref().clone(), span: self.span(raw) };
        if !is_view_name(&name.name) {
            self.report(name.span, BadName::View { name: name.name.clone() });
        } else if let Some(first) = earlier.iter().find(|o| o.name.name == name.name) {
            self.report(name.span, Twice::ViewNamed { name: name.name.clone(), first: first.name.span });
        }
        name
    }

    /// A view's `size`, within what every device holds.
    fn view_size(&mut self, raw: &Option<Spanned<[u32; 2]>>) -> [u32; 2] {
        let Some(s) = raw else { return DEFAULT_VIEW_SIZE };
        let [width, height] = *s.get_ref();
        if !(1..=MAX_VIEW_SIZE).contains(&width) || !(1..=MAX_VIEW_SIZE).contains(&height) {
            self.report(self.span(s), ViewRange::ViewSize { width, height });
        }
        [width, height]
    }

    /// A raycast view's `camera`; the keys of slice views have no effect on it.
    fn raycast_keys(&mut self, v: &RawView, view: &mut View) {
        if let Some(c) = &v.camera {
            view.camera = self.camera(c.get_ref());
        }
        let slice_keys = [
            (v.axis.as_ref().map(Spanned::span), "axis"),
            (v.position.as_ref().map(Spanned::span), "position"),
            (v.slab.as_ref().map(Spanned::span), "slab"),
            (v.convention.as_ref().map(Spanned::span), "convention"),
        ];
        for (range, key) in slice_keys {
            if let Some(r) = range {
                let span = self.range(r);
                self.ignored_at(span, key, "on a raycast view");
            }
        }
    }

    /// A slice view's `axis` (needed), `position`, `slab` and `convention`; a `camera` has no
    /// effect on it.
    fn slice_keys(&mut self, v: &RawView, view: &mut View) {
        if view.render.compositing.value == Compositing::Pathtrace {
            // The path tracer is for 3D views; a slice shown with the scene's path-traced views
            // is composited as DVR, and says so only where its own table asked for it.
            let own = v.render.as_ref().and_then(|r| r.get_ref().compositing.as_ref());
            if let Some(c) = own {
                self.ignored(c, "compositing = \"pathtrace\"", "on a slice view: it is composited by DVR");
            }
            view.render.compositing.value = Compositing::Dvr;
        }
        if let Some(c) = &v.camera {
            self.ignored(c, "camera", "on a slice view");
        }
        view.axis = self.located(&v.axis);
        if view.axis.is_none() {
            self.report(view.kind.span, Missing::SliceAxis { view: view.name.name.clone() });
        }
        if let Some(p) = &v.position {
            view.position = *p.get_ref();
            if !(0.0..=1.0).contains(&view.position) {
                self.report(self.span(p), ViewRange::SlicePosition);
            }
        }
        if let Some(s) = &v.slab {
            view.slab = *s.get_ref();
            if !(view.slab >= 0.0 && view.slab.is_finite()) {
                self.report(self.span(s), ViewRange::Slab);
            }
        }
        if let Some(c) = &v.convention {
            view.convention = *c.get_ref();
        }
    }

    pub(super) fn camera(&mut self, c: &RawCamera) -> Camera {
        let mut out = DEFAULT_CAMERA;
        for (field, key, slot) in [
            (&c.azimuth, "azimuth", &mut out.azimuth),
            (&c.elevation, "elevation", &mut out.elevation),
            (&c.distance, "distance", &mut out.distance),
            (&c.fov, "fov", &mut out.fov),
        ] {
            let Some(value) = field else { continue };
            let x = *value.get_ref();
            *slot = x;
            let problem = match key {
                "distance" if !(x > 0.0 && x.is_finite()) => Some(ViewRange::CameraDistance { x }),
                "fov" if !(x > 0.0 && x < 180.0) => Some(ViewRange::CameraFov { x }),
                _ if !x.is_finite() => Some(ViewRange::CameraAngle { key, x }),
                _ => None,
            };
            if let Some(problem) = problem {
                self.report(self.span(value), problem);
            }
        }
        out
    }
}

/// `[A-Za-z0-9_-]+`: a view name, which names output files (`3d` is fine).
pub fn is_view_name(s: &str) -> bool {
    !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

/// [`Cx::light_settings`]'s result.
struct Light {
    tone_mapping: ToneMapping,
    exposure: Option<Located<f32>>,
    auto_exposure: bool,
    white_point: Option<Located<f32>>,
    preintegration: Preintegration,
    shadows: Shadows,
}

/// The smallest memory budget: a few bricks of each level.
const MIN_MEMORY: u64 = 64 << 20;

/// A size in bytes from text like `"512 MiB"`, `"2 GiB"`, `"1.5GB"` or `"65536"` (units of 1024:
/// KiB, MiB, GiB, TiB; KB, MB, GB and TB are read as the same, as memory is counted).
pub(crate) fn parse_bytes(text: &str) -> Option<u64> {
    let text = text.trim();
    let split = text.find(|c: char| !(c.is_ascii_digit() || c == '.')).unwrap_or(text.len());
    let (number, unit) = text.split_at(split);
    let number: f64 = number.parse().ok()?;
    let scale: u64 = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 1,
        "k" | "kb" | "kib" => 1 << 10,
        "m" | "mb" | "mib" => 1 << 20,
        "g" | "gb" | "gib" => 1 << 30,
        "t" | "tb" | "tib" => 1 << 40,
        _ => return None,
    };
    let bytes = number * scale as f64;
    (bytes.is_finite() && bytes >= 0.0 && bytes < u64::MAX as f64).then_some(bytes as u64)
}

/// Whether a volume's data is a Zarr store (a folder or a URL): what `multiscale`, `channel`
/// and `time` choose from.
fn is_store(source: &VolumeSource) -> bool {
    match source {
        VolumeSource::File(f) => is_zarr(&f.resolved),
        VolumeSource::Url(_) => true,
        VolumeSource::Phantom(_) => false,
    }
}

/// Whether a volume without `bricks` is bricked: a Zarr store, or a file larger than a quarter
/// of the GPU budget (its samples as half floats would take at least half of it, more for 8-bit
/// data). Decided from the file system alone, so `vrsc explain` and the renderer agree.
fn outgrows_a_texture(source: &VolumeSource, memory: &Memory) -> bool {
    let file = match source {
        VolumeSource::File(file) => file,
        VolumeSource::Url(_) => return true,
        VolumeSource::Phantom(_) => return false,
    };
    is_zarr(&file.resolved) || std::fs::metadata(&file.resolved).is_ok_and(|m| m.is_file() && m.len() > memory.gpu / 4)
}

/// A channel list and its span.
type ChannelList = (Vec<RawEntry>, Range<usize>);
/// A list of transfer functions and its span.
type TfList = (Vec<String>, Range<usize>);

/// A volume's `tf`: one transfer function (the first of a list too), and the list, if it is one.
fn split_tf(tf: Option<Spanned<RawTf>>) -> (Option<Spanned<String>>, Option<TfList>) {
    let Some(tf) = tf else { return (None, None) };
    let span = tf.span();
    match tf.into_inner() {
        RawTf::One(t) => (Some(Spanned::new(span, t)), None),
        RawTf::Many(list) => {
            let first = list.first().map(|t| Spanned::new(span.clone(), t.clone()));
            (first, Some((list, span)))
        }
    }
}

/// A volume's `channel`: one entry, or a list of them.
fn split_channels(channel: Option<Spanned<RawChannels>>) -> (Option<Spanned<RawEntry>>, Option<ChannelList>) {
    let Some(c) = channel else { return (None, None) };
    let span = c.span();
    match c.into_inner() {
        RawChannels::One(e) => (Some(Spanned::new(span, e)), None),
        RawChannels::Many(list) => (None, Some((list, span))),
    }
}
