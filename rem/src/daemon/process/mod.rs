//! The OS processes REM runs on this host.
//!
//! # Layout
//!
//! - `table`: the processes, their lifetimes, events and output.
//! - `child`: building one (environment, nice, user).
//! - `logbuf`: bounded stdout / stderr keepers.

pub(crate) mod child;
pub(crate) mod logbuf;
pub(crate) mod table;
