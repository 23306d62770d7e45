//! Peak memory of `sunray render` per triangle (issue "Production-size scenes"): writes
//! tetra at the given size (4^size triangles) with `sunray spd` (NFF and YARI, and a binary
//! PLY mesh measured with this build only) and compiles it into a model
//! file (what workers receive) with `sunray compile`, renders each with 2 threads at a small
//! resolution in a child process, and reads the child's peak resident set size (`wait4`'s
//! `ru_maxrss`). With other programs (an older build) they are run alternately, round by
//! round, so that a noisy machine affects them alike.

use std::path::{Path, PathBuf};
use std::process::Command;

/// One program's peak resident memory on one scene in one round.
#[derive(Clone, Debug)]
pub struct Peak {
    /// The program measured.
    pub program: PathBuf,
    /// The scene it rendered.
    pub scene: PathBuf,
    /// Its peak resident set size, bytes.
    pub bytes: u64,
}

/// Why a measurement failed.
#[derive(Debug, thiserror::Error)]
pub enum MemoryBenchError {
    /// A child could not be started or waited for.
    #[error("running {program}: {source}")]
    Run {
        /// The program.
        program: String,
        /// What the OS said.
        source: std::io::Error,
    },
    /// A child failed.
    #[error("{program} {what} failed ({status})")]
    Failed {
        /// The program.
        program: String,
        /// Which step.
        what: &'static str,
        /// Its exit status.
        status: String,
    },
    /// The smooth twin of a scene could not be read or written.
    #[error("smooth twin of {path}: {source}")]
    Twin {
        /// The scene file.
        path: String,
        /// Why.
        source: std::io::Error,
    },
}

/// Runs `cmd` to its end; its peak resident set size in bytes.
fn peak_of(mut cmd: Command, what: &'static str) -> Result<u64, MemoryBenchError> {
    let program = cmd.get_program().to_string_lossy().to_string();
    let run = |source| MemoryBenchError::Run {
        program: program.clone(),
        source,
    };
    let child = cmd.spawn().map_err(run)?;
    let pid = child.id() as libc::pid_t;
    let mut status = 0;
    // SAFETY: wait4 fills the zeroed rusage of the child we started and have not waited for.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    if r != pid {
        return Err(run(std::io::Error::last_os_error()));
    }
    if !(libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0) {
        return Err(MemoryBenchError::Failed {
            program,
            what,
            status: format!("wait status {status}"),
        });
    }
    // ru_maxrss is in KiB on Linux.
    Ok(usage.ru_maxrss as u64 * 1024)
}

/// Writes tetra at `size` into `dir` with `program spd`, as NFF and as YARI, and its compiled
/// model with `program compile`; the model's path, the NFF file's and the YARI file's.
pub fn write_tetra(
    program: &Path,
    dir: &Path,
    size: u32,
) -> Result<[PathBuf; 3], MemoryBenchError> {
    let nff = dir.join(format!("tetra{size}.nff"));
    let yari = nff.with_extension("yari");
    for file in [&nff, &yari] {
        let mut cmd = Command::new(program);
        cmd.args(["spd", "tetra", "--size", &size.to_string(), "-o"])
            .arg(file);
        peak_of(cmd, "spd")?;
    }
    let model = nff.with_extension(yari::modelfile::EXTENSION);
    let mut cmd = Command::new(program);
    cmd.arg("compile").arg(&nff).arg("-o").arg(&model);
    cmd.stdout(std::process::Stdio::null());
    peak_of(cmd, "compile")?;
    Ok([model, nff, yari])
}

/// Writes tetra at `size` as a binary PLY mesh (`tetraN.ply`, corners shared as meshes
/// share them) with `program spd`: issue "Meshes"'s 160-bytes-a-triangle target. Its path.
pub fn write_ply(program: &Path, dir: &Path, size: u32) -> Result<PathBuf, MemoryBenchError> {
    let ply = dir.join(format!("tetra{size}.ply"));
    let mut cmd = Command::new(program);
    cmd.args(["spd", "tetra", "--size", &size.to_string(), "-o"])
        .arg(&ply);
    peak_of(cmd, "spd")?;
    Ok(ply)
}

