use super::*;
use crate::parse::parse;
use crate::span::Source;

fn reparse(text: &str) -> Scene {
    let mut s = parse(&Source::new("t.yari", text))
        .unwrap_or_else(|d| panic!("{}", d.render(&Source::new("t.yari", text))));
    erase_spans(&mut s);
    s
}

#[test]
fn thesis_scenes_round_trip() {
    for name in ["tetra16.yari", "cubes.yari"] {
        let text = crate::test_support::thesis_example(name);
        let first = reparse(&text);
        let written = write_scene(&first);
        assert_eq!(reparse(&written), first, "{name}:\n{written}");
    }
}

#[test]
fn extensions_and_awkward_numbers_round_trip() {
    let text = "samples(4); resolution(10, 20); ambient(color = 0.1,0.2,0.3);
        light(position = 1e-300,-0,3; color = 1,1,1; radius = 0.25);
        camera(position = 0,0,5; at = 0,0,0; up = 0,1,0; angle = 30; aperture = 0.1; focus = 4.5);
        begin
          attribute(color = red; kdr = 0.1; texture = 2 1,0,0 .5,.5,.5; gloss = 3; texture_space = 1 0 0 0 0 1 0 0 0 0 1 0);
          motion(1, 2, 3); transform(1 2 3 4 5 6 7 8 9 10 11 12);
          begin scale(1e300, 1, 1); end
          quadric(1 0 0 0 1 0 0 1 0 -1; clip = -1,-1,-1 1,1,1; plane = 0,0,1 0.5);
          sphere(center = 0.1,0.2,0.30000000000000004; radius = 123456789012345680000);
          polygon(vertices = 3; 0,0,0 1,0,0 0,1,0);
        end";
    let first = reparse(text);
    let written = write_scene(&first);
    assert_eq!(reparse(&written), first, "{written}");
    assert!(written.contains("1e-300"), "{written}");
}

fn compile_text(name: &str, text: &str) -> crate::model::World {
    let src = Source::new(name, text);
    let scene = parse(&src).unwrap_or_else(|d| panic!("{}", d.render(&src)));
    match crate::compile::compile(&scene, &crate::colour::ColourTable::builtin()) {
        Ok(c) => c.world,
        Err(d) => panic!("{}", d.render(&src)),
    }
}

const RICH: &str = "samples(9); resolution(64, 48); background(color = UNC_Blue); ambient(color = 0.1,0.1,0.1);
    light(position = 1,2,3; color = white; radius = 0.5); light(position = -1,2,3; color = 0.3,0.3,0.3);
    camera(position = 0,1,10; at = 0,0,0; up = 0,1,0; angle = 25; aperture = 0.05);
    begin
      attribute(color = purple; kdr = 0.3; kdt = 0.4; refract = 1.5; gloss = 2; translucency = 3; transmissivity = 0.8;
                texture = 2 0.2,0.3,0.4 1,2,3);
      begin rotate(10, 20, 30); scale(1, 2, 0.5); translate(1, 2, 3);
        sphere(center = 0.1,0.2,0.3; radius = 0.7);
        polygon(vertices = 4; 0,0,0 1,0,0 1,1,0 0,1,0);
        quadric(1 0 0 0 1 0 0 -1 0 0; clip = -1,-1,-1 1,1,1; plane = 1,1,0 0.25);
      end
      motion(0.5, 0, 0);
      begin rotate(0, 45, 0); sphere(center = 1,1,1; radius = 2); end
      attribute(color = red);
      polygon(vertices = 3; 0,0,0 1,0,0 0,1,0);
    end";

#[test]
fn compiled_worlds_round_trip_exactly_through_write_world() {
    let mut cases: Vec<(String, String)> = ["tetra16.yari", "cubes.yari"]
        .iter()
        .map(|n| (n.to_string(), crate::test_support::thesis_example(n)))
        .collect();
    cases.push(("rich.yari".into(), RICH.into()));
    for (name, text) in cases {
        let world = compile_text(&name, &text);
        let flat = write_world(&world);
        let again = compile_text("flat.yari", &flat);
        assert_eq!(again, world, "{name}:\n{flat}");
        // parse -> write_scene -> parse compiles to the same world too.
        let src = Source::new(name.as_str(), text.as_str());
        let rewritten = write_scene(&parse(&src).unwrap());
        assert_eq!(compile_text("re.yari", &rewritten), world, "{name}");
    }
    let rich = compile_text("rich.yari", RICH);
    let f = &rich.features;
    assert!(f.ellipsoids == 1 && f.spheres == 1 && f.quadrics == 1 && f.polygons == 2);
    assert!(
        f.textures
            && f.gloss
            && f.translucency
            && f.motion_blur
            && f.area_lights
            && f.depth_of_field
            && f.antialiasing
    );
}

const SMOOTH: &str = "begin
      polygon(vertices = 3; 0,0,0 1,0,0 0,1,0; normals = 0,0,1 0.1,0,1 0,0.30000000000000004,1);
      begin rotate(10, 20, 30); scale(1, 2, 0.5); translate(1, 2, 3);
        polygon(vertices = 4; 0,0,0 1,0,0 1,1,0 0,1,0; normals = 0,0,1 1,0,1 1,1,1 0,1,1);
      end
      motion(0.5, 0, 0);
      polygon(vertices = 3; 0,0,0 1,0,0 0,1,0; normals = 0,0,-1 0,0,-1 0,0,-1e-100);
      polygon(vertices = 3; 0,0,0 1,0,0 0,1,0);
    end";

#[test]
fn smooth_polygons_round_trip_through_both_writers() {
    // The syntax tree: write, parse, the same tree.
    let first = reparse(SMOOTH);
    let written = write_scene(&first);
    assert_eq!(reparse(&written), first, "{written}");
    assert!(written.contains("; normals =  0,0,1  0.1,0,1  0,0.30000000000000004,1)"));
    // The compiled world: write it flat, compile it again, the same world to the bit.
    let world = compile_text("smooth.yari", SMOOTH);
    let flat = write_world(&world);
    assert_eq!(compile_text("flat.yari", &flat), world, "{flat}");
    let smooth: Vec<&Vec<glam::DVec3>> = world
        .objects
        .iter()
        .filter_map(|o| match &o.shape {
            crate::model::Shape::SmoothPolygon { normals, .. } => Some(normals),
            _ => None,
        })
        .collect();
    assert_eq!(smooth.len(), 3);
    assert_eq!(smooth[2][2], glam::DVec3::new(0.0, 0.0, -1e-100));
    assert_eq!(world.features.polygons, 4);
}
