//! Terminal output: logging, and the progress sink that shows a job's loops as progress bars.

use std::sync::Mutex;

use endoloc_jobs::Progress;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Sets up `tracing` output on stderr; `RUST_LOG` overrides the verbosity flag.
pub fn init_logging(verbose: u8) {
    let default = match verbose {
        0 => "warn",
        1 => "info",
        _ => "debug",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .without_time()
        .try_init();
}

/// Prints a report on stdout. A closed stdout (`endoloc … | head`) is not an error: the job's
/// files are written by then.
pub fn print(report: &dyn std::fmt::Display) -> std::io::Result<()> {
    use std::io::Write as _;
    match writeln!(std::io::stdout().lock(), "{report}") {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => other,
    }
}

/// Progress bars on stderr (hidden when stderr is not a terminal, so that logs and CI output
/// stay clean) and notes as lines on stderr; `quiet` keeps only warnings.
pub struct Terminal {
    bar: Mutex<Option<ProgressBar>>,
    quiet: bool,
}

impl Terminal {
    /// A sink for the terminal.
    pub fn new(quiet: bool) -> Self {
        Terminal {
            bar: Mutex::new(None),
            quiet,
        }
    }

    fn with_bar(&self, f: impl FnOnce(&ProgressBar)) {
        if let Ok(guard) = self.bar.lock()
            && let Some(bar) = guard.as_ref()
        {
            f(bar);
        }
    }
}

impl Progress for Terminal {
    fn start(&self, label: &str, total: u64) {
        if self.quiet {
            return;
        }
        let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
        bar.set_style(
            ProgressStyle::with_template(
                "{msg:>12} [{elapsed_precise}] {wide_bar} {pos}/{len} ({per_sec}, eta {eta})",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar.set_message(label.to_string());
        if let Ok(mut guard) = self.bar.lock()
            && let Some(old) = guard.replace(bar)
        {
            old.finish_and_clear();
        }
    }
    fn inc(&self, n: u64) {
        self.with_bar(|b| b.inc(n));
    }
    fn position(&self, done: u64, total: u64) {
        self.with_bar(|b| {
            b.set_length(total);
            b.set_position(done);
        });
    }
    fn message(&self, msg: &str) {
        self.with_bar(|b| b.set_message(msg.to_string()));
    }
    fn finish(&self) {
        if let Ok(mut guard) = self.bar.lock()
            && let Some(bar) = guard.take()
        {
            bar.finish_and_clear();
        }
    }
    fn note(&self, line: &str) {
        if !self.quiet || line.starts_with("warning") {
            let mut guard = self.bar.lock().ok();
            match guard.as_mut().and_then(|g| g.as_ref()) {
                Some(bar) => bar.suspend(|| eprintln!("{line}")),
                None => eprintln!("{line}"),
            }
        }
    }
}
