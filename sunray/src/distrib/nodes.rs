//! Per-node statistics and the thesis's per-node table (Tables 4.5 to 4.9): node, host,
//! cores, load at start, scanlines, eye and secondary rays, intersection tests, CPU,
//! elapsed, preprocessing and render seconds. A failed node's row says FAULT (Table 4.7).
//! The same data is written by `--stats-json` as the `nodes` array of [`JobStats`].

use super::strategy::Strategy;
use super::timeline::{NodeTimeline, Timeline};
use crate::stats::{Counters, RenderStats};
use serde::Serialize;

/// How a node ended.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Outcome {
    /// Still starting (never sent Ready).
    #[default]
    Starting,
    /// Worked to the end.
    Ok,
    /// Stopped answering and never came back.
    Silent,
    /// Its process exited early or its host was lost.
    Fault,
    /// Gave its slots back to the farm's queue (another job's share) and left.
    Retired,
}

/// How far a worker got towards rendering, as it last said (so that a node that rendered
/// nothing says why).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Stage {
    /// Spawned; it has not said Ready yet.
    #[default]
    Spawned,
    /// Getting the scene's model.
    Fetching,
    /// Building (or reading) its accelerator.
    Building,
    /// Ready for lines.
    Rendering,
}

impl Stage {
    /// What a node at this stage was doing, for people: "still fetching the scene", ...
    pub fn doing(self) -> &'static str {
        match self {
            Stage::Spawned => "still starting",
            Stage::Fetching => "still fetching the scene",
            Stage::Building => "still building its accelerator",
            Stage::Rendering => "ready, no line left for it",
        }
    }
}

/// One worker's figures. Counters are those of the lines accepted from it.
#[derive(Clone, Debug, Default, Serialize)]
pub struct NodeStats {
    /// 1-based, in spawn order.
    pub node: usize,
    /// REM's id of the worker process.
    pub proc_id: String,
    /// The host it ran on, as REM names it.
    pub host: String,
    /// The worker's process id on its host.
    pub pid: u32,
    /// Cores the worker could use (`available_parallelism` on its host).
    pub cores: u32,
    /// Render threads the worker ran.
    pub threads: u32,
    /// The worker reads later passes carrying only the pixels they take (its Ready says so).
    #[serde(skip)]
    pub sparse_passes: bool,
    /// Load per core when the job started: REM's figure (cgroup-aware) when `rem_load`, else
    /// the load average the worker reported.
    pub load_at_start: f64,
    /// True when `load_at_start` is REM's figure rather than the worker's own load average.
    pub rem_load: bool,
    /// How the node ended (OK, silent, fault, or never started).
    pub outcome: Outcome,
    /// Why a faulty node failed.
    pub fault: Option<String>,
    /// Lines accepted from this node.
    pub scanlines: u64,
    /// Completions dropped because another node finished the line first.
    pub dropped: u64,
    /// Lines it held when it failed or timed out, given back to the queue.
    pub lines_given_back: u64,
    /// Eye rays over the accepted lines (the table's "eye rays" column).
    pub eye_rays: u64,
    /// Shadow, reflected and refracted rays over the accepted lines (the "secondary" column).
    pub secondary_rays: u64,
    /// Every counter summed over the lines accepted from this node.
    pub counters: Counters,
    /// The worker process's user + system CPU seconds, as it last reported them.
    pub cpu_s: f64,
    /// The worker's wall-clock seconds from start to its last report.
    pub elapsed_s: f64,
    /// The worker's seconds to build its accelerator (or read it from its host's cache).
    pub preprocess_s: f64,
    /// Bytes of the scene's model the worker's host fetched from other hosts (0 when it had
    /// every chunk cached).
    pub scene_bytes_received: u64,
    /// Whether the worker's host had the whole model cached.
    pub scene_cached: bool,
    /// The worker's seconds to get the model (through its host's remd) and decode it.
    pub scene_fetch_s: f64,
    /// Whether the worker read its accelerator from its host's cache instead of building it.
    pub accel_cached: bool,
    /// Whether the worker used its host's prepared scene, mapped in place.
    pub scene_mapped: bool,
    /// The worker's seconds from the Scene message to a scene ready to render.
    pub scene_ready_s: f64,
    /// The worker's render threads' wall-clock seconds spent rendering.
    pub render_s: f64,
    /// Render threads' time waiting for their next fresh line, summed over threads (after
    /// their first line).
    pub wait_s: f64,
    /// Render threads' time waiting for their first line (start-up).
    pub first_wait_s: f64,
    /// Render threads' time waiting for a duplicate line (the tail: no fresh line was left).
    pub tail_wait_s: f64,
    /// Seconds from the start of the job to this node's last accepted line.
    pub finished_at_s: f64,
    /// How far it got towards rendering.
    pub stage: Stage,
    /// Its steps in the job's timeline.
    pub timeline: NodeTimeline,
}

