//! Random YARI scene text for the parse benchmark and the fuzz driver: a fixed-seed
//! generator (splitmix64), so every run sees the same inputs.

#![allow(dead_code)]

use std::fmt::Write;

/// splitmix64: small, fast, and the same on every machine.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in `0..n` (n > 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
    }
    pub fn chance(&mut self, p: f64) -> bool {
        self.range(0.0, 1.0) < p
    }
}

/// The preamble of a generated scene.
pub fn preamble(out: &mut String, samples: u32) {
    out.push_str("/* generated */\nresolution(512, 512);\nbackground(color = UNC_Blue);\nambient(color = 0.1,0.1,0.1);\n");
    out.push_str("camera(position = 0,-60,25; at = 0,0,0; up = 0,0,1; angle = 30);\n");
    out.push_str("light(position = 30,-40,60; color = white);\nlight(position = -30,-40,60; color = 0.5,0.5,0.5);\n");
    if samples > 1 {
        let _ = writeln!(out, "samples({samples});");
    }
}

/// A large scene for the benchmark: `primitives` triangles and spheres (about 3 to 1) in
/// blocks of 100 with their own attribute and transformation.
pub fn big_scene(rng: &mut Rng, primitives: usize) -> String {
    let mut out = String::with_capacity(primitives * 80);
    preamble(&mut out, 1);
    out.push_str("begin\n");
    for i in 0..primitives {
        if i % 100 == 0 {
            if i > 0 {
                out.push_str("end\n");
            }
            let _ = writeln!(
                out,
                "begin\n  attribute(color = {:.3},{:.3},{:.3}; kdr = {:.2}; phong = 20);\n  rotate(0, 0, {:.1}); translate({:.2}, {:.2}, 0);",
                rng.range(0.0, 1.0),
                rng.range(0.0, 1.0),
                rng.range(0.0, 1.0),
                rng.range(0.3, 1.0),
                rng.range(0.0, 360.0),
                rng.range(-50.0, 50.0),
                rng.range(-50.0, 50.0)
            );
        }
        let (x, y, z) = (
            rng.range(-10.0, 10.0),
            rng.range(-10.0, 10.0),
            rng.range(0.0, 10.0),
        );
        if i % 4 == 3 {
            let _ = writeln!(
                out,
                "  sphere(center = {x:.4},{y:.4},{z:.4}; radius = {:.4});",
                rng.range(0.05, 0.5)
            );
        } else {
            let _ = writeln!(
                out,
                "  polygon(vertices = 3; {x:.4},{y:.4},{z:.4}  {:.4},{:.4},{z:.4}  {x:.4},{:.4},{:.4});",
                x + rng.range(0.1, 1.0),
                y,
                y + rng.range(0.1, 1.0),
                z + rng.range(0.0, 0.5)
            );
        }
    }
    if primitives > 0 {
        out.push_str("end\n");
    }
    out.push_str("end\n");
    out
}

/// A number written in one of the forms YARI allows.
fn number(rng: &mut Rng, out: &mut String) {
    let v = match rng.below(10) {
        0 => 0.0,
        1 => 1.0,
        2 => -1.0,
        3 => rng.range(-1.0, 1.0),
        4 => rng.range(-1e3, 1e3),
        5 => rng.range(0.0, 90.0),
        6 => (rng.below(5) as f64) - 2.0,
        7 => rng.range(-1.0, 1.0) * 10f64.powi(rng.below(40) as i32 - 20),
        8 => rng.range(0.0, 1.0),
        _ => rng.range(-10.0, 10.0),
    };
    let _ = match rng.below(4) {
        0 => write!(out, "{v}"),
        1 => write!(out, "{v:e}"),
        2 => write!(out, "{v:.3}"),
        _ => {
            let s = format!("{v:.4}");
            out.push_str(&s.replacen("0.", ".", 1));
            Ok(())
        }
    };
}

fn vector(rng: &mut Rng, out: &mut String) {
    for i in 0..3 {
        if i > 0 {
            out.push_str(if rng.chance(0.5) { "," } else { " " });
        }
        number(rng, out);
    }
}

