//! `.tlog` telemetry logs: every frame in and out, as QGroundControl, Mission Planner and
//! MAVProxy write them — each record is an 8-byte big-endian timestamp (microseconds since
//! the Unix epoch) followed by the raw MAVLink frame (pymavlink `mavutil.mavlogfile`
//! reads `>Q` then parses the frame; `mavlogdump.py` prints them).
//!
//! `TlogWriter` is the synchronous writer; [`spawn_tlog`] runs one on a tokio task so
//! that every link can log through a cheap channel; [`read_tlog`] reads a file back.

use super::codec::{Codec, Frame};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use tokio::sync::mpsc;

/// Errors writing or reading a tlog.
#[derive(Debug, thiserror::Error)]
pub enum TlogError {
    /// The file could not be created, written or read.
    #[error("tlog {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// The file ends in the middle of a record.
    #[error("tlog {path}: truncated record at byte {offset}")]
    Truncated {
        /// The file.
        path: String,
        /// Byte offset of the record.
        offset: usize,
    },
}

/// Writes tlog records to a file (buffered; [`TlogWriter::flush`] or drop to persist).
pub(crate) struct TlogWriter {
    path: PathBuf,
    out: BufWriter<File>,
    /// Records written.
    pub records: u64,
}

impl TlogWriter {
    /// Create (truncate) `path`.
    pub(crate) fn create(path: &Path) -> Result<TlogWriter, TlogError> {
        let f = File::create(path).map_err(|source| TlogError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Ok(TlogWriter {
            path: path.to_path_buf(),
            out: BufWriter::new(f),
            records: 0,
        })
    }

    /// Append one frame seen at `unix_us` (µs since 1970-01-01 UTC).
    pub(crate) fn write(&mut self, unix_us: u64, frame: &[u8]) -> Result<(), TlogError> {
        let io = |source| TlogError::Io {
            path: self.path.display().to_string(),
            source,
        };
        self.out.write_all(&unix_us.to_be_bytes()).map_err(io)?;
        self.out.write_all(frame).map_err(|source| TlogError::Io {
            path: self.path.display().to_string(),
            source,
        })?;
        self.records += 1;
        Ok(())
    }

    /// Flush buffered records to the OS and the disk.
    pub(crate) fn flush(&mut self) -> Result<(), TlogError> {
        self.out.flush().map_err(|source| TlogError::Io {
            path: self.path.display().to_string(),
            source,
        })?;
        self.out
            .get_ref()
            .sync_data()
            .map_err(|source| TlogError::Io {
                path: self.path.display().to_string(),
                source,
            })
    }
}

/// Handle to a tlog writer task: clone it into every link.
#[derive(Clone, Debug)]
pub struct TlogHandle {
    tx: mpsc::UnboundedSender<(u64, Vec<u8>)>,
}

impl TlogHandle {
    /// Queue a frame for the log (never blocks; dropped only if the writer has failed).
    pub fn record(&self, unix_us: u64, frame: &[u8]) {
        let _ = self.tx.send((unix_us, frame.to_vec()));
    }
}

/// Start a writer task for `path`. The task ends, flushing the file, when every
/// [`TlogHandle`] is dropped; await the returned join handle to be sure it is on disk.
pub fn spawn_tlog(
    path: &Path,
) -> Result<(TlogHandle, tokio::task::JoinHandle<Result<u64, TlogError>>), TlogError> {
    let mut w = TlogWriter::create(path)?;
    let (tx, mut rx) = mpsc::unbounded_channel::<(u64, Vec<u8>)>();
    let task = tokio::task::spawn_blocking(move || {
        let mut since_flush = 0u32;
        while let Some((t, f)) = rx.blocking_recv() {
            w.write(t, &f)?;
            since_flush += 1;
            // Flush in batches: drain what is queued, then flush when idle.
            if rx.is_empty() || since_flush >= 256 {
                w.out.flush().map_err(|source| TlogError::Io {
                    path: w.path.display().to_string(),
                    source,
                })?;
                since_flush = 0;
            }
        }
        w.flush()?;
        Ok(w.records)
    });
    Ok((TlogHandle { tx }, task))
}

/// Read every record of a tlog: (µs since the epoch, decoded frame). Frames that do not
/// decode are skipped (and counted in the returned codec statistics).
pub fn read_tlog(path: &Path) -> Result<Vec<(u64, Frame)>, TlogError> {
    let data = std::fs::read(path).map_err(|source| TlogError::Io {
        path: path.display().to_string(),
        source,
    })?;
    let mut out = Vec::new();
    let mut i = 0;
    while i < data.len() {
        if i + 8 + 2 > data.len() {
            return Err(TlogError::Truncated {
                path: path.display().to_string(),
                offset: i,
            });
        }
        let mut ts = [0u8; 8];
        ts.copy_from_slice(&data[i..i + 8]);
        let t = u64::from_be_bytes(ts);
        let body = &data[i + 8..];
        let len = usize::from(body[1]);
        let total = match body[0] {
            super::codec::STX_V2 => 10 + len + 2 + if body[2] & 1 != 0 { 13 } else { 0 },
            _ => 6 + len + 2,
        };
        if body.len() < total {
            return Err(TlogError::Truncated {
                path: path.display().to_string(),
                offset: i,
            });
        }
        let mut c = Codec::new();
        if let Some(f) = c.decode(&body[..total], 0).into_iter().next() {
            out.push((t, f));
        }
        i += 8 + total;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use fleetmap_core::proto::heartbeat::gcs_heartbeat;

    #[test]
    fn write_and_read_back() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.tlog");
        let mut c = Codec::new();
        let f1 = c.encode(
            fleetmap_core::proto::GCS_SYSID,
            fleetmap_core::proto::GCS_COMPID,
            &gcs_heartbeat(),
            0,
        );
        let f2 = c.encode(1, 1, &gcs_heartbeat(), 0);
        {
            let mut w = TlogWriter::create(&p).unwrap();
            w.write(1_700_000_000_000_001, &f1).unwrap();
            w.write(1_700_000_000_000_002, &f2).unwrap();
            w.flush().unwrap();
        }
        let bytes = std::fs::read(&p).unwrap();
        assert_eq!(&bytes[..8], &1_700_000_000_000_001u64.to_be_bytes());
        assert_eq!(&bytes[8..8 + f1.len()], &f1[..]);
        let recs = read_tlog(&p).unwrap();
        assert_eq!(recs.len(), 2);
        assert_eq!(recs[1].0, 1_700_000_000_000_002);
        assert_eq!(recs[1].1.sysid(), 1);
    }
}
