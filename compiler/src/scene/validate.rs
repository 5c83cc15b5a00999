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

    pub(super) fn emit(&mut self, d: Diagnostic) {
        self.errors.push(d);
    }

    pub(super) fn invalid(&self, span: Span, message: impl Into<String>) -> Diagnostic {
        Diagnostic::new(Code::SceneInvalid, span, message)
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
                    self.emit(self.invalid(span, format!("the window `width` must be positive, not {width}")));
                    return None;
                }
                Located { value: [level - width / 2.0, level + width / 2.0], span }
            }
            (None, None, None) => return None,
            (Some(w), _, _) => {
                let d = self.invalid(self.span(w), "a volume has either `window` or `level` and `width`, not both");
                self.emit(d);
                return None;
            }
            (None, Some(l), None) => {
                self.emit(
                    self.invalid(self.span(l), "`level` needs `width`").with_help("add `width = W` (data units)"),
                );
                return None;
            }
            (None, None, Some(w)) => {
                self.emit(
                    self.invalid(self.span(w), "`width` needs `level`").with_help("add `level = L` (data units)"),
                );
                return None;
            }
        };
        let [lo, hi] = located.value;
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            self.emit(
                self.invalid(located.span, format!("the window [{lo}, {hi}] must have its low end below its high end")),
            );
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
                _ => {
                    let d = self
                        .invalid(self.span(value), format!("`{key}` must be a size of at least 64 MiB"))
                        .with_label("like \"512 MiB\" or \"2 GiB\"");
                    self.emit(d);
                }
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
        let mut views = self.views(raw.views, shared.as_ref(), &render, &meshes);
        // The occupancy grid of empty-space skipping is made from every voxel's value, which a
        // bricked volume never has in memory: its rays skip nothing (constant bricks still cost
        // one page-table read per sample, not a texture fetch).
        let mut render = render;
        if volumes.iter().any(|v| v.bricked && matches!(v.role.value, Role::Primary | Role::Additional)) {
            render.empty_space_skipping = false;
            for view in &mut views {
                view.render.empty_space_skipping = false;
            }
        }
        Scene { render, volumes, modules, uniforms, views, meshes, memory, dir: self.dir.to_path_buf() }
    }

    /// `[render]`. One check per key, in the table's order; the checks share only the table,
    /// so they stay in one function that reads like the table.
    pub(super) fn render(&mut self, raw: Option<Spanned<RawRender>>) -> Render {
        let (table, r) = match raw {
            Some(r) => (self.span(&r), r.into_inner()),
            None => (Span::new(self.base, self.base), RawRender::default()),
        };
        let compositing = match &r.compositing {
            Some(c) => Located { value: *c.get_ref(), span: self.span(c) },
            None => Located { value: Compositing::Dvr, span: table },
        };
        let iso_value = r.iso_value.as_ref().map(|v| Located { value: *v.get_ref(), span: self.span(v) });
        match (&iso_value, compositing.value) {
            (None, Compositing::Iso) => {
                self.emit(
                    self.invalid(compositing.span, "`compositing = \"iso\"` needs an `iso_value`")
                        .with_label("iso-surface compositing")
                        .with_help("add `iso_value = 0.5` (a normalized data value) to [render]"),
                );
            }
            (Some(_), Compositing::Iso) => {}
            (Some(_), _) => {
                self.ignored(r.iso_value.as_ref().expect("some"), "iso_value", "unless compositing is \"iso\"")
            }
            (None, _) => {}
        }
        let iso_value = iso_value.filter(|_| compositing.value == Compositing::Iso);
        if let Some(v) = &iso_value
            && !v.value.is_finite()
        {
            self.emit(self.invalid(v.span, "`iso_value` must be a finite number"));
        }
        let shading = r.shading.as_ref().is_some_and(|s| *s.get_ref());
        let lights = match &r.lights {
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
        };
        let boundary = r.boundary.as_ref().is_some_and(|b| *b.get_ref());
        let tone = r.tone.as_ref().is_some_and(|t| *t.get_ref());
        if tone && !shading {
            let span = self.span(r.tone.as_ref().expect("tone is set"));
            self.emit(
                self.invalid(span, "tone shading needs `shading = true`")
                    .with_label("tone shading modulates the lighting")
                    .with_help("add `shading = true` to [render]"),
            );
        }
        let step_size = r.step_size.as_ref().map(|s| Located { value: *s.get_ref(), span: self.span(s) });
        if let Some(s) = &step_size
            && !(s.value > 0.0 && s.value.is_finite())
        {
            self.emit(
                self.invalid(s.span, "`step_size` must be a distance greater than 0")
                    .with_label("millimetres")
                    .with_note("without `step_size`, rays step half the primary volume's smallest voxel spacing"),
            );
        }
        let max_samples = r.max_samples.as_ref().map(|s| Located { value: *s.get_ref(), span: self.span(s) });
        if let Some(m) = &max_samples
            && !(1..=MAX_SAMPLES_LIMIT).contains(&m.value)
        {
            self.emit(self.invalid(m.span, format!("`max_samples` must be between 1 and {MAX_SAMPLES_LIMIT}")));
        }
        let jitter = r.jitter.as_ref().map(|s| Located { value: *s.get_ref(), span: self.span(s) });
        if let Some(j) = &jitter
            && !(0.0..=1.0).contains(&j.value)
        {
            self.emit(self.invalid(j.span, "`jitter` must be between 0 (off) and 1 (up to one step)"));
        }
        let background = r.background.as_ref().map(|s| Located { value: *s.get_ref(), span: self.span(s) });
        if let Some(b) = &background
            && !b.value.iter().all(|c| (0.0..=1.0).contains(c))
        {
            self.emit(
                self.invalid(b.span, "`background` components must be between 0 and 1")
                    .with_label("premultiplied RGBA"),
            );
        }
        let light = self.light_settings(&r, compositing.value, shading, lights.is_empty());
        // On by default wherever skipping is exact; MinIP and average read every sample: they
        // never skip.
        let exact = matches!(compositing.value, Compositing::Dvr | Compositing::Mip | Compositing::Iso);
        let empty_space_skipping = r.empty_space_skipping.as_ref().map_or(exact, |skip| *skip.get_ref());
        Render {
            compositing,
            iso_value,
            shading,
            lights,
            boundary,
            tone,
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
            shadows: light.shadows,
        }
    }

    /// The keys of light transport: tone mapping and its values, pre-integration, shadows.
    fn light_settings(&mut self, r: &RawRender, compositing: Compositing, shading: bool, no_lights: bool) -> Light {
        let tone_mapping = r.tone_mapping.as_ref().map_or(ToneMapping::Off, |t| *t.get_ref());
        let located =
            |v: &Option<Spanned<f32>>, cx: &Self| v.as_ref().map(|s| Located { value: *s.get_ref(), span: cx.span(s) });
        let mut exposure = located(&r.exposure, self);
        if let Some(e) = &exposure {
            if tone_mapping == ToneMapping::Off {
                self.ignored_at(e.span, "exposure", "without `tone_mapping`");
                exposure = None;
            } else if !e.value.is_finite() {
                self.emit(self.invalid(e.span, "`exposure` must be a finite number of stops"));
            }
        }
        let mut auto_exposure = r.auto_exposure.as_ref().is_some_and(|a| *a.get_ref());
        if auto_exposure && tone_mapping == ToneMapping::Off {
            self.ignored(r.auto_exposure.as_ref().expect("set"), "auto_exposure", "without `tone_mapping`");
            auto_exposure = false;
        }
        let mut white_point = located(&r.white_point, self);
        if let Some(w) = &white_point {
            if tone_mapping != ToneMapping::Reinhard {
                self.ignored_at(w.span, "white_point", "unless `tone_mapping = \"reinhard\"`");
                white_point = None;
            } else if !(w.value > 0.0 && w.value.is_finite()) {
                self.emit(
                    self.invalid(w.span, "`white_point` must be a radiance greater than 0")
                        .with_label("the smallest radiance shown as white"),
                );
            }
        }
        let mut preintegration = r.preintegration.as_ref().is_some_and(|p| *p.get_ref());
        if preintegration && compositing != Compositing::Dvr {
            self.ignored(r.preintegration.as_ref().expect("set"), "preintegration", "unless compositing is \"dvr\"");
            preintegration = false;
        }
        let mut shadows = r.shadows.as_ref().map_or(Shadows::Off, |s| *s.get_ref());
        if shadows != Shadows::Off {
            let span = self.span(r.shadows.as_ref().expect("set"));
            if !shading {
                self.emit(
                    self.invalid(span, "shadows need `shading = true`")
                        .with_label("shadows attenuate the lights")
                        .with_help("add `shading = true` to [render]"),
                );
            } else if no_lights {
                self.ignored_at(span, "shadows", "without lights");
                shadows = Shadows::Off;
            }
        }
        Light { tone_mapping, exposure, auto_exposure, white_point, preintegration, shadows }
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
                let earlier = earlier.span;
                self.emit(
                    Diagnostic::new(Code::InvalidInstance, span, format!("the {what} `{name}` is listed twice"))
                        .with_label("again here")
                        .with_secondary(earlier, "first here"),
                );
                continue;
            }
            out.push(Ident { name, span });
        }
        out
    }

    /// Reports a name that is not an identifier or is a keyword; returns whether it is fine.
    /// Instance names (volumes, lights, module instances) report E0607, other names E0702.
    pub(super) fn check_name(&mut self, name: &str, span: Span, what: &str) -> bool {
        let code = if what == "uniform" { Code::SceneInvalid } else { Code::InvalidInstance };
        if !is_identifier(name) {
            self.emit(
                Diagnostic::new(code, span, format!("the {what} name `{name}` is not an identifier"))
                    .with_label("not an identifier")
                    .with_note("names are letters, digits and `_`, and do not start with a digit"),
            );
            false
        } else if crate::lexer::is_keyword(name) {
            self.emit(
                Diagnostic::new(code, span, format!("the {what} name `{name}` is a VRS keyword"))
                    .with_label("a keyword")
                    .with_help("choose another name"),
            );
            false
        } else {
            true
        }
    }

    /// `[[volume]]` tables. One check per key, in the table's order, as for [`Self::render`].
    pub(super) fn volumes(&mut self, raw: Vec<Spanned<RawVolume>>, memory: &Memory) -> Vec<Volume> {
        let mut out: Vec<Volume> = Vec::new();
        for v in raw {
            let span = self.span(&v);
            let v = v.into_inner();
            let name = Ident { name: v.name.get_ref().clone(), span: self.span(&v.name) };
            let name_ok = self.check_name(&name.name, name.span, "volume");
            if name_ok && let Some(earlier) = out.iter().find(|o| o.name.name == name.name) {
                let earlier = earlier.name.span;
                self.emit(
                    Diagnostic::new(Code::InvalidInstance, name.span, format!("two volumes are named `{}`", name.name))
                        .with_label("second volume with this name")
                        .with_secondary(earlier, "first here"),
                );
            }
            let role = Located { value: *v.role.get_ref(), span: self.span(&v.role) };
            if role.value == Role::Primary
                && let Some(first) = out.iter().find(|o| o.role.value == Role::Primary)
            {
                let first = first.role.span;
                self.emit(
                    self.invalid(role.span, "a scene has exactly one primary volume")
                        .with_label("a second primary volume")
                        .with_secondary(first, "the primary volume")
                        .with_help("make this one `role = \"additional\"`"),
                );
            }
            let source = match (v.path, v.phantom) {
                (Some(path), None) => self.volume_path(&path),
                (None, Some(p)) => {
                    let span = self.span(&p);
                    if !is_identifier(p.get_ref()) {
                        self.emit(
                            self.invalid(span, format!("the phantom name `{}` is not an identifier", p.get_ref())),
                        );
                    }
                    VolumeSource::Phantom(Located { value: p.into_inner(), span })
                }
                (Some(path), Some(p)) => {
                    let span = self.span(&p);
                    self.emit(
                        self.invalid(span, "a volume has either `path` or `phantom`, not both")
                            .with_label("second source")
                            .with_secondary(self.span(&path), "the volume's file"),
                    );
                    VolumeSource::File(self.file_ref(&path, "path"))
                }
                (None, None) => {
                    self.emit(
                        self.invalid(name.span, format!("the volume `{}` has no data", name.name))
                            .with_label("neither `path` nor `phantom`")
                            .with_help("add `path = \"FILE\"` (relative to the scene) or `phantom = \"NAME\"`"),
                    );
                    VolumeSource::Phantom(Located { value: String::new(), span })
                }
            };
            let fallback = match (v.fallback, &source) {
                (Some(f), VolumeSource::Phantom(_)) => {
                    self.ignored(&f, "fallback", "on a volume that is a phantom");
                    None
                }
                (Some(f), VolumeSource::Url(_)) => {
                    self.ignored(&f, "fallback", "on a remote store (an unreachable server is an error)");
                    None
                }
                (Some(f), _) => {
                    let span = self.span(&f);
                    if !is_identifier(f.get_ref()) {
                        self.emit(
                            self.invalid(span, format!("the phantom name `{}` is not an identifier", f.get_ref())),
                        );
                    }
                    Some(Located { value: f.into_inner(), span })
                }
                (None, _) => None,
            };
            // One transfer function, or one per channel of a channel list (see `channels`).
            let (tf_one, tf_list) = match &v.tf {
                Some(tf) => match tf.get_ref() {
                    RawTf::One(t) => (Some(Spanned::new(tf.span(), t.clone())), None),
                    RawTf::Many(list) => {
                        let span = tf.span();
                        let first = list.first().map(|t| Spanned::new(span.clone(), t.clone()));
                        (first, Some((list.clone(), span)))
                    }
                },
                None => (None, None),
            };
            let tf = match (&tf_one, role.value) {
                (Some(tf), Role::Mask) => {
                    self.ignored(tf, "tf", "on a mask volume");
                    None
                }
                (Some(tf), _) => Some(self.tf_ref(tf)),
                (None, Role::Mask) => None,
                (None, Role::Tag) => Some(TfRef::Preset(Located { value: DEFAULT_TAG_TF.into(), span: Span::DUMMY })),
                (None, _) => Some(TfRef::Preset(Located { value: DEFAULT_TF.into(), span: Span::DUMMY })),
            };
            let window = self.window(&v.window, &v.level, &v.width);
            let bricks = v.bricks.as_ref().map(|b| Located { value: *b.get_ref(), span: self.span(b) });
            let bricked = bricks.as_ref().map_or_else(|| outgrows_a_texture(&source, memory), |b| b.value);
            let lookup = match &v.lookup {
                Some(path) if !bricked => {
                    self.ignored(
                        path,
                        "lookup",
                        "on a volume kept in one texture (`bricks = true` keeps it in bricks)",
                    );
                    None
                }
                Some(path) => Some(self.file_ref(path, "lookup")),
                None => None,
            };
            let (channel, channels) = match v.channel {
                Some(c) => {
                    let span = c.span();
                    match c.into_inner() {
                        RawChannels::One(e) => (Some(Spanned::new(span, e)), None),
                        RawChannels::Many(list) => (None, Some((list, span))),
                    }
                }
                None => (None, None),
            };
            let zarr = self.zarr_keys(&source, v.multiscale, channel, v.time);
            let volume = Volume { name, role, source, fallback, tf, window, bricks, bricked, lookup, zarr, span };
            match channels {
                Some((_, list_span)) if !is_store(&volume.source) => {
                    let span = self.range(list_span);
                    self.ignored_at(span, "channel", "on a volume that is not a Zarr store");
                    out.push(volume);
                }
                Some((list, list_span)) => {
                    for each in self.channels(volume, list, list_span, tf_list) {
                        self.check_unique_name(&out, &each);
                        out.push(each);
                    }
                }
                None => {
                    if let Some((_, tf_span)) = tf_list {
                        let span = self.range(tf_span);
                        self.emit(
                            self.invalid(span, "a list of `tf` needs a list of `channel`")
                                .with_label("one per channel"),
                        );
                    }
                    out.push(volume);
                }
            }
        }
        if !out.iter().any(|v| v.role.value == Role::Primary) {
            let span = out.first().map_or(Span::new(self.base, self.base), |v| v.role.span);
            let mut d = self
                .invalid(span, "the scene has no primary volume")
                .with_help("give one [[volume]] `role = \"primary\"`: it defines the coordinates the rays march in");
            if out.is_empty() {
                d.label = "no [[volume]] tables".into();
            }
            self.emit(d);
        }
        out
    }

    pub(super) fn tf_ref(&mut self, tf: &Spanned<String>) -> TfRef {
        let span = self.span(tf);
        let value = tf.get_ref();
        if value.is_empty() {
            self.emit(self.invalid(span, "an empty `tf`").with_help("name a preset such as `grayscale`, or a file"));
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
            self.emit(
                self.invalid(span, format!("`{scheme}://` stores are not supported"))
                    .with_label("not an HTTP(S) URL")
                    .with_help("a remote Zarr store is read over `https://` or `http://` (an S3 or GCS bucket by its HTTPS address)"),
            );
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
        list_span: std::ops::Range<usize>,
        tfs: Option<(Vec<String>, std::ops::Range<usize>)>,
    ) -> Vec<Volume> {
        let span = self.range(list_span.clone());
        if list.is_empty() {
            self.emit(self.invalid(span, "an empty `channel` list").with_label("name at least one channel"));
            return vec![volume];
        }
        if let Some((tfs, tf_span)) = &tfs
            && tfs.len() != list.len()
        {
            let tf_span = self.range(tf_span.clone());
            self.emit(
                self.invalid(tf_span, format!("{} transfer functions for {} channels", tfs.len(), list.len()))
                    .with_label("one per channel")
                    .with_secondary(span, "the channels"),
            );
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

    /// E0702 when a volume made from a channel list takes the name of an earlier one.
    fn check_unique_name(&mut self, earlier: &[Volume], volume: &Volume) {
        if let Some(first) = earlier.iter().find(|o| o.name.name == volume.name.name) {
            let first = first.name.span;
            self.emit(
                Diagnostic::new(
                    Code::InvalidInstance,
                    volume.name.span,
                    format!("two volumes are named `{}`", volume.name.name),
                )
                .with_label("a channel's volume, named after the table and the channel's place")
                .with_secondary(first, "first here"),
            );
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
                    cx.emit(cx.invalid(span, format!("`{key} = {i}` is negative")).with_label("an index from 0"));
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
            self.emit(self.invalid(span, format!("an empty `{key}`")).with_label("a path is needed here"));
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
                    self.emit(
                        self.invalid(path_span, format!("`std::{name}` does not name a standard module"))
                            .with_note("standard modules are `std::NAME`, NAME an identifier (see stdlib/README.md)"),
                    );
                }
                ModuleSource::Std(Located { value: name.to_string(), span: path_span })
            }
            None => ModuleSource::File(self.file_ref(&m.path, "path")),
        };
        let instances = m.instances.map(|list| {
            if list.get_ref().is_empty() {
                self.emit(
                    self.invalid(self.span(&list), "an empty `instances` list")
                        .with_label("instantiates nothing")
                        .with_help("list instance names, or leave `instances` out for a plain module"),
                );
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
                    self.emit(
                        self.invalid(name_span, format!("`{name}` is set both in [render] and in [uniforms]"))
                            .with_label("set again here")
                            .with_secondary(earlier, "set in [render]")
                            .with_help("keep one of them"),
                    );
                    continue;
                }
            }
            let value = value.into_inner();
            if let Some(problem) = value.problem(0) {
                self.emit(self.invalid(span, format!("invalid value for the uniform `{name}`: {problem}")));
                continue;
            }
            out.insert(name, UniformSetting { value, name_span, span });
        }
        out
    }

    /// `[[view]]` tables. One check per key, in the table's order, as for [`Self::render`].
    pub(super) fn views(
        &mut self,
        raw: Vec<Spanned<RawView>>,
        shared: Option<&Spanned<RawRender>>,
        render: &Render,
        meshes: &[Mesh],
    ) -> Vec<View> {
        if raw.is_empty() {
            self.emit(
                self.invalid(Span::new(self.base, self.base), "the scene has no [[view]]")
                    .with_label("nothing to render")
                    .with_help("add a view: `[[view]]`, `name = \"3d\"`, `kind = \"raycast\"`"),
            );
        }
        let mut out: Vec<View> = Vec::new();
        let mut planes = Vec::new();
        for v in raw {
            let span = self.span(&v);
            let v = v.into_inner();
            let name = Ident { name: v.name.get_ref().clone(), span: self.span(&v.name) };
            let name_ok = is_view_name(&name.name);
            if !name_ok {
                self.emit(
                    self.invalid(name.span, format!("the view name `{}` is not a plain file name", name.name))
                        .with_label("letters, digits, `_` and `-` only")
                        .with_note("a view's name names its output files (`NAME.wgsl`, `NAME.png`)"),
                );
            }
            if name_ok && let Some(earlier) = out.iter().find(|o| o.name.name == name.name) {
                let earlier = earlier.name.span;
                self.emit(
                    self.invalid(name.span, format!("two views are named `{}`", name.name))
                        .with_label("second view with this name")
                        .with_secondary(earlier, "first here")
                        .with_note("a view's name names its output files (`NAME.wgsl`, `NAME.png`)"),
                );
            }
            let kind = match &v.kind {
                Some(k) => Located { value: *k.get_ref(), span: self.span(k) },
                None => Located { value: ViewKind::Raycast, span: name.span },
            };
            let size = match &v.size {
                Some(s) => {
                    let [w, h] = *s.get_ref();
                    if !(1..=MAX_VIEW_SIZE).contains(&w) || !(1..=MAX_VIEW_SIZE).contains(&h) {
                        self.emit(
                            self.invalid(
                                self.span(s),
                                format!("a view's width and height must be 1 to {MAX_VIEW_SIZE}"),
                            )
                            .with_label(format!("{w} x {h} pixels")),
                        );
                    }
                    [w, h]
                }
                None => DEFAULT_VIEW_SIZE,
            };
            let mut camera = DEFAULT_CAMERA;
            let mut axis = None;
            let mut position = DEFAULT_SLICE_POSITION;
            let mut slab = 0.0;
            let mut convention = Convention::default();
            match kind.value {
                ViewKind::Raycast => {
                    if let Some(c) = &v.camera {
                        camera = self.camera(c.get_ref());
                    }
                    let slice_keys = [
                        (v.axis.as_ref().map(|a| a.span()), "axis"),
                        (v.position.as_ref().map(|p| p.span()), "position"),
                        (v.slab.as_ref().map(|s| s.span()), "slab"),
                        (v.convention.as_ref().map(|c| c.span()), "convention"),
                    ];
                    for (range, key) in slice_keys {
                        if let Some(r) = range {
                            let span = self.range(r);
                            self.ignored_at(span, key, "on a raycast view");
                        }
                    }
                }
                ViewKind::Slice => {
                    if let Some(c) = &v.camera {
                        self.ignored(c, "camera", "on a slice view");
                    }
                    match &v.axis {
                        Some(a) => axis = Some(Located { value: *a.get_ref(), span: self.span(a) }),
                        None => {
                            self.emit(
                                self.invalid(kind.span, format!("the slice view `{}` needs an `axis`", name.name))
                                    .with_label("a slice view")
                                    .with_help("add `axis = \"axial\"` (axial, coronal or sagittal: the plane's orientation in the patient)"),
                            );
                        }
                    }
                    if let Some(p) = &v.position {
                        position = *p.get_ref();
                        if !(0.0..=1.0).contains(&position) {
                            self.emit(
                                self.invalid(self.span(p), "a slice `position` must be between 0 and 1")
                                    .with_label("normalized along the axis"),
                            );
                        }
                    }
                    if let Some(s) = &v.slab {
                        slab = *s.get_ref();
                        if !(slab >= 0.0 && slab.is_finite()) {
                            self.emit(
                                self.invalid(self.span(s), "a `slab` thickness must be 0 or more")
                                    .with_label("millimetres"),
                            );
                        }
                    }
                    if let Some(c) = &v.convention {
                        convention = *c.get_ref();
                    }
                }
            }
            let modules = v.modules.into_iter().map(|m| self.module(m)).collect();
            let render = match &v.render {
                Some(own) => self.view_render(shared, own),
                None => render.clone(),
            };
            let overlay = match &v.overlay {
                Some(list) => self.view_meshes(Some(list), meshes),
                None => Vec::new(),
            };
            let meshes = self.view_meshes(v.meshes.as_ref(), meshes);
            out.push(View {
                name,
                kind,
                size,
                camera,
                axis,
                position,
                slab,
                convention,
                render,
                modules,
                meshes,
                overlay,
                planes: Vec::new(),
                span,
            });
            planes.push(v.planes);
        }
        for (i, list) in planes.into_iter().enumerate() {
            if let Some(list) = list {
                let resolved = self.view_planes(&out, i, &list);
                out[i].planes = resolved;
            }
        }
        out
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
                "distance" if !(x > 0.0 && x.is_finite()) => Some("the camera `distance` must be greater than 0"),
                "fov" if !(x > 0.0 && x < 180.0) => Some("the camera `fov` must be between 0 and 180 degrees"),
                _ if !x.is_finite() => Some("camera angles must be finite numbers"),
                _ => None,
            };
            if let Some(problem) = problem {
                self.emit(self.invalid(self.span(value), problem).with_label(format!("{key} = {x}")));
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
    preintegration: bool,
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
