//! The membership protocol: SWIM (Das, Gupta and Motivala, 2002) as the `foca` crate
//! implements it — each member probes one other per period, asks k others to probe it
//! when it does not answer, suspects it before declaring it down, and spreads changes on
//! the datagrams it sends anyway — with what REM adds around it:
//!
//! - `member`: a member's identity (REM name, UDP and gRPC addresses, a stamp new at each
//!   start);
//! - `seal`: every datagram authenticated with the cluster secret (HMAC, clock and a replay
//!   window);
//! - `reports`: load reports spread as foca custom broadcasts, the newest kept per member;
//! - `health`: Lifeguard's local health awareness (a slow member stretches its timeouts);
//! - `config`: the protocol's timing ([`SwimConfig`]);
//! - `node`: one member without I/O, driven by `crate::membership::driver` (UDP, tokio's clock) or
//!   by a simulation.
//!
//! foca was chosen over hand-written SWIM and over `memberlist` (a port of HashiCorp's,
//! bringing its own network stack): it is transport-agnostic (so datagrams can be sealed
//! and a thousand members simulated deterministically in one process), small, and has no
//! runtime of its own.

pub mod config;
pub mod health;
pub mod member;
pub mod node;
pub mod reports;
pub mod seal;

pub use config::SwimConfig;
pub use member::MemberId;
pub use node::{Change, Outbox, SwimNode, SwimTimer, Traffic};
