//! The reflection that `vrsc` gives each view (in process, or as the `VIEW.json` of `vrsc build`):
//! what the runtime needs to bind resources and fill the uniform block. The types are defined
//! once, in `vrs-reflection`, for the compiler and the runtime alike.

pub(crate) use vrs_reflection::{BindingInfo, BindingKind};
pub use vrs_reflection::{FunctionInfo, FunctionStatus, Reflection, UniformInfo, content_hash};
