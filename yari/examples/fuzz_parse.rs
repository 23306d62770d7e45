//! Fuzz driver: random and mutated YARI inputs through parse, compile and the writers, each
//! inside `catch_unwind`. Counts panics and round-trip mismatches; exits non-zero on any.
//!
//! ```text
//! cargo run --release -p yari --example fuzz_parse -- [INPUTS] [SEED]
//! ```
//!
//! Inputs come from a fixed-seed generator: random bytes, random token strings, generated
//! scenes, and the thesis scenes and generated scenes mutated (bytes flipped, ranges deleted
//! or duplicated, tokens inserted, files spliced). Every input that parses must write back
//! (`write_scene`) to the same syntax tree; every input that compiles must write back
//! (`write_world`) to the same world and survive the model file; a damaged copy of that model
//! file (payload bytes changed, hash fixed) must not panic the decoder. Failing inputs are
//! saved.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a measurement tool: a failure ends it with a message

#[path = "support/scene_gen.rs"]
mod scene_gen;

use scene_gen::Rng;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::process::ExitCode;
use std::time::Instant;
use yari::colour::ColourTable;
use yari::span::Source;

const TOKENS: &[&str] = &[
    "begin",
    "end",
    "(",
    ")",
    ";",
    ",",
    "=",
    " ",
    "\n",
    "/*",
    "*/",
    "sphere",
    "polygon",
    "quadric",
    "attribute",
    "translate",
    "scale",
    "rotate",
    "motion",
    "transform",
    "camera",
    "light",
    "resolution",
    "background",
    "ambient",
    "samples",
    "color",
    "center",
    "radius",
    "vertices",
    "normals",
    "position",
    "at",
    "up",
    "angle",
    "aperture",
    "focus",
    "kdr",
    "kdt",
    "ka",
    "phong",
    "refract",
    "texture",
    "texture_space",
    "gloss",
    "translucency",
    "transmissivity",
    "clip",
    "plane",
    "red",
    "UNC_Blue",
    "0",
    "1",
    "-1",
    ".5",
    "-.816497",
    "1e-3",
    "1e308",
    "1e309",
    "-0",
    "3",
    "4",
    "90",
    "1e-320",
    "é",
    "\t",
    "#",
    "@",
    "e5",
    "..",
    "+",
    "-",
];

fn main() -> ExitCode {
    let mut args = std::env::args().skip(1);
    let inputs: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(100_000);
    let seed: u64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(1);
    let mut rng = Rng(seed);
    let dir = format!("{}/../examples/thesis", env!("CARGO_MANIFEST_DIR"));
    let mut seeds: Vec<String> = ["tetra16.yari", "cubes.yari"]
        .iter()
        .filter_map(|n| std::fs::read_to_string(format!("{dir}/{n}")).ok())
        .collect();
    if seeds.len() < 2 {
        eprintln!("warning: thesis scenes not found under {dir}; using generated seeds only");
    }
    // A scene of smooth polygons (vertex normals).
    let smooth = format!("{dir}/../smooth/terminator.yari");
    seeds.extend(std::fs::read_to_string(smooth).ok());
    for _ in 0..64 {
        seeds.push(scene_gen::small_scene(&mut rng));
    }
    let colours = ColourTable::builtin();
    std::panic::set_hook(Box::new(|_| {}));
    let out_dir = std::env::temp_dir().join(format!("yari-fuzz-{seed}"));
    let (mut panics, mut mismatches, mut saved) = (0usize, 0usize, 0usize);
    let mut stages = [0usize; 3];
    let mut bytes_total = 0usize;
    let start = Instant::now();
    for i in 0..inputs {
        let input = make_input(&mut rng, &seeds);
        bytes_total += input.len();
        let text = String::from_utf8_lossy(&input).into_owned();
        let result = catch_unwind(AssertUnwindSafe(|| check(&text, &colours)));
        let failure = match result {
            Ok(Ok(stage)) => {
                stages[stage] += 1;
                None
            }
            Ok(Err(why)) => {
                mismatches += 1;
                Some(why)
            }
            Err(_) => {
                panics += 1;
                Some("panic".to_string())
            }
        };
        if let Some(why) = failure {
            if saved < 20 {
                let _ = std::fs::create_dir_all(&out_dir);
                let path = out_dir.join(format!("case-{i}.yari"));
                let _ = std::fs::write(&path, &input);
                eprintln!("input {i}: {why} (saved to {})", path.display());
                saved += 1;
            }
        }
    }
    let secs = start.elapsed().as_secs_f64();
    println!(
        "{inputs} inputs ({:.1} MB) in {secs:.1} s: {} parse errors, {} compile errors, {} compiled; {panics} panics, {mismatches} round-trip mismatches",
        bytes_total as f64 / 1e6,
        stages[0],
        stages[1],
        stages[2]
    );
    if panics + mismatches > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}

