//! Progress display: one spinner per stage on stderr, hidden with `--quiet` or when stderr is
//! not a terminal.

use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::time::{Duration, Instant};

/// Progress reporting for a command.
#[derive(Clone, Debug)]
pub struct Progress {
    draw: bool,
    /// Print informational lines on stdout.
    pub verbose_stdout: bool,
}

impl Progress {
    /// Spinners only when stderr is a terminal and not `--quiet`.
    pub fn new(quiet: bool) -> Self {
        Self { draw: !quiet && std::io::stderr().is_terminal(), verbose_stdout: !quiet }
    }

    /// Start a stage; the spinner disappears when the guard is dropped or finished.
    pub fn stage(&self, message: &str) -> Stage {
        let bar = if self.draw {
            let b = ProgressBar::new_spinner();
            b.set_style(
                ProgressStyle::with_template("{spinner} {msg} {elapsed}")
                    .unwrap_or_else(|_| ProgressStyle::default_spinner()),
            );
            b.set_message(message.to_string());
            b.enable_steady_tick(Duration::from_millis(120));
            Some(b)
        } else {
            None
        };
        tracing::info!("{message}");
        Stage { bar, start: Instant::now() }
    }

    /// Print an informational line (unless quiet).
    pub fn say(&self, line: impl AsRef<str>) {
        if self.verbose_stdout {
            println!("{}", line.as_ref());
        }
    }
}

/// A running stage.
pub struct Stage {
    bar: Option<ProgressBar>,
    start: Instant,
}

impl Stage {
    /// Update the message (e.g. an iteration count).
    pub fn set_message(&self, m: impl Into<String>) {
        if let Some(b) = &self.bar {
            b.set_message(m.into());
        }
    }
    /// Seconds since the stage started.
    pub fn seconds(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }
}

impl Drop for Stage {
    fn drop(&mut self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}