impl NodeStats {
    /// Counts one accepted line and its counters, and refreshes the eye and secondary columns.
    pub fn add_line(&mut self, c: &Counters) {
        self.scanlines += 1;
        self.counters += *c;
        self.eye_rays = self.counters.eye;
        self.secondary_rays = self.counters.rays() - self.counters.eye;
    }

    /// Takes how its model came, as the worker told it (once fetched, in Preparing; whole,
    /// in its first Request).
    pub fn scene_came(&mut self, f: &super::messages::proto::SceneFetch) {
        (
            self.scene_bytes_received,
            self.scene_cached,
            self.scene_fetch_s,
        ) = (f.bytes_received, f.cached, f.fetch_s);
        self.accel_cached = f.accel_cached;
        (self.scene_mapped, self.scene_ready_s) = (f.scene_mapped, f.scene_ready_s);
    }
}

/// Line accounting of a job.
#[derive(Clone, Debug, Default, Serialize)]
pub struct LineCounts {
    /// Lines in the image (its height).
    pub total: u32,
    /// Taken from the checkpoint of an earlier run.
    pub resumed: u32,
    /// Rendered and accepted in this run (with a target error, passes of lines: a line is
    /// rendered once per pass).
    pub rendered: u32,
    /// Finished (those of the checkpoint included): every line, when the image is done.
    pub finished: u32,
    /// Given back to the queue by failed or silent nodes (and rendered again).
    pub requeued: u64,
    /// Extra copies of straggling lines handed to idle nodes.
    pub duplicated: u64,
    /// Completions dropped because the line was already in.
    pub dropped: u64,
    /// Lines handed back unstarted by workers whose window shrank (and handed out again).
    pub released: u64,
}

/// The controller's own cost: CPU time of the submit process (which, with the embedded
/// default, includes the private remd) and the messages it traded.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ControllerCost {
    /// User + system CPU seconds of the submit process.
    pub cpu_s: f64,
    /// Messages received from workers and REM.
    pub messages_in: u64,
    /// Messages sent to workers.
    pub messages_out: u64,
    /// Per line rendered in this run.
    pub cpu_ms_per_line: f64,
    /// Messages in and out per line rendered in this run.
    pub messages_per_line: f64,
}

/// What `sunray submit --stats-json` writes.
#[derive(Clone, Debug, Default, Serialize)]
pub struct JobStats {
    /// The job id.
    pub job: String,
    /// How lines were handed out; `None` when not known.
    pub strategy: Option<Strategy>,
    /// Workers the job asked for (`--hosts`, or the resumed job's count).
    pub hosts: u32,
    /// How many lines were resumed, rendered, requeued and duplicated.
    pub lines: LineCounts,
    /// Wall time of the whole job in this run.
    pub elapsed_s: f64,
    /// Scene, image and counted totals over every line of the image, as `sunray render`
    /// reports them (load and preprocessing are the controller's).
    pub totals: RenderStats,
    /// The controller's own CPU time and message counts.
    pub controller: ControllerCost,
    /// Bytes of the scene's model the submitting host's remd sent to other hosts when the
    /// job was submitted (0 when they had every chunk: a second job of the same scene).
    pub scene_bytes_sent: u64,
    /// Render threads' time waiting for work over their render time, all nodes (0..1): the
    /// waits that ended with a fresh line. Neither the start-up wait for the first line nor
    /// the tail (waits for duplicates of stragglers, when no fresh line is left) is included.
    pub wait_share: f64,
    /// Render threads' time waiting for duplicates at the tail over their render time.
    pub tail_wait_share: f64,
    /// One entry per worker, in spawn order.
    pub nodes: Vec<NodeStats>,
    /// The job's steps, in seconds since it was submitted (DESIGN section 10).
    pub timeline: Timeline,
}

