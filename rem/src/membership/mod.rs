//! Which daemons exist, which are alive, and their load: the SWIM protocol, its UDP driver,
//! this host's own load figures, and the connections to the other daemons.
//!
//! # Layout
//!
//! - [`swim`]: the membership protocol (SWIM on foca, sealed datagrams, load reports,
//!   local health), free of I/O.
//! - `driver`: its UDP driver, joining, lost and returning hosts.
//! - `load`: this host's load (sysinfo) and REM process count; `cgroup`: the CPU limit and
//!   use of remd's control group (containers).
//! - `peers`: cached, signed connections to other daemons.
//! - [`slots`]: the render slots this host lends and its processes hold (the owner first).

pub(crate) mod cgroup;
pub(crate) mod driver;
pub(crate) mod load;
pub(crate) mod peers;
pub mod slots;
pub mod swim;
