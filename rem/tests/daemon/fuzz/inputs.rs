//! Every RPC of both services, and the fuzz inputs: a call of one RPC to one daemon, with a
//! body of some shape and a credential, valid or garbage, all made from the seed and index.

use super::credentials::{client_key, sha256_hex, unix_ms};
use super::rng::Rng;
use super::values::{Gen, World};
use super::FAKE_DAEMONS;
use prost::Message;
use rem::wire::proto;
use tonic::codegen::http::uri::PathAndQuery;

/// Every RPC of both services.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(super) enum Rpc {
    Hosts,
    Spawn,
    Ps,
    Kill,
    Logs,
    Attach,
    PutCheckpoint,
    GetCheckpoint,
    PutJob,
    ListJobs,
    StartJob,
    PutChunk,
    GetChunk,
    CachedChunks,
    AdoptProcess,
    Queue,
    StartLocal,
    KillLocal,
    LogsLocal,
    PsLocal,
    Forward,
    StoreReplica,
    FetchReplica,
    StoreJob,
    ListJobsLocal,
    StoreChunk,
    HasChunks,
    FetchChunk,
    AdoptLocal,
}

const RPCS: [Rpc; 29] = [
    Rpc::Hosts,
    Rpc::Spawn,
    Rpc::Ps,
    Rpc::Kill,
    Rpc::Logs,
    Rpc::Attach,
    Rpc::PutCheckpoint,
    Rpc::GetCheckpoint,
    Rpc::PutJob,
    Rpc::ListJobs,
    Rpc::StartJob,
    Rpc::PutChunk,
    Rpc::GetChunk,
    Rpc::CachedChunks,
    Rpc::AdoptProcess,
    Rpc::Queue,
    Rpc::StartLocal,
    Rpc::KillLocal,
    Rpc::LogsLocal,
    Rpc::PsLocal,
    Rpc::Forward,
    Rpc::StoreReplica,
    Rpc::FetchReplica,
    Rpc::StoreJob,
    Rpc::ListJobsLocal,
    Rpc::StoreChunk,
    Rpc::HasChunks,
    Rpc::FetchChunk,
    Rpc::AdoptLocal,
];

impl Rpc {
    /// The method's name (what a peer proof signs, and the last part of its path).
    pub(super) fn name(self) -> &'static str {
        match self {
            Rpc::Hosts => "Hosts",
            Rpc::Spawn => "Spawn",
            Rpc::Ps => "Ps",
            Rpc::Kill => "Kill",
            Rpc::Logs => "Logs",
            Rpc::Attach => "Attach",
            Rpc::PutCheckpoint => "PutCheckpoint",
            Rpc::GetCheckpoint => "GetCheckpoint",
            Rpc::StartLocal => "StartLocal",
            Rpc::KillLocal => "KillLocal",
            Rpc::LogsLocal => "LogsLocal",
            Rpc::PsLocal => "PsLocal",
            Rpc::Forward => "Forward",
            Rpc::StoreReplica => "StoreReplica",
            Rpc::FetchReplica => "FetchReplica",
            Rpc::PutJob => "PutJob",
            Rpc::ListJobs => "ListJobs",
            Rpc::StartJob => "StartJob",
            Rpc::StoreJob => "StoreJob",
            Rpc::ListJobsLocal => "ListJobsLocal",
            Rpc::PutChunk => "PutChunk",
            Rpc::GetChunk => "GetChunk",
            Rpc::CachedChunks => "CachedChunks",
            Rpc::StoreChunk => "StoreChunk",
            Rpc::HasChunks => "HasChunks",
            Rpc::FetchChunk => "FetchChunk",
            Rpc::AdoptProcess => "AdoptProcess",
            Rpc::Queue => "Queue",
            Rpc::AdoptLocal => "AdoptLocal",
        }
    }

    pub(super) fn is_peer(self) -> bool {
        self >= Rpc::StartLocal
    }

    fn is_stream(self) -> bool {
        matches!(self, Rpc::Attach | Rpc::Forward)
    }

    pub(super) fn path(self) -> PathAndQuery {
        let service = if self.is_peer() { "Peer" } else { "Rem" };
        PathAndQuery::try_from(format!("/rem.v1.{service}/{}", self.name())).unwrap()
    }

    /// The digest a peer proof covers: of the body as the daemon decodes and re-encodes it
    /// (`-` for a stream); of the bytes when they do not decode (the call fails before).
    pub(super) fn body_digest(self, body: &[u8]) -> String {
        fn canonical<M: Message + Default>(b: &[u8]) -> Option<Vec<u8>> {
            M::decode(b).ok().map(|m| m.encode_to_vec())
        }
        let canon = match self {
            Rpc::Forward => return "-".into(),
            Rpc::StartLocal => canonical::<proto::StartLocalRequest>(body),
            Rpc::KillLocal => canonical::<proto::KillLocalRequest>(body),
            Rpc::LogsLocal => canonical::<proto::LogsLocalRequest>(body),
            Rpc::PsLocal => canonical::<proto::PsRequest>(body),
            Rpc::StoreReplica => canonical::<proto::Checkpoint>(body),
            Rpc::FetchReplica => canonical::<proto::FetchReplicaRequest>(body),
            Rpc::StoreJob => canonical::<proto::Checkpoint>(body),
            Rpc::ListJobsLocal => canonical::<proto::ListJobsLocalRequest>(body),
            Rpc::StoreChunk => canonical::<proto::PutChunkRequest>(body),
            Rpc::HasChunks => canonical::<proto::HasChunksRequest>(body),
            Rpc::FetchChunk => canonical::<proto::GetChunkRequest>(body),
            Rpc::AdoptLocal => canonical::<proto::AdoptLocalRequest>(body),
            _ => None,
        };
        sha256_hex(canon.as_deref().unwrap_or(body))
    }
}

