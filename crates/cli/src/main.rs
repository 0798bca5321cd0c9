//! `clothcast`: the command-line front end of the pipeline (see `clothcast --help`).
//!
//! Exit codes: 0 success, 2 bad input or usage (the message names the file, element or key),
//! 1 internal failure. No input file makes clothcast panic; if a bug does, the panic is
//! caught, reported as an internal error, and the exit code is 1.

mod args;
mod commands;
mod config;
mod failure;
mod input;
mod progress;
mod stages;
mod summary;

use clap::Parser;
use std::io::IsTerminal;
use std::process::ExitCode;

fn init_logging(verbose: u8) {
    let level = match verbose {
        0 => "warn",
        1 => "info",
        2 => "debug",
        _ => "trace",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_env("CLOTHCAST_LOG")
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(level));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .with_target(false)
        .try_init();
}

fn main() -> ExitCode {
    let cli = args::Cli::parse();
    init_logging(cli.verbose);
    std::panic::set_hook(Box::new(|info| {
        let msg = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown panic".into());
        let at = info.location().map(|l| format!(" at {}:{}", l.file(), l.line())).unwrap_or_default();
        eprintln!(
            "internal error: {msg}{at}\nThis is a bug in clothcast; please report it with the input that caused it."
        );
    }));
    match std::panic::catch_unwind(|| commands::dispatch(&cli)) {
        Ok(Ok(())) => ExitCode::SUCCESS,
        Ok(Err(f)) => {
            match &f {
                failure::Failure::Input(e) | failure::Failure::Internal(e) => {
                    eprintln!("error: {}", failure::printable(&format!("{e:#}")))
                }
                failure::Failure::Reported(_) => {}
            }
            ExitCode::from(f.exit_code())
        }
        Err(_) => ExitCode::from(1),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn control_characters_are_escaped_in_messages() {
        assert_eq!(crate::failure::printable("a\0b\x1b[31m\nc\td"), "a\\u{0}b\\u{1b}[31m\nc\td");
    }
}
