//! The gRPC services (`Rem` for clients and processes, `Peer` for daemons): thin adapters
//! from protobuf requests to `Daemon` operations, and from `Error` to `tonic::Status`. Who
//! may call what is decided here: a `Rem` call's [`Caller`] (a user's key, or a process token)
//! comes from the interceptor, and the user it proved is who the call acts for. A process
//! REM started on this host (a job's controller, say) acts for the user it belongs to, once
//! its token is checked here ([`Service::user`]); never as admin. A `Peer` call is verified
//! here (`peer_auth`) and answered with this daemon's proof.

use std::sync::Arc;

use tonic::{Request, Response, Status, Streaming};

use crate::auth::identity::Identity;
use crate::auth::peer_auth::{digest, method};
use crate::auth::secret::{caller, Caller};
use crate::daemon::ops::Daemon;
use crate::wire::ids::{shown, ProcId};
use crate::wire::proto::{self, peer_server::Peer, rem_server::Rem};

/// Both services over one daemon.
#[derive(Clone)]
pub struct Service(pub Arc<Daemon>);

fn proc_id(s: &str) -> Result<ProcId, Status> {
    ProcId::parse(s).ok_or_else(|| Status::invalid_argument(format!("bad process id {}", shown(s))))
}

#[tonic::async_trait]
impl Rem for Service {
    async fn hosts(
        &self,
        req: Request<proto::HostsRequest>,
    ) -> Result<Response<proto::HostsReply>, Status> {
        // A process token is not checked by the interceptor: `user` checks it (the fuzz run
        // found that any token listed the hosts when nothing did).
        self.user(&req)?;
        Ok(Response::new(proto::HostsReply {
            hosts: self.0.membership.hosts(),
        }))
    }

    async fn spawn(
        &self,
        req: Request<proto::SpawnRequest>,
    ) -> Result<Response<proto::SpawnReply>, Status> {
        let who = self.user(&req)?;
        Ok(Response::new(self.0.spawn(&who, req.into_inner()).await?))
    }

    async fn adopt_process(
        &self,
        req: Request<proto::AdoptProcessRequest>,
    ) -> Result<Response<proto::AdoptProcessReply>, Status> {
        let who = self.user(&req)?;
        let r = req.into_inner();
        let process = self.0.adopt(&who, proc_id(&r.proc_id)?, &r.owner).await?;
        Ok(Response::new(proto::AdoptProcessReply {
            process: Some(process),
        }))
    }

    async fn ps(&self, req: Request<proto::PsRequest>) -> Result<Response<proto::PsReply>, Status> {
        self.user(&req)?;
        Ok(Response::new(proto::PsReply {
            processes: self.0.ps().await?,
        }))
    }

    async fn kill(
        &self,
        req: Request<proto::KillRequest>,
    ) -> Result<Response<proto::KillReply>, Status> {
        let who = self.user(&req)?;
        self.0
            .kill(&who, proc_id(&req.into_inner().proc_id)?)
            .await?;
        Ok(Response::new(proto::KillReply {}))
    }

    async fn logs(
        &self,
        req: Request<proto::LogsRequest>,
    ) -> Result<Response<proto::LogsReply>, Status> {
        let who = self.user(&req)?;
        let r = req.into_inner();
        let from = (r.stdout_from, r.stderr_from);
        Ok(Response::new(
            self.0.logs(&who, proc_id(&r.proc_id)?, from).await?,
        ))
    }

    type AttachStream = crate::daemon::server::attach::FrameStream;

    async fn attach(
        &self,
        req: Request<Streaming<proto::ClientFrame>>,
    ) -> Result<Response<Self::AttachStream>, Status> {
        let caller = caller(&req)?;
        Ok(Response::new(
            crate::daemon::server::attach::attach(self.0.clone(), caller, req.into_inner()).await?,
        ))
    }

    async fn put_checkpoint(
        &self,
        req: Request<proto::PutCheckpointRequest>,
    ) -> Result<Response<proto::PutCheckpointReply>, Status> {
        let who = self.user(&req)?;
        let req = req.into_inner();
        let fence = crate::daemon::ops::Fence {
            epoch: req.epoch,
            job: req.fence_job,
        };
        let (version, stored_on) = self
            .0
            .put_checkpoint(&who, req.job, req.data, fence)
            .await?;
        Ok(Response::new(proto::PutCheckpointReply {
            version,
            stored_on,
        }))
    }

    async fn get_checkpoint(
        &self,
        req: Request<proto::GetCheckpointRequest>,
    ) -> Result<Response<proto::GetCheckpointReply>, Status> {
        let who = self.user(&req)?;
        let checkpoint = self.0.get_checkpoint(&who, req.into_inner().job).await?;
        Ok(Response::new(proto::GetCheckpointReply { checkpoint }))
    }

