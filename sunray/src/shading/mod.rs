//! Shading: the Hall model (thesis 3.1.1, Tables 3.1 and 3.2) and the optics it needs.
//!
//! - [`optics`]: reflection, refraction and Fresnel factors.
//! - [`media`]: the nested transparent volumes a ray travels inside.
//! - [`hall`]: the recursive ray tracer ([`hall::Tracer`]): finds the hit and what shading
//!   needs of it (textured normal, media on either side), then adds
//! - [`direct`]: the direct terms (ambient, diffuse and highlights, through shadow rays),
//! - [`shadow`]: shadow rays, opaque and transparent occluders in one walk, and
//! - [`secondary`]: the reflected and refracted rays.

pub mod direct;
pub mod hall;
pub mod media;
pub mod optics;
pub mod secondary;
pub mod shadow;

pub use hall::{TraceOptions, Tracer};
pub use media::Media;

#[cfg(test)]
mod ray_tree_tests;
#[cfg(test)]
mod smooth_tests;
#[cfg(test)]
mod tests;
