//! Render statistics, counted (never estimated): per-thread [`Counters`] summed at the end, and
//! the [`RenderStats`] table / JSON.

use serde::Serialize;
use std::ops::AddAssign;

/// Event counts of one thread, one scanline or a whole render.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
pub struct Counters {
    /// Primary rays cast from the camera, one per pixel sample.
    pub eye: u64,
    /// Of `eye`, those that hit a primitive (the rest see the background).
    pub eye_hits: u64,
    /// Shadow rays cast towards point lights from shaded points.
    pub shadow: u64,
    /// Of `shadow`, those cast to lights behind a transmitting surface (Hall's diffuse and
    /// specular transmission terms).
    pub shadow_behind: u64,
    /// Secondary rays cast in the mirror direction (Hall's global reflection term).
    pub reflected: u64,
    /// Secondary rays cast through transmitting surfaces (Hall's global transmission term).
    pub refracted: u64,
    /// Hits on a transmitting closed surface, with depth left, where total internal
    /// reflection left no refracted ray. Haines's "refract rays" counts these too: his
    /// figure is `refracted + total_internal` (docs/renderer.md, "SPD invariants").
    pub total_internal: u64,
    /// Ray / primitive intersection tests performed.
    pub intersection_tests: u64,
    /// Octree voxels (leaves) visited; BVH nodes visited for the BVH.
    pub voxels: u64,
    /// Tests skipped because the mailbox already held the answer for this ray.
    pub mailbox_hits: u64,
    /// Mailbox look-ups.
    pub mailbox_uses: u64,
}

impl AddAssign for Counters {
    fn add_assign(&mut self, o: Counters) {
        self.eye += o.eye;
        self.eye_hits += o.eye_hits;
        self.shadow += o.shadow;
        self.shadow_behind += o.shadow_behind;
        self.reflected += o.reflected;
        self.refracted += o.refracted;
        self.total_internal += o.total_internal;
        self.intersection_tests += o.intersection_tests;
        self.voxels += o.voxels;
        self.mailbox_hits += o.mailbox_hits;
        self.mailbox_uses += o.mailbox_uses;
    }
}

impl Counters {
    /// All rays cast: eye + shadow + reflected + refracted (`shadow_behind` is part of `shadow`).
    pub fn rays(&self) -> u64 {
        self.eye + self.shadow + self.reflected + self.refracted
    }
}

/// The ray counts of [`RenderStats`], under the JSON key `rays`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Rays {
    /// Primary rays cast from the camera.
    pub eye: u64,
    /// Of `eye`, those that hit a primitive.
    pub eye_hits: u64,
    /// Shadow rays cast towards point lights.
    pub shadow: u64,
    /// Of `shadow`, those cast to lights behind a transmitting surface.
    pub shadow_behind: u64,
    /// Reflected secondary rays.
    pub reflected: u64,
    /// Refracted (transmitted) secondary rays.
    pub refracted: u64,
    /// Refracted rays that total internal reflection stopped ([`Counters::total_internal`]).
    pub total_internal: u64,
    /// The sum of eye, shadow, reflected and refracted rays ([`Counters::rays`]).
    pub total: u64,
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
    /// Ray / primitive intersection tests performed.
    pub intersection_tests: u64,
    /// Octree voxels (or BVH nodes) visited.
    pub voxels: u64,
    /// Intersection tests skipped because the mailbox held the answer.
    pub mailbox_hits: u64,
    /// Mailbox look-ups.
    pub mailbox_uses: u64,
    /// Wall-clock and CPU times of the phases.
    pub time: Times,
    /// Worker threads that rendered.
    pub threads: usize,
    /// Total rays divided by `time.render_s` (0 when the render time is 0).
    pub rays_per_s: f64,
}

impl RenderStats {
    /// Copies the summed counters in and derives `rays.total` and `rays_per_s` (set `time.render_s`
    /// first).
    pub fn set_counters(&mut self, c: &Counters) {
        self.rays = Rays {
            eye: c.eye,
            eye_hits: c.eye_hits,
            shadow: c.shadow,
            shadow_behind: c.shadow_behind,
            reflected: c.reflected,
            refracted: c.refracted,
            total_internal: c.total_internal,
            total: c.rays(),
        };
        self.intersection_tests = c.intersection_tests;
        self.voxels = c.voxels;
        self.mailbox_hits = c.mailbox_hits;
        self.mailbox_uses = c.mailbox_uses;
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
        row("eye rays", self.rays.eye.to_string());
        row("eye rays that hit", self.rays.eye_hits.to_string());
        row("shadow rays", self.rays.shadow.to_string());
        row("  to lights behind", self.rays.shadow_behind.to_string());
        row("reflected rays", self.rays.reflected.to_string());
        row("refracted rays", self.rays.refracted.to_string());
        row("  stopped by TIR", self.rays.total_internal.to_string());
        row("total rays", self.rays.total.to_string());
        row("intersection tests", self.intersection_tests.to_string());
        row("voxels visited", self.voxels.to_string());
        row(
            "mailbox hits / uses",
            format!("{} / {}", self.mailbox_hits, self.mailbox_uses),
        );
        row("load time", format!("{:.3} s", self.time.load_s));
        row(
            "preprocessing time",
            format!("{:.3} s", self.time.preprocess_s),
        );
        row("render time", format!("{:.3} s", self.time.render_s));
        row("cpu time", format!("{:.3} s", self.time.cpu_s));
        row("threads", self.threads.to_string());
        row("rays per second", format!("{:.0}", self.rays_per_s));
        s
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
    fn cpu_time_is_measured() {
        let mut x = 0u64;
        for i in 0..5_000_000u64 {
            x = x.wrapping_add(i * i);
        }
        std::hint::black_box(x);
        assert!(process_cpu_seconds() > 0.0);
    }
}
