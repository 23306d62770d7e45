//! `cargo bench -p sunray`: the same figures as `sunray bench throughput`, and Table 4.2.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a measurement tool: a failure ends it with a message

fn main() {
    // `cargo bench` passes `--bench`; a filter argument, if any, picks one table.
    let filter: Option<String> = std::env::args().skip(1).find(|a| !a.starts_with('-'));
    let want = |name: &str| filter.as_deref().is_none_or(|f| name.contains(f));
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    if want("throughput") {
        match sunray::bench::throughput(512, threads) {
            Ok(t) => print!("{t}"),
            Err(e) => eprintln!("throughput: {e}"),
        }
    }
    if want("table42") {
        match sunray::bench::table42(512) {
            Ok(t) => print!("{t}"),
            Err(e) => eprintln!("table42: {e}"),
        }
    }
}
