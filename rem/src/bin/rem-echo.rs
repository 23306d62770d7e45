//! `rem-echo`: a small REM process for tests, benchmarks and trying a cluster out.
//!
//! - `rem-echo echo`: attaches through the environment REM gives it and sends every message
//!   back to its sender, until the relay closes.
//! - `rem-echo sink N`: receives N messages, then answers the sender of the last with "done".
//! - `rem-echo spin SECONDS`: keeps one core busy for that long.
//! - `rem-echo exit CODE`: writes a line to stdout and one to stderr, exits with CODE.
//! - `rem-echo env SECONDS`: prints its environment (`NAME=VALUE` lines, sorted) and its user
//!   id (`uid=N`), then sleeps that long.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use rem::{Incoming, ProcId, RemClient};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("echo") => match echo() {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("rem-echo: {e}");
                ExitCode::FAILURE
            }
        },
        Some("sink") => {
            let n: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(0);
            match sink(n) {
                Ok(()) => ExitCode::SUCCESS,
                Err(e) => {
                    eprintln!("rem-echo: {e}");
                    ExitCode::FAILURE
                }
            }
        }
        Some("env") => {
            let mut vars: Vec<String> = std::env::vars_os()
                .map(|(k, v)| format!("{}={}", k.to_string_lossy(), v.to_string_lossy()))
                .collect();
            vars.sort();
            // SAFETY: getuid has no preconditions.
            vars.push(format!("uid={}", unsafe { libc::getuid() }));
            println!("{}", vars.join("\n"));
            let secs: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(10.0);
            std::thread::sleep(Duration::from_secs_f64(secs));
            ExitCode::SUCCESS
        }
        Some("spin") => {
            let secs: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(10.0);
            let end = Instant::now() + Duration::from_secs_f64(secs);
            let mut x = 0u64;
            while Instant::now() < end {
                for i in 0..100_000u64 {
                    x = x.wrapping_mul(31).wrapping_add(i);
                }
                std::hint::black_box(x);
            }
            ExitCode::SUCCESS
        }
        Some("exit") => {
            let code: u8 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(0);
            println!(
                "rem-echo stdout {}",
                std::env::var("REM_PROC_ID").unwrap_or_default()
            );
            eprintln!("rem-echo stderr");
            ExitCode::from(code)
        }
        _ => {
            eprintln!("usage: rem-echo echo | sink N | spin SECONDS | exit CODE");
            ExitCode::from(2)
        }
    }
}

fn echo() -> anyhow::Result<()> {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()?;
    rt.block_on(async {
        let mut relay = RemClient::attach_from_env().await?;
        println!("attached as {}", relay.id());
        let sender = relay.sender();
        loop {
            match relay.recv().await {
                Ok(Incoming::Message { from, payload }) => {
                    let Some(from) = ProcId::parse(&from) else {
                        continue;
                    };
                    sender.send(&from, payload).await?;
                }
                Ok(_) => {}
                Err(rem::Error::Closed) => return Ok(()),
                Err(e) => return Err(e.into()),
            }
        }
    })
}

fn sink(n: u64) -> anyhow::Result<()> {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()?;
    rt.block_on(async {
        let mut relay = RemClient::attach_from_env().await?;
        let mut seen = 0u64;
        loop {
            if let Incoming::Message { from, .. } = relay.recv().await? {
                seen += 1;
                if seen == n {
                    let from = ProcId::parse(&from).ok_or_else(|| anyhow::anyhow!("bad sender"))?;
                    relay.send(&from, b"done".to_vec()).await?;
                    seen = 0;
                }
            }
        }
    })
}
