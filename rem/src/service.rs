//! The gRPC services (`Rem` for clients and processes, `Peer` for daemons): thin adapters
//! from protobuf requests to `Daemon` operations, and from `Error` to `tonic::Status`.

use std::sync::Arc;

use tonic::{Request, Response, Status, Streaming};

use crate::daemon::Daemon;
use crate::ids::ProcId;
use crate::proto::{self, peer_server::Peer, rem_server::Rem};

/// Both services over one daemon.
#[derive(Clone)]
pub struct Service(pub Arc<Daemon>);

fn proc_id(s: &str) -> Result<ProcId, Status> {
    ProcId::parse(s).ok_or_else(|| Status::invalid_argument(format!("bad process id {s:?}")))
}

#[tonic::async_trait]
impl Rem for Service {
    async fn hosts(
        &self,
        _: Request<proto::HostsRequest>,
    ) -> Result<Response<proto::HostsReply>, Status> {
        Ok(Response::new(proto::HostsReply {
            hosts: self.0.membership.hosts(),
        }))
    }

    async fn spawn(
        &self,
        req: Request<proto::SpawnRequest>,
    ) -> Result<Response<proto::SpawnReply>, Status> {
        Ok(Response::new(self.0.spawn(req.into_inner()).await?))
    }

    async fn ps(&self, _: Request<proto::PsRequest>) -> Result<Response<proto::PsReply>, Status> {
        Ok(Response::new(proto::PsReply {
            processes: self.0.ps().await?,
        }))
    }

    async fn kill(
        &self,
        req: Request<proto::KillRequest>,
    ) -> Result<Response<proto::KillReply>, Status> {
        self.0.kill(proc_id(&req.into_inner().proc_id)?).await?;
        Ok(Response::new(proto::KillReply {}))
    }

    async fn logs(
        &self,
        req: Request<proto::LogsRequest>,
    ) -> Result<Response<proto::LogsReply>, Status> {
        Ok(Response::new(
            self.0.logs(proc_id(&req.into_inner().proc_id)?).await?,
        ))
    }

    type AttachStream = crate::attach::FrameStream;

    async fn attach(
        &self,
        req: Request<Streaming<proto::ClientFrame>>,
    ) -> Result<Response<Self::AttachStream>, Status> {
        Ok(Response::new(
            crate::attach::attach(self.0.clone(), req.into_inner()).await?,
        ))
    }

    async fn put_checkpoint(
        &self,
        req: Request<proto::PutCheckpointRequest>,
    ) -> Result<Response<proto::PutCheckpointReply>, Status> {
        let req = req.into_inner();
        let (version, stored_on) = self.0.put_checkpoint(req.job, req.data).await?;
        Ok(Response::new(proto::PutCheckpointReply {
            version,
            stored_on,
        }))
    }

    async fn get_checkpoint(
        &self,
        req: Request<proto::GetCheckpointRequest>,
    ) -> Result<Response<proto::GetCheckpointReply>, Status> {
        let checkpoint = self.0.get_checkpoint(req.into_inner().job).await?;
        Ok(Response::new(proto::GetCheckpointReply { checkpoint }))
    }
}

#[tonic::async_trait]
impl Peer for Service {
    async fn heartbeat(
        &self,
        req: Request<proto::HeartbeatRequest>,
    ) -> Result<Response<proto::HeartbeatReply>, Status> {
        let (sender, members) = self.0.membership.heard(req.into_inner()).await;
        Ok(Response::new(proto::HeartbeatReply {
            sender: Some(sender),
            members,
        }))
    }

    async fn start_local(
        &self,
        req: Request<proto::StartLocalRequest>,
    ) -> Result<Response<proto::StartLocalReply>, Status> {
        let processes = self.0.start_local(req.into_inner()).await?;
        Ok(Response::new(proto::StartLocalReply { processes }))
    }

    async fn kill_local(
        &self,
        req: Request<proto::KillRequest>,
    ) -> Result<Response<proto::KillReply>, Status> {
        self.0
            .processes
            .kill(proc_id(&req.into_inner().proc_id)?)
            .await?;
        Ok(Response::new(proto::KillReply {}))
    }

    async fn logs_local(
        &self,
        req: Request<proto::LogsRequest>,
    ) -> Result<Response<proto::LogsReply>, Status> {
        Ok(Response::new(
            self.0
                .processes
                .logs(proc_id(&req.into_inner().proc_id)?)
                .await?,
        ))
    }

    async fn ps_local(
        &self,
        _: Request<proto::PsRequest>,
    ) -> Result<Response<proto::PsReply>, Status> {
        Ok(Response::new(proto::PsReply {
            processes: self.0.processes.list().await?,
        }))
    }

    async fn forward(
        &self,
        req: Request<Streaming<proto::PeerBatch>>,
    ) -> Result<Response<proto::ForwardReply>, Status> {
        let mut inbound = req.into_inner();
        loop {
            let batch = tokio::select! {
                b = inbound.message() => b?,
                _ = self.0.stop.cancelled() => None,
            };
            let Some(batch) = batch else { break };
            for item in batch.items {
                self.0.router.deliver_from_peer(item).await;
            }
        }
        Ok(Response::new(proto::ForwardReply {}))
    }

    async fn store_replica(
        &self,
        req: Request<proto::Checkpoint>,
    ) -> Result<Response<proto::StoreReplicaReply>, Status> {
        let cp = req.into_inner();
        if cp.data.len() > self.0.max_message {
            return Err(Status::resource_exhausted("checkpoint over the size limit"));
        }
        self.0.checkpoints.put(&cp).await?;
        Ok(Response::new(proto::StoreReplicaReply {}))
    }

    async fn fetch_replica(
        &self,
        req: Request<proto::GetCheckpointRequest>,
    ) -> Result<Response<proto::GetCheckpointReply>, Status> {
        let checkpoint = self.0.checkpoints.get(&req.into_inner().job).await?;
        Ok(Response::new(proto::GetCheckpointReply { checkpoint }))
    }
}
