//! The `modeler` command: subcommands that each load the project, apply one operation and
//! save it atomically, and a script mode that applies many and saves once at the end.
//!
//! # Layout
//! - this file: the session (project loaded on demand, saved only after success) and the
//!   dispatch of commands.
//! - `commands`, `shape_args`: the clap types.
//! - `args`: value parsers (vectors, colours, textures).
//! - `edit`: the editing operations on a project.
//! - `script`: script mode.
//! - `show`: the listing of a project.
//! - `values`: how the library's planes, skeleton kinds and preview styles are spelled.

mod args;
pub mod commands;
mod edit;
mod script;
mod shape_args;
mod show;
mod values;

use crate::error::ModelError;
use crate::mesh_files::folder_of;
use crate::preview::{self, Options};
use crate::project::{write_atomic, Project, Transform};
use commands::{Cli, Command};
use std::io::Write;
use std::path::{Path, PathBuf};
use yari::colour::ColourTable;

/// A project being worked on by one command or one script.
pub(crate) struct Session<'a> {
    pub path: PathBuf,
    project: Option<Project>,
    dirty: bool,
    colours: ColourTable,
    out: &'a mut dyn Write,
    in_script: bool,
}

/// Runs one command line: the project is saved only if the command succeeds.
pub fn run(cli: Cli, out: &mut dyn Write) -> Result<(), ModelError> {
    let mut s = Session::new(&cli.project, out)?;
    s.execute(cli.command)?;
    s.finish()
}

impl<'a> Session<'a> {
    pub fn new(path: &Path, out: &'a mut dyn Write) -> Result<Session<'a>, ModelError> {
        let colours = ColourTable::for_run(None).map_err(|e| ModelError::Yari(e.to_string()))?;
        Ok(Session {
            path: path.to_path_buf(),
            project: None,
            dirty: false,
            colours,
            out,
            in_script: false,
        })
    }

    /// The project, read from its file the first time it is needed.
    pub fn project(&mut self) -> Result<&mut Project, ModelError> {
        if self.project.is_none() {
            if !self.path.exists() {
                return Err(ModelError::NoProject {
                    path: self.path.display().to_string(),
                });
            }
            self.project = Some(Project::load(&self.path)?);
        }
        self.project.as_mut().ok_or_else(|| ModelError::NoProject {
            path: self.path.display().to_string(),
        })
    }

    /// Saves the project if anything changed.
    pub fn finish(self) -> Result<(), ModelError> {
        match (&self.project, self.dirty) {
            (Some(p), true) => p.save(&self.path),
            _ => Ok(()),
        }
    }

    fn replace(&mut self, project: Project, force: bool) -> Result<(), ModelError> {
        if !force && !self.in_script && self.path.exists() {
            return Err(ModelError::Exists {
                path: self.path.display().to_string(),
            });
        }
        self.project = Some(project);
        self.dirty = true;
        Ok(())
    }

    fn write_out(&mut self, text: &str) -> Result<(), ModelError> {
        self.out
            .write_all(text.as_bytes())
            .map_err(|e| ModelError::io(Path::new("<stdout>"), e))
    }

    /// Writes the project as YARI to `output` (standard output without one, or `-`), its
    /// relative mesh files named from the written file's folder ([`crate::mesh_files`]).
    fn export(&mut self, output: Option<PathBuf>) -> Result<(), ModelError> {
        let here = folder_of(&self.path).to_path_buf();
        match output {
            Some(path) if path.as_os_str() != "-" => {
                let mut p = self.project()?.clone();
                crate::mesh_files::rebase(&mut p, &here, folder_of(&path));
                write_atomic(&path, crate::export::to_yari(&p).as_bytes())
            }
            _ => {
                let text = crate::export::to_yari(self.project()?);
                self.write_out(&text)
            }
        }
    }

    /// Applies one command.
    pub fn execute(&mut self, cmd: Command) -> Result<(), ModelError> {
        use Command as C;
        let table = self.colours.clone();
        match cmd {
            C::New(a) => {
                let p = if a.empty {
                    Project {
                        version: crate::project::FORMAT_VERSION,
                        ..Project::default()
                    }
                } else {
                    Project::new_default()
                };
                return self.replace(p, a.force);
            }
            C::Import(a) => {
                let text =
                    std::fs::read_to_string(&a.file).map_err(|e| ModelError::io(&a.file, e))?;
                let src = yari::span::Source::new(a.file.display().to_string(), text);
                let mut p = crate::import::from_yari(&src)?;
                let (from, to) = (folder_of(&a.file), folder_of(&self.path));
                crate::mesh_files::rebase(&mut p, from, to);
                return self.replace(p, a.force);
            }
            C::Export(a) => return self.export(a.output),
            C::Preview(a) => {
                let opts = Options {
                    size: a.size as usize,
                    style: a.style,
                };
                let folder = folder_of(&self.path).to_path_buf();
                let img = preview::render_project(self.project()?, &folder, &opts)?;
                return preview::write_png(&img, &a.output);
            }
            C::Show(a) => {
                let text = show::show(self.project()?, a.name.as_deref())?;
                return self.write_out(&text);
            }
            C::Script(a) => {
                if self.in_script {
                    return Err(ModelError::bad_arg(
                        "script",
                        "scripts do not run other scripts",
                    ));
                }
                return script::run_file(self, &a.file);
            }
            _ => {}
        }
        let p = self.project()?;
        match cmd {
            C::Skeleton(c) => edit::skeleton_cmd(p, c)?,
            C::Add(c) => edit::add_cmd(p, c)?,
            C::Combine(a) => p.combine(&a.name, &a.objects)?,
            C::Explode(a) => {
                p.explode(&a.name)?;
            }
            C::Revolve(a) => edit::revolve(p, a)?,
            C::Extrude(a) => edit::extrude(p, a)?,
            C::Translate(a) => edit::transform(p, &a.name, Transform::Translate(a.by), None)?,
            C::Rotate(a) => edit::transform(p, &a.name, Transform::Rotate(a.degrees), a.about)?,
            C::Scale(a) => edit::transform(p, &a.name, Transform::Scale(a.factors), a.about)?,
            C::Surface(a) => edit::surface(p, a, &table)?,
            C::Rename(a) => p.rename_object(&a.old, &a.new)?,
            C::Copy(a) => p.copy_object(&a.old, &a.new)?,
            C::Delete(a) => {
                p.remove_object(&a.name)?;
            }
            C::Camera(a) => edit::camera(p, a)?,
            C::View(a) => edit::view(p, a)?,
            C::Light(c) => edit::light(p, c, &table)?,
            C::Background(a) => {
                edit::check_color(&a.color, &table, "COLOR")?;
                p.settings.background = Some(a.color);
            }
            C::Ambient(a) => {
                edit::check_color(&a.color, &table, "COLOR")?;
                p.settings.ambient = Some(a.color);
            }
            C::Resolution(a) => p.settings.resolution = Some([a.width, a.height]),
            C::Samples(a) => p.settings.samples = Some(a.samples),
            C::New(_) | C::Import(_) | C::Export(_) | C::Preview(_) | C::Show(_) | C::Script(_) => {
            }
        }
        self.dirty = true;
        Ok(())
    }
}

#[cfg(test)]
mod tests;
