//! Workers joining the running job (the farm's share keeper started them: the job's share of
//! the queue grew, or a worker was lost) and retiring from it (the share shrank: another
//! job's user is below their share, or a higher priority waits). A retiring worker gets no
//! more lines and is told Retire: it hands back its queued lines unstarted, finishes and
//! reports those it is rendering, and exits, so no rendered work is lost and the image keeps
//! its bytes. Whatever it still holds when it exits goes back to the queue. A worker refused
//! at its Ready (it renders another image version) is told Retire too, holding nothing.

use super::crew::to_retire;
use super::link::WorkerLink;
use super::{Controller, WorkerProc};
use crate::distrib::messages::{self, proto, Body};
use serde_json::json;

impl<L: WorkerLink> Controller<L> {
    /// Workers started while the job runs join the table and get the Scene.
    pub(super) async fn add_workers(&mut self, workers: Vec<WorkerProc>) {
        for w in workers {
            if self.finishing || self.table.is_finished() {
                self.link.kill(&w.proc_id).await;
                continue;
            }
            let i = self.table.add_node();
            debug_assert_eq!(i, self.procs.len());
            self.by_proc.insert(w.proc_id.to_string(), i);
            self.procs.push(w.proc_id.clone());
            self.exited.push(false);
            self.stamps_to_echo.push(None);
            self.assigned_once.push(false);
            self.adopted.push(false);
            self.retiring.push(false);
            self.slots.push(w.slots);
            self.nodes.push(w.node_row(i, Some(self.cfg.clock.now())));
            if let Some(crew) = &self.cfg.crew {
                crew.joined(i, &w.host, w.slots);
            }
            self.view.event(
                json!({"event": "spawned", "node": i + 1, "proc": w.proc_id.to_string(),
                "host": w.host, "pid": w.pid, "adopted": false, "slots": w.slots}),
            );
            if let Err(e) = self.link.send(&w.proc_id, self.cfg.scene.clone()).await {
                self.on_gone(i, format!("cannot send the scene: {e}"), false);
            }
        }
    }

    /// Gives back at least `slots` slots: the newest live workers stop (one stays when
    /// `keep_one`).
    pub(super) async fn retire(&mut self, slots: u32, keep_one: bool) {
        if self.finishing {
            return;
        }
        let live: Vec<(usize, u32)> = (0..self.procs.len())
            .filter(|&i| !self.exited[i] && !self.retiring[i])
            .map(|i| (i, self.slots[i]))
            .collect();
        for i in to_retire(&live, slots, keep_one) {
            self.retiring[i] = true;
            self.table.close(i);
            if let Some(crew) = &self.cfg.crew {
                crew.left(i, false);
            }
            self.view.event(json!({"event": "retired", "node": i + 1,
                "host": self.nodes[i].host, "slots": self.slots[i]}));
            self.tell_retire(i).await;
        }
    }

    /// Tells the workers refused at their Ready ([`super::incoming`]: another image version)
    /// to stop; they were counted as faults then, and hold no lines.
    pub(super) async fn stop_refused(&mut self) {
        for i in std::mem::take(&mut self.refused) {
            self.tell_retire(i).await;
        }
    }

    /// Sends node `i` a Retire.
    async fn tell_retire(&mut self, i: usize) {
        let stop = messages::encode(Body::Retire(proto::Retire {}));
        if self.link.send(&self.procs[i], stop).await.is_ok() {
            self.messages_out += 1;
        }
    }
}
