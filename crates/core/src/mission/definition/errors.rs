//! The problems found in a mission file: [`DefError`] (one, located by file, line, column
//! and key path) and [`DefErrors`] (every one, in file order).

use super::*;

/// One problem in a mission file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DefError {
    /// The file name as given to [`MissionDef::parse`] / [`MissionDef::from_bytes`].
    pub file: String,
    /// 1-based line of the offending value (0 when unknown, e.g. a definition built in code).
    pub line: usize,
    /// 1-based column, in characters (0 when unknown).
    pub column: usize,
    /// Key path of the offending value (`grid.cell_size_m`, `vehicles[2].sysid`); empty for
    /// syntax errors and whole-file problems.
    pub path: String,
    /// What was expected and what was found.
    pub message: String,
}

impl fmt::Display for DefError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        if self.line > 0 {
            write!(f, ":{}:{}", self.line, self.column)?;
        }
        if self.path.is_empty() {
            write!(f, ": {}", self.message)
        } else {
            write!(f, ": {}: {}", self.path, self.message)
        }
    }
}

/// Every problem found in a mission file, in file order. Displays one per line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DefErrors {
    /// The problems (never empty when returned as an error).
    pub errors: Vec<DefError>,
}

impl fmt::Display for DefErrors {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, e) in self.errors.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "{e}")?;
        }
        Ok(())
    }
}

impl std::error::Error for DefErrors {}
