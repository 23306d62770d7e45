use super::commands::Cli;
use super::*;
use clap::{CommandFactory, Parser};

fn run_args(project: &Path, args: &[&str]) -> Result<String, ModelError> {
    let mut argv = vec!["modeler", "-p", project.to_str().unwrap()];
    argv.extend_from_slice(args);
    let cli = Cli::try_parse_from(argv).map_err(|e| ModelError::bad_arg("argv", e.to_string()))?;
    let mut out = Vec::new();
    run(cli, &mut out)?;
    Ok(String::from_utf8(out).unwrap())
}

fn script(project: &Path, dir: &Path, text: &str) -> Result<String, ModelError> {
    let file = dir.join("s.modeler");
    std::fs::write(&file, text).unwrap();
    run_args(project, &["script", file.to_str().unwrap()])
}

const BUILD: &str = r#"
# a small scene
new
skeleton new prof --plane xy --kind bezier 0,0 1,0 1,0.5 0.5,1 0.3,1.5 0.3,2 0,2
skeleton smooth prof 4
revolve body --profile prof --axis y --step 45
skeleton new cross --plane xy --closed -0.1,2 0.1,2 0.1,2.5 -0.1,2.5
extrude top --outline cross --depth 0.2 --centred
combine piece body top
surface piece --color "0.9,0.9,0.8" --kdr 0.8 --phong 40
add sphere ball --center 3,1,0 --radius 1
light add fill --position -10,5,10 --color 0.5,0.5,0.5
"#;

#[test]
fn a_script_builds_a_scene_and_saves_once() {
    let dir = tempfile::tempdir().unwrap();
    let proj = dir.path().join("p.json");
    script(&proj, dir.path(), BUILD).unwrap();
    let p = Project::load(&proj).unwrap();
    assert_eq!(p.object_names(), ["piece", "body", "top", "ball"]);
    assert_eq!(p.object("body").unwrap().primitives.len(), 8 * 4 * 2);
    assert_eq!(p.object("top").unwrap().primitives.len(), 6);
    assert_eq!(p.settings.lights.len(), 2);
    let listing = run_args(&proj, &["show"]).unwrap();
    assert!(
        listing.contains("piece: composite of 2") && listing.contains("prof: plane xy"),
        "{listing}"
    );
}

#[test]
fn a_failing_script_leaves_the_project_as_it_was() {
    let dir = tempfile::tempdir().unwrap();
    let proj = dir.path().join("p.json");
    script(&proj, dir.path(), BUILD).unwrap();
    let before = std::fs::read(&proj).unwrap();
    let err = script(
        &proj,
        dir.path(),
        "translate ball 1,0,0\nrotate piece 0,45\nadd sphere x --center 0,0,0 --radius 1\n",
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("s.modeler:2:") && err.contains("x,y,z"),
        "{err}"
    );
    assert_eq!(std::fs::read(&proj).unwrap(), before);
    let err = script(
        &proj,
        dir.path(),
        "translate ball 1,0,0\nsurface nothere --kdr 0.5\n",
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("s.modeler:2:") && err.contains("nothere"),
        "{err}"
    );
    assert_eq!(std::fs::read(&proj).unwrap(), before);
    // No temporary files are left beside the project.
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(names.iter().all(|n| !n.contains(".tmp")), "{names:?}");
}

#[test]
fn bad_commands_name_the_bad_argument_and_change_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let proj = dir.path().join("p.json");
    script(&proj, dir.path(), BUILD).unwrap();
    let before = std::fs::read(&proj).unwrap();
    let cases: &[(&[&str], &str)] = &[
        (&["surface", "ball", "--color", "nosuchcolour"], "--color"),
        (&["surface", "ball", "--kdr", "2"], "--kdr"),
        (
            &["revolve", "r", "--profile", "cross", "--axis", "z"],
            "cross",
        ),
        (
            &["revolve", "r", "--profile", "prof", "--step", "0"],
            "--step",
        ),
        (
            &["extrude", "e", "--outline", "cross", "--by", "1,0,0"],
            "--by",
        ),
        (&["skeleton", "move", "prof", "99", "0,0"], "INDEX"),
        (&["combine", "g", "ball", "ghost"], "ghost"),
        (
            &[
                "add", "sphere", "ball", "--center", "0,0,0", "--radius", "1",
            ],
            "ball",
        ),
        (&["camera", "--angle", "95"], "--angle"),
        (&["new"], "--force"),
    ];
    for (args, needle) in cases {
        let err = run_args(&proj, args).unwrap_err().to_string();
        assert!(err.contains(needle), "{args:?}: {err}");
        assert_eq!(std::fs::read(&proj).unwrap(), before, "{args:?}");
    }
}

