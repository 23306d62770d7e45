//! Peak memory of `sunray render` per triangle (issue "Production-size scenes"): writes
//! tetra at the given size (4^size triangles) with `sunray spd` and compiles it into a model
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

/// Writes tetra at `size` into `dir` with `program spd`, and its compiled model with
/// `program compile`; the model's path and the NFF file's.
pub fn write_tetra(
    program: &Path,
    dir: &Path,
    size: u32,
) -> Result<[PathBuf; 2], MemoryBenchError> {
    let nff = dir.join(format!("tetra{size}.nff"));
    let mut cmd = Command::new(program);
    cmd.args(["spd", "tetra", "--size", &size.to_string(), "-o"])
        .arg(&nff);
    peak_of(cmd, "spd")?;
    let model = nff.with_extension(yari::modelfile::EXTENSION);
    let mut cmd = Command::new(program);
    cmd.arg("compile").arg(&nff).arg("-o").arg(&model);
    cmd.stdout(std::process::Stdio::null());
    peak_of(cmd, "compile")?;
    Ok([model, nff])
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
