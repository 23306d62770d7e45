//! The daemon, remd: its settings, its state and operations, the relay, the processes it
//! runs, and its faces (gRPC, the web view), wired together by [`server`].
//!
//! # Layout
//!
//! - [`config`]: remd's settings (TOML, environment, and what the `remd` binary's flags give).
//! - [`limits`]: the daemon's hard limits; [`policy`]: which programs (and first arguments)
//!   and environment names may be spawned; `placement`: ranking hosts by load per core and
//!   free slots; [`shares`]: the queue's rule (priorities, fair shares between users).
//! - `ops`: the daemon's shared state and operations (processes, records, chunk sharing,
//!   jobs the farm keeps running).
//! - `relay`: mailboxes, daemon-to-daemon links, byte budgets, job owners and `Lost` reports.
//! - `process`: the OS processes REM runs here (building one, its output keepers).
//! - `listener`: the connection gate (caps, preface timeout, accept errors).
//! - [`server`]: wiring, the gRPC services, attach streams, and shutdown.
//! - [`web`]: the web view (`remd --web`): the page, the JSON API, logins.
//! - [`embedded`]: a remd inside the current process (the embedded default, tests).

pub mod config;
pub mod embedded;
pub mod limits;
pub(crate) mod listener;
pub(crate) mod ops;
pub(crate) mod placement;
pub mod policy;
pub(crate) mod process;
pub(crate) mod relay;
pub mod server;
pub mod shares;
pub mod web;
