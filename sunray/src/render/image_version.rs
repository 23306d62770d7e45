//! Which pixels this build renders: [`IMAGE_VERSION`], a number raised whenever a change moves
//! any pixel of any scene (a bit of an `f32`, a sample count of a render to an error).
//!
//! A farm is upgraded host by host, and a job's checkpoint outlives the build that started it,
//! so one image could be made of lines from two builds that render different pixels: no longer
//! the bytes `sunray render` gives. So the version travels: in a worker's `Ready` (the
//! controller gives lines only to workers of its own version; any other is a fault of that
//! node, told to stop) and in the render settings of the `Scene` message and the checkpoint
//! (a worker refuses a Scene of another version, a controller a checkpoint:
//! `Settings::from_proto` in `distrib::messages`). Builds from before the field said nothing;
//! they rendered version 1's pixels ([`version_said`]).
//!
//! The test below holds the version to the pixels: it renders small scenes that touch every
//! sampler and the optional paths of the tracer (textures, reflection, refraction, area
//! lights, gloss, translucency, depth of field, motion blur, quadrics, a render to an error)
//! and compares a hash of their `f32` bytes with the one recorded there for this version. A
//! change that moves a pixel fails it until the version is raised and the new hash recorded.

/// The version of the pixels this build renders.
pub const IMAGE_VERSION: u32 = 1;

/// The version a peer's message means: 0 (a build before the field) is version 1.
fn version_said(field: u32) -> u32 {
    field.max(1)
}

/// The version a peer that said `field` renders when it is not this build's (`None`: the
/// same pixels); what a Ready and the render settings of a Scene or a checkpoint are read by.
pub fn other_than_ours(field: u32) -> Option<u32> {
    Some(version_said(field)).filter(|&v| v != IMAGE_VERSION)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{Accel, AccelOptions};
    use crate::render::adaptive::Adaptive;
    use crate::render::test_scene::compiled;
    use crate::render::{render_image, Progress, RenderOptions};
    use crate::sampler::Sampler;
    use crate::scene::Scene;
    use sha2::{Digest, Sha256};
    use yari::spd::Database;

    /// SHA-256 (first 16 hex digits) of the test's images at [`IMAGE_VERSION`].
    const PIXELS_HASH: &str = "bbb607865196b3ec";

    /// Every optional path of the tracer on a few pixels: a textured floor, a mirror, a glass
    /// sphere, a glossy and a translucent one, a clipped quadric, a moving sphere, an area
    /// light, under a lens.
    const FEATURES: &str = "background(color = 0.1,0.1,0.3); ambient(color = 0.2,0.2,0.2);
camera(position = 0,2,8; at = 0,0.5,0; up = 0,1,0; angle = 30; aperture = 0.1; focus = 8);
light(position = -6,8,6; color = 1,1,1; radius = 1);
light(position = 5,6,4; color = 0.4,0.4,0.4);
begin
  begin attribute(color = 0.9,0.9,0.9; texture = 5 0.2,0.2,0.2 0.5,0.5,0.5);
    polygon(vertices = 4; -6,0,-6 -6,0,6 6,0,6 6,0,-6); end
  begin attribute(color = 1,1,1; kdr = 0.05); sphere(center = -1.8,0.8,0; radius = 0.8); end
  begin attribute(color = 1,1,1; kdr = 0.1; kdt = 0.05; refract = 1.5);
    sphere(center = 0,0.7,1.5; radius = 0.7); end
  begin attribute(color = 0.9,0.7,0.3; kdr = 0.3; gloss = 8; phong = 30);
    sphere(center = 1.8,0.8,0; radius = 0.8); end
  begin attribute(color = 0.6,0.9,0.6; kdt = 0.4; translucency = 10);
    sphere(center = 0.5,0.5,-2; radius = 0.5); end
  begin attribute(color = 0.3,0.5,1); translate(-0.5,0,-1);
    quadric(1 0 0 0 0 0 0 1 0 -0.04; clip = -0.2,0,-0.2 0.2,1.2,0.2); end
  begin attribute(color = 1,0.3,0.3); motion(0.3,0,0);
    sphere(center = 1,2,-1; radius = 0.3); end
end";

    /// The renders the hash covers: each sampler, a fixed count and a target error.
    fn images() -> Vec<Vec<[f32; 3]>> {
        let (scene, accel) = compiled(FEATURES);
        let base = RenderOptions::asked([24, 18], 4);
        let renders = [
            base,
            RenderOptions {
                sampler: Sampler::Sobol,
                ..base
            },
            RenderOptions {
                adaptive: Some(Adaptive::new(0.05, None, Some(64))),
                ..base
            },
            RenderOptions::asked([24, 18], 1),
        ];
        let mut out: Vec<_> = renders
            .iter()
            .map(|opts| render_image(&scene, &accel, opts, 2, false, Progress::Hidden).0)
            .map(|film| film.pixels)
            .collect();
        // A pinhole and many triangles: the footprint and the BVH's leaf kernels.
        let world = crate::bench::spd_world(Database::Tetra, 4).expect("tetra compiles");
        let mut scene = Scene::new(world);
        let accel = Accel::build(&mut scene.prims, &AccelOptions::default());
        let opts = RenderOptions::asked([24, 18], 1);
        out.push(
            render_image(&scene, &accel, &opts, 1, false, Progress::Hidden)
                .0
                .pixels,
        );
        out
    }

    fn hash(images: &[Vec<[f32; 3]>]) -> String {
        let mut h = Sha256::new();
        for p in images.iter().flatten().flatten() {
            h.update(p.to_le_bytes());
        }
        h.finalize()[..8]
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect()
    }

    #[test]
    fn the_pixels_are_the_versions() {
        let got = hash(&images());
        assert_eq!(
            got,
            PIXELS_HASH,
            "the test images' pixels changed: if the change meant to move pixels, raise \
             IMAGE_VERSION to {} and set PIXELS_HASH to \"{got}\" (a host whose CPU or libm \
             rounds differently renders other bytes too, and cannot share a farm's image)",
            IMAGE_VERSION + 1
        );
    }

    #[test]
    fn a_changed_pixel_changes_the_hash() {
        let mut images = images();
        let before = hash(&images);
        images[2][100][1] = f32::from_bits(images[2][100][1].to_bits() ^ 1);
        assert_ne!(hash(&images), before);
    }

    #[test]
    fn a_peer_that_said_nothing_is_version_1() {
        assert_eq!(version_said(0), 1);
        assert_eq!(version_said(7), 7);
        assert_eq!(other_than_ours(IMAGE_VERSION), None);
        assert_eq!(other_than_ours(IMAGE_VERSION + 1), Some(IMAGE_VERSION + 1));
    }
}
