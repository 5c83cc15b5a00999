//! Runtime for shaders composed by `vrsc` (see issue: the runtime is built on top of the composer).
