//! SIGINT, SIGTERM and SIGHUP (Ctrl-C, Slurm and Kubernetes pre-emption, a
//! closed terminal): remove what this process created — temporary files
//! and directories, lock files; an old directory moved aside by a swap is
//! emptied of owned files, anything else in it moved back — and then end
//! the process as the signal would have (the parent sees "killed by
//! SIGTERM", which schedulers read as pre-emption, not failure).
//!
//! The handler runs on a thread of its own (signal-hook's iterator), not in
//! signal context, so it may take locks and call the file system. It holds
//! the registry's mutex from the clean-up to the end, so no writer of this
//! process starts another step in between; [`finish`] lets `main` wait for
//! a clean-up in progress instead of exiting under it. A flag set in signal
//! context stops every writer of this process at its next step even before
//! the handler thread has woken, so a signal that lands in the last system
//! call of a write still ends the process by the signal, never with exit 0.

use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
use signal_hook::iterator::Signals;

/// Installs the handler (once, at the start of `main`).
pub fn install() -> std::io::Result<()> {
    for sig in [SIGINT, SIGTERM, SIGHUP] {
        signal_hook::flag::register(sig, std::sync::Arc::clone(&crate::registry::SIGNALLED))?;
    }
    let mut signals = Signals::new([SIGINT, SIGTERM, SIGHUP])?;
    std::thread::Builder::new()
        .name("gibake-signals".into())
        .spawn(move || {
            if let Some(sig) = signals.forever().next() {
                let guard = crate::registry::cleanup_all();
                // Keep the registry locked until the process is gone.
                std::mem::forget(guard);
                let _ = signal_hook::low_level::emulate_default_handler(sig);
                std::process::exit(128 + sig);
            }
        })?;
    Ok(())
}

/// Waits for a clean-up in progress (a signal arrived): call before `main`
/// returns, so the process does not exit while temporaries are removed.
pub fn finish() {
    drop(crate::registry::lock());
}
