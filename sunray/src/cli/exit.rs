//! The exit codes of `sunray`, named once. 0 is success and 1 any error (a message on stderr).

/// `sunray submit`: no worker was left to finish the image; its lines are in the checkpoint
/// and `sunray submit --resume JOB` continues it.
pub const NO_WORKERS_LEFT: u8 = 3;

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