#[test]
fn a_missing_project_is_explained() {
    let dir = tempfile::tempdir().unwrap();
    let err = run_args(&dir.path().join("none.json"), &["show"])
        .unwrap_err()
        .to_string();
    assert!(err.contains("modeler new"), "{err}");
}

#[test]
fn every_command_has_help_and_the_parser_is_consistent() {
    let cmd = Cli::command();
    cmd.clone().debug_assert();
    fn visit(cmd: &clap::Command, path: &mut Vec<String>, count: &mut usize) {
        for sub in cmd.get_subcommands() {
            path.push(sub.get_name().to_string());
            let mut argv = vec!["modeler".to_string()];
            argv.extend(path.iter().cloned());
            argv.push("--help".into());
            let err = Cli::try_parse_from(&argv).unwrap_err();
            assert_eq!(err.kind(), clap::error::ErrorKind::DisplayHelp, "{argv:?}");
            assert!(sub.get_about().is_some(), "{argv:?} has no description");
            *count += 1;
            visit(sub, path, count);
            path.pop();
        }
    }
    let mut count = 0;
    visit(&cmd, &mut Vec::new(), &mut count);
    assert!(count > 30, "{count}");
}

#[test]
fn export_and_import_through_the_command_line_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let proj = dir.path().join("p.json");
    script(&proj, dir.path(), BUILD).unwrap();
    let yari_path = dir.path().join("scene.yari");
    run_args(&proj, &["export", "-o", yari_path.to_str().unwrap()]).unwrap();
    let proj2 = dir.path().join("q.json");
    run_args(&proj2, &["import", yari_path.to_str().unwrap()]).unwrap();
    let (a, b) = (
        Project::load(&proj).unwrap(),
        Project::load(&proj2).unwrap(),
    );
    assert_eq!(a.objects, b.objects);
    assert_eq!(a.settings, b.settings);
    // Exported text on stdout matches the file.
    assert_eq!(
        run_args(&proj2, &["export"]).unwrap(),
        std::fs::read_to_string(&yari_path).unwrap()
    );
    let png = dir.path().join("v.png");
    run_args(
        &proj,
        &[
            "preview",
            "-o",
            png.to_str().unwrap(),
            "--size",
            "40",
            "--style",
            "wire",
        ],
    )
    .unwrap();
    assert_eq!(image::open(&png).unwrap().width(), 2 * 40 + 6);
}

