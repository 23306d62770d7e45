//! The `sunray` command: parses flags and hands over to [`sunray::cli`].

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    if let Err(e) = yari::cpu::check() {
        eprintln!("sunray: error: {e}");
        return ExitCode::FAILURE;
    }
    let args = sunray::cli::Cli::parse();
    match sunray::cli::run(args) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("{}", sunray::cli::error_report(&e));
            ExitCode::from(sunray::cli::exit::code_of(&e))
        }
    }
}