fn numbers(rng: &mut Rng, out: &mut String, n: usize) {
    for i in 0..n {
        if i > 0 {
            out.push(' ');
        }
        number(rng, out);
    }
}

const COLOURS: &[&str] = &["white", "red", "UNC_Blue", "purple", "grey", "nosuch"];

fn colour(rng: &mut Rng, out: &mut String) {
    if rng.chance(0.3) {
        out.push_str(COLOURS[rng.below(COLOURS.len())]);
    } else {
        vector(rng, out);
    }
}

/// A small scene using every statement, with random (sometimes invalid) values.
pub fn small_scene(rng: &mut Rng) -> String {
    let mut out = String::new();
    for _ in 0..rng.below(6) {
        match rng.below(7) {
            0 => out.push_str(&format!(
                "resolution({}, {});\n",
                1 + rng.below(600),
                1 + rng.below(600)
            )),
            1 => out.push_str(&format!("samples({});\n", rng.below(20))),
            2 => {
                out.push_str("background(color = ");
                colour(rng, &mut out);
                out.push_str(");\n");
            }
            3 => {
                out.push_str("ambient(color = ");
                colour(rng, &mut out);
                out.push_str(");\n");
            }
            4 | 5 => {
                out.push_str("light(position = ");
                vector(rng, &mut out);
                out.push_str("; color = ");
                colour(rng, &mut out);
                if rng.chance(0.3) {
                    out.push_str("; radius = ");
                    number(rng, &mut out);
                }
                out.push_str(");\n");
            }
            _ => {
                for (i, f) in ["position", "at", "up"].iter().enumerate() {
                    out.push_str(if i == 0 { "camera(" } else { "; " });
                    out.push_str(f);
                    out.push_str(" = ");
                    vector(rng, &mut out);
                }
                out.push_str("; angle = ");
                number(rng, &mut out);
                if rng.chance(0.2) {
                    out.push_str("; aperture = ");
                    number(rng, &mut out);
                    out.push_str("; focus = ");
                    number(rng, &mut out);
                }
                out.push_str(");\n");
            }
        }
    }
    body(rng, &mut out, 0);
    out
}

fn body(rng: &mut Rng, out: &mut String, depth: usize) {
    out.push_str("begin\n");
    for _ in 0..rng.below(8) {
        match rng.below(12) {
            0 if depth < 4 => body(rng, out, depth + 1),
            1 => {
                out.push_str("attribute(color = ");
                colour(rng, out);
                for f in [
                    "kdr",
                    "kdt",
                    "ka",
                    "phong",
                    "refract",
                    "gloss",
                    "translucency",
                    "transmissivity",
                ] {
                    if rng.chance(0.3) {
                        out.push_str("; ");
                        out.push_str(f);
                        out.push_str(" = ");
                        number(rng, out);
                    }
                }
                if rng.chance(0.3) {
                    out.push_str(&format!("; texture = {} ", rng.below(7)));
                    vector(rng, out);
                    out.push(' ');
                    vector(rng, out);
                }
                out.push_str(");\n");
            }
            2 | 3 => {
                out.push_str("sphere(center = ");
                vector(rng, out);
                out.push_str("; radius = ");
                number(rng, out);
                out.push_str(");\n");
            }
            4 | 5 => {
                let n = rng.below(6);
                out.push_str(&format!("polygon(vertices = {n};"));
                for _ in 0..n {
                    out.push_str("  ");
                    vector(rng, out);
                }
                out.push_str(");\n");
            }
            6 => {
                out.push_str("quadric(");
                numbers(rng, out, 10);
                if rng.chance(0.5) {
                    out.push_str("; clip = -1,-1,-1 1,1,1");
                }
                if rng.chance(0.3) {
                    out.push_str("; plane = ");
                    vector(rng, out);
                    out.push(' ');
                    number(rng, out);
                }
                out.push_str(");\n");
            }
            7 => {
                out.push_str("transform(");
                numbers(rng, out, 12);
                out.push_str(");\n");
            }
            _ => {
                let t = ["translate", "scale", "rotate", "motion"][rng.below(4)];
                out.push_str(t);
                out.push('(');
                vector(rng, out);
                out.push_str(");\n");
            }
        }
    }
    out.push_str("end\n");
}
