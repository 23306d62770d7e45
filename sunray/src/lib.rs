//! SunRay: a ray tracer with the Hall shading model (thesis chapter 3 and section 4.2), and
//! SunRay III, its distributed controller and workers over REM (section 4.2.4).
//!
//! # Layout
//! - [`cli`]: the `sunray` command's subcommands, each in its own module.
//! - [`geometry`]: rays, boxes and primitives (spheres, ellipsoids, triangles, quadrics).
//! - [`accel`]: exhaustive search, Glassner's octree with mailbox, and a SAH BVH.
//! - [`shading`]: the Hall model's recursive ray tracer.
//! - [`texture`]: Perlin noise and the solid textures (wood, marble, bumps, ...).
//! - [`camera`], [`film`], [`sampler`]: eye rays, images and files, counter-based random numbers;
//!   [`sobol`]: the Sobol samples the sampler draws, by table.
//! - [`scene`]: a model ready to render; [`render`]: the scanline render loop.
//! - [`prepared`]: scenes kept ready on a host (tables and BVH), mapped in place when used;
//!   [`store`]: a table owned or viewed in a mapped file.
//! - [`stats`]: counted statistics.
//! - [`distrib`]: SunRay III: the controller and worker actors over REM, strategies, grants,
//!   checkpoints and the per-node table.
//! - [`bench`]: the thesis's Tables 4.1 and 4.2 and throughput runs on SPD scenes.

pub mod accel;
pub mod bench;
pub mod camera;
pub mod cli;
pub mod distrib;
pub mod film;
pub mod geometry;
pub mod prepared;
pub mod render;
pub mod sampler;
pub mod scene;
pub mod shading;
pub mod sobol;
pub mod stats;
pub mod store;
pub mod texture;