/// One input through everything: 0 = parse error, 1 = compile error, 2 = compiled.
/// `Err` is a round-trip mismatch.
fn check(text: &str, colours: &ColourTable) -> Result<usize, String> {
    let src = Source::new("fuzz.yari", text);
    let mut scene = match yari::parse::parse(&src) {
        Ok(s) => s,
        Err(d) => {
            let _ = d.render(&src);
            return Ok(0);
        }
    };
    let written = yari::writer::write_scene(&scene);
    let mut again = yari::parse::parse(&Source::new("w.yari", written.as_str())).map_err(|d| {
        format!(
            "write_scene output does not parse: {}",
            d.render(&Source::new("w.yari", written.as_str()))
        )
    })?;
    let compiled = yari::compile::compile(&scene, colours);
    yari::writer::erase_spans(&mut scene);
    yari::writer::erase_spans(&mut again);
    if again != scene {
        return Err("parse(write_scene(ast)) differs from ast".into());
    }
    let compiled = match compiled {
        Ok(c) => c,
        Err(d) => {
            let _ = d.render(&src);
            return Ok(1);
        }
    };
    let world = compiled.world;
    yari::modelfile::validate(&world).map_err(|e| format!("compiled world is invalid: {e}"))?;
    let flat = yari::writer::write_world(&world);
    let flat_src = Source::new("flat.yari", flat.as_str());
    let back = yari::parse::parse(&flat_src)
        .map_err(|d| format!("write_world output does not parse: {}", d.render(&flat_src)))?;
    let back = yari::compile::compile(&back, colours).map_err(|d| {
        format!(
            "write_world output does not compile: {}",
            d.render(&flat_src)
        )
    })?;
    if back.world != world {
        return Err("compile(parse(write_world(w))) differs from w".into());
    }
    let bytes = yari::modelfile::to_bytes(&world).map_err(|e| e.to_string())?;
    if yari::modelfile::from_bytes(&bytes).map_err(|e| e.to_string())? != world {
        return Err("model file round trip differs".into());
    }
    damaged_model(bytes, text.len() as u64);
    Ok(2)
}

/// Damages a model file's payload but fixes its hash, so the decoder itself meets the bad
/// bytes: it must fail or succeed, never panic.
fn damaged_model(mut bytes: Vec<u8>, seed: u64) {
    const HEADER: usize = 28;
    if bytes.len() <= HEADER {
        return;
    }
    let mut rng = Rng(seed);
    for _ in 0..1 + rng.below(4) {
        let i = HEADER + rng.below(bytes.len() - HEADER);
        bytes[i] = (rng.next_u64() & 0xff) as u8;
    }
    if rng.chance(0.3) {
        let keep = HEADER + rng.below(bytes.len() - HEADER);
        bytes.truncate(keep);
        let len = (keep - HEADER) as u64;
        bytes[12..20].copy_from_slice(&len.to_le_bytes());
    }
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in &bytes[HEADER..] {
        h ^= u64::from(*b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    bytes[20..28].copy_from_slice(&h.to_le_bytes());
    let _ = yari::modelfile::from_bytes(&bytes);
}

fn make_input(rng: &mut Rng, seeds: &[String]) -> Vec<u8> {
    match rng.below(8) {
        0 => {
            const ALPHABET: &[u8] = b"beginendsphrola()=;,.-+0123456789eE /*\n\t_UNCxyz#\xff";
            (0..rng.below(200))
                .map(|_| ALPHABET[rng.below(ALPHABET.len())])
                .collect()
        }
        1 => {
            let mut s = String::new();
            for _ in 0..rng.below(80) {
                s.push_str(TOKENS[rng.below(TOKENS.len())]);
                if rng.chance(0.5) {
                    s.push(' ');
                }
            }
            s.into_bytes()
        }
        2 => scene_gen::small_scene(rng).into_bytes(),
        3 => {
            let a = seeds[rng.below(seeds.len())].as_bytes();
            let b = seeds[rng.below(seeds.len())].as_bytes();
            let (i, j) = (rng.below(a.len() + 1), rng.below(b.len() + 1));
            let mut v = a[..i].to_vec();
            v.extend_from_slice(&b[j..]);
            v
        }
        _ => {
            let mut v = seeds[rng.below(seeds.len())].as_bytes().to_vec();
            for _ in 0..1 + rng.below(4) {
                mutate(rng, &mut v);
            }
            v
        }
    }
}

fn mutate(rng: &mut Rng, v: &mut Vec<u8>) {
    let n = v.len();
    if n == 0 {
        v.extend_from_slice(TOKENS[rng.below(TOKENS.len())].as_bytes());
        return;
    }
    let i = rng.below(n);
    match rng.below(6) {
        0 => v[i] = (rng.next_u64() & 0xff) as u8,
        1 => {
            let j = (i + 1 + rng.below(32)).min(n);
            v.drain(i..j);
        }
        2 => {
            let t = TOKENS[rng.below(TOKENS.len())].as_bytes();
            v.splice(i..i, t.iter().copied());
        }
        3 => {
            let j = (i + 1 + rng.below(64)).min(n);
            let chunk = v[i..j].to_vec();
            v.splice(j..j, chunk);
        }
        4 => v.truncate(i),
        _ => {
            // Replace a digit run with another number.
            if v[i].is_ascii_digit() {
                let nums = ["0", "1e308", "-1e-308", "90", "1e30", "7", "-.0"];
                let s = nums[rng.below(nums.len())].as_bytes();
                v.splice(i..i + 1, s.iter().copied());
            } else {
                v.swap(i, rng.below(n));
            }
        }
    }
}
