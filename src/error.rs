//! Errors: bad input apart from numerical failure and I/O (exit status 2, 3 and 4 in the CLI).

use std::fmt;

/// Everything grainstat can fail with.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The user's input (scene, solver file, sample, result file to resume) is wrong.
    #[error(transparent)]
    Input(#[from] InputError),
    /// The numerical method failed; the last converged state has been written.
    #[error(transparent)]
    Numeric(#[from] NumericError),
    /// Reading or writing a file failed.
    #[error("{path}: {message}")]
    Io {
        /// The file.
        path: String,
        /// What went wrong.
        message: String,
    },
}

impl Error {
    /// A file error with its path.
    pub fn io(path: impl fmt::Display, message: impl fmt::Display) -> Self {
        Error::Io {
            path: path.to_string(),
            message: message.to_string(),
        }
    }
}

/// A problem in an input file: which file, which key, which line, and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct InputError {
    /// The file the problem is in.
    pub file: String,
    /// 1-based line, when known.
    pub line: Option<usize>,
    /// Dotted key path (`material.friction`, `walls[2].normal`), when known.
    pub key: Option<String>,
    /// What is wrong, and what would be right.
    pub message: String,
}

impl InputError {
    /// An error not tied to a key or line.
    pub fn new(file: impl Into<String>, message: impl Into<String>) -> Self {
        InputError {
            file: file.into(),
            line: None,
            key: None,
            message: message.into(),
        }
    }

    /// The same error with a key path.
    pub fn at_key(mut self, key: impl Into<String>) -> Self {
        self.key = Some(key.into());
        self
    }

    /// The same error with a line.
    pub fn at_line(mut self, line: usize) -> Self {
        self.line = Some(line);
        self
    }
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        if let Some(line) = self.line {
            write!(f, ":{line}")?;
        }
        if let Some(key) = &self.key {
            write!(f, ": key `{key}`")?;
        }
        write!(f, ": {}", self.message)
    }
}

impl std::error::Error for InputError {}

/// A numerical failure of the solver.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NumericError {
    /// The solver did not reach the tolerance: the minimisation within its iterations, after
    /// halving the step `cuts` times.
    #[error(
        "increment {increment} did not converge: relative residual {residual:.3e}{} (worst \
         grain {worst_grain}); the last converged state was written",
        if *cuts > 0 { format!(" after cutting the step {cuts} times") } else { String::new() }
    )]
    NotConverged {
        /// The load increment (1-based).
        increment: usize,
        /// `|R|_inf / F_ref` at the best iterate.
        residual: f64,
        /// The grain with the largest residual.
        worst_grain: usize,
        /// How often the increment was halved.
        cuts: u32,
    },
    /// No equilibrium near the last one: the minimisation carried some grains on by more than
    /// their diameter while the potential kept falling (method note, step 4), in a step that
    /// changed the load by `load_change` of itself from the last equilibrium: the limit load
    /// lies within that bracket.
    #[error(
        "no equilibrium near in increment {increment}: the descent carried {} grain(s) on \
         while the potential kept falling (first: {}), residual {residual:.2e}, within \
         {:.2}% of the load carried",
        grains.len(),
        grains.iter().take(8).map(|g| g.to_string()).collect::<Vec<_>>().join(", "),
        100.0 * load_change
    )]
    NoEquilibrium {
        /// The load increment (1-based).
        increment: usize,
        /// `|R|_inf / F_ref` where it stopped.
        residual: f64,
        /// The grains carried on: those that moved more than their diameter, and the grains
        /// moving with them.
        grains: Vec<usize>,
        /// How much the step that found no equilibrium changed the load, as a share of it.
        load_change: f64,
    },
    /// The first cluster broke out of the sample in a stage that ends there
    /// ([`crate::scene::Stage::until_breakout`]): the cylinder test's functional failure
    /// (thesis 4.4.2), its load bracketed as any breakout's is.
    #[error(
        "a cluster of {} grain(s) broke out in increment {increment} (first: {}), within \
         {:.2}% of the load carried",
        grains.len(),
        grains.iter().take(8).map(|g| g.to_string()).collect::<Vec<_>>().join(", "),
        100.0 * load_change
    )]
    BrokeOut {
        /// The load increment (1-based).
        increment: usize,
        /// The cluster's grains.
        grains: Vec<usize>,
        /// How much the step it broke out in changed the load, as a share of it.
        load_change: f64,
    },
    /// A stage produced NaN or infinity.
    #[error("{what} is not finite at {place}")]
    NotFinite {
        /// The quantity.
        what: &'static str,
        /// The grain or contact.
        place: String,
    },
    /// The tangent could not be factorised even with regularisation.
    #[error("the tangent matrix is singular ({detail})")]
    Singular {
        /// What the factorisation reported.
        detail: String,
    },
}

/// Result with grainstat's error.
pub type Result<T, E = Error> = std::result::Result<T, E>;
