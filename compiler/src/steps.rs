//! The fixed, ordered list of pipeline steps (`docs/language.md`, "Steps and placement").
//!
//! Public face: [`Step`] (every step in execution order, with its dotted name and group) and
//! [`Step::lookup`], which says what a dotted path names ([`StepLookup`]); the checker, the
//! composer and the language server's completion and hover use them.

use std::fmt;

macro_rules! steps {
    ($($(#[$doc:meta])* $variant:ident = $name:literal, $group:literal;)*) => {
        /// One step of the raycasting pipeline, in execution order.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub enum Step { $($(#[$doc])* $variant),* }

        impl Step {
            /// Every step, in execution order.
            pub const ALL: &'static [Step] = &[$(Step::$variant),*];

            /// The dotted name: `shading.lights`.
            pub fn name(self) -> &'static str {
                match self { $(Step::$variant => $name),* }
            }

            /// The group the step belongs to: `shading`.
            pub(crate) fn group(self) -> &'static str {
                match self { $(Step::$variant => $group),* }
            }
        }
    };
}

steps! {
    /// `ray.setup`: once per ray, before the march: the camera ray, light directions, skipping
    /// to the first content.
    RaySetup = "ray.setup", "ray";
    /// `start`: the first step of each sample: the sample's position along the ray.
    Start = "start", "start";
    /// `sampling.primary`: reads the primary volume at the sample position.
    SamplingPrimary = "sampling.primary", "sampling";
    /// `sampling.mask`: reads the mask volumes, one substep each.
    SamplingMask = "sampling.mask", "sampling";
    /// `sampling.tag`: reads the tag (label) volumes, one substep each.
    SamplingTag = "sampling.tag", "sampling";
    /// `sampling.additional`: reads the additional volumes, one substep each.
    SamplingAdditional = "sampling.additional", "sampling";
    /// `sampling.gradient`: the gradient and the shading normal at the sample.
    SamplingGradient = "sampling.gradient", "sampling";
    /// `classification.primary`: turns the primary value into colour and opacity (transfer
    /// function, masks, tags).
    ClassificationPrimary = "classification.primary", "classification";
    /// `classification.additional`: classifies each additional volume, one substep each.
    ClassificationAdditional = "classification.additional", "classification";
    /// `shading.lights`: the light each light source contributes, one substep each.
    ShadingLights = "shading.lights", "shading";
    /// `shading.boundary`: boundary enhancement.
    ShadingBoundary = "shading.boundary", "shading";
    /// `shading.tone`: tone shading.
    ShadingTone = "shading.tone", "shading";
    /// `compositing.primary_color`: the sample's colour before lighting.
    CompositingPrimaryColor = "compositing.primary_color", "compositing";
    /// `compositing.shading`: applies the lighting to that colour.
    CompositingShading = "compositing.shading", "compositing";
    /// `compositing.alpha`: the rendering mode's rule (DVR opacity, MIP, MinIP, average, iso hit).
    CompositingAlpha = "compositing.alpha", "compositing";
    /// `compositing.additional`: composites each additional volume, one substep each.
    CompositingAdditional = "compositing.additional", "compositing";
    /// `end`: the last step of each sample: accumulation, advancing the ray, skipping empty space.
    End = "end", "end";
    /// `ray.finish`: once per ray, after the march: the background and the pixel's final value.
    RayFinish = "ray.finish", "ray";
    /// `filter.setup`: once per pixel of a view's filter pass: reads the pixel's buffers (its
    /// colour, its depth) into the pixel state.
    FilterSetup = "filter.setup", "filter";
    /// `filter.apply`: the view's filters, one substep each, in the order listed.
    FilterApply = "filter.apply", "filter";
    /// `filter.finish`: the pixel's filtered colour, which the pass writes.
    FilterFinish = "filter.finish", "filter";
}

/// The two pipelines steps belong to: a view's raycaster, and its image-space filter pass.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum PipelineKind {
    /// The ray pipeline: `ray.setup` .. `ray.finish`, once per ray and per sample.
    #[default]
    Ray,
    /// The filter pipeline: `filter.setup` .. `filter.finish`, once per pixel of the picture.
    Filter,
}

impl PipelineKind {
    /// How messages name the pipeline.
    pub fn describe(self) -> &'static str {
        match self {
            PipelineKind::Ray => "the ray pipeline",
            PipelineKind::Filter => "the filter pipeline",
        }
    }
}

/// What a dotted path names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepLookup {
    /// A single step.
    Step(Step),
    /// A group of several steps: its first and last step. (`ray` is not a group one can place
    /// into: its two steps are not adjacent.)
    Group {
        /// The group's first step in execution order.
        first: Step,
        /// The group's last step in execution order.
        last: Step,
    },
    /// Neither a step nor a group.
    Unknown,
}

impl Step {
    /// What a dotted path names: a step, a group of steps, or nothing.
    pub fn lookup(path: &str) -> StepLookup {
        if let Some(step) = Step::ALL.iter().find(|s| s.name() == path) {
            return StepLookup::Step(*step);
        }
        let mut members = Step::ALL.iter().filter(|s| s.group() == path && path != "ray" && s.name() != path);
        match (members.next(), members.next_back()) {
            (Some(first), Some(last)) => StepLookup::Group { first: *first, last: *last },
            (Some(only), None) => StepLookup::Group { first: *only, last: *only },
            _ => StepLookup::Unknown,
        }
    }

    /// Steps that run once per ray rather than once per sample.
    pub(crate) fn is_per_ray(self) -> bool {
        matches!(self, Step::RaySetup | Step::RayFinish)
    }

    /// Steps of the ray pipeline's sample loop.
    pub(crate) fn is_sample_step(self) -> bool {
        self.kind() == PipelineKind::Ray && !self.is_per_ray()
    }

    /// The pipeline the step belongs to.
    pub fn kind(self) -> PipelineKind {
        match self {
            Step::FilterSetup | Step::FilterApply | Step::FilterFinish => PipelineKind::Filter,
            _ => PipelineKind::Ray,
        }
    }

    /// The closest known step or group name, for "did you mean".
    pub fn suggest(path: &str) -> Option<&'static str> {
        let groups = ["sampling", "classification", "shading", "compositing", "filter"];
        Step::ALL
            .iter()
            .map(|s| s.name())
            .chain(groups)
            .map(|name| (crate::suggest::edit_distance(path, name), name))
            .filter(|(d, name)| *d <= 2.max(name.len() / 4))
            .min()
            .map(|(_, name)| name)
    }
}

impl fmt::Display for Step {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lookups() {
        assert_eq!(Step::lookup("shading.lights"), StepLookup::Step(Step::ShadingLights));
        assert_eq!(Step::lookup("start"), StepLookup::Step(Step::Start));
        assert_eq!(
            Step::lookup("compositing"),
            StepLookup::Group { first: Step::CompositingPrimaryColor, last: Step::CompositingAdditional }
        );
        assert_eq!(Step::lookup("ray"), StepLookup::Unknown);
        assert_eq!(Step::lookup("filter"), StepLookup::Group { first: Step::FilterSetup, last: Step::FilterFinish });
        assert_eq!(Step::FilterApply.kind(), PipelineKind::Filter);
        assert!(!Step::FilterApply.is_sample_step() && Step::End.is_sample_step());
        assert_eq!(Step::suggest("shadingg.lights"), Some("shading.lights"));
    }
}
