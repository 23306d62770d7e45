//! Whom a worker answers to: the controller that started it or, in a farm job, a successor
//! that took the job over. When a farm job's controller is gone the worker keeps rendering
//! the lines it holds and waits (at most [`WorkerConfig::adopt_wait`](super::WorkerConfig))
//! for an Adopt message; it believes one only if REM's job record names the sender as the
//! job's controller at a later epoch, and from then on obeys the successor alone, so an old
//! controller coming back from a partition is not heard.

use crate::distrib::messages::{self, proto, Body};
use rem::{Incoming, ProcId, RemClient};
use std::future::Future;
use tokio::time::Instant;

/// What one delivery means to the worker.
#[derive(Debug)]
#[allow(clippy::large_enum_variant)] // one per delivery, matched at once: never stored
pub enum Heard {
    /// A message from its controller.
    Body(Body),
    /// A claim to the job by another process, to be checked.
    Adopt(ProcId, proto::Adopt),
    /// Its controller is gone (REM could not deliver to it).
    Gone,
    /// Nothing for the worker (other senders, garbage, events).
    Nothing,
}

/// The worker's controller, and what it keeps while it has none.
#[derive(Debug)]
pub struct Owner {
    /// The controller's process.
    pub id: ProcId,
    /// The job, from the Scene.
    job: String,
    /// The controller's epoch; 0: a `sunray submit` in-process job, which nobody takes over.
    epoch: u64,
    /// When the controller went away (a farm job's worker then waits for a successor).
    pub orphaned: Option<Instant>,
    /// Takeovers so far: lines granted before the last one are reported with grant 0.
    pub generation: u32,
    /// Done messages rendered while orphaned, for the successor.
    pending: Vec<proto::Done>,
}

impl Owner {
    /// The controller `id` that sent `scene`.
    pub fn new(id: ProcId, scene: &proto::Scene) -> Owner {
        Owner {
            id,
            job: scene.job.clone(),
            epoch: scene.epoch,
            orphaned: None,
            generation: 0,
            pending: Vec::new(),
        }
    }

    /// Sorts a delivery.
    pub fn hear(&self, incoming: Incoming) -> Heard {
        match incoming {
            Incoming::Message { from, payload } => match messages::decode(&payload) {
                Ok(body) if from == self.id.as_str() => Heard::Body(body),
                Ok(Body::Adopt(a)) => match ProcId::parse(&from) {
                    Some(id) => Heard::Adopt(id, a),
                    None => Heard::Nothing,
                },
                _ => Heard::Nothing,
            },
            Incoming::Undeliverable { to, .. } if to == self.id.as_str() => Heard::Gone,
            _ => Heard::Nothing,
        }
    }

    /// Whether a successor may take the job over (a farm job).
    pub fn succeedable(&self) -> bool {
        self.epoch > 0
    }

    /// Whether `adopt` from `from` is worth checking: this job, a later epoch.
    pub fn newer_claim(&self, from: &ProcId, adopt: &proto::Adopt) -> bool {
        self.succeedable() && adopt.job == self.job && adopt.epoch > self.epoch && *from != self.id
    }

    /// `done`, with grant 0 if it was granted before the last takeover; kept for the
    /// successor while there is no controller (`None` returned), else to be sent.
    pub fn report(&mut self, mut done: proto::Done, generation: u32) -> Option<proto::Done> {
        if generation != self.generation {
            done.grant = 0;
        }
        if self.orphaned.is_some() {
            self.pending.push(done);
            return None;
        }
        Some(done)
    }

    /// The successor `id` at `epoch` has the job: returns the Done messages kept for it
    /// (every one with grant 0).
    pub fn take_over(&mut self, id: ProcId, epoch: u64) -> Vec<proto::Done> {
        self.id = id;
        self.epoch = epoch;
        self.orphaned = None;
        self.generation += 1;
        let mut kept = std::mem::take(&mut self.pending);
        for d in &mut kept {
            d.grant = 0;
        }
        kept
    }
}

/// Where a worker checks a successor's claim: REM's job records.
pub trait Records {
    /// The controller process and epoch the record of `job` names, if there is a record.
    fn controller_of(&self, job: &str) -> impl Future<Output = Option<(String, u64)>> + Send;
}

