//! Where a project's mesh files are. A `mesh(file = ...)` primitive's relative file is
//! relative to the project file's folder, as it is to the YARI file's folder in a scene: the
//! preview reads it from there, `import` rewrites the scene's relative files so they name
//! the same files from the project's folder, and `export -o FILE` rewrites them so they name
//! the same files from FILE's folder. Absolute files are kept as they are.

use crate::project::{Primitive, Project};
use std::path::{Path, PathBuf};

/// The folder relative mesh files of the project or YARI file at `file` are found in: the
/// YARI loader's rule (empty for a bare file name: the current folder).
pub use yari::load::folder_of;

/// Rewrites every relative mesh file of `project`, written relative to folder `from`, to name
/// the same file relative to folder `to` (absolute where no relative path reaches it).
pub fn rebase(project: &mut Project, from: &Path, to: &Path) {
    let (from, to) = (resolved(from), resolved(to));
    if from == to {
        return;
    }
    for o in &mut project.objects {
        o.walk_mut(&mut |o| {
            for p in &mut o.primitives {
                if let Primitive::Mesh { file, .. } = p {
                    if Path::new(file.as_str()).is_relative() {
                        let target = resolved(&from.join(file.as_str()));
                        let moved = pathdiff::diff_paths(&target, &to).unwrap_or(target);
                        *file = moved.to_string_lossy().into_owned();
                    }
                }
            }
        });
    }
}

/// `path` made absolute, through symbolic links where it exists (empty: the current folder).
fn resolved(path: &Path) -> PathBuf {
    let path = if path.as_os_str().is_empty() {
        Path::new(".")
    } else {
        path
    };
    std::fs::canonicalize(path)
        .or_else(|_| std::path::absolute(path))
        .unwrap_or_else(|_| path.to_path_buf())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::project::Object;

    fn with_mesh(file: &str) -> Project {
        let mut p = Project::default();
        p.objects.push(Object {
            name: "m".into(),
            surface: None,
            transforms: Vec::new(),
            primitives: Vec::new(),
            children: vec![Object {
                name: "inner".into(),
                surface: None,
                transforms: Vec::new(),
                primitives: vec![Primitive::Mesh {
                    file: file.into(),
                    materials_file: false,
                }],
                children: Vec::new(),
            }],
        });
        p
    }

    fn file_of(p: &Project) -> String {
        match &p.objects[0].children[0].primitives[0] {
            Primitive::Mesh { file, .. } => file.clone(),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn relative_files_keep_naming_the_same_file_from_another_folder() {
        let dir = tempfile::tempdir().unwrap();
        let (scenes, projects) = (dir.path().join("scenes"), dir.path().join("work/projects"));
        std::fs::create_dir_all(scenes.join("meshes")).unwrap();
        std::fs::create_dir_all(&projects).unwrap();
        std::fs::write(scenes.join("meshes/cube.obj"), "v 0 0 0\n").unwrap();
        let mut p = with_mesh("meshes/cube.obj");
        rebase(&mut p, &scenes, &projects);
        let moved = file_of(&p);
        assert!(Path::new(&moved).is_relative(), "{moved}");
        assert_eq!(
            std::fs::canonicalize(projects.join(&moved)).unwrap(),
            std::fs::canonicalize(scenes.join("meshes/cube.obj")).unwrap()
        );
        // And back: the file as first written.
        rebase(&mut p, &projects, &scenes);
        assert_eq!(file_of(&p), "meshes/cube.obj");
        // The same folder, or an absolute file: unchanged.
        rebase(&mut p, &scenes, &scenes.join("."));
        assert_eq!(file_of(&p), "meshes/cube.obj");
        let absolute = scenes.join("meshes/cube.obj").display().to_string();
        let mut q = with_mesh(&absolute);
        rebase(&mut q, &scenes, &projects);
        assert_eq!(file_of(&q), absolute);
    }

    #[test]
    fn a_bare_file_name_is_in_the_current_folder() {
        let current = resolved(Path::new("."));
        assert_eq!(resolved(folder_of(Path::new("p.json"))), current);
        assert_eq!(folder_of(Path::new("a/b/p.json")), Path::new("a/b"));
    }
}