#[test]
fn editing_commands_change_what_they_say() {
    let dir = tempfile::tempdir().unwrap();
    let proj = dir.path().join("p.json");
    script(&proj, dir.path(), BUILD).unwrap();
    let edits = "copy piece piece2\nrename ball moon\ndelete moon\nexplode piece2\n\
        translate piece 1,2,3\nrotate piece 0,90,0 --about 1,0,0\nscale piece2.body 2\n\
        surface piece2.top --texture \"marble 0.2,0.2,0.2 0.5,0.5,0.5\" --ka 0.3\nsurface piece --inherit\n\
        camera --position 0,5,20 --up 0,1,0 --angle 30\nview --from 10,10,10\n\
        light move fill 1,2,3\nlight color fill yellow\nlight delete key\n\
        background black\nambient 0.1,0.1,0.1\nresolution 320 200\nsamples 4\n\
        skeleton add prof --at 1 0,3\nskeleton remove prof 1\nskeleton set cross --depth 2 --closed false\nskeleton delete cross\n\
        add polygon tri --vertices 0,0,0 1,0,0 0,1,0\nadd quadric q --coeffs 1 0 0 0 1 0 0 1 0 -1 --box 1,1,1 -1,-1,-1 --plane 0,0,1,0.5\n\
        skeleton new pts --plane yz --kind points --depth 4 0,0 0,2\nadd sphere s --from pts\n";
    script(&proj, dir.path(), edits).unwrap();
    let p = Project::load(&proj).unwrap();
    assert_eq!(
        p.object_names(),
        [
            "piece",
            "body",
            "top",
            "piece2.body",
            "piece2.top",
            "tri",
            "q",
            "s"
        ]
    );
    assert_eq!(p.object("piece").unwrap().surface, None);
    assert_eq!(p.object("body").unwrap().transforms.len(), 4);
    assert_eq!(
        p.object("piece2.body").unwrap().transforms,
        [Transform::Scale([2.0; 3])]
    );
    // The copy's parts kept the composite's surface when it was exploded, plus the new fields.
    let top2 = p.object("piece2.top").unwrap().surface.clone().unwrap();
    assert_eq!(
        (top2.kdr, top2.ka, top2.texture.map(|t| t.id)),
        (Some(0.8), Some(0.3), Some(2.0))
    );
    let s = &p.settings;
    assert_eq!(
        s.camera.as_ref().map(|c| (c.position, c.angle)),
        Some(([0.0, 5.0, 20.0], 30.0))
    );
    assert_eq!(
        s.view.as_ref().map(|v| (v.from, v.at)),
        Some(([10.0; 3], [0.0; 3]))
    );
    assert_eq!(s.lights.len(), 1);
    assert_eq!(
        (s.lights[0].position, &s.lights[0].color),
        (
            [1.0, 2.0, 3.0],
            &crate::project::Color::Named("yellow".into())
        )
    );
    assert_eq!((s.resolution, s.samples), (Some([320, 200]), Some(4)));
    assert_eq!(
        p.skeletons
            .iter()
            .map(|s| s.name.as_str())
            .collect::<Vec<_>>(),
        ["prof", "pts"]
    );
    assert_eq!(p.skeletons[0].points[0], [0.0, 0.0]);
    let q = &p.object("q").unwrap().primitives[0];
    let crate::project::Primitive::Quadric { clip, .. } = q else {
        panic!("{q:?}")
    };
    assert_eq!(
        clip[0],
        crate::project::Clip::Box {
            min: [-1.0; 3],
            max: [1.0; 3]
        }
    );
    // A sphere from two points of a yz skeleton at x = 4.
    let ball = &p.object("s").unwrap().primitives[0];
    assert_eq!(
        ball,
        &crate::project::Primitive::Sphere {
            center: [4.0, 0.0, 0.0],
            radius: 2.0
        }
    );
    // The view reset goes back to the camera.
    script(&proj, dir.path(), "view --camera\n").unwrap();
    assert!(Project::load(&proj).unwrap().settings.view.is_none());
}

/// A scene whose mesh file sits beside it, imported into a project in another folder: the
/// preview finds the mesh from the project's folder, and `export -o` to a third folder
/// writes a scene that finds it from there (none of them is the current folder).
#[test]
fn relative_mesh_files_follow_the_project_and_the_exported_scene() {
    let dir = tempfile::tempdir().unwrap();
    let (scenes, work, out) = (
        dir.path().join("scenes"),
        dir.path().join("work"),
        dir.path().join("out/deep"),
    );
    for d in [scenes.join("meshes"), work.clone(), out.clone()] {
        std::fs::create_dir_all(d).unwrap();
    }
    let obj = "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nf 1 2 3\n";
    std::fs::write(scenes.join("meshes/tri.obj"), obj).unwrap();
    let scene = scenes.join("scene.yari");
    std::fs::write(
        &scene,
        "camera(position = 0,0,-5; at = 0,0,0; up = 0,1,0; angle = 30);\n\
         light(position = -5,5,-5; color = 1,1,1);\nbegin\n\
         attribute(color = 1,0.5,0.2; kdr = 0.8);\n\
         mesh(file = \"meshes/tri.obj\");\nend\n",
    )
    .unwrap();
    let proj = work.join("p.json");
    run_args(&proj, &["import", scene.to_str().unwrap()]).unwrap();
    let png = work.join("v.png");
    let preview = ["preview", "-o", png.to_str().unwrap(), "--size", "32"];
    run_args(&proj, &preview).unwrap();
    assert!(png.exists());
    let exported = out.join("x.yari");
    run_args(&proj, &["export", "-o", exported.to_str().unwrap()]).unwrap();
    let colours = yari::colour::ColourTable::builtin();
    let loaded = yari::load::load_path(&exported, &colours).unwrap();
    assert_eq!(loaded.meshes.len(), 1, "the exported scene reads the mesh");
    // Exported again to the scene's own folder: the file as first written.
    let back = scenes.join("again.yari");
    run_args(&proj, &["export", "-o", back.to_str().unwrap()]).unwrap();
    let text = std::fs::read_to_string(&back).unwrap();
    assert!(text.contains("\"meshes/tri.obj\""), "{text}");
}
