//! A member's identity in the SWIM protocol: its REM name, the UDP address its datagrams
//! come from and go to, the address its gRPC services are reached at, and a stamp that is
//! new at every start (and every rejoin), so a restarted daemon replaces its old self.

use std::net::SocketAddr;

use serde::{Deserialize, Serialize};

/// Longest gRPC address a member may advertise.
pub const MAX_GRPC_ADDR: usize = 256;

/// One daemon as the membership protocol knows it.
#[derive(Clone, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct MemberId {
    /// Its REM name (unique in the cluster).
    pub name: String,
    /// Where its membership datagrams go (UDP, the port of its gRPC listener).
    pub addr: SocketAddr,
    /// What other daemons and processes dial for its services (`--advertise`).
    pub grpc: String,
    /// Start time in ms, plus one per rejoin: the larger wins for one address.
    pub stamp: u64,
}

impl MemberId {
    /// A placeholder for a `--join` address whose member is not known yet: foca accepts an
    /// announce sent to any identity with the receiver's address.
    pub fn seed(addr: SocketAddr) -> MemberId {
        MemberId {
            name: String::new(),
            addr,
            grpc: String::new(),
            stamp: 0,
        }
    }

    /// Whether the fields are what a member may claim: a valid name and a bounded address.
    pub fn is_valid(&self) -> bool {
        crate::wire::ids::is_valid_name(&self.name)
            && !self.grpc.is_empty()
            && self.grpc.len() <= MAX_GRPC_ADDR
    }
}

impl std::fmt::Debug for MemberId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}@{}#{}", self.name, self.addr, self.stamp)
    }
}

impl foca::Identity for MemberId {
    type Addr = SocketAddr;

    /// A member declared down rejoins at once under a newer stamp.
    fn renew(&self) -> Option<Self> {
        Some(MemberId {
            stamp: self.stamp.wrapping_add(1),
            ..self.clone()
        })
    }

    fn addr(&self) -> SocketAddr {
        self.addr
    }

    fn win_addr_conflict(&self, adversary: &Self) -> bool {
        self.stamp > adversary.stamp
    }
}
