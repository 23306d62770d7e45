//! remd's integration tests, one test binary (each module was a binary of its own; one
//! binary links the daemon's code once instead of eight times):
//!
//! - [`attacks`]: the attack battery, written as an attacker would try each.
//! - [`cluster`]: three real remd processes on loopback: membership, load, placement.
//! - [`connections`]: connection caps against a flood of idle connections.
//! - [`failure`]: a killed, a hung (SIGSTOPped), a restarted daemon; SIGTERM.
//! - [`fuzz`]: a seeded fuzz run of the protobuf API against two live daemons.
//! - [`jobs`]: job records kept on two hosts, fenced by epoch, per user.
//! - [`relay`]: 100,000 messages between processes on two daemons; checkpoints.
//! - [`security`]: secret, allow-list, size limit, malformed requests, TLS.
//! - [`slots`]: render slots lent, held and given back; the queue's shares.
//! - [`common`]: the harness (daemons in this process or as real processes).
//!
//! One module: `cargo test --release -p rem --test daemon attacks::`.
#![allow(clippy::unwrap_used, clippy::expect_used)] // tests: a failed unwrap is a failed test

mod attacks;
mod cluster;
mod common;
mod connections;
mod failure;
mod fuzz;
mod jobs;
mod relay;
mod security;
mod slots;