impl Records for RemClient {
    async fn controller_of(&self, job: &str) -> Option<(String, u64)> {
        let records = self.list_jobs().await.ok()?;
        records
            .into_iter()
            .filter(|r| r.id == job)
            .max_by_key(|r| r.epoch)
            .map(|r| (r.controller, r.epoch))
    }
}

/// Whether REM's record confirms that `from` controls `adopt.job` at `adopt.epoch`.
pub async fn confirmed(records: &impl Records, from: &ProcId, adopt: &proto::Adopt) -> bool {
    records
        .controller_of(&adopt.job)
        .await
        .is_some_and(|(controller, epoch)| controller == from.as_str() && epoch == adopt.epoch)
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Record(Option<(String, u64)>);

    impl Records for Record {
        async fn controller_of(&self, _job: &str) -> Option<(String, u64)> {
            self.0.clone()
        }
    }

    fn owner(epoch: u64) -> Owner {
        let scene = proto::Scene {
            job: "j".into(),
            epoch,
            ..Default::default()
        };
        Owner::new(ProcId::new("a", 1), &scene)
    }

    fn message(from: &str, body: Body) -> Incoming {
        Incoming::Message {
            from: from.into(),
            payload: messages::encode(body),
        }
    }

    fn adopt(epoch: u64) -> proto::Adopt {
        proto::Adopt {
            job: "j".into(),
            epoch,
        }
    }

    #[test]
    fn only_the_controller_is_obeyed_and_others_may_only_claim_the_job() {
        let o = owner(1);
        let nmw = || Body::NoMoreWork(proto::NoMoreWork {});
        assert!(matches!(o.hear(message("a/1", nmw())), Heard::Body(_)));
        assert!(matches!(o.hear(message("b/2", nmw())), Heard::Nothing));
        assert!(matches!(
            o.hear(message("b/2", Body::Adopt(adopt(2)))),
            Heard::Adopt(_, _)
        ));
        let gone = Incoming::Undeliverable {
            to: "a/1".into(),
            reason: String::new(),
        };
        assert!(matches!(o.hear(gone), Heard::Gone));
        let b = ProcId::new("b", 2);
        assert!(o.newer_claim(&b, &adopt(2)));
        assert!(!o.newer_claim(&b, &adopt(1)), "not a later epoch");
        assert!(!o.newer_claim(
            &b,
            &proto::Adopt {
                job: "k".into(),
                epoch: 2
            }
        ));
        assert!(!owner(0).newer_claim(&b, &adopt(2)), "an in-process job");
    }

    #[tokio::test]
    async fn a_claim_is_believed_only_as_the_record_says() {
        let b = ProcId::new("b", 2);
        let says = |c: &str, e| Record(Some((c.to_string(), e)));
        assert!(confirmed(&says("b/2", 2), &b, &adopt(2)).await);
        assert!(!confirmed(&says("c/3", 2), &b, &adopt(2)).await);
        assert!(!confirmed(&says("b/2", 3), &b, &adopt(2)).await);
        assert!(!confirmed(&Record(None), &b, &adopt(2)).await);
    }

    #[test]
    fn lines_done_while_orphaned_wait_for_the_successor_with_grant_zero() {
        let mut o = owner(1);
        let done = |line| proto::Done {
            line,
            grant: 7,
            ..Default::default()
        };
        assert_eq!(o.report(done(1), 0).unwrap().grant, 7);
        o.orphaned = Some(Instant::now());
        assert!(o.report(done(2), 0).is_none());
        let kept = o.take_over(ProcId::new("b", 2), 2);
        assert_eq!(
            kept.iter().map(|d| (d.line, d.grant)).collect::<Vec<_>>(),
            [(2, 0)]
        );
        assert_eq!(o.id.as_str(), "b/2");
        // A line granted by the first controller, finished after the takeover.
        assert_eq!(o.report(done(3), 0).unwrap().grant, 0);
        assert_eq!(o.report(done(4), 1).unwrap().grant, 7);
    }
}
