//! The client side of REM: what the `rem` command, job owners and spawned processes use to
//! talk to their local remd.
//!
//! # Layout
//!
//! - [`rem_client`]: [`RemClient`](rem_client::RemClient), one connection to a remd
//!   (spawning, killing, listing, checkpoints, job records, chunks).
//! - [`relay`]: [`Relay`](relay::Relay), the message stream of a job owner or a process.
//! - [`spawn`]: what a spawn asks for ([`SpawnRequest`](spawn::SpawnRequest)) and starts.
//! - `rpc`: the generated client with the credential attached, under both.
//! - [`blob`]: large byte strings put and fetched as lists of chunks.

pub mod blob;
pub mod relay;
pub mod rem_client;
pub(crate) mod rpc;
pub mod spawn;
