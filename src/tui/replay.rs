//! Replay files: a recorded sequence of models, played back by `fleetmap tui --replay FILE`.
//!
//! JSON Lines, one [`ReplayFrame`] per line: `{"t_ms": 1500, "model": {...}}` where `t_ms`
//! is the frame's time since the start of the recording (milliseconds, non-decreasing) and
//! `model` a [`Model`] (every field optional; the map's `rows` are glyph strings, north
//! first — see [`crate::panes::MapModel`]). Blank lines and lines starting with `#` are
//! skipped. `fleetmap tui --export-sample FILE` writes an example.

use crate::panes::Model;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One recorded snapshot.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReplayFrame {
    /// Milliseconds since the start of the recording.
    pub t_ms: u64,
    /// The snapshot.
    pub model: Model,
}

/// A problem with a replay file.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// The file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// Why.
        source: std::io::Error,
    },
    /// A line is not a frame.
    #[error("{path}:{line}: not a replay frame: {message}")]
    Parse {
        /// The file.
        path: String,
        /// 1-based line number.
        line: usize,
        /// What serde said.
        message: String,
    },
    /// Time went backwards.
    #[error("{path}:{line}: t_ms {t_ms} is before the previous frame's {previous}")]
    OutOfOrder {
        /// The file.
        path: String,
        /// 1-based line number.
        line: usize,
        /// This frame's time.
        t_ms: u64,
        /// The previous frame's time.
        previous: u64,
    },
    /// No frames at all.
    #[error("{0}: no frames")]
    Empty(String),
}

/// Parse replay text (`path` is only used in error messages).
pub(crate) fn parse_replay(text: &str, path: &str) -> Result<Vec<ReplayFrame>, ReplayError> {
    let mut frames: Vec<ReplayFrame> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let trimmed = line.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        let frame: ReplayFrame = serde_json::from_str(trimmed).map_err(|e| ReplayError::Parse {
            path: path.to_string(),
            line: i + 1,
            message: e.to_string(),
        })?;
        if let Some(prev) = frames.last()
            && frame.t_ms < prev.t_ms
        {
            return Err(ReplayError::OutOfOrder {
                path: path.to_string(),
                line: i + 1,
                t_ms: frame.t_ms,
                previous: prev.t_ms,
            });
        }
        frames.push(frame);
    }
    if frames.is_empty() {
        return Err(ReplayError::Empty(path.to_string()));
    }
    Ok(frames)
}

/// Read a replay file.
pub fn read_replay(path: &Path) -> Result<Vec<ReplayFrame>, ReplayError> {
    let shown = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| ReplayError::Io {
        path: shown.clone(),
        source,
    })?;
    parse_replay(&text, &shown)
}

/// Write frames as a replay file (atomically).
pub(crate) fn write_replay(path: &Path, frames: &[ReplayFrame]) -> Result<(), ReplayError> {
    let shown = path.display().to_string();
    let mut text = String::new();
    for f in frames {
        let line = serde_json::to_string(f).map_err(|e| ReplayError::Parse {
            path: shown.clone(),
            line: 0,
            message: e.to_string(),
        })?;
        text.push_str(&line);
        text.push('\n');
    }
    fleetmap_io::files::atomic_write(path, text.as_bytes()).map_err(|source| ReplayError::Io {
        path: shown,
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_minimal_frames_and_reports_line_numbers() {
        let text = "# comment\n{\"t_ms\": 0, \"model\": {}}\n\n{\"t_ms\": 10, \"model\": {\"vehicles\": [{\"sysid\": 3}]}}\n";
        let frames = parse_replay(text, "x.jsonl").expect("valid");
        assert_eq!(frames.len(), 2);
        assert_eq!(frames[1].model.vehicles[0].sysid, 3);

        let err = parse_replay(
            "{\"t_ms\": 5, \"model\": {}}\n{\"t_ms\": 1, \"model\": {}}",
            "x",
        )
        .unwrap_err();
        assert!(
            err.to_string().starts_with("x:2: t_ms 1 is before"),
            "{err}"
        );
        let err = parse_replay("{\"t_ms\": 5}\n", "x").unwrap_err();
        assert!(
            err.to_string().starts_with("x:1: not a replay frame"),
            "{err}"
        );
        assert!(matches!(
            parse_replay("\n# nothing\n", "x"),
            Err(ReplayError::Empty(_))
        ));
    }
}