/// Render threads' time waiting for work, as shares of their render time over all nodes:
/// (waits that ended with a fresh line, waits for duplicates at the tail). See
/// [`JobStats::wait_share`].
pub fn wait_shares(nodes: &[NodeStats]) -> (f64, f64) {
    let busy: f64 = nodes
        .iter()
        .map(|n| n.render_s * f64::from(n.threads))
        .sum();
    let waited: f64 = nodes.iter().map(|n| n.wait_s).sum();
    let tail_waited: f64 = nodes.iter().map(|n| n.tail_wait_s).sum();
    let share = |s: f64| if busy > 0.0 { s / busy } else { 0.0 };
    (share(waited), share(tail_waited))
}

impl JobStats {
    /// What `sunray submit` prints at the end: a heading, the per-node table, the line
    /// accounting and the controller's cost.
    pub fn summary(&self) -> String {
        let strategy = self.strategy.map_or("?", Strategy::name);
        let l = &self.lines;
        let c = &self.controller;
        // Rendered to an error, a line is rendered once per pass.
        let rendered = match &self.totals.error {
            Some(_) => format!("{} line passes rendered", l.rendered),
            None => format!("{} rendered", l.rendered),
        };
        format!(
            "SunRay III job {} ({strategy} strategy, {} worker(s)): {:.2} s\n{}{}\n\
             scene: {:.1} MB sent by the submitting host\n\
             lines: {} ({} from the checkpoint, {rendered}; {} given back, {} handed back unstarted, {} duplicated, {} dropped)\n\
             controller: {:.3} ms CPU and {:.1} messages per line; workers waited {:.2}% of their render time for work ({:.2}% at the tail for copies of stragglers)\n",
            self.job,
            self.hosts,
            self.elapsed_s,
            table(&self.nodes),
            self.timeline.line(),
            self.scene_bytes_sent as f64 / 1e6,
            l.total, l.resumed, l.requeued, l.released, l.duplicated, l.dropped,
            c.cpu_ms_per_line,
            c.messages_per_line,
            self.wait_share * 100.0,
            self.tail_wait_share * 100.0
        )
    }
}

/// `1234567` as `1,234,567`.
pub fn thousands(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::with_capacity(digits.len() + digits.len() / 3);
    for (i, ch) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(ch);
    }
    out
}

/// How a node got the scene's model: `cached` when its host had it, else the megabytes its
/// host fetched from other hosts.
fn scene_column(n: &NodeStats) -> String {
    if n.scene_cached {
        "cached".into()
    } else {
        format!("{:.1} MB", n.scene_bytes_received as f64 / 1e6)
    }
}

/// The per-node table, with a total row.
pub fn table(nodes: &[NodeStats]) -> String {
    let mut s = format!(
        "{:>4}  {:<12} {:>5} {:>6} {:>9} {:>12} {:>12} {:>15} {:>9} {:>9} {:>9} {:>9} {:>9} {:>6}\n",
        "node",
        "host",
        "cores",
        "load",
        "scanlines",
        "eye rays",
        "secondary",
        "intersections",
        "cpu s",
        "elapsed s",
        "preproc s",
        "render s",
        "scene",
        "accel"
    );
    let mut total = NodeStats::default();
    for n in nodes {
        let host = truncate(&n.host, 12);
        if n.outcome == Outcome::Fault {
            let why = n.fault.as_deref().unwrap_or("never started");
            s.push_str(&format!(
                "{:>4}  {:<12} {:>5} {:>6} FAULT ({} line(s) in before: {})\n",
                n.node, host, "-", "-", n.scanlines, why
            ));
        } else if n.scanlines == 0 {
            s.push_str(&format!(
                "{:>4}  {:<12} {:>5} {:>6} rendered nothing: {}\n",
                n.node,
                host,
                n.cores,
                "-",
                n.stage.doing()
            ));
        } else {
            let mark = match n.outcome {
                Outcome::Silent => " (silent)",
                Outcome::Retired => " (retired)",
                _ => "",
            };
            s.push_str(&format!(
                "{:>4}  {:<12} {:>5} {:>6.2} {:>9} {:>12} {:>12} {:>15} {:>9.2} {:>9.2} {:>9.2} {:>9.2} {:>9} {:>6}{}\n",
                n.node,
                host,
                n.cores,
                n.load_at_start,
                n.scanlines,
                thousands(n.eye_rays),
                thousands(n.secondary_rays),
                thousands(n.counters.intersection_tests),
                n.cpu_s,
                n.elapsed_s,
                n.preprocess_s,
                n.render_s,
                scene_column(n),
                if n.accel_cached { "cached" } else { "built" },
                mark
            ));
        }
        total.scanlines += n.scanlines;
        total.eye_rays += n.eye_rays;
        total.secondary_rays += n.secondary_rays;
        total.counters += n.counters;
        total.cpu_s += n.cpu_s;
    }
    s.push_str(&format!(
        "{:>4}  {:<12} {:>5} {:>6} {:>9} {:>12} {:>12} {:>15} {:>9.2}\n",
        "all",
        "",
        "",
        "",
        total.scanlines,
        thousands(total.eye_rays),
        thousands(total.secondary_rays),
        thousands(total.counters.intersection_tests),
        total.cpu_s
    ));
    s
}

