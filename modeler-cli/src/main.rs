//! `modeler`: see the library docs and docs/modeler.md.

use clap::Parser;
use modeler::cli::{commands::Cli, run};
use std::process::ExitCode;

fn main() -> ExitCode {
    if let Err(e) = yari::cpu::check() {
        eprintln!("modeler: error: {e}");
        return ExitCode::FAILURE;
    }
    let cli = Cli::parse();
    let mut stdout = std::io::stdout().lock();
    match run(cli, &mut stdout) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("modeler: error: {e}");
            ExitCode::FAILURE
        }
    }
}
