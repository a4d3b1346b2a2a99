//! What every asynchronous command sets up: the runtime, the logging, and the one shutdown token.

use anyhow::{Context, Result};
use std::future::Future;
use tokio_util::sync::CancellationToken;

/// The multi-thread runtime (zenoh needs it).
fn runtime() -> Result<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")
}

/// Runs `command` to its end on a new runtime. No signal handler is installed: SIGINT and SIGTERM
/// keep their default action (used by `loadgen`, which has nothing to wind down).
pub fn block_on(command: impl Future<Output = Result<()>>) -> Result<()> {
    runtime()?.block_on(command)
}

/// Runs `command` on a new runtime with the process's shutdown token: one token, created here and
/// cancelled by the first SIGINT or SIGTERM, which the command hands down to the service and the
/// tools (they select on it and wind down cleanly).
pub fn block_on_until_signal<F, Fut>(command: F) -> Result<()>
where
    F: FnOnce(CancellationToken) -> Fut,
    Fut: Future<Output = Result<()>>,
{
    runtime()?.block_on(async {
        let shutdown = CancellationToken::new();
        tokio::spawn(cancel_on_signal(shutdown.clone()));
        command(shutdown).await
    })
}

/// Cancels `token` on SIGINT or SIGTERM (SIGINT only where SIGTERM cannot be watched).
async fn cancel_on_signal(token: CancellationToken) {
    let ctrl_c = tokio::signal::ctrl_c();
    #[cfg(unix)]
    {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut term) => {
                tokio::select! {
                    _ = ctrl_c => {},
                    _ = term.recv() => {},
                }
            }
            Err(_) => {
                let _ = ctrl_c.await;
            }
        }
    }
    #[cfg(not(unix))]
    let _ = ctrl_c.await;
    token.cancel();
}

/// Logs to stderr, quiet (warnings only) unless RUST_LOG says otherwise.
pub fn init_logging() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn"));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .try_init();
}