/// Writes the smooth twin of tetra's NFF file `nff` beside it (`NAME-smooth.nff`) and
/// compiles it with `program compile` (`NAME-smooth.srw`): the same triangles, each a `pp`
/// whose vertex normals point away from the centre of the scene's bounds, so the triangles
/// meeting at a corner share its normal, as in a real smooth mesh. The text is streamed
/// line by line (twice: bounds, then output), so this process stays small: a child's peak
/// resident size as `wait4` reports it can include its parent's. The model's path.
pub fn write_smooth_twin(program: &Path, nff: &Path) -> Result<PathBuf, MemoryBenchError> {
    use std::io::{BufRead, BufWriter, Write};
    let err = |source| MemoryBenchError::Twin {
        path: nff.display().to_string(),
        source,
    };
    let lines = || -> Result<_, MemoryBenchError> {
        let f = std::fs::File::open(nff).map_err(err)?;
        Ok(std::io::BufReader::new(f).lines())
    };
    let point = |l: &str| -> Option<glam::DVec3> {
        let v: Vec<f64> = l
            .split_whitespace()
            .filter_map(|w| w.parse().ok())
            .collect();
        (v.len() == 3).then(|| glam::DVec3::new(v[0], v[1], v[2]))
    };
    // Vertex lines are the lines after a `p n` line.
    let (mut lo, mut hi) = (glam::DVec3::INFINITY, glam::DVec3::NEG_INFINITY);
    let mut left = 0usize;
    for line in lines()? {
        let line = line.map_err(err)?;
        if left > 0 {
            left -= 1;
            if let Some(v) = point(&line) {
                (lo, hi) = (lo.min(v), hi.max(v));
            }
        } else if let Some(n) = line.strip_prefix("p ") {
            left = n.trim().parse().unwrap_or(0);
        }
    }
    let centre = (lo + hi) / 2.0;
    let twin = nff.with_file_name(format!(
        "{}-smooth.nff",
        nff.file_stem().unwrap_or_default().to_string_lossy()
    ));
    let mut out = BufWriter::new(std::fs::File::create(&twin).map_err(err)?);
    for line in lines()? {
        let line = line.map_err(err)?;
        let written = if left > 0 {
            left -= 1;
            match point(&line) {
                Some(v) => {
                    let n = v - centre;
                    writeln!(out, "{line} {} {} {}", n.x, n.y, n.z)
                }
                None => writeln!(out, "{line}"),
            }
        } else if let Some(n) = line.strip_prefix("p ") {
            left = n.trim().parse().unwrap_or(0);
            writeln!(out, "pp {n}")
        } else {
            writeln!(out, "{line}")
        };
        written.map_err(err)?;
    }
    out.flush().map_err(err)?;
    drop(out);
    let model = twin.with_extension(yari::modelfile::EXTENSION);
    let mut cmd = Command::new(program);
    cmd.arg("compile").arg(&twin).arg("-o").arg(&model);
    cmd.stdout(std::process::Stdio::null());
    peak_of(cmd, "compile")?;
    Ok(model)
}

/// Each program's peak memory rendering each of `scenes` (2 threads, 64x64), `rounds`
/// times, alternately.
pub fn measure(
    programs: &[PathBuf],
    scenes: &[PathBuf],
    rounds: usize,
    dir: &Path,
) -> Result<Vec<Peak>, MemoryBenchError> {
    let mut peaks = Vec::new();
    for _ in 0..rounds.max(1) {
        for (p, scene) in programs
            .iter()
            .flat_map(|p| scenes.iter().map(move |s| (p, s)))
        {
            let mut cmd = Command::new(p);
            cmd.args([
                "render",
                "-q",
                "--threads",
                "2",
                "--resolution",
                "64x64",
                "-o",
            ])
            .arg(dir.join("memory.png"))
            .arg(scene);
            peaks.push(Peak {
                program: p.clone(),
                scene: scene.clone(),
                bytes: peak_of(cmd, "render")?,
            });
        }
    }
    Ok(peaks)
}

/// The table `sunray bench memory` prints: each program's lowest peak over the rounds on
/// each scene, in MiB and bytes per triangle.
pub fn table(peaks: &[Peak], triangles: u64) -> String {
    let mut rows: Vec<(&PathBuf, &PathBuf)> = Vec::new();
    for p in peaks {
        if !rows.contains(&(&p.program, &p.scene)) {
            rows.push((&p.program, &p.scene));
        }
    }
    let mut s = format!(
        "peak resident memory of sunray render (2 threads, 64x64), tetra: {triangles} triangles\n"
    );
    s += &format!(
        "{:>12} {:>12}  {:<14} program\n",
        "MiB", "B/triangle", "scene"
    );
    for (prog, scene) in rows {
        let best = peaks
            .iter()
            .filter(|p| &p.program == prog && &p.scene == scene)
            .map(|p| p.bytes)
            .min()
            .unwrap_or(0);
        let name = scene.file_name().unwrap_or_default().to_string_lossy();
        s += &format!(
            "{:>12.1} {:>12.1}  {:<14} {}\n",
            best as f64 / (1u64 << 20) as f64,
            best as f64 / triangles.max(1) as f64,
            name,
            prog.display()
        );
    }
    s
}
