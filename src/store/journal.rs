//! The `events.jsonl` journal format: one JSON object per line, `{"seq": N, "event": …}`,
//! sequence numbers 1, 2, 3, … without gaps, every line terminated by `\n`.
//!
//! Crash model: a record is appended with one `write` of the whole line (newline included)
//! followed by `fdatasync`, and only then acknowledged. A crash can therefore leave at most
//! one *unterminated* segment at the end of the file (a prefix of the line being written,
//! possibly empty of useful bytes). That segment is the *torn tail*: it was never
//! acknowledged, readers skip it and report it, and the next append truncates it first.
//! Every newline-terminated line, the last one included, must be a valid record in
//! sequence; anything else is corruption and is reported with its line number.

use super::StoreError;
use super::migrate::{self, Doc};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One acknowledged journal record.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Logged<E> {
    /// Sequence number, 1 for the first event of the run.
    pub seq: u64,
    /// The event as the runner wrote it.
    pub event: E,
}

/// The unterminated bytes a crash left at the end of the journal (never acknowledged).
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct TornTail {
    /// 1-based line number the torn record would have had.
    pub line: usize,
    /// Byte offset in `events.jsonl` where the torn bytes start (= the valid length).
    pub offset: u64,
    /// How many torn bytes follow.
    pub len: u64,
    /// The first bytes of the torn segment (lossy UTF-8, at most 80 characters), for logs.
    pub(crate) preview: String,
}

impl std::fmt::Display for TornTail {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "torn last record at line {} ({} bytes at offset {}, never acknowledged): {:?}",
            self.line, self.len, self.offset, self.preview
        )
    }
}

/// The journal as read back: every complete record, and the torn tail if a crash left one.
#[derive(Clone, Debug, PartialEq)]
pub struct EventLog<E> {
    /// The records, in sequence order (`events[i].seq == i + 1`).
    pub events: Vec<Logged<E>>,
    /// The unterminated segment at the end of the file, if any.
    pub torn_tail: Option<TornTail>,
}

/// A journal line borrowed from the file contents.
pub(crate) struct RawLine<'a> {
    /// 1-based line number.
    pub(crate) line_no: usize,
    /// The line without its newline.
    pub bytes: &'a [u8],
}

/// The journal split into complete lines and an optional torn tail.
pub(crate) struct Split<'a> {
    pub lines: Vec<RawLine<'a>>,
    pub torn: Option<TornTail>,
    /// Length of the valid prefix (all complete lines), in bytes.
    pub(crate) valid_len: u64,
}

/// Split journal contents into newline-terminated lines and the unterminated remainder.
pub(crate) fn split(bytes: &[u8]) -> Split<'_> {
    let mut lines = Vec::new();
    let mut start = 0usize;
    let mut line_no = 0usize;
    while let Some(pos) = bytes[start..].iter().position(|&b| b == b'\n') {
        line_no += 1;
        lines.push(RawLine {
            line_no,
            bytes: &bytes[start..start + pos],
        });
        start += pos + 1;
    }
    let torn = (start < bytes.len()).then(|| {
        let rest = &bytes[start..];
        let preview: String = String::from_utf8_lossy(rest).chars().take(80).collect();
        TornTail {
            line: line_no + 1,
            offset: start as u64,
            len: rest.len() as u64,
            preview,
        }
    });
    Split {
        lines,
        torn,
        valid_len: start as u64,
    }
}

#[derive(Deserialize)]
struct Line<E> {
    seq: u64,
    event: E,
}

