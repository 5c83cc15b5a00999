//! The composer: turns the checked functions of the modules a scene names into one pipeline.
//!
//! [`place`] instantiates templates (`$`), applies every placement in module order, merges the
//! state and uniform declarations of the placed functions and checks the data flow of the linear
//! pipeline. Its [`place::Composition`] is what emission builds the shader from.

pub mod backends;
pub mod build;
pub mod cache;
pub mod contribution;
pub mod entry;
pub mod explain;
pub mod place;
pub mod probe;
pub mod reflect;
pub mod uniform_check;
pub mod view;
