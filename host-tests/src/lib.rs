//! The std harness of micropt: image files, multi-threaded rendering of the
//! `no_std` core, error metrics. The `micropt` CLI, the integration tests and
//! the benchmarks are built on it.
#![cfg_attr(target_os = "none", no_std)]
#![cfg(not(target_os = "none"))]
#![deny(missing_docs)]

pub mod bench;
pub mod image;
pub mod metrics;
pub mod reference;
pub mod render;
pub mod smallpt;

pub use image::Image;
pub use render::{
    BudgetJob, BudgetOutput, RenderJob, RenderOutput, load_scene, render, render_budget,
};
