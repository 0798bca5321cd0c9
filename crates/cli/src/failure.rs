//! How a command fails: the exit code depends on whose fault it is.
//!
//! - [`Failure::Input`]: bad input or usage (a mesh file, a config key, a value): exit 2.
//! - [`Failure::Internal`]: the machine failed (a solver did not converge, a disk write failed):
//!   exit 1.
//! - [`Failure::Reported`]: the command already printed its verdict (e.g. `check` on an
//!   unusable mesh); exit with the given code and print nothing more.

/// A failed command.
#[derive(Debug)]
pub enum Failure {
    /// The user's input is at fault (exit 2).
    Input(anyhow::Error),
    /// Something failed inside clothcast or the machine (exit 1).
    Internal(anyhow::Error),
    /// Already reported; exit with this code.
    Reported(u8),
}

impl Failure {
    /// Process exit code.
    pub fn exit_code(&self) -> u8 {
        match self {
            Failure::Input(_) => 2,
            Failure::Internal(_) => 1,
            Failure::Reported(c) => *c,
        }
    }
}

/// Attach a fault class (and optional context) to a `Result`.
pub trait Blame<T> {
    /// The error is the user's input.
    fn input(self) -> Result<T, Failure>;
    /// The error is internal.
    fn internal(self) -> Result<T, Failure>;
}

impl<T, E: Into<anyhow::Error>> Blame<T> for Result<T, E> {
    fn input(self) -> Result<T, Failure> {
        self.map_err(|e| Failure::Input(e.into()))
    }
    fn internal(self) -> Result<T, Failure> {
        self.map_err(|e| Failure::Internal(e.into()))
    }
}

/// A message with its control characters (other than line breaks and tabs) escaped: a path or
/// value quoted from the input may hold a NUL or an escape sequence the terminal should not get.
pub fn printable(message: &str) -> String {
    message
        .chars()
        .map(|c| if c.is_control() && c != '\n' && c != '\t' { c.escape_default().to_string() } else { c.to_string() })
        .collect()
}

#[cfg(test)]
mod tests {
    use clothcast_mesh::MeshError;
    use clothcast_mesh::sparse::SolveError;

    fn inner() -> SolveError {
        SolveError::Internal("INNER".into())
    }

    /// An error that wraps another is printed (as `main` does: with its chain, `{:#}`) with
    /// the inner one's message once: an error whose message already holds the inner one
    /// does not give it as its source too.
    #[test]
    fn a_wrapped_error_is_printed_once() {
        let io = || std::io::Error::other("INNER");
        let newton = clothcast_sim::newton::NewtonError { error: inner(), stats: Box::default() };
        let cases: Vec<anyhow::Error> = vec![
            clothcast_sim::SimError::Solver(newton).into(),
            clothcast_field::FieldError::Solver(inner()).into(),
            clothcast_flatten::FlattenError::Solver(inner()).into(),
            clothcast_flatten::FlattenError::Patch {
                patch: 3,
                error: Box::new(clothcast_flatten::FlattenError::Solver(inner())),
            }
            .into(),
            clothcast_layout::LayoutError::Solver(inner()).into(),
            clothcast_layout::LayoutError::Remesh(MeshError::Io { path: "m.obj".into(), error: io() }).into(),
            clothcast_pattern::PatternError::Io(io()).into(),
            crate::config::ConfigError::Io { path: "c.toml".into(), source: io() }.into(),
        ];
        for e in cases {
            let printed = format!("{e:#}");
            assert_eq!(printed.matches("INNER").count(), 1, "{printed}");
        }
    }
}
