//! Geometry: vectors, rays, and the two shapes (spheres and infinite planes)
//! with robust f32 intersection and error-bounded hit points.

mod plane;
mod ray;
mod sphere;
mod vec3;

pub use plane::Plane;
pub use ray::{Hit, ObjectId, Ray};
pub use sphere::Sphere;
pub(crate) use sphere::{line_misses, line_misses_by_far};
pub use vec3::{Color, Vec3};
