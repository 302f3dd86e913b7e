//! [`RunDir`]: one run of a mission, as a directory that survives crashes at any moment.
//!
//! ```text
//! RUN_DIR/
//!   run.json       RunMeta: schema_version, kind, creation time, mission source, connections
//!   mission.toml   verbatim copy of the mission definition the run was started with
//!   state.json     the latest snapshot (StateEnvelope<T>), replaced atomically on every save
//!   events.jsonl   append-only journal, one {"seq", "event"} object per line, fsync per record
//!   images/        created on demand (captured images)
//!   exports/       created on demand (GeoJSON, KML, CSV …)
//! ```
//!
//! Durability contract: [`RunDir::append_event`] and [`RunDir::save_state`] return `Ok` only
//! after the bytes are on stable storage (fdatasync of the journal; for snapshots a temporary
//! file, fsync, rename and a directory fsync). Whatever returned `Ok` before a crash (SIGKILL, power
//! loss on a file system that honours fsync) is there when the run is opened again; a record
//! that was being appended during the crash is either complete or reported as a torn tail.
//!
//! Single writer: one process writes a run at a time (the runner that owns it). Readers in
//! other processes see complete snapshots and may see a torn tail while a record is being
//! written.

use super::StoreError;
use super::journal::{self, EventLog, TornTail};
use super::migrate::{self, Doc, SCHEMA_VERSION};
use fleetmap_io::files::{atomic_write, sync_dir};
use serde::de::{DeserializeOwned, IgnoredAny};
use serde::{Deserialize, Serialize};
use std::fs::{self, File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// File name of the run metadata.
pub(crate) const META_FILE: &str = "run.json";
/// File name of the state snapshot.
pub(crate) const STATE_FILE: &str = "state.json";
/// File name of the event journal.
pub(crate) const EVENTS_FILE: &str = "events.jsonl";
/// File name of the copy of the mission definition.
pub(crate) const MISSION_FILE: &str = "mission.toml";
/// Subdirectory for captured images.
pub(crate) const IMAGES_DIR: &str = "images";
/// Subdirectory for exported maps and tables.
pub(crate) const EXPORTS_DIR: &str = "exports";

/// What a run is: written once to `run.json` when the run is created.
///
/// `fleetmap resume RUN_DIR` reads it to know which runner to start, which mission file
/// (the copy in `mission.toml`) and which connections to reopen.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunMeta {
    /// Run-directory format version; [`RunDir::create`] sets it to [`SCHEMA_VERSION`].
    pub(crate) schema_version: u32,
    /// Which runner owns the run, e.g. `"runway-mapping"` or `"spatial-classification"`.
    /// `state.json` must carry the same kind.
    pub kind: String,
    /// Creation time, milliseconds since the Unix epoch (the caller reads the clock).
    pub(crate) created_unix_ms: u64,
    /// Where the mission definition was read from (the copy is `mission.toml`), if any.
    #[serde(default)]
    pub mission_path: Option<String>,
    /// Connection strings of the vehicles (`udpin:0.0.0.0:14550`, `serial:/dev/ttyUSB0:57600` …).
    #[serde(default)]
    pub connections: Vec<String>,
    /// Version of the fleetmap that created the run (`CARGO_PKG_VERSION`).
    #[serde(default)]
    pub(crate) fleetmap_version: String,
    /// Anything else the runner wants to keep with the run (JSON `null` when unused).
    #[serde(default)]
    pub extra: serde_json::Value,
}

impl RunMeta {
    /// Metadata for a new run of `kind`, created at `created_unix_ms`; no mission path, no
    /// connections, no extra data.
    pub fn new(kind: impl Into<String>, created_unix_ms: u64) -> RunMeta {
        RunMeta {
            schema_version: SCHEMA_VERSION,
            kind: kind.into(),
            created_unix_ms,
            mission_path: None,
            connections: Vec::new(),
            fleetmap_version: env!("CARGO_PKG_VERSION").to_string(),
            extra: serde_json::Value::Null,
        }
    }
}