/// How an input's body was made.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(super) enum Shape {
    Raw,
    Valid,
    Mutated,
}

/// The credential an input carries.
#[derive(Clone, Debug)]
pub(super) enum Credential {
    /// The client key (`Rem`), or a daemon's proof signed as this name (`Peer`).
    Valid(String),
    None,
    /// `x-rem-client-key-bin` with these bytes.
    ClientKey(Vec<u8>),
    /// `x-rem-proc-token` with this text.
    ProcessToken(String),
    /// `x-rem-peer` with this text.
    PeerLine(String),
    /// A proof by this name whose MAC covers another body.
    SignedOtherBody(String),
    /// A proof by this name, for this `TO`, at this time (ms).
    SignedAt(String, String, u64),
}

/// One fuzz input: a call of `rpc` to daemon `daemon`.
#[derive(Clone, Debug)]
pub(super) struct Input {
    pub(super) index: usize,
    pub(super) daemon: usize,
    pub(super) rpc: Rpc,
    pub(super) shape: Shape,
    /// The body (one frame), or the frames of a stream.
    pub(super) frames: Vec<Vec<u8>>,
    pub(super) credential: Credential,
}

impl Input {
    /// Input `index` of the run seeded `seed`.
    pub(super) fn make(seed: u64, index: usize, world: &World) -> Input {
        let mut rng = Rng::for_input(seed, index);
        let daemon = rng.below(world.names.len());
        let rpc = rng.pick(&RPCS);
        let valid = rng.one_in(2);
        let from = if rng.one_in(2) {
            rng.pick(&FAKE_DAEMONS).to_string()
        } else {
            world.names[1 - daemon].clone()
        };
        let shape = rng.pick(&[Shape::Raw, Shape::Valid, Shape::Mutated]);
        let credential = if valid {
            Credential::Valid(from.clone())
        } else {
            garbage_credential(&mut rng, rpc, &from, world, daemon)
        };
        let n_frames = if rpc.is_stream() {
            rng.pick(&[0, 1, 1, 2, 2, 3, 4])
        } else {
            1
        };
        let mut g = Gen {
            rng: &mut rng,
            world,
        };
        let frames = (0..n_frames)
            .map(|i| match shape {
                Shape::Raw => g.raw(),
                Shape::Valid => g.message(rpc, &from, i == 0),
                Shape::Mutated => {
                    let m = g.message(rpc, &from, i == 0);
                    g.mutate(m)
                }
            })
            .collect();
        Input {
            index,
            daemon,
            rpc,
            shape,
            frames,
            credential,
        }
    }
}

fn garbage_credential(
    rng: &mut Rng,
    rpc: Rpc,
    from: &str,
    world: &World,
    daemon: usize,
) -> Credential {
    let me = world.names[daemon].clone();
    match rng.below(9) {
        0 | 1 => Credential::None,
        2 => {
            let n = rng.pick(&[0, 1, 31, 32, 33, 64, 4096]);
            Credential::ClientKey(rng.bytes(n))
        }
        3 if rpc.is_peer() => Credential::ClientKey(client_key().to_vec()),
        3 | 4 => {
            let n = rng.pick(&[0, 1, 64, 128, 129, 4000]);
            let token = match rng.below(3) {
                0 => hex::encode(rng.bytes(n / 2)),
                1 => rng.alnum(n),
                _ => String::from_utf8_lossy(&rng.bytes(n)).into_owned(),
            };
            Credential::ProcessToken(token)
        }
        5 => {
            let ts = unix_ms().to_string();
            let mac = hex::encode(rng.bytes(32));
            let line = match rng.below(6) {
                0 => String::new(),
                1 => format!("{from} {me} {ts} n{} {mac}", rng.next()),
                2 => format!("{from} {me} {ts} n {mac} extra"),
                3 => format!("{from}  {me} {ts} n {mac}"),
                4 => format!("../x {me} {ts} {} {mac}", "n".repeat(200)),
                _ => rng.alnum(80).replace('.', " "),
            };
            Credential::PeerLine(line)
        }
        6 => Credential::SignedOtherBody(from.into()),
        7 => {
            let when = rng.pick(&[0, unix_ms() - 31_000, unix_ms() + 31_000, u64::MAX]);
            Credential::SignedAt(from.into(), me, when)
        }
        _ => {
            // Signed, but as the target itself, or for the other daemon.
            let other = world.names[1 - daemon].clone();
            if rng.one_in(2) {
                Credential::SignedAt(me.clone(), me, unix_ms())
            } else {
                Credential::SignedAt(from.into(), other, unix_ms())
            }
        }
    }
}
