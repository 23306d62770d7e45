//! What a daemon keeps on disk: checkpoints, job records, chunks and the process cache, and
//! which peer keeps a key's second copy. Each store knows its files and bounds; copying to
//! peers is the daemon's (`daemon::ops`).
//!
//! # Layout
//!
//! - `checkpoint`: atomic, sealed checkpoint files per user and job.
//! - [`job_store`]: job records (epochs, retention), kept in a checkpoint store of their own.
//! - [`chunks`]: the content-addressed chunk cache (scenes in pieces, checked by hash, LRU).
//! - [`replicas`]: which peer keeps a key's second copy (rendezvous hashing).
//! - [`process_cache`]: the folder where processes keep what they can rebuild
//!   (`REM_CACHE_DIR`), bounded, its contents untrusted.

pub(crate) mod checkpoint;
pub mod chunks;
pub mod job_store;
pub mod process_cache;
pub mod replicas;