/// The `state.json` document: the runner's state `T` with the store's bookkeeping.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StateEnvelope<T> {
    /// Run-directory format version ([`SCHEMA_VERSION`] when written by this build).
    pub(crate) schema_version: u32,
    /// The run kind (same as `run.json`).
    pub kind: String,
    /// How many snapshots have been saved in this run, this one included (1, 2, 3 …).
    pub(crate) generation: u64,
    /// Sequence number of the last journal record acknowledged before this snapshot
    /// (0 = none): on resume, records after it happened after the snapshot.
    pub journal_seq: u64,
    /// The runner's state.
    pub state: T,
}

/// An open run directory (see the module documentation for the layout and guarantees).
#[derive(Debug)]
pub struct RunDir {
    path: PathBuf,
    meta: RunMeta,
    /// The journal, opened for writing on the first append.
    journal: Option<File>,
    /// Sequence number the next record gets.
    next_seq: u64,
    /// Length of the valid journal prefix in bytes.
    valid_len: u64,
    /// The file may hold bytes after `valid_len` (a torn tail or a failed write) that must be
    /// cut off before the next append.
    needs_truncate: bool,
    /// The torn tail found when the run was opened.
    torn_at_open: Option<TornTail>,
    /// Generation of the newest snapshot (0 = none yet).
    generation: u64,
}

fn read_json(path: &Path) -> Result<Option<serde_json::Value>, StoreError> {
    let bytes = match fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(StoreError::io(path)(e)),
    };
    serde_json::from_slice(&bytes)
        .map(Some)
        .map_err(|e| StoreError::Corrupt {
            path: path.to_path_buf(),
            line: Some(e.line()),
            reason: format!("not valid JSON: {e}"),
        })
}

fn to_json_pretty<T: Serialize>(what: &'static str, value: &T) -> Result<Vec<u8>, StoreError> {
    let mut bytes = serde_json::to_vec_pretty(value)
        .map_err(|source| StoreError::Serialize { what, source })?;
    bytes.push(b'\n');
    Ok(bytes)
}

fn check_plain_name(name: &str) -> Result<(), StoreError> {
    let ok = !name.is_empty()
        && name != "."
        && name != ".."
        && !name.contains('/')
        && !name.contains('\\')
        && !name.contains('\0');
    if ok {
        Ok(())
    } else {
        Err(StoreError::InvalidName { name: name.into() })
    }
}

