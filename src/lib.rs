//! # micropt
//!
//! A `no_std`, allocation-free, f32 Monte Carlo path tracer for analytic
//! scenes of spheres and infinite planes, built to run on microcontroller
//! display boards and to give the same bits on the host.
//!
//! ```
//! use micropt::{parse::parse, Renderer, Stats, Vec3, film::{tiles, draw_tile, TILE}};
//! use embedded_graphics::{framebuffer::{Framebuffer, buffer_size}, pixelcolor::{Rgb565, raw::{RawU16, BigEndian}}};
//!
//! let scene = parse(include_str!("../scenes/sphere-over-plane.scene"))?;
//! let renderer = Renderer::new(&scene, 32, 24).unwrap().seed(7);
//! let mut fb = Framebuffer::<Rgb565, RawU16, BigEndian, 32, 24, { buffer_size::<Rgb565>(32, 24) }>::new();
//! let mut stats = Stats::default();
//! let mut tile_px = [Vec3::ZERO; (TILE * TILE) as usize];
//! for tile in tiles(32, 24) {
//!     renderer.render_tile(&tile, 2, &mut tile_px, &mut stats);
//!     draw_tile(&mut fb, &tile, &tile_px, 1.0).unwrap();
//! }
//! assert_eq!(stats.paths, 32 * 24 * 2);
//! # Ok::<(), micropt::parse::ParseError>(())
//! ```
//!
//! Modules, one per concept, each importing only from those listed before
//! it (docs/architecture.md): [`math`] (every float function, explicitly),
//! [`sampler`] (random streams, Sobol points, the concentric disk),
//! [`geometry`] (vectors, rays, spheres, planes), [`camera`], [`error`]
//! (what can be wrong with a scene, and the value checks), [`light`],
//! [`material`], [`analysis`] (work a scene never needs), [`scene`],
//! [`parse`], [`stats`] (work counters), `highlight` (lights seen in mirror
//! balls, sampled from the light's side; feature `highlight`), `caustic`
//! (the light reaching a surface through a mirror or glass ball, sampled
//! through the ball; feature `highlight`), [`integrator`], [`film`], [`render`], [`budget`] (fixed budgets,
//! progressive and adaptive), [`multicore`] (one budgeted render shared
//! between cores; its atomic work queues on targets with atomic
//! read-modify-write), [`denoise`] (the streaming denoiser: guided filters
//! chosen per pixel by their estimated error).

#![no_std]
#![cfg_attr(
    not(all(target_arch = "arm", target_abi = "eabihf")),
    forbid(unsafe_code)
)]
#![cfg_attr(all(target_arch = "arm", target_abi = "eabihf"), deny(unsafe_code))]
#![deny(missing_docs)]
#![deny(missing_debug_implementations)]
#![deny(trivial_casts)]
// `!(x > 0.0)` is deliberate throughout: unlike `x <= 0.0` it is also true
// for NaN, which is how invalid values are rejected without a panic.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod analysis;
pub mod budget;
pub mod camera;
#[cfg(feature = "highlight")]
pub mod caustic;
pub mod demo;
pub mod denoise;
pub mod error;
pub mod film;
pub mod geometry;
#[cfg(feature = "highlight")]
pub mod highlight;
pub mod integrator;
pub mod light;
pub mod material;
pub mod math;
pub mod multicore;
#[cfg(feature = "parser")]
pub mod parse;
pub mod render;
pub mod sampler;
pub mod scene;
pub mod stats;

pub use budget::{AdaptiveOptions, Budget, Clock};
pub use camera::{Camera, CameraError, CameraSpec};
pub use geometry::{Color, Hit, ObjectId, Plane, Ray, Sphere, Vec3};
pub use integrator::{Options, Skip, Stats, Strategy};
pub use material::Material;
pub use render::Renderer;
pub use scene::{MaterialId, Scene, SceneBuilder, SceneError, SceneView};

/// The README's Rust examples, compiled and run as doctests (only when
/// rustdoc collects doctests), so that the README cannot drift from the API.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
