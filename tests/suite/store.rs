//! End-to-end tests of the run store (`src/store`): a writer process killed with SIGKILL at
//! random moments never loses an acknowledged event or snapshot, and every way a crash can
//! cut the journal is read back correctly.
//!
//! The writer is this test binary itself: `parent` spawns it with
//! `--ignored --exact store::writer_process` and `FLEETMAP_STORE_WRITER=<run dir>` in the
//! environment (an ignored test, so that a normal `cargo test` never runs it on its own).

use crate::common;
use fleetmap::store::{RunDir, RunMeta};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::io::{BufRead, BufReader, Write};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const WRITER_ENV: &str = "FLEETMAP_STORE_WRITER";
const KIND: &str = "store-kill-test";

/// The writer's event: its content is a function of its sequence number, so the parent can
/// check every byte of every acknowledged record.
#[derive(Debug, PartialEq, Serialize, Deserialize)]
struct Ev {
    n: u64,
    pad: String,
}

fn event_for(seq: u64) -> Ev {
    // Sizes from 0 to ~48 KiB so that some writes span many pages and a kill can land
    // in the middle of one (leaving a torn tail).
    let len = (seq.wrapping_mul(7919) % 49_152) as usize;
    let c = (b'a' + (seq % 26) as u8) as char;
    Ev {
        n: seq,
        pad: std::iter::repeat_n(c, len).collect(),
    }
}

/// The writer's state snapshot.
#[derive(Debug, PartialEq, Serialize, Deserialize)]
struct St {
    counter: u64,
    last_seq: u64,
}

/// Writer mode: append events and save snapshots in a loop, printing `ack event SEQ` after
/// each acknowledged append and `ack state COUNTER` after each acknowledged save, until
/// killed (or after a safety limit, should the parent be gone).
#[test]
#[ignore = "writer process for sigkill_at_100_random_moments_loses_nothing_acknowledged"]
fn writer_process() {
    let Ok(dir) = std::env::var(WRITER_ENV) else {
        return;
    };
    let mut run = RunDir::open(&dir).expect("writer: open run");
    let mut counter = run
        .load_state::<St>()
        .expect("writer: load state")
        .map_or(0, |s| s.counter);
    let out = std::io::stdout();
    let started = Instant::now();
    for i in 0u64.. {
        let seq = run.last_seq() + 1;
        let got = run.append_event(&event_for(seq)).expect("writer: append");
        assert_eq!(got, seq);
        writeln!(out.lock(), "ack event {seq}").expect("writer: stdout");
        if i % 3 == 0 {
            counter += 1;
            run.save_state(&St {
                counter,
                last_seq: seq,
            })
            .expect("writer: save");
            writeln!(out.lock(), "ack state {counter}").expect("writer: stdout");
        }
        if started.elapsed() > Duration::from_secs(20) {
            break;
        }
    }
}