impl RunDir {
    /// Create a new run at `path` (which must not exist, or be an empty directory), with
    /// `meta` (its `schema_version` is set to `SCHEMA_VERSION`) and, when given, a verbatim
    /// copy of the mission definition in `mission.toml`.
    ///
    /// `run.json` is written last, so a crash during creation leaves a directory that
    /// [`RunDir::open`] rejects as [`StoreError::NotARun`] rather than a half-made run.
    pub fn create(
        path: impl AsRef<Path>,
        meta: RunMeta,
        mission_toml: Option<&str>,
    ) -> Result<RunDir, StoreError> {
        let path = path.as_ref().to_path_buf();
        match fs::read_dir(&path) {
            Ok(mut entries) => {
                if entries.next().is_some() {
                    return Err(StoreError::AlreadyExists { path });
                }
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                fs::create_dir_all(&path).map_err(StoreError::io(&path))?;
                if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
                    sync_dir(parent).map_err(StoreError::io(parent))?;
                }
            }
            Err(e) => return Err(StoreError::io(&path)(e)),
        }
        if let Some(text) = mission_toml {
            let p = path.join(MISSION_FILE);
            atomic_write(&p, text.as_bytes()).map_err(StoreError::io(&p))?;
        }
        let events = path.join(EVENTS_FILE);
        File::create(&events)
            .and_then(|f| f.sync_all())
            .map_err(StoreError::io(&events))?;
        let meta = RunMeta {
            schema_version: SCHEMA_VERSION,
            ..meta
        };
        let p = path.join(META_FILE);
        atomic_write(&p, &to_json_pretty("run.json", &meta)?).map_err(StoreError::io(&p))?;
        Ok(RunDir {
            path,
            meta,
            journal: None,
            next_seq: 1,
            valid_len: 0,
            needs_truncate: false,
            torn_at_open: None,
            generation: 0,
        })
    }

    /// Open an existing run: reads and version-checks `run.json`, scans the journal
    /// (corruption anywhere but a torn last record is an error naming the line), reads the
    /// snapshot's header, and removes temporary files a crash may have left behind.
    pub fn open(path: impl AsRef<Path>) -> Result<RunDir, StoreError> {
        let path = path.as_ref().to_path_buf();
        let meta_path = path.join(META_FILE);
        let doc =
            read_json(&meta_path)?.ok_or_else(|| StoreError::NotARun { path: path.clone() })?;
        let version = migrate::version_of(&meta_path, None, &doc)?;
        let doc = migrate::upgrade(&meta_path, None, Doc::Meta, version, doc)?;
        let meta: RunMeta = serde_json::from_value(doc).map_err(|e| StoreError::Corrupt {
            path: meta_path.clone(),
            line: None,
            reason: format!("not run metadata: {e}"),
        })?;

        remove_stale_temps(&path);

        let events_path = path.join(EVENTS_FILE);
        let bytes = match fs::read(&events_path) {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
            Err(e) => return Err(StoreError::io(&events_path)(e)),
        };
        let split = journal::split(&bytes);
        let records = journal::parse::<IgnoredAny>(&events_path, &split, version)?;

        let mut run = RunDir {
            path,
            meta,
            journal: None,
            next_seq: records.len() as u64 + 1,
            valid_len: split.valid_len,
            needs_truncate: split.torn.is_some(),
            torn_at_open: split.torn,
            generation: 0,
        };
        if let Some(env) = run.load_state_envelope::<IgnoredAny>()? {
            run.generation = env.generation;
        }
        Ok(run)
    }

    /// The run directory.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The run's metadata (`run.json`).
    pub fn meta(&self) -> &RunMeta {
        &self.meta
    }

    /// The copy of the mission definition (`mission.toml`), if the run was created with one.
    pub(crate) fn mission_text(&self) -> Result<Option<String>, StoreError> {
        let p = self.path.join(MISSION_FILE);
        match fs::read_to_string(&p) {
            Ok(s) => Ok(Some(s)),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(StoreError::io(&p)(e)),
        }
    }

    /// The torn journal tail found when the run was opened (cut off by the next append).
    pub(crate) fn torn_tail_at_open(&self) -> Option<&TornTail> {
        self.torn_at_open.as_ref()
    }

    /// Sequence number of the last acknowledged journal record (0 = empty journal).
    pub fn last_seq(&self) -> u64 {
        self.next_seq - 1
    }

    #[cfg(test)]
    /// Generation of the newest snapshot (0 = no `state.json` yet).
    pub(crate) fn generation(&self) -> u64 {
        self.generation
    }

    /// Replace `state.json` with `state` atomically and durably; returns the new generation.
    ///
    /// The envelope records the run kind, the generation and the last journal sequence
    /// number. Returns only after the directory fsync, i.e. the snapshot is acknowledged.
    pub fn save_state<T: Serialize>(&mut self, state: &T) -> Result<u64, StoreError> {
        let env = StateEnvelope {
            schema_version: SCHEMA_VERSION,
            kind: self.meta.kind.clone(),
            generation: self.generation + 1,
            journal_seq: self.last_seq(),
            state,
        };
        let p = self.path.join(STATE_FILE);
        atomic_write(&p, &to_json_pretty("the state", &env)?).map_err(StoreError::io(&p))?;
        self.generation += 1;
        Ok(self.generation)
    }

    /// The latest snapshot's state, or `None` when nothing has been saved yet.
    pub fn load_state<T: DeserializeOwned>(&self) -> Result<Option<T>, StoreError> {
        Ok(self.load_state_envelope()?.map(|e| e.state))
    }

    /// The latest snapshot with its envelope (generation, journal position).
    pub fn load_state_envelope<T: DeserializeOwned>(
        &self,
    ) -> Result<Option<StateEnvelope<T>>, StoreError> {
        let Some(env) = self.load_state_value()? else {
            return Ok(None);
        };
        let p = self.path.join(STATE_FILE);
        serde_json::from_value(env)
            .map(Some)
            .map_err(|e| StoreError::Corrupt {
                path: p,
                line: None,
                reason: format!("the state does not match the expected type: {e}"),
            })
    }

    /// The latest snapshot as raw JSON (envelope included, upgraded to the current store
    /// schema), for runners that migrate their own state format.
    pub(crate) fn load_state_value(&self) -> Result<Option<serde_json::Value>, StoreError> {
        let p = self.path.join(STATE_FILE);
        let Some(doc) = read_json(&p)? else {
            return Ok(None);
        };
        let version = migrate::version_of(&p, None, &doc)?;
        let doc = migrate::upgrade(&p, None, Doc::State, version, doc)?;
        let kind = doc
            .get("kind")
            .and_then(|k| k.as_str())
            .ok_or_else(|| StoreError::Corrupt {
                path: p.clone(),
                line: None,
                reason: "missing \"kind\"".into(),
            })?;
        if kind != self.meta.kind {
            return Err(StoreError::KindMismatch {
                path: p,
                expected: self.meta.kind.clone(),
                found: kind.into(),
            });
        }
        Ok(Some(doc))
    }

    /// Append `event` to the journal and fsync; returns its sequence number once it is
    /// durable ("acknowledged"). A torn tail left by a crash is truncated first.
    pub fn append_event<E: Serialize>(&mut self, event: &E) -> Result<u64, StoreError> {
        let seq = self.next_seq;
        let line = journal::encode(seq, event)?;
        let p = self.path.join(EVENTS_FILE);
        let io = StoreError::io(&p);
        let f = match self.journal.as_mut() {
            Some(f) => f,
            None => {
                let existed = p.exists();
                let f = OpenOptions::new()
                    .read(true)
                    .write(true)
                    .create(true)
                    .truncate(false)
                    .open(&p)
                    .map_err(StoreError::io(&p))?;
                if !existed {
                    sync_dir(&self.path).map_err(StoreError::io(&self.path))?;
                }
                let len = f.metadata().map_err(StoreError::io(&p))?.len();
                if len != self.valid_len {
                    self.needs_truncate = true;
                }
                self.journal.insert(f)
            }
        };
        let result = (|| {
            if self.needs_truncate {
                f.set_len(self.valid_len)?;
                f.sync_all()?;
                self.needs_truncate = false;
            }
            f.seek(SeekFrom::Start(self.valid_len))?;
            f.write_all(&line)?;
            f.sync_data()
        })();
        match result {
            Ok(()) => {
                self.valid_len += line.len() as u64;
                self.next_seq += 1;
                Ok(seq)
            }
            Err(e) => {
                // Part of the line may be in the file: cut it off before the next append.
                self.needs_truncate = true;
                Err(io(e))
            }
        }
    }

    /// Read the whole journal: every acknowledged record, and the torn tail if one is there.
    pub fn read_events<E: DeserializeOwned>(&self) -> Result<EventLog<E>, StoreError> {
        let p = self.path.join(EVENTS_FILE);
        let mut bytes = Vec::new();
        match File::open(&p) {
            Ok(mut f) => {
                f.read_to_end(&mut bytes).map_err(StoreError::io(&p))?;
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(StoreError::io(&p)(e)),
        }
        let split = journal::split(&bytes);
        let events = journal::parse(&p, &split, self.meta.schema_version)?;
        Ok(EventLog {
            events,
            torn_tail: split.torn,
        })
    }

    /// The `images/` subdirectory, created (durably) on first use.
    pub(crate) fn images_dir(&self) -> Result<PathBuf, StoreError> {
        self.subdir(IMAGES_DIR)
    }

    /// The `exports/` subdirectory, created (durably) on first use.
    pub(crate) fn exports_dir(&self) -> Result<PathBuf, StoreError> {
        self.subdir(EXPORTS_DIR)
    }

    /// Write `bytes` to `images/NAME` atomically; returns the file's path.
    pub fn write_image(&self, name: &str, bytes: &[u8]) -> Result<PathBuf, StoreError> {
        check_plain_name(name)?;
        let p = self.images_dir()?.join(name);
        atomic_write(&p, bytes).map_err(StoreError::io(&p))?;
        Ok(p)
    }

    /// Write `bytes` to `exports/NAME` atomically; returns the file's path.
    pub(crate) fn write_export(&self, name: &str, bytes: &[u8]) -> Result<PathBuf, StoreError> {
        check_plain_name(name)?;
        let p = self.exports_dir()?.join(name);
        atomic_write(&p, bytes).map_err(StoreError::io(&p))?;
        Ok(p)
    }

    fn subdir(&self, name: &str) -> Result<PathBuf, StoreError> {
        let p = self.path.join(name);
        if !p.is_dir() {
            fs::create_dir_all(&p).map_err(StoreError::io(&p))?;
            sync_dir(&self.path).map_err(StoreError::io(&self.path))?;
        }
        Ok(p)
    }
}

