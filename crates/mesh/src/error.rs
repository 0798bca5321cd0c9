//! The mesh crate's error type.

use crate::validate::Problem;
use std::fmt;
use std::path::PathBuf;

/// `impl From<$inner> for $outer`, wrapping it in the tuple variant `$outer::$variant`: what
/// thiserror's `#[from]` does, but without making the inner error the `source` too. Every
/// error of the workspace that wraps another holds it in its message (`"…: {0}"`), and the
/// CLI prints errors with their chain (`{:#}`), so with `#[from]` the inner message would be
/// printed twice.
#[macro_export]
macro_rules! wrap_error {
    ($outer:ident :: $variant:ident ( $inner:ty )) => {
        impl From<$inner> for $outer {
            fn from(e: $inner) -> Self {
                $outer::$variant(e)
            }
        }
    };
}

/// Everything that can go wrong reading, validating or editing a mesh. Every variant names the
/// file, line or element involved.
///
/// All variants except [`MeshError::Io`] (for files that exist but cannot be read) are the
/// user's input to fix: the CLI maps them to exit code 2.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MeshError {
    /// The file could not be opened or read.
    #[error("cannot read {path}: {error}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error (in the message, not a `source`: printed with its chain, the reason
        /// would come twice).
        error: std::io::Error,
    },
    /// The file extension is not a mesh format we read.
    #[error("{path}: unknown mesh format (expected .obj, .ply, .stl or .off)")]
    UnknownFormat {
        /// The file.
        path: String,
    },
    /// The file has no content.
    #[error("{path}: the file is empty")]
    EmptyFile {
        /// The file.
        path: String,
    },
    /// The file does not follow its format.
    #[error("{path}{}: {message}", line_suffix(*line))]
    Malformed {
        /// The file.
        path: String,
        /// 1-based line, when the format has lines.
        line: Option<usize>,
        /// What is wrong.
        message: String,
    },
    /// The file ends before the data its header announces.
    #[error("{path}: truncated file: {message}")]
    Truncated {
        /// The file.
        path: String,
        /// What was missing.
        message: String,
    },
    /// A face refers to a vertex that does not exist.
    #[error(
        "{path}{}: face {face} refers to vertex {index}, but the file has {vertices} vertices (valid: {})",
        line_suffix(*line), valid_range(*vertices, *first_index)
    )]
    IndexOutOfRange {
        /// The file.
        path: String,
        /// 1-based line, when the format has lines.
        line: Option<usize>,
        /// 0-based index of the polygon in the file.
        face: usize,
        /// The offending index as written (0-based for PLY/OFF, 1-based or negative for OBJ).
        index: i64,
        /// Number of vertices in the file.
        vertices: usize,
        /// Index of the first vertex in the format (1 for OBJ, 0 otherwise).
        first_index: i64,
    },
    /// The surface is not a valid manifold triangle mesh.
    #[error("{}", ProblemSummary(problems))]
    Invalid {
        /// Every problem found.
        problems: Vec<Problem>,
    },
}

fn line_suffix(line: Option<usize>) -> String {
    line.map(|l| format!(":{l}")).unwrap_or_default()
}

fn valid_range(n: usize, first: i64) -> String {
    if n == 0 { "none".into() } else { format!("{first}..{}", n as i64 - 1 + first) }
}

/// Display of a problem list: the first few, then counts.
pub struct ProblemSummary<'a>(pub &'a [Problem]);

impl fmt::Display for ProblemSummary<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let problems = self.0;
        if problems.is_empty() {
            return write!(f, "no problems");
        }
        writeln!(f, "invalid mesh: {} problem(s)", problems.len())?;
        const SHOWN: usize = 8;
        for p in problems.iter().take(SHOWN) {
            writeln!(f, "  - {p} [{}]", p.remedy())?;
        }
        if problems.len() > SHOWN {
            let mut kinds: Vec<(&str, usize)> = Vec::new();
            for p in &problems[SHOWN..] {
                match kinds.iter_mut().find(|(k, _)| *k == p.kind()) {
                    Some((_, n)) => *n += 1,
                    None => kinds.push((p.kind(), 1)),
                }
            }
            let rest: Vec<String> = kinds.iter().map(|(k, n)| format!("{n} {k}")).collect();
            write!(
                f,
                "  ... and {} more ({}); `clothcast check` lists them all",
                problems.len() - SHOWN,
                rest.join(", ")
            )?;
        }
        Ok(())
    }
}
