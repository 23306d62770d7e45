//! The exit codes of `sunray`, named once. 0 is success and 1 any error (a message on stderr).

/// A mesh file (OBJ, PLY) that cannot be read: the file and the line or byte on stderr.
pub const BAD_MESH: u8 = 2;

/// The exit code of the error `e` a command ended with: [`BAD_MESH`] for a mesh file that
/// cannot be read, else 1.
pub fn code_of(e: &anyhow::Error) -> u8 {
    let mesh = e.chain().any(|c| {
        c.downcast_ref::<yari::mesh::MeshError>().is_some()
            || matches!(
                c.downcast_ref::<yari::load::LoadError>(),
                Some(yari::load::LoadError::Mesh(_))
            )
    });
    if mesh {
        BAD_MESH
    } else {
        1
    }
}

/// `sunray submit`: no worker was left to finish the image; its lines are in the checkpoint
/// and `sunray submit --resume JOB` continues it.
pub const NO_WORKERS_LEFT: u8 = 3;

/// `sunray controller`: every line is in, but the checkpoint store refused the last save;
/// REM starts the controller again (its record still says running).
pub const NOT_STORED: u8 = 3;

/// `sunray worker`: the controller went away, so the worker stopped.
pub const CONTROLLER_GONE: u8 = 3;

/// `sunray watch` (and `submit` following a farm job): the job failed.
pub const JOB_FAILED: u8 = 3;

/// `sunray watch` (and `submit` following a farm job): the job was cancelled.
pub const JOB_CANCELLED: u8 = 4;

/// `sunray controller`: a newer controller has the job, so this one stood down.
pub const SUPERSEDED: u8 = 5;

/// `sunray submit` following a farm job: Ctrl-C stopped the following; the job goes on.
pub const STOPPED_FOLLOWING: u8 = 130;

/// `sunray submit` running its job's controller here (the default set-up, `--in-process`,
/// `--resume`): Ctrl-C stopped the job; its checkpoint keeps what was done.
pub const INTERRUPTED: u8 = 130;
