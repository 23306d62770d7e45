//! Who may do what: the cluster secret and the credentials made from it, users and admins,
//! daemons proving the secret to each other, and the tokens of spawned processes.
//!
//! # Layout
//!
//! - [`secret`]: the cluster [`Secret`](secret::Secret), the client key made from it, and
//!   the interceptors that send and check a client's key or a process's token.
//! - [`identity`]: who a client is (user, admin), users' keys and client-key files, and who
//!   may act on what (ownership).
//! - `peer_auth`: how daemons prove the secret to each other (HMAC) without sending it.
//! - `token`: random tokens (a spawned process attaches with its own).
//! - [`cluster_files`]: the secret and TLS certificate a cluster's daemons share
//!   (`rem credentials`).

pub mod cluster_files;
pub mod identity;
pub(crate) mod peer_auth;
pub mod secret;
pub(crate) mod token;
