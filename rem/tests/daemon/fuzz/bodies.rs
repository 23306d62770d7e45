//! A call's body: a valid message of each RPC's request type, raw protobuf-looking bytes,
//! or a message mutated (bit flips, truncation, duplicated bytes, overlong varints).

use super::credentials::checkpoint_seal;
use super::inputs::Rpc;
use super::values::Gen;
use prost::Message;
use rem::wire::proto::{self, client_frame, peer_item};

impl Gen<'_> {
    /// A valid message of `rpc`'s request type (`from`: the daemon a peer call is signed as),
    /// encoded.
    pub(super) fn message(&mut self, rpc: Rpc, from: &str, first: bool) -> Vec<u8> {
        match rpc {
            Rpc::Hosts => proto::HostsRequest {}.encode_to_vec(),
            Rpc::Ps | Rpc::PsLocal => proto::PsRequest {}.encode_to_vec(),
            Rpc::Spawn => self.spawn_request().encode_to_vec(),
            Rpc::StartJob => proto::StartJobRequest {
                record: Some(self.job_record()),
                controller_anywhere: self.rng.one_in(2),
            }
            .encode_to_vec(),
            Rpc::StartLocal => proto::StartLocalRequest {
                job: self.job(),
                owner: self.proc_id(),
                program: self.program(),
                args: self.args(),
                env: self.env(),
                nice: self.nice(),
                count: self.u32(),
                user: self.user(),
                job_record: if self.rng.one_in(2) {
                    String::new()
                } else {
                    self.job()
                },
                job_epoch: self.u64(),
                slots_min: self.u32(),
                slots_max: self.u32(),
            }
            .encode_to_vec(),
            Rpc::Kill => proto::KillRequest {
                proc_id: self.proc_id(),
            }
            .encode_to_vec(),
            Rpc::KillLocal => proto::KillLocalRequest {
                proc_id: self.proc_id(),
                acting: self.acting(),
            }
            .encode_to_vec(),
            Rpc::AdoptProcess => proto::AdoptProcessRequest {
                proc_id: self.proc_id(),
                owner: self.proc_id(),
            }
            .encode_to_vec(),
            Rpc::AdoptLocal => proto::AdoptLocalRequest {
                proc_id: self.proc_id(),
                owner: self.proc_id(),
                acting: self.acting(),
            }
            .encode_to_vec(),
            Rpc::Logs => proto::LogsRequest {
                proc_id: self.proc_id(),
                stdout_from: self.u64(),
                stderr_from: self.u64(),
            }
            .encode_to_vec(),
            Rpc::LogsLocal => proto::LogsLocalRequest {
                proc_id: self.proc_id(),
                acting: self.acting(),
                stdout_from: self.u64(),
                stderr_from: self.u64(),
            }
            .encode_to_vec(),
            Rpc::PutCheckpoint => proto::PutCheckpointRequest {
                job: self.job(),
                data: self.data(),
                epoch: if self.rng.one_in(2) { 0 } else { self.u64() },
                fence_job: if self.rng.one_in(2) {
                    String::new()
                } else {
                    self.job()
                },
            }
            .encode_to_vec(),
            Rpc::GetCheckpoint => proto::GetCheckpointRequest { job: self.job() }.encode_to_vec(),
            Rpc::FetchReplica => proto::FetchReplicaRequest {
                job: self.job(),
                user: self.user(),
            }
            .encode_to_vec(),
            Rpc::Attach => {
                let frame = if first && !self.rng.one_in(8) {
                    client_frame::Frame::Hello(proto::Hello {
                        proc_id: if self.rng.one_in(2) {
                            String::new()
                        } else {
                            self.proc_id()
                        },
                        job: self.job(),
                    })
                } else {
                    client_frame::Frame::Batch(proto::EnvelopeBatch {
                        envelopes: self.many(Gen::envelope),
                    })
                };
                proto::ClientFrame { frame: Some(frame) }.encode_to_vec()
            }
            Rpc::Forward => proto::PeerBatch {
                from_host: if self.rng.one_in(4) {
                    self.string()
                } else {
                    from.to_string()
                },
                items: self.many(|g| {
                    let item = match g.rng.below(4) {
                        0 => None,
                        1 => Some(peer_item::Item::Envelope(proto::Envelope {
                            from: if g.rng.one_in(2) {
                                format!("{from}/{}", g.rng.below(9))
                            } else {
                                g.proc_id()
                            },
                            ..g.envelope()
                        })),
                        2 => Some(peer_item::Item::Event(g.event())),
                        _ => Some(peer_item::Item::Undeliverable(g.undeliverable())),
                    };
                    proto::PeerItem { item }
                }),
            }
            .encode_to_vec(),
            Rpc::PutJob => proto::PutJobRequest {
                record: (!self.rng.one_in(8)).then(|| self.job_record()),
            }
            .encode_to_vec(),
            Rpc::ListJobs => proto::ListJobsRequest {}.encode_to_vec(),
            Rpc::Queue => proto::QueueRequest {}.encode_to_vec(),
            Rpc::PutChunk | Rpc::StoreChunk => {
                let data = self.string().into_bytes();
                let hash = if self.rng.one_in(2) {
                    rem::wire::chunk_name::name_of(&data)
                } else {
                    self.string()
                };
                proto::PutChunkRequest {
                    hash,
                    data: data.into(),
                }
                .encode_to_vec()
            }
            Rpc::GetChunk | Rpc::FetchChunk => proto::GetChunkRequest {
                hash: self.string(),
            }
            .encode_to_vec(),
            Rpc::HasChunks | Rpc::CachedChunks => proto::HasChunksRequest {
                hashes: self.strings(),
            }
            .encode_to_vec(),
            Rpc::ListJobsLocal => proto::ListJobsLocalRequest {
                user: self.user(),
                all: self.rng.one_in(2),
            }
            .encode_to_vec(),
            Rpc::StoreReplica | Rpc::StoreJob => {
                let record = self.job_record();
                let mut cp = proto::Checkpoint {
                    job: if self.rng.one_in(2) {
                        record.id.clone()
                    } else {
                        self.job()
                    },
                    data: if self.rng.one_in(2) {
                        record.encode_to_vec()
                    } else {
                        self.data()
                    },
                    version: self.u64(),
                    written_by: if self.rng.one_in(2) {
                        from.to_string()
                    } else {
                        self.string()
                    },
                    mac: self.rng.bytes(32),
                    user: self.user(),
                    epoch: if self.rng.one_in(2) { 0 } else { self.u64() },
                };
                if self.rng.one_in(2) {
                    cp.mac = checkpoint_seal(&cp).to_vec();
                }
                cp.encode_to_vec()
            }
        }
    }

    /// Raw bytes: random, or random protobuf-looking fields (tags, varints, length prefixes
    /// that lie).
    pub(super) fn raw(&mut self) -> Vec<u8> {
        let r = &mut *self.rng;
        if r.one_in(3) {
            let n = r.len();
            return r.bytes(n);
        }
        let mut out = Vec::new();
        for _ in 0..r.below(12) {
            let random = r.next();
            let field = r.pick(&[
                1u64,
                2,
                3,
                4,
                5,
                6,
                7,
                8,
                15,
                16,
                2047,
                1 << 28,
                random >> 35,
            ]);
            let wire = r.below(8) as u64;
            put_varint(&mut out, (field << 3) | wire);
            match wire {
                0 => put_varint(&mut out, r.pick(&[0, 1, u64::MAX, random])),
                1 => out.extend(r.bytes(8)),
                5 => out.extend(r.bytes(4)),
                2 => {
                    let n = r.len();
                    let claimed = r.pick(&[n as u64, n as u64 + 1, u64::MAX, 1 << 31, 0]);
                    put_varint(&mut out, claimed);
                    out.extend(r.bytes(n));
                }
                _ => {
                    let n = r.below(8);
                    out.extend(r.bytes(n));
                }
            }
        }
        out
    }

    /// `bytes` mutated: bit flips, truncation, duplicated, inserted and overwritten bytes,
    /// overlong varints, the message appended to itself.
    pub(super) fn mutate(&mut self, mut b: Vec<u8>) -> Vec<u8> {
        let r = &mut *self.rng;
        for _ in 0..1 + r.below(3) {
            let at = r.below(b.len() + 1);
            match r.below(8) {
                0 | 1 if !b.is_empty() => {
                    for _ in 0..1 + r.below(8) {
                        let i = r.below(b.len());
                        b[i] ^= 1 << r.below(8);
                    }
                }
                2 => b.truncate(at),
                3 if !b.is_empty() => {
                    let start = r.below(b.len());
                    let end = (start + 1 + r.below(64)).min(b.len());
                    let copy = b[start..end].to_vec();
                    b.splice(at..at, copy);
                }
                4 => {
                    let n = 1 + r.below(16);
                    let bytes = r.bytes(n);
                    b.splice(at..at, bytes);
                }
                5 if at < b.len() => b[at] = r.pick(&[0x00, 0xFF, 0x7F, 0x80]),
                6 => {
                    let long = r.pick(&[vec![0xFFu8; 10], vec![0x80; 11], vec![0xFF; 9]]);
                    b.splice(at..at, long);
                }
                _ => {
                    let copy = b.clone();
                    b.extend(copy);
                }
            }
        }
        b
    }
}

fn put_varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}
