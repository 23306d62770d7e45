//! What the end-to-end tests share, written once: the binaries ([`bins`]), fixtures from the
//! repository or our generators ([`fixtures`]), reference renders and JSON ([`reference`]),
//! real `remd` processes on loopback ([`remd`]), a `sunray submit --events` followed as it
//! runs ([`submit_run`]), remd's web view and a headless browser on it ([`web`]), a small
//! tmpfs for full-disk tests ([`small_fs`]), and the Docker Compose cluster ([`compose`]). The tests themselves
//! live in `tests/tests/`.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

pub mod bins;
pub mod compose;
pub mod fixtures;
pub mod reference;
pub mod remd;
pub mod small_fs;
pub mod submit_run;
pub mod web;
