//! `remd`: the REM daemon. Parses settings, binds, prints `remd listening on ADDR` (and, with
//! `--web`, `remd web view on http://ADDR/`), runs until
//! SIGTERM or Ctrl-C, then shuts down cleanly (see `rem::daemon::server`).
//!
//! - `args`: the flags (clap), turned into the library's `DaemonOptions`.

use std::io::Write;
use std::process::ExitCode;

mod args;

use args::RemdArgs;
use clap::Parser;
use rem::daemon::config::DaemonSettings;

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info")),
        )
        .with_writer(std::io::stderr)
        .init();
    // Connection caps, not the descriptor limit, should decide what remd refuses.
    if let Err(e) = rem::raise_fd_limit() {
        tracing::warn!(error = %e, "cannot raise the open-file limit");
    }
    let settings = match DaemonSettings::from_options(RemdArgs::parse().into_options()) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("remd: {e}");
            return ExitCode::from(2);
        }
    };
    let runtime = match tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
    {
        Ok(r) => r,
        Err(e) => {
            eprintln!("remd: cannot start the runtime: {e}");
            return ExitCode::FAILURE;
        }
    };
    match runtime.block_on(serve(settings)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("remd: {e:#}");
            ExitCode::FAILURE
        }
    }
}

async fn serve(settings: DaemonSettings) -> anyhow::Result<()> {
    let listener = rem::bind_listener(settings.listen)
        .map_err(|e| anyhow::anyhow!("cannot listen on {}: {e}", settings.listen))?;
    let addr = listener.local_addr()?;
    println!("{}{addr}", rem::wire::LISTENING);
    let web = match settings.web {
        Some(at) => {
            let web = rem::bind_listener(at)
                .map_err(|e| anyhow::anyhow!("cannot serve the web view on {at}: {e}"))?;
            println!("{}http://{}/", rem::wire::WEB_VIEW, web.local_addr()?);
            Some(web)
        }
        None => None,
    };
    std::io::stdout().flush()?;
    let mut term = tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())?;
    let shutdown = async move {
        tokio::select! {
            _ = term.recv() => {}
            _ = tokio::signal::ctrl_c() => {}
        }
    };
    rem::daemon::server::run_with_web(settings, listener, web, shutdown).await?;
    Ok(())
}