fn spawn_writer(dir: &Path) -> std::process::Child {
    let exe = std::env::current_exe().expect("test binary path");
    Command::new(exe)
        .args([
            "--ignored",
            "--exact",
            &common::test_name(module_path!(), "writer_process"),
            "--nocapture",
            "--test-threads=1",
        ])
        .env(WRITER_ENV, dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("spawn writer")
}

#[test]
fn sigkill_at_100_random_moments_loses_nothing_acknowledged() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let mut meta = RunMeta::new(KIND, 0);
    meta.connections = vec!["udpin:127.0.0.1:14550".into()];
    RunDir::create(&dir, meta, Some("name = \"kill test\"\n")).unwrap();

    let mut rng = ChaCha8Rng::seed_from_u64(0x00C0_FFEE);
    let mut acked_seq = 0u64; // every event up to this one was acknowledged
    let mut acked_counter = 0u64; // the newest acknowledged snapshot
    let mut torn_rounds = 0;
    let mut total_acks = 0u64;
    for round in 0..100 {
        let kill_after_acks = rng.random_range(0..16u32);
        let extra_delay = Duration::from_micros(rng.random_range(0..4_000u64));

        let mut child = spawn_writer(&dir);
        let stdout = child.stdout.take().unwrap();
        let mut lines = BufReader::new(stdout).lines();
        let mut acks_this_round = 0u32;
        let record = |line: &str, acked_seq: &mut u64, acked_counter: &mut u64| -> bool {
            // libtest prints "test writer_process ... " without a newline before the first ack.
            let Some(at) = line.find("ack ") else {
                return false;
            };
            let mut it = line[at..].split_whitespace();
            match (
                it.next(),
                it.next(),
                it.next().and_then(|n| n.parse::<u64>().ok()),
            ) {
                (Some("ack"), Some("event"), Some(n)) => {
                    assert_eq!(n, *acked_seq + 1, "round {round}: acks out of order");
                    *acked_seq = n;
                    true
                }
                (Some("ack"), Some("state"), Some(n)) => {
                    assert!(n > *acked_counter, "round {round}: state counter went back");
                    *acked_counter = n;
                    true
                }
                _ => false,
            }
        };
        while acks_this_round < kill_after_acks {
            let Some(Ok(line)) = lines.next() else {
                panic!("round {round}: writer ended before being killed");
            };
            if record(&line, &mut acked_seq, &mut acked_counter) {
                acks_this_round += 1;
                total_acks += 1;
            }
        }
        std::thread::sleep(extra_delay);
        child.kill().expect("SIGKILL the writer");
        child.wait().expect("reap the writer");
        // Acks the writer printed before it died but we had not read yet count too.
        for line in lines.map_while(Result::ok) {
            if record(&line, &mut acked_seq, &mut acked_counter) {
                total_acks += 1;
            }
        }

        let run = RunDir::open(&dir)
            .unwrap_or_else(|e| panic!("round {round}: the run must open after SIGKILL: {e}"));
        let log = run
            .read_events::<Ev>()
            .unwrap_or_else(|e| panic!("round {round}: the journal must load: {e}"));
        if log.torn_tail.is_some() {
            torn_rounds += 1;
        }
        assert!(
            log.events.len() as u64 >= acked_seq,
            "round {round}: {} events on disk but {acked_seq} were acknowledged",
            log.events.len()
        );
        for e in &log.events {
            assert_eq!(
                e.event,
                event_for(e.seq),
                "round {round}: event {} damaged",
                e.seq
            );
        }
        let env = run
            .load_state_envelope::<St>()
            .unwrap_or_else(|e| panic!("round {round}: the state must load: {e}"));
        if acked_counter > 0 {
            let env = env
                .as_ref()
                .unwrap_or_else(|| panic!("round {round}: acknowledged state missing"));
            assert!(
                env.state.counter >= acked_counter,
                "round {round}: state {} is older than the acknowledged {acked_counter}",
                env.state.counter
            );
            assert_eq!(env.kind, KIND);
            assert_eq!(env.state.last_seq, env.journal_seq);
            assert!(env.journal_seq <= log.events.len() as u64);
        }
        // Events written but not acknowledged before the kill are durable too from now on:
        // the next round's acks continue after them.
        acked_seq = acked_seq.max(log.events.len() as u64);
        acked_counter = acked_counter.max(env.map_or(0, |e| e.state.counter));
    }
    eprintln!(
        "store kill test: 100 kills, {total_acks} acks, {acked_seq} events, {torn_rounds} torn tails"
    );

    // After all those crashes the journal is still valid JSONL once appended to.
    let mut run = RunDir::open(&dir).unwrap();
    let seq = run.append_event(&event_for(run.last_seq() + 1)).unwrap();
    let log = run.read_events::<Ev>().unwrap();
    assert!(log.torn_tail.is_none());
    assert_eq!(log.events.len() as u64, seq);
    let text = std::fs::read_to_string(dir.join("events.jsonl")).unwrap();
    for (i, line) in text.lines().enumerate() {
        serde_json::from_str::<serde_json::Value>(line)
            .unwrap_or_else(|e| panic!("line {} is not JSON: {e}", i + 1));
    }
}

/// Every byte position at which a crash can cut the journal: the run opens, the complete
/// records are all there, a cut inside a record is reported as a torn tail, and the next
/// append leaves a valid journal.
#[test]
fn every_cut_point_of_the_journal_is_recovered() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let mut run = RunDir::create(&dir, RunMeta::new(KIND, 0), None).unwrap();
    for seq in 1..=3 {
        run.append_event(&Ev {
            n: seq,
            pad: "é\"\\\n".repeat(seq as usize),
        })
        .unwrap();
    }
    drop(run);
    let events = dir.join("events.jsonl");
    let full = std::fs::read(&events).unwrap();
    let ends: Vec<usize> = full
        .iter()
        .enumerate()
        .filter(|(_, b)| **b == b'\n')
        .map(|(i, _)| i + 1)
        .collect();
    for cut in 0..=full.len() {
        std::fs::write(&events, &full[..cut]).unwrap();
        let complete = ends.iter().filter(|&&e| e <= cut).count();
        let mut run = RunDir::open(&dir).unwrap_or_else(|e| panic!("cut {cut}: {e}"));
        let log = run.read_events::<Ev>().unwrap();
        assert_eq!(log.events.len(), complete, "cut {cut}");
        let torn = ends.iter().all(|&e| e != cut) && cut != 0;
        assert_eq!(log.torn_tail.is_some(), torn, "cut {cut}");
        if let Some(t) = &log.torn_tail {
            assert_eq!(t.line, complete + 1);
            assert_eq!(t.offset as usize + t.len as usize, cut);
        }
        let seq = run
            .append_event(&Ev {
                n: 99,
                pad: String::new(),
            })
            .unwrap();
        assert_eq!(seq as usize, complete + 1, "cut {cut}");
        let log = run.read_events::<Ev>().unwrap();
        assert!(log.torn_tail.is_none(), "cut {cut}");
        assert_eq!(log.events.last().unwrap().event.n, 99);
    }
}

/// Damage anywhere but the last record is an error that names the line.
#[test]
fn corruption_in_the_middle_is_an_error_naming_the_line() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("run");
    let mut run = RunDir::create(&dir, RunMeta::new(KIND, 0), None).unwrap();
    for seq in 1..=5 {
        run.append_event(&event_for(seq % 3)).unwrap();
    }
    drop(run);
    let events = dir.join("events.jsonl");
    let text = std::fs::read_to_string(&events).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    lines[3] = "{\"seq\":4,\"event\":{\"n\":1,\"pad\":\"b"; // cut short, then more lines follow
    std::fs::write(&events, lines.join("\n") + "\n").unwrap();
    let e = RunDir::open(&dir).unwrap_err().to_string();
    assert!(e.contains("events.jsonl:4: corrupt"), "{e}");
}
