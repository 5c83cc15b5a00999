//! The fixed, ordered list of pipeline steps (section 6 of the language spec).

use std::fmt;

macro_rules! steps {
    ($($variant:ident = $name:literal, $group:literal;)*) => {
        /// One step of the raycasting pipeline, in execution order.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub enum Step { $($variant),* }

        impl Step {
            /// Every step, in execution order.
            pub const ALL: &'static [Step] = &[$(Step::$variant),*];

            /// The dotted name: `shading.lights`.
            pub fn name(self) -> &'static str {
                match self { $(Step::$variant => $name),* }
            }

            /// The group the step belongs to: `shading`.
            pub fn group(self) -> &'static str {
                match self { $(Step::$variant => $group),* }
            }
        }
    };
}

steps! {
    RaySetup = "ray.setup", "ray";
    Start = "start", "start";
    SamplingPrimary = "sampling.primary", "sampling";
    SamplingMask = "sampling.mask", "sampling";
    SamplingTag = "sampling.tag", "sampling";
    SamplingAdditional = "sampling.additional", "sampling";
    SamplingGradient = "sampling.gradient", "sampling";
    ClassificationPrimary = "classification.primary", "classification";
    ClassificationAdditional = "classification.additional", "classification";
    ShadingLights = "shading.lights", "shading";
    ShadingBoundary = "shading.boundary", "shading";
    ShadingTone = "shading.tone", "shading";
    CompositingPrimaryColor = "compositing.primary_color", "compositing";
    CompositingShading = "compositing.shading", "compositing";
    CompositingAlpha = "compositing.alpha", "compositing";
    CompositingAdditional = "compositing.additional", "compositing";
    End = "end", "end";
    RayFinish = "ray.finish", "ray";
}

/// What a dotted path names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepLookup {
    Step(Step),
    /// A group of several steps: its first and last step. (`ray` is not a group one can place
    /// into: its two steps are not adjacent.)
    Group {
        first: Step,
        last: Step,
    },
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
    pub fn is_per_ray(self) -> bool {
        matches!(self, Step::RaySetup | Step::RayFinish)
    }

    /// The closest known step or group name, for "did you mean".
    pub fn suggest(path: &str) -> Option<&'static str> {
        let groups = ["sampling", "classification", "shading", "compositing"];
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
        assert_eq!(Step::suggest("shadingg.lights"), Some("shading.lights"));
    }
}