/// Parse and sequence-check every complete line of `split`, written with run schema
/// version `version` (lines of older versions are upgraded first).
pub(crate) fn parse<E: DeserializeOwned>(
    path: &Path,
    split: &Split<'_>,
    version: u32,
) -> Result<Vec<Logged<E>>, StoreError> {
    let mut out = Vec::with_capacity(split.lines.len());
    for raw in &split.lines {
        let corrupt = |reason: String| StoreError::Corrupt {
            path: path.to_path_buf(),
            line: Some(raw.line_no),
            reason,
        };
        if raw.bytes.iter().all(u8::is_ascii_whitespace) {
            return Err(corrupt(
                "empty line (expected a {\"seq\", \"event\"} record)".into(),
            ));
        }
        let line: Line<E> = if version == migrate::SCHEMA_VERSION {
            serde_json::from_slice(raw.bytes)
        } else {
            let value: serde_json::Value = serde_json::from_slice(raw.bytes)
                .map_err(|e| corrupt(format!("not a JSON record: {e}")))?;
            let value = migrate::upgrade(path, Some(raw.line_no), Doc::Event, version, value)?;
            serde_json::from_value(value)
        }
        .map_err(|e| {
            corrupt(format!(
                "not a journal record ({{\"seq\", \"event\"}}): {e}"
            ))
        })?;
        let expected = out.len() as u64 + 1;
        if line.seq != expected {
            return Err(corrupt(format!(
                "sequence number {} where {expected} was expected (records lost or reordered)",
                line.seq
            )));
        }
        out.push(Logged {
            seq: line.seq,
            event: line.event,
        });
    }
    Ok(out)
}

/// Serialise one record as a journal line (newline included).
pub(crate) fn encode<E: Serialize>(seq: u64, event: &E) -> Result<Vec<u8>, StoreError> {
    #[derive(Serialize)]
    struct LineRef<'a, E> {
        seq: u64,
        event: &'a E,
    }
    let mut bytes =
        serde_json::to_vec(&LineRef { seq, event }).map_err(|source| StoreError::Serialize {
            what: "an event",
            source,
        })?;
    bytes.push(b'\n');
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::Value;

    fn p() -> &'static Path {
        Path::new("events.jsonl")
    }

    #[test]
    fn complete_lines_and_torn_tail() {
        let text = b"{\"seq\":1,\"event\":\"a\"}\n{\"seq\":2,\"event\":\"b\"}\n{\"seq\":3,\"ev";
        let s = split(text);
        assert_eq!(s.lines.len(), 2);
        let torn = s.torn.clone().unwrap();
        assert_eq!(torn.line, 3);
        assert_eq!(torn.offset, 44);
        assert_eq!(torn.len, 12);
        assert_eq!(s.valid_len, 44);
        let ev: Vec<Logged<String>> = parse(p(), &s, migrate::SCHEMA_VERSION).unwrap();
        assert_eq!(
            ev[1],
            Logged {
                seq: 2,
                event: "b".into()
            }
        );
    }

    #[test]
    fn corruption_in_the_middle_names_the_line() {
        let text = b"{\"seq\":1,\"event\":1}\n{\"seq\":2,\"ev\n{\"seq\":3,\"event\":3}\n";
        let e = parse::<Value>(p(), &split(text), migrate::SCHEMA_VERSION).unwrap_err();
        assert!(e.to_string().starts_with("events.jsonl:2: corrupt"), "{e}");
    }

    #[test]
    fn a_gap_in_sequence_numbers_is_corruption() {
        let text = b"{\"seq\":1,\"event\":1}\n{\"seq\":3,\"event\":3}\n";
        let e = parse::<Value>(p(), &split(text), migrate::SCHEMA_VERSION).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains(":2: corrupt") && msg.contains("sequence number 3"),
            "{msg}"
        );
    }

    #[test]
    fn empty_lines_are_corruption() {
        let text = b"{\"seq\":1,\"event\":1}\n\n";
        let e = parse::<Value>(p(), &split(text), migrate::SCHEMA_VERSION).unwrap_err();
        assert!(e.to_string().contains(":2: corrupt: empty line"), "{e}");
    }

    #[test]
    fn encode_round_trips() {
        let line = encode(7, &serde_json::json!({"k": "multi\nline"})).unwrap();
        assert_eq!(line.iter().filter(|&&b| b == b'\n').count(), 1);
        let s = split(&line);
        assert!(s.torn.is_none());
        let v: Line<Value> = serde_json::from_slice(s.lines[0].bytes).unwrap();
        assert_eq!(v.seq, 7);
    }
}
