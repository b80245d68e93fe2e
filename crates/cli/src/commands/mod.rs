//! The subcommands of `keycomp`, one module each: its arguments (clap) and its `run`.

pub mod demo;
pub mod detect;
pub mod index;
pub mod keypoints;
pub mod r#match;
pub mod query;
pub mod render;
pub mod serve;
pub mod surface;
pub mod transform;