    async fn put_job(
        &self,
        req: Request<proto::PutJobRequest>,
    ) -> Result<Response<proto::PutJobReply>, Status> {
        let who = self.user(&req)?;
        let record = req
            .into_inner()
            .record
            .ok_or_else(|| Status::invalid_argument("no job record"))?;
        let stored_on = self.0.put_job(&who, record).await?;
        Ok(Response::new(proto::PutJobReply { stored_on }))
    }

    async fn start_job(
        &self,
        req: Request<proto::StartJobRequest>,
    ) -> Result<Response<proto::StartJobReply>, Status> {
        let who = self.user(&req)?;
        let req = req.into_inner();
        let record = req
            .record
            .ok_or_else(|| Status::invalid_argument("no job record"))?;
        let record = self
            .0
            .start_job(&who, record, req.controller_anywhere)
            .await?;
        Ok(Response::new(proto::StartJobReply {
            record: Some(record),
        }))
    }

    async fn put_chunk(
        &self,
        req: Request<proto::PutChunkRequest>,
    ) -> Result<Response<proto::PutChunkReply>, Status> {
        let who = self.user(&req)?;
        Ok(Response::new(
            self.0.put_chunk(&who, req.into_inner()).await?,
        ))
    }

    async fn get_chunk(
        &self,
        req: Request<proto::GetChunkRequest>,
    ) -> Result<Response<proto::GetChunkReply>, Status> {
        let who = self.user(&req)?;
        let hash = req.into_inner().hash;
        Ok(Response::new(self.0.get_chunk(&who, hash).await?))
    }

    async fn cached_chunks(
        &self,
        req: Request<proto::HasChunksRequest>,
    ) -> Result<Response<proto::HasChunksReply>, Status> {
        self.user(&req)?;
        let has = self.0.has_chunks(&req.get_ref().hashes).await?;
        Ok(Response::new(proto::HasChunksReply { has }))
    }

    async fn list_jobs(
        &self,
        req: Request<proto::ListJobsRequest>,
    ) -> Result<Response<proto::ListJobsReply>, Status> {
        let who = self.user(&req)?;
        let records = self.0.list_jobs(&who).await?;
        Ok(Response::new(proto::ListJobsReply { records }))
    }

    /// Any user may see the queue (as `condor_q` shows everyone's jobs): ids, users,
    /// priorities and slots, not the jobs' settings.
    async fn queue(
        &self,
        req: Request<proto::QueueRequest>,
    ) -> Result<Response<proto::QueueReply>, Status> {
        self.user(&req)?;
        Ok(Response::new(self.0.queue().await?))
    }
}

impl Service {
    /// Who a `Rem` call acts for: the user a client proved, or the user of the process of this
    /// host whose token the call carries.
    fn user<T>(&self, req: &Request<T>) -> Result<Identity, Status> {
        match caller(req)? {
            Caller::Client(who) => Ok(who),
            Caller::Process(token) => self
                .0
                .router
                .user_of_token(&token)
                .map(Identity::user)
                .ok_or_else(|| {
                    Status::unauthenticated(
                        "the process token is not one of a process of this host",
                    )
                }),
        }
    }

    /// The calling daemon's name, if `req` proves the daemon key for `method`.
    fn peer<T: prost::Message>(&self, req: &Request<T>, method: &str) -> Result<String, Status> {
        self.0
            .peers
            .key()
            .verify(req, method, &digest(req.get_ref()))
    }

    /// A reply carrying this daemon's proof.
    fn answer<T: prost::Message, R>(&self, req: &Request<R>, method: &str, msg: T) -> Response<T> {
        self.0.peers.key().reply(req, method, msg)
    }
}

#[tonic::async_trait]
impl Peer for Service {
    async fn start_local(
        &self,
        req: Request<proto::StartLocalRequest>,
    ) -> Result<Response<proto::StartLocalReply>, Status> {
        self.peer(&req, method::START)?;
        let processes = self.0.start_local(req.get_ref().clone()).await?;
        Ok(self.answer(&req, method::START, proto::StartLocalReply { processes }))
    }

    async fn kill_local(
        &self,
        req: Request<proto::KillLocalRequest>,
    ) -> Result<Response<proto::KillReply>, Status> {
        self.peer(&req, method::KILL)?;
        let r = req.get_ref();
        let who = Identity::from_acting(r.acting.as_ref())?;
        self.0.processes.kill(proc_id(&r.proc_id)?, who).await?;
        Ok(self.answer(&req, method::KILL, proto::KillReply {}))
    }

    async fn adopt_local(
        &self,
        req: Request<proto::AdoptLocalRequest>,
    ) -> Result<Response<proto::AdoptProcessReply>, Status> {
        self.peer(&req, method::ADOPT)?;
        let r = req.get_ref();
        let who = Identity::from_acting(r.acting.as_ref())?;
        let process = self
            .0
            .processes
            .adopt(proc_id(&r.proc_id)?, r.owner.clone(), who)
            .await?;
        Ok(self.answer(
            &req,
            method::ADOPT,
            proto::AdoptProcessReply {
                process: Some(process),
            },
        ))
    }

