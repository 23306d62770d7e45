//! The relay: how messages travel between processes, on this host and across daemons.
//!
//! # Layout
//!
//! - `router`: mailboxes and daemon-to-daemon links.
//! - `budget`: byte budgets of the relay's queues.
//! - `jobs`: job owners and `Lost` reports.

pub(crate) mod budget;
pub(crate) mod jobs;
pub(crate) mod router;
