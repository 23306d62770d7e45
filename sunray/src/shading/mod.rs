//! Shading: the Hall model (thesis 3.1.1, Tables 3.1 and 3.2) and the optics it needs.
//!
//! - [`optics`]: reflection, refraction and Fresnel factors.
//! - [`media`]: the nested transparent volumes a ray travels inside.
//! - [`hall`]: the recursive ray tracer ([`hall::Tracer`]) that shades a hit with the Hall
//!   terms, casts shadow rays and spawns reflected and refracted rays.

pub mod hall;
pub mod media;
pub mod optics;

pub use hall::{TraceOptions, Tracer};
pub use media::Media;

#[cfg(test)]
mod tests;