fn truncate(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_string()
    } else {
        s.chars().take(n - 1).chain(['~']).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thousands_separators() {
        assert_eq!(thousands(0), "0");
        assert_eq!(thousands(999), "999");
        assert_eq!(thousands(1000), "1,000");
        assert_eq!(thousands(1_336_510), "1,336,510");
    }

    fn node(i: usize, lines: u64) -> NodeStats {
        let mut n = NodeStats {
            node: i,
            host: format!("host{i}"),
            cores: 2,
            load_at_start: 0.5,
            outcome: Outcome::Ok,
            cpu_s: 1.5,
            elapsed_s: 2.0,
            ..Default::default()
        };
        for _ in 0..lines {
            n.add_line(&Counters {
                eye: 100,
                shadow: 30,
                reflected: 20,
                intersection_tests: 1000,
                ..Default::default()
            });
        }
        n
    }

    #[test]
    fn table_has_a_row_per_node_a_fault_row_and_totals() {
        let mut bad = node(2, 3);
        bad.outcome = Outcome::Fault;
        bad.fault = Some("host b lost".into());
        let t = table(&[node(1, 5), bad, node(3, 4)]);
        let rows: Vec<&str> = t.lines().collect();
        assert_eq!(rows.len(), 5, "{t}");
        assert!(rows[0].contains("intersections") && rows[0].contains("preproc s"));
        assert!(
            rows[1].contains("host1") && rows[1].contains("5,000"),
            "{t}"
        );
        assert!(
            rows[2].contains("FAULT") && rows[2].contains("host b lost"),
            "{t}"
        );
        assert!(rows[2].contains("3 line(s)"), "{t}");
        // Totals count every accepted line, the faulty node's included.
        assert!(
            rows[4].starts_with(" all") && rows[4].contains(" 12 "),
            "{t}"
        );
        assert!(rows[4].contains("12,000"), "{t}");
    }

    #[test]
    fn the_bytes_the_submitting_host_sent_are_in_the_summary_and_the_json() {
        let stats = JobStats {
            job: "j".into(),
            scene_bytes_sent: 26_500_000,
            nodes: vec![node(1, 2)],
            ..Default::default()
        };
        assert!(
            stats
                .summary()
                .contains("scene: 26.5 MB sent by the submitting host"),
            "{}",
            stats.summary()
        );
        let v = serde_json::to_value(&stats).unwrap();
        assert_eq!(v["scene_bytes_sent"], 26_500_000);
    }

    #[test]
    fn secondary_rays_are_all_but_eye_rays() {
        let n = node(1, 2);
        assert_eq!((n.eye_rays, n.secondary_rays), (200, 100));
        let v = serde_json::to_value(&n).unwrap();
        for key in [
            "/host",
            "/cores",
            "/load_at_start",
            "/scanlines",
            "/eye_rays",
            "/secondary_rays",
            "/counters/intersection_tests",
            "/cpu_s",
            "/elapsed_s",
            "/preprocess_s",
            "/scene_bytes_received",
            "/scene_cached",
            "/scene_fetch_s",
            "/accel_cached",
            "/scene_mapped",
            "/scene_ready_s",
            "/render_s",
            "/outcome",
        ] {
            assert!(v.pointer(key).is_some(), "{key}");
        }
        assert_eq!(v.pointer("/outcome").unwrap(), "ok");
    }
}
