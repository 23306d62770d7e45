//! SunRay III (thesis section 4.2.4): a controller hands out scanlines to worker processes
//! that REM started on the least-loaded hosts; every message goes through REM's relay.
//!
//! ```text
//! sunray submit --hosts N scene            remd (each host)            sunray worker
//!   compile scene once  --spawn N------->  place on least-loaded  ---> attach to relay
//!   controller actor    --Scene--------------------------------------> build accelerator
//!                       <-Ready, Request(window)---------------------
//!                       --Assign(lines, grants)----------------------> render threads
//!                       <-Done(line, grant, pixels, counters, window)  (lines to hold)
//!                       --NoMoreWork---------------------------------> exit
//! ```
//!
//! # Layout
//! - [`messages`]: the protobuf messages of `proto/sunray.proto` and their conversions.
//! - [`strategy`]: SunRay I, II and III line distribution, and the queue of lines to hand out.
//! - [`grants`]: the grant table (assign, complete, first completion wins, faults, timeouts,
//!   duplication of stragglers).
//! - [`line_passes`]: a job rendered to an error, a (line, pass) at a time: the lines'
//!   estimates between their passes; [`settled`]: a line whose pixels are all done, as its
//!   checkpoint keeps it.
//! - [`checkpoint`]: the controller's progress in REM's checkpoint store.
//! - [`job_record`]: a SunRay job as REM's job record (behind `sunray jobs`).
//! - [`nodes`]: per-node statistics and the thesis's per-node table.
//! - [`timeline`]: a job's steps (controller up, per node spawned, scene and accelerator
//!   ready, first line; last line, image stored, finished) in seconds since submit.
//! - [`controller`]: the controller actor; [`progress`]: its progress bar, events, preview.
//! - [`web_view`]: what a farm job publishes for remd's web view (`JOB.web.json`, the
//!   per-node table, the job's history and what the image is; `JOB.web.png`, the image so
//!   far), and when.
//! - [`worker`]: the worker process; [`pool`]: its render threads; [`window`]: how many
//!   lines it holds.
//! - [`model_chunks`]: the scene's model shipped as REM chunks and fetched by the workers;
//!   [`shipped_scenes`]: the scenes this user shipped before, so a second submit of a file
//!   compiles and sends nothing.
//! - [`connection`]: reaching REM; [`embedded`]: the private remd of the default set-up.
//! - [`job`]: a job from start to end (plan, first checkpoint, workers, controller, totals),
//!   one path wherever its controller runs: in `submit` (`--in-process`) or in the farm.
//! - [`farm`]: jobs owned by the farm (`submit --detach`, the controller process REM keeps
//!   running, `watch`, `fetch`, `cancel`).

pub mod checkpoint;
pub mod connection;
pub mod controller;
pub mod embedded;
pub mod farm;
pub mod grants;
pub mod job;
pub mod job_record;
pub mod line_passes;
pub mod messages;
pub mod model_chunks;
pub mod nodes;
pub mod pool;
pub mod progress;
pub mod settled;
pub mod shipped_scenes;
pub mod strategy;
pub mod timeline;
pub mod web_view;
pub mod window;
pub mod worker;