/// Remove `.NAME.tmpPID` files that `atomic_write` leaves when a process dies between
/// creating its temporary file and renaming it. Failures are ignored (they are harmless).
/// Remove the temporary files of [`atomic_write`] that a crashed writer left behind. The
/// temporary name ends with the writer's process id: a file of a process that is still
/// running (this one, or a GCS flying the run while `fleetmap report` reads it) is being
/// written now and is left alone — removing it would make that writer's rename fail.
fn remove_stale_temps(dir: &Path) {
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(name) = name.to_str() else { continue };
        let pid = [META_FILE, STATE_FILE, MISSION_FILE]
            .iter()
            .find_map(|f| name.strip_prefix(&format!(".{f}.tmp")));
        if let Some(pid) = pid
            && !writer_alive(pid)
        {
            let _ = fs::remove_file(entry.path());
        }
    }
}

/// Whether the process `pid` (the suffix of a temporary file) may still be writing it:
/// this process, or any live process where `/proc` tells (elsewhere every writer counts as
/// alive: a stale temporary file only takes space).
fn writer_alive(pid: &str) -> bool {
    let Ok(pid) = pid.parse::<u32>() else {
        return false;
    };
    if pid == std::process::id() {
        return true;
    }
    let proc = Path::new("/proc");
    !proc.join("self").exists() || proc.join(pid.to_string()).exists()
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::{Value, json};

    fn new_run(dir: &Path) -> RunDir {
        let mut meta = RunMeta::new("runway-mapping", 1_700_000_000_000);
        meta.connections = vec!["udpin:0.0.0.0:14550".into()];
        meta.mission_path = Some("missions/runway-field-test.toml".into());
        RunDir::create(dir.join("run"), meta, Some("name = \"x\"\n")).unwrap()
    }

    #[test]
    fn open_removes_only_the_temporaries_of_dead_writers() {
        let tmp = tempfile::tempdir().unwrap();
        let run = new_run(tmp.path());
        let dir = run.path().to_path_buf();
        // A writer that is running now (this process) and one that died (no such pid).
        let live = dir.join(format!(".{STATE_FILE}.tmp{}", std::process::id()));
        let dead = dir.join(format!(".{STATE_FILE}.tmp{}", u32::MAX));
        let legacy = dir.join(format!(".{META_FILE}.tmp"));
        for f in [&live, &dead, &legacy] {
            fs::write(f, b"{").unwrap();
        }
        RunDir::open(&dir).unwrap();
        assert!(live.exists(), "a live writer's temporary file was removed");
        assert!(!dead.exists());
        assert!(!legacy.exists());
    }

    #[test]
    fn create_open_round_trip() {
        let tmp = tempfile::tempdir().unwrap();
        let mut run = new_run(tmp.path());
        assert_eq!(run.append_event(&json!({"a": 1})).unwrap(), 1);
        assert_eq!(run.append_event(&json!({"a": 2})).unwrap(), 2);
        assert_eq!(run.save_state(&json!({"cells": [1, 2]})).unwrap(), 1);
        drop(run);
        let run = RunDir::open(tmp.path().join("run")).unwrap();
        assert_eq!(run.meta().kind, "runway-mapping");
        assert_eq!(run.meta().connections, ["udpin:0.0.0.0:14550"]);
        assert_eq!(
            run.mission_text().unwrap().as_deref(),
            Some("name = \"x\"\n")
        );
        assert_eq!(run.last_seq(), 2);
        assert_eq!(run.generation(), 1);
        let env = run.load_state_envelope::<Value>().unwrap().unwrap();
        assert_eq!(env.journal_seq, 2);
        assert_eq!(env.state, json!({"cells": [1, 2]}));
        let log = run.read_events::<Value>().unwrap();
        assert_eq!(log.events.len(), 2);
        assert!(log.torn_tail.is_none());
    }

    #[test]
    fn create_refuses_a_non_empty_directory() {
        let tmp = tempfile::tempdir().unwrap();
        new_run(tmp.path());
        let e = RunDir::create(tmp.path().join("run"), RunMeta::new("x", 0), None).unwrap_err();
        assert!(matches!(e, StoreError::AlreadyExists { .. }), "{e}");
    }

    #[test]
    fn open_without_run_json_is_not_a_run() {
        let tmp = tempfile::tempdir().unwrap();
        let e = RunDir::open(tmp.path()).unwrap_err();
        assert!(
            e.to_string().contains("not a fleetmap run directory"),
            "{e}"
        );
    }

    #[test]
    fn torn_tail_is_reported_then_truncated_by_the_next_append() {
        let tmp = tempfile::tempdir().unwrap();
        let mut run = new_run(tmp.path());
        run.append_event(&json!(1)).unwrap();
        let events = tmp.path().join("run").join(EVENTS_FILE);
        let mut f = OpenOptions::new().append(true).open(&events).unwrap();
        f.write_all(b"{\"seq\":2,\"event\":\"half").unwrap();
        drop(f);
        drop(run);

        let mut run = RunDir::open(tmp.path().join("run")).unwrap();
        let torn = run.torn_tail_at_open().cloned().unwrap();
        assert_eq!(torn.line, 2);
        let log = run.read_events::<Value>().unwrap();
        assert_eq!(log.events.len(), 1);
        assert_eq!(log.torn_tail, Some(torn));

        assert_eq!(run.append_event(&json!("two")).unwrap(), 2);
        let log = run.read_events::<Value>().unwrap();
        assert!(log.torn_tail.is_none());
        assert_eq!(log.events[1].event, json!("two"));
        let text = fs::read_to_string(&events).unwrap();
        assert_eq!(text.lines().count(), 2);
        assert!(text.ends_with('\n'));
    }

    #[test]
    fn corruption_before_the_last_line_fails_open() {
        let tmp = tempfile::tempdir().unwrap();
        let mut run = new_run(tmp.path());
        for i in 0..3 {
            run.append_event(&json!(i)).unwrap();
        }
        let events = tmp.path().join("run").join(EVENTS_FILE);
        let text = fs::read_to_string(&events)
            .unwrap()
            .replacen("\"seq\":2", "\"seq\":2,", 1);
        fs::write(&events, text).unwrap();
        let e = RunDir::open(tmp.path().join("run")).unwrap_err();
        assert!(e.to_string().contains("events.jsonl:2: corrupt"), "{e}");
    }

    #[test]
    fn state_from_a_newer_fleetmap_is_refused() {
        let tmp = tempfile::tempdir().unwrap();
        let mut run = new_run(tmp.path());
        run.save_state(&json!(1)).unwrap();
        let p = tmp.path().join("run").join(STATE_FILE);
        let doc = json!({"schema_version": SCHEMA_VERSION + 1, "kind": "runway-mapping",
                         "generation": 2, "journal_seq": 0, "state": 1});
        fs::write(&p, doc.to_string()).unwrap();
        let e = RunDir::open(tmp.path().join("run")).unwrap_err();
        assert!(e.to_string().contains("written by a newer fleetmap"), "{e}");
        assert!(e.to_string().contains("state.json"), "{e}");
    }

    #[test]
    fn run_json_from_a_newer_fleetmap_is_refused() {
        let tmp = tempfile::tempdir().unwrap();
        new_run(tmp.path());
        let p = tmp.path().join("run").join(META_FILE);
        let mut doc: Value = serde_json::from_slice(&fs::read(&p).unwrap()).unwrap();
        doc["schema_version"] = json!(SCHEMA_VERSION + 5);
        fs::write(&p, doc.to_string()).unwrap();
        let e = RunDir::open(tmp.path().join("run")).unwrap_err();
        assert!(matches!(e, StoreError::NewerVersion { .. }), "{e}");
    }

    #[test]
    fn state_of_another_kind_is_refused() {
        let tmp = tempfile::tempdir().unwrap();
        let mut run = new_run(tmp.path());
        run.save_state(&json!(1)).unwrap();
        let p = tmp.path().join("run").join(STATE_FILE);
        let text = fs::read_to_string(&p)
            .unwrap()
            .replace("runway-mapping", "other");
        fs::write(&p, text).unwrap();
        let e = RunDir::open(tmp.path().join("run")).unwrap_err();
        assert!(matches!(e, StoreError::KindMismatch { .. }), "{e}");
    }

    #[test]
    fn garbled_state_is_a_clear_error() {
        let tmp = tempfile::tempdir().unwrap();
        let mut run = new_run(tmp.path());
        run.save_state(&json!({"x": 1})).unwrap();
        fs::write(
            tmp.path().join("run").join(STATE_FILE),
            "{\n\"schema_version\": 1,\n  oops",
        )
        .unwrap();
        let e = RunDir::open(tmp.path().join("run")).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("state.json:3: corrupt: not valid JSON"),
            "{msg}"
        );
    }

    #[test]
    fn state_of_the_wrong_type_is_a_clear_error() {
        let tmp = tempfile::tempdir().unwrap();
        let mut run = new_run(tmp.path());
        run.save_state(&json!({"x": 1})).unwrap();
        let e = run.load_state::<Vec<u32>>().unwrap_err();
        assert!(
            e.to_string().contains("does not match the expected type"),
            "{e}"
        );
    }

    #[test]
    fn subdirectories_are_created_on_demand() {
        let tmp = tempfile::tempdir().unwrap();
        let run = new_run(tmp.path());
        assert!(!run.path().join(IMAGES_DIR).exists());
        let p = run.write_image("cell_0_0_1.png", b"png").unwrap();
        assert_eq!(fs::read(p).unwrap(), b"png");
        let p = run.write_export("map.geojson", b"{}").unwrap();
        assert!(p.starts_with(run.path().join(EXPORTS_DIR)));
        for bad in ["", "..", "a/b", "."] {
            assert!(matches!(
                run.write_export(bad, b""),
                Err(StoreError::InvalidName { .. })
            ));
        }
    }

    #[test]
    fn stale_temporary_files_are_removed_on_open() {
        let tmp = tempfile::tempdir().unwrap();
        new_run(tmp.path());
        let stale = tmp.path().join("run").join(".state.json.tmp4242");
        fs::write(&stale, "partial").unwrap();
        RunDir::open(tmp.path().join("run")).unwrap();
        assert!(!stale.exists());
    }

    #[test]
    fn unserialisable_state_is_an_error_not_a_panic() {
        let tmp = tempfile::tempdir().unwrap();
        let mut run = new_run(tmp.path());
        let mut m = std::collections::HashMap::new();
        m.insert(vec![1u8], 2u8);
        assert!(matches!(
            run.save_state(&m),
            Err(StoreError::Serialize { .. })
        ));
        assert!(matches!(
            run.append_event(&m),
            Err(StoreError::Serialize { .. })
        ));
        assert_eq!(run.last_seq(), 0);
    }
}