    async fn logs_local(
        &self,
        req: Request<proto::LogsLocalRequest>,
    ) -> Result<Response<proto::LogsReply>, Status> {
        self.peer(&req, method::LOGS)?;
        let r = req.get_ref();
        let who = Identity::from_acting(r.acting.as_ref())?;
        let from = (r.stdout_from, r.stderr_from);
        let logs = self
            .0
            .processes
            .logs(proc_id(&r.proc_id)?, who, from)
            .await?;
        Ok(self.answer(&req, method::LOGS, logs))
    }

    async fn ps_local(
        &self,
        req: Request<proto::PsRequest>,
    ) -> Result<Response<proto::PsReply>, Status> {
        self.peer(&req, method::PS)?;
        let processes = self.0.processes.list().await?;
        Ok(self.answer(&req, method::PS, proto::PsReply { processes }))
    }

    async fn forward(
        &self,
        req: Request<Streaming<proto::PeerBatch>>,
    ) -> Result<Response<proto::ForwardReply>, Status> {
        let from = self.0.peers.key().verify(&req, method::FORWARD, "-")?;
        let mut inbound = req.into_inner();
        loop {
            let batch = tokio::select! {
                b = inbound.message() => b?,
                _ = self.0.stop.cancelled() => None,
            };
            let Some(batch) = batch else { break };
            for item in batch.items {
                self.0.router.deliver_from_peer(&from, item).await?;
            }
        }
        Ok(Response::new(proto::ForwardReply {}))
    }

    async fn store_replica(
        &self,
        req: Request<proto::Checkpoint>,
    ) -> Result<Response<proto::StoreReplicaReply>, Status> {
        self.peer(&req, method::STORE)?;
        self.0.keep_checkpoint(req.get_ref()).await?;
        Ok(self.answer(&req, method::STORE, proto::StoreReplicaReply {}))
    }

    async fn fetch_replica(
        &self,
        req: Request<proto::FetchReplicaRequest>,
    ) -> Result<Response<proto::GetCheckpointReply>, Status> {
        self.peer(&req, method::FETCH)?;
        let r = req.get_ref();
        let checkpoint = self.0.checkpoints.get(&r.user, &r.job).await?;
        Ok(self.answer(
            &req,
            method::FETCH,
            proto::GetCheckpointReply { checkpoint },
        ))
    }

    async fn store_job(
        &self,
        req: Request<proto::Checkpoint>,
    ) -> Result<Response<proto::StoreReplicaReply>, Status> {
        self.peer(&req, method::STORE_JOB)?;
        self.0.job_store.put(req.get_ref()).await?;
        self.0.queue_memo.forget();
        Ok(self.answer(&req, method::STORE_JOB, proto::StoreReplicaReply {}))
    }

    async fn store_chunk(
        &self,
        req: Request<proto::PutChunkRequest>,
    ) -> Result<Response<proto::PutChunkReply>, Status> {
        self.peer(&req, method::STORE_CHUNK)?;
        self.0.store_chunk(req.get_ref().clone()).await?;
        let reply = proto::PutChunkReply {
            stored_on: vec![self.0.name.clone()],
            bytes_sent: 0,
        };
        Ok(self.answer(&req, method::STORE_CHUNK, reply))
    }

    async fn has_chunks(
        &self,
        req: Request<proto::HasChunksRequest>,
    ) -> Result<Response<proto::HasChunksReply>, Status> {
        self.peer(&req, method::HAS_CHUNKS)?;
        let has = self.0.has_chunks(&req.get_ref().hashes).await?;
        Ok(self.answer(&req, method::HAS_CHUNKS, proto::HasChunksReply { has }))
    }

    async fn fetch_chunk(
        &self,
        req: Request<proto::GetChunkRequest>,
    ) -> Result<Response<proto::GetChunkReply>, Status> {
        self.peer(&req, method::FETCH_CHUNK)?;
        let data = self.0.fetch_chunk(&req.get_ref().hash).await?;
        let reply = proto::GetChunkReply {
            data,
            from_host: self.0.name.clone(),
            cached: true,
        };
        Ok(self.answer(&req, method::FETCH_CHUNK, reply))
    }

    async fn list_jobs_local(
        &self,
        req: Request<proto::ListJobsLocalRequest>,
    ) -> Result<Response<proto::ListJobsLocalReply>, Status> {
        self.peer(&req, method::LIST_JOBS)?;
        let r = req.get_ref();
        let user = (!r.all).then_some(r.user.as_str());
        let records = self.0.job_store.list(user).await?;
        Ok(self.answer(
            &req,
            method::LIST_JOBS,
            proto::ListJobsLocalReply { records },
        ))
    }
}
