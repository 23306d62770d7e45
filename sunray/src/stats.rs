//! Render statistics, counted (never estimated): per-thread [`Counters`] summed at the end, and
//! the [`RenderStats`] table / JSON.
//!
//! Every counter is named once, in [`with_counters!`]: the [`Counters`] fields, their sum,
//! the statistics' [`Rays`] and [`Work`], the table's rows and the conversion to and from
//! the wire's `Counters` message (`distrib::messages`) come from that list. Adding a counter
//! is a line there and a field in `proto/sunray.proto`.

use serde::Serialize;
use std::ops::AddAssign;

/// Calls `$then!` with every counter, in the order of the JSON keys and the table's rows:
/// the ray counts (`rays` in the statistics) and the work counts (at their top level), each
/// as `name: "row label"` with its doc; an empty label continues the row before (`hits /
/// uses`).
macro_rules! with_counters {
    ($then:ident) => {
        $then! {
            rays {
                /// Primary rays cast from the camera, one per pixel sample.
                eye: "eye rays",
                /// Of `eye`, those that hit a primitive (the rest see the background).
                eye_hits: "eye rays that hit",
                /// Shadow rays cast towards point lights from shaded points.
                shadow: "shadow rays",
                /// Of `shadow`, those cast to lights behind a transmitting surface (Hall's
                /// diffuse and specular transmission terms).
                shadow_behind: "  to lights behind",
                /// Secondary rays cast in the mirror direction (Hall's global reflection term).
                reflected: "reflected rays",
                /// Secondary rays cast through transmitting surfaces (Hall's global
                /// transmission term).
                refracted: "refracted rays",
                /// Hits on a transmitting closed surface, with depth left, where total
                /// internal reflection left no refracted ray. Haines's "refract rays" counts
                /// these too: his figure is `refracted + total_internal` (docs/renderer.md,
                /// "SPD invariants").
                total_internal: "  stopped by TIR",
            }
            work {
                /// Ray / primitive intersection tests performed.
                intersection_tests: "intersection tests",
                /// Octree voxels (leaves) visited; BVH nodes visited for the BVH.
                voxels: "voxels visited",
                /// Tests skipped because the mailbox already held the answer for this ray.
                mailbox_hits: "mailbox hits / uses",
                /// Mailbox look-ups.
                mailbox_uses: "",
            }
        }
    };
}
pub(crate) use with_counters;

