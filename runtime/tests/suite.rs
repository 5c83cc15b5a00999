//! The runtime's integration tests, one module per file beside this one, in one test binary:
//! a binary per file cost a link of the whole runtime each (63 s of a cold two-core build for
//! the nineteen, against 11 s for this one), and one process lets the test threads share out
//! the long tests of every file. `cargo test -p vrs-runtime --test suite renderer_tree::` runs one
//! file's tests.

mod common;

mod bricks;
mod combinations;
mod contribution;
mod examples;
mod filters;
mod golden;
mod light;
mod meshes;
mod mni;
mod pathtrace;
mod patient_space;
mod phantoms;
mod probe;
mod renderer_tree;
mod runtime;
mod scene_fuzz;
mod skipping;
mod zarr_fixtures;
