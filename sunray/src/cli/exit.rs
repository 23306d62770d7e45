//! The exit codes of `sunray`, named once. 0 is success and 1 any error (a message on stderr).

/// `sunray submit`: no worker was left to finish the image; its lines are in the checkpoint
/// and `sunray submit --resume JOB` continues it.
pub const NO_WORKERS_LEFT: u8 = 3;

/// `sunray worker`: the controller went away, so the worker stopped.
pub const CONTROLLER_GONE: u8 = 3;