/// The counters' types, from [`with_counters!`].
macro_rules! define_counters {
    (
        rays { $($(#[$rdoc:meta])* $ray:ident: $rlabel:literal,)* }
        work { $($(#[$wdoc:meta])* $work:ident: $wlabel:literal,)* }
    ) => {
        /// Event counts of one thread, one scanline or a whole render.
        #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
        pub struct Counters {
            $($(#[$rdoc])* pub $ray: u64,)*
            $($(#[$wdoc])* pub $work: u64,)*
        }

        impl AddAssign for Counters {
            fn add_assign(&mut self, o: Counters) {
                $(self.$ray += o.$ray;)*
                $(self.$work += o.$work;)*
            }
        }

        /// The ray counts of [`RenderStats`], under the JSON key `rays`.
        #[derive(Clone, Debug, Default, Serialize)]
        pub struct Rays {
            $($(#[$rdoc])* pub $ray: u64,)*
            /// The sum of eye, shadow, reflected and refracted rays ([`Counters::rays`]).
            pub total: u64,
        }

        /// The work counts of [`RenderStats`], at the JSON's top level.
        #[derive(Clone, Debug, Default, Serialize)]
        pub struct Work {
            $($(#[$wdoc])* pub $work: u64,)*
        }

        impl Rays {
            fn of(c: &Counters) -> Rays {
                Rays {
                    $($ray: c.$ray,)*
                    total: c.rays(),
                }
            }

            /// The table's rows, label and count.
            fn rows(&self) -> Vec<(&'static str, u64)> {
                vec![$(($rlabel, self.$ray),)*]
            }
        }

        impl Work {
            fn of(c: &Counters) -> Work {
                Work { $($work: c.$work,)* }
            }

            /// The table's rows, label and count.
            fn rows(&self) -> Vec<(&'static str, u64)> {
                vec![$(($wlabel, self.$work),)*]
            }
        }
    };
}
with_counters!(define_counters);

impl Counters {
    /// All rays cast: eye + shadow + reflected + refracted (`shadow_behind` is part of `shadow`).
    pub fn rays(&self) -> u64 {
        self.eye + self.shadow + self.reflected + self.refracted
    }
}

/// Wall-clock phases of a render in seconds, under the JSON key `time`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Times {
    /// Reading and compiling the scene file, in seconds.
    pub load_s: f64,
    /// Building the accelerator (octree or BVH), in seconds.
    pub preprocess_s: f64,
    /// Tracing every pixel, in seconds (wall clock).
    pub render_s: f64,
    /// User + system CPU time of the process during preprocessing and rendering.
    pub cpu_s: f64,
}

/// What `--stats-json` writes.
#[derive(Clone, Debug, Default, Serialize)]
pub struct RenderStats {
    /// The scene's file name (or the built-in scene's name).
    pub scene: String,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Samples per pixel.
    pub samples: u32,
    /// What the samples drew from: `stratified` or `sobol` (`sobol` with a target error).
    pub sampler: String,
    /// The accelerator built, `auto` resolved: `exhaustive`, `octree` or `bvh`.
    pub accel: String,
    /// Whether the mailbox (skip repeated tests of one ray against one primitive) was on.
    pub mailbox: bool,
    /// Scene objects before they are split into primitives.
    pub objects: usize,
    /// Primitives the accelerator indexes (bounded and unbounded).
    pub primitives: usize,
    /// Of `primitives`, those without a bounding box (quadrics their clip does not bound),
    /// tested against every ray.
    pub unbounded: usize,
    /// Cells of the accelerator: octree voxels (every node) or BVH nodes.
    pub accel_nodes: usize,
    /// Ray counts by kind.
    pub rays: Rays,
    /// Intersection tests, voxels visited and the mailbox's hits and uses.
    #[serde(flatten)]
    pub work: Work,
    /// Wall-clock and CPU times of the phases.
    pub time: Times,
    /// Worker threads that rendered.
    pub threads: usize,
    /// Total rays divided by `time.render_s` (0 when the render time is 0).
    pub rays_per_s: f64,
    /// With a target error (`--target-error`), what the pixels reached and took.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<ErrorStats>,
}

/// What a render to a target error reached: the estimated errors of the pixels' means
/// (linear radiance, each pixel's worst channel) and the samples they took.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ErrorStats {
    /// The target asked for.
    pub target: f64,
    /// The root mean square of the pixels' estimated errors.
    pub rms: f64,
    /// The largest estimated error of a pixel (above the target only where a pixel stopped
    /// at the most samples allowed).
    pub max: f64,
    /// Pixels that stopped at the most samples allowed, their error still above the target.
    pub at_max_samples: u64,
    /// Samples per pixel, on average.
    pub mean_samples: f64,
    /// How many pixels took how many samples: from `from` to `to` inclusive, powers of two.
    pub histogram: Vec<SamplesBucket>,
}

/// Pixels whose sample count lies in `from..=to`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct SamplesBucket {
    /// The fewest samples of the bucket.
    pub from: u32,
    /// The most.
    pub to: u32,
    /// Pixels in it.
    pub pixels: u64,
}

impl RenderStats {
    /// Copies the summed counters in and derives `rays.total` and `rays_per_s` (set `time.render_s`
    /// first).
    pub fn set_counters(&mut self, c: &Counters) {
        self.rays = Rays::of(c);
        self.work = Work::of(c);
        self.rays_per_s = if self.time.render_s > 0.0 {
            c.rays() as f64 / self.time.render_s
        } else {
            0.0
        };
    }

    /// A plain two-column table for the terminal.
    pub fn table(&self) -> String {
        let mut s = String::new();
        let mut row = |k: &str, v: String| s.push_str(&format!("{k:<22} {v:>16}\n"));
        row("scene", self.scene.clone());
        row(
            "image",
            format!("{}x{} x{}", self.width, self.height, self.samples),
        );
        row(
            "accelerator",
            format!(
                "{} (mailbox {})",
                self.accel,
                if self.mailbox { "on" } else { "off" }
            ),
        );
        row(
            "objects / primitives",
            format!("{} / {}", self.objects, self.primitives),
        );
        row("accelerator cells", self.accel_nodes.to_string());
        counter_rows(&mut row, self.rays.rows());
        row("total rays", self.rays.total.to_string());
        counter_rows(&mut row, self.work.rows());
        row("load time", format!("{:.3} s", self.time.load_s));
        row(
            "preprocessing time",
            format!("{:.3} s", self.time.preprocess_s),
        );
        row("render time", format!("{:.3} s", self.time.render_s));
        row("cpu time", format!("{:.3} s", self.time.cpu_s));
        row("threads", self.threads.to_string());
        row("rays per second", format!("{:.0}", self.rays_per_s));
        if let Some(e) = &self.error {
            row("target error", format!("{}", e.target));
            row("estimated error rms", format!("{:.5}", e.rms));
            row("  max", format!("{:.5}", e.max));
            row("samples per pixel", format!("{:.1}", e.mean_samples));
        }
        s
    }
}

/// Writes counters' `rows` with `row`; a row with an empty label continues the one before it
/// (`hits / uses`).
fn counter_rows(row: &mut impl FnMut(&str, String), rows: Vec<(&'static str, u64)>) {
    let mut pending: Option<(&str, String)> = None;
    for (label, n) in rows {
        match &mut pending {
            Some((_, value)) if label.is_empty() => value.push_str(&format!(" / {n}")),
            _ => {
                if let Some((l, v)) = pending.take() {
                    row(l, v);
                }
                pending = Some((label, n.to_string()));
            }
        }
    }
    if let Some((l, v)) = pending {
        row(l, v);
    }
}

/// User + system CPU time of this process so far, in seconds (getrusage).
pub fn process_cpu_seconds() -> f64 {
    // SAFETY: getrusage writes into the zeroed struct we pass; RUSAGE_SELF is always valid.
    let mut u: libc::rusage = unsafe { std::mem::zeroed() };
    let rc = unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut u) };
    if rc != 0 {
        return 0.0;
    }
    let tv = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    tv(u.ru_utime) + tv(u.ru_stime)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counters_sum_field_by_field() {
        let mut a = Counters {
            eye: 1,
            shadow: 2,
            intersection_tests: 3,
            ..Default::default()
        };
        a += Counters {
            eye: 10,
            reflected: 5,
            intersection_tests: 1,
            ..Default::default()
        };
        assert_eq!(
            (a.eye, a.shadow, a.reflected, a.intersection_tests),
            (11, 2, 5, 4)
        );
        assert_eq!(a.rays(), 18);
    }

    #[test]
    fn json_has_the_documented_keys() {
        let mut s = RenderStats::default();
        s.set_counters(&Counters {
            eye: 4,
            eye_hits: 2,
            ..Default::default()
        });
        let v = serde_json::to_value(&s).unwrap();
        for path in [
            "/rays/eye",
            "/rays/eye_hits",
            "/rays/shadow",
            "/rays/reflected",
            "/rays/refracted",
            "/rays/total_internal",
            "/intersection_tests",
            "/voxels",
            "/mailbox_hits",
            "/time/preprocess_s",
            "/time/render_s",
            "/time/cpu_s",
            "/threads",
        ] {
            assert!(v.pointer(path).is_some(), "{path}");
        }
        assert_eq!(v.pointer("/rays/eye_hits").unwrap(), 2);
    }

    #[test]
    fn every_counter_keeps_its_row_and_its_key() {
        let mut s = RenderStats::default();
        s.set_counters(&Counters {
            eye: 1,
            eye_hits: 2,
            shadow: 3,
            shadow_behind: 4,
            reflected: 5,
            refracted: 6,
            total_internal: 7,
            intersection_tests: 8,
            voxels: 9,
            mailbox_hits: 10,
            mailbox_uses: 11,
        });
        let rows: Vec<String> = [
            ("eye rays", "1"),
            ("eye rays that hit", "2"),
            ("shadow rays", "3"),
            ("  to lights behind", "4"),
            ("reflected rays", "5"),
            ("refracted rays", "6"),
            ("  stopped by TIR", "7"),
            ("total rays", "15"),
            ("intersection tests", "8"),
            ("voxels visited", "9"),
            ("mailbox hits / uses", "10 / 11"),
        ]
        .iter()
        .map(|(k, v)| format!("{k:<22} {v:>16}"))
        .collect();
        let table = s.table();
        let shown: Vec<&str> = table.lines().skip(5).take(rows.len()).collect();
        assert_eq!(shown, rows);
        assert!(table
            .lines()
            .nth(5 + rows.len())
            .unwrap()
            .starts_with("load time"));
        let json = serde_json::to_string(&s).unwrap();
        let keys = r#""rays":{"eye":1,"eye_hits":2,"shadow":3,"shadow_behind":4,"reflected":5,"refracted":6,"total_internal":7,"total":15},"intersection_tests":8,"voxels":9,"mailbox_hits":10,"mailbox_uses":11,"time":{"#;
        assert!(json.contains(keys), "{json}");
    }

    #[test]
    fn cpu_time_is_measured() {
        let mut x = 0u64;
        for i in 0..5_000_000u64 {
            x = x.wrapping_add(i * i);
        }
        std::hint::black_box(x);
        assert!(process_cpu_seconds() > 0.0);
    }
}
