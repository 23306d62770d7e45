//! The scene the render loop's unit tests render to an error (test support, written once).

use crate::accel::{Accel, AccelKind, AccelOptions};
use crate::scene::Scene;

/// A sphere, its shadow under an area light and the background around: pixels that stop at
/// their first samples, and pixels that need every pass.
const SHADOWED_SPHERE: &str = "background(color = 0.1,0.1,0.3);
camera(position = 0,0,-8; at = 0,0,0; up = 0,1,0; angle = 30);
light(position = -6,6,-6; color = 1,1,1; radius = 1.5);
begin
  attribute(color = 1,0.6,0.4; kdr = 0.7; ka = 0.1; phong = 20);
  sphere(center = 0,0.6,0; radius = 0.8);
  polygon(vertices = 4; -3,-0.3,-3 -3,-0.3,3 3,-0.3,3 3,-0.3,-3);
end
";

/// [`SHADOWED_SPHERE`] compiled, with its BVH.
pub fn shadowed_sphere() -> (Scene, Accel) {
    compiled(SHADOWED_SPHERE)
}

/// A YARI scene's `text` compiled, with its BVH.
pub fn compiled(text: &str) -> (Scene, Accel) {
    let table = yari::colour::ColourTable::default();
    let loaded = yari::load::load_str("t.yari", text, yari::load::InputKind::Yari, &table)
        .expect("the test scene compiles");
    let mut scene = Scene::new(loaded.world);
    let opts = AccelOptions {
        kind: AccelKind::Bvh,
        ..AccelOptions::default()
    };
    let accel = Accel::build(&mut scene.prims, &opts);
    (scene, accel)
}
