//! Mission transfers in virtual time: the GCS's sans-IO mission client
//! ([`fleetmap_core::proto::mission::MissionClient`]) against the simulator's vehicle-side mission
//! protocol ([`MissionServer`], ArduPilot or PX4 behaviour) over a simulated network that
//! loses, duplicates and delays messages. Used by `fleetmap bench transfer` (round-trip times
//! of a mission at given losses) and by `tests/suite/mavlink_proto.rs` (the transfer property).
//!
//! Pure and deterministic: no sockets, no clock reads, no async runtime. Time is virtual
//! ([`Time`], starting at zero) and jumps from one event to the next (a message arriving, a
//! protocol timer firing), so an hour of retries on a bad radio takes milliseconds to
//! compute, and the elapsed times are what an operator would wait on a radio link with those
//! faults. The same seed, faults and operations give the same deliveries and times.
//!
//! The network ([`Net`]) works on whole decoded messages, each direction independently: a
//! message is lost with probability [`NetFaults::loss`]; otherwise it is delivered once, or
//! twice with probability [`NetFaults::dup`], each copy after [`NetFaults::latency_ms`] plus
//! a delay drawn uniformly from 0 to [`NetFaults::jitter_ms`] (so copies and consecutive
//! messages may overtake each other when there is jitter).

use crate::flavour::SimAutopilot;
use crate::mission_server::{self, HomeItem, MissionServer};
use fleetmap_core::mission::item::{MissionItem, MissionType};
use fleetmap_core::mission::wire::{ItemsDiffer, compare_items};
use fleetmap_core::proto::Endpoint;
use fleetmap_core::proto::mission::{
    MissionClient, MissionConfig, MissionError, MissionEvent, MissionOp, MissionOutcome,
};
use fleetmap_core::time::Time;
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega::{MISSION_CURRENT_DATA, MavMessage, MavMissionResult};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use std::collections::BinaryHeap;
use std::time::Duration;

/// The simulated vehicle's MAVLink address (system 1, autopilot component 1).
pub const VEHICLE: Endpoint = Endpoint::new(1, fleetmap_core::proto::AUTOPILOT_COMPID);

/// The header of what the GCS sends (system 255, component 190, as [`Endpoint::gcs`]).
pub(crate) const GCS_HEADER: MavHeader = MavHeader {
    system_id: fleetmap_core::proto::GCS_SYSID as u32,
    component_id: fleetmap_core::proto::GCS_COMPID,
    sequence: 0,
};

/// The header of what the vehicle sends ([`VEHICLE`]).
pub(crate) const VEHICLE_HEADER: MavHeader = MavHeader {
    system_id: 1,
    component_id: fleetmap_core::proto::AUTOPILOT_COMPID,
    sequence: 0,
};

/// Home the simulated ArduPilot keeps in mission slot 0 (near the runway of the papers,
/// 600 m above mean sea level).
pub const HOME: HomeItem = HomeItem {
    lat_e7: 371_950_000,
    lon_e7: -805_800_000,
    alt_amsl_m: 600.0,
};

/// Faults of the simulated network, the same in each direction.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct NetFaults {
    /// Probability (0–1) that a message is lost.
    pub loss: f64,
    /// Probability (0–1) that a message that is not lost is delivered twice.
    pub dup: f64,
    /// Fixed one-way delay of every copy, milliseconds.
    pub latency_ms: u64,
    /// Extra one-way delay of each copy, drawn uniformly from 0 to this many milliseconds
    /// (inclusive): messages overtake each other when it is larger than their spacing.
    pub jitter_ms: u64,
}

impl NetFaults {
    #[cfg(test)]
    /// A network that delivers everything, at once and in order.
    pub(crate) const PERFECT: NetFaults = NetFaults {
        loss: 0.0,
        dup: 0.0,
        latency_ms: 0,
        jitter_ms: 0,
    };
}

/// A copy of a message on its way.
#[derive(PartialEq, Eq)]
struct InFlight {
    /// Arrival time.
    at: Time,
    /// Send order (ties in `at` are delivered in send order).
    order: u64,
    /// GCS → vehicle (else vehicle → GCS).
    to_vehicle: bool,
    /// Index in [`Net::msgs`].
    idx: usize,
}

impl Ord for InFlight {
    // Reversed: the max-heap pops the earliest arrival first.
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        (o.at, o.order).cmp(&(self.at, self.order))
    }
}

impl PartialOrd for InFlight {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}

/// The simulated network between the GCS and the vehicle (both directions).
pub struct Net {
    rng: ChaCha8Rng,
    faults: NetFaults,
    heap: BinaryHeap<InFlight>,
    msgs: Vec<MavMessage>,
    order: u64,
    /// Drop this many MISSION_ACK ACCEPTED from the vehicle, whatever the faults (lost final
    /// ACKs, for tests).
    pub drop_accepts: u32,
    /// Messages handed to the network.
    pub sent: u64,
    /// Messages lost (by [`NetFaults::loss`] or [`Net::drop_accepts`]).
    pub lost: u64,
    /// Messages delivered twice.
    pub duplicated: u64,
}

impl Net {
    /// A network with `faults`, its random draws seeded with `seed`.
    pub fn new(seed: u64, faults: NetFaults) -> Net {
        Net {
            rng: ChaCha8Rng::seed_from_u64(seed),
            faults,
            heap: BinaryHeap::new(),
            msgs: Vec::new(),
            order: 0,
            drop_accepts: 0,
            sent: 0,
            lost: 0,
            duplicated: 0,
        }
    }

    /// The faults of this network.
    pub fn faults(&self) -> NetFaults {
        self.faults
    }

    /// `msg` enters the network at `now`, towards the vehicle or towards the GCS.
    pub fn send(&mut self, msg: MavMessage, to_vehicle: bool, now: Time) {
        self.sent += 1;
        if let MavMessage::MISSION_ACK(a) = &msg
            && !to_vehicle
            && a.mavtype == MavMissionResult::MAV_MISSION_ACCEPTED
            && self.drop_accepts > 0
        {
            self.drop_accepts -= 1;
            self.lost += 1;
            return;
        }
        if self.rng.random_bool(self.faults.loss) {
            self.lost += 1;
            return;
        }
        let copies = if self.rng.random_bool(self.faults.dup) {
            self.duplicated += 1;
            2
        } else {
            1
        };
        for _ in 0..copies {
            let delay = self.faults.latency_ms + self.rng.random_range(0..=self.faults.jitter_ms);
            self.msgs.push(msg.clone());
            self.order += 1;
            self.heap.push(InFlight {
                at: now + Duration::from_millis(delay),
                order: self.order,
                to_vehicle,
                idx: self.msgs.len() - 1,
            });
        }
    }

    /// When the next copy arrives, if any is on its way.
    pub(crate) fn next_arrival(&self) -> Option<Time> {
        self.heap.peek().map(|f| f.at)
    }

    /// The next copy that has arrived by `now`: the message and whether it goes to the
    /// vehicle.
    pub(crate) fn poll(&mut self, now: Time) -> Option<(MavMessage, bool)> {
        if self.heap.peek().is_none_or(|f| f.at > now) {
            return None;
        }
        let f = self.heap.pop()?;
        let msg = self.msgs.get(f.idx)?.clone();
        Some((msg, f.to_vehicle))
    }
}

/// The harness itself misbehaved (a bug in the protocol machines, never a lossy link).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum HarnessError {
    /// No timer set and no message on its way, yet the operation has not finished.
    #[error("nothing left to happen: a hang (mission {op} after {:.3} s)", elapsed.as_secs_f64())]
    Hang {
        /// The operation (upload, download, …).
        op: &'static str,
        /// Virtual time since the operation was started.
        elapsed: Duration,
    },
    /// The operation is still running after [`MissionClient::budget`].
    #[error("operation still running after its budget of {budget:?}")]
    OverBudget {
        /// The operation's budget.
        budget: Duration,
    },
}

/// One operation run to completion.
#[derive(Clone, Debug, PartialEq)]
pub struct Transfer {
    /// What the client reported.
    pub result: Result<MissionOutcome, MissionError>,
    /// Virtual time from the start of the operation (queued behind the client's settle time)
    /// to its result.
    pub elapsed: Duration,
    /// Times the transfer started over from scratch ([`MissionEvent::Restarted`]).
    pub restarts: u32,
}

/// An upload followed by a download of the same list.
#[derive(Clone, Debug, PartialEq)]
pub struct RoundTrip {
    /// The upload.
    pub upload: Transfer,
    /// The download that followed it.
    pub download: Transfer,
    /// `Ok` when both succeeded and the items read back are the items sent (as
    /// [`compare_items`] judges, with ArduPilot's dropped parameters allowed); otherwise what
    /// went wrong.
    pub verdict: Result<(), RoundTripFailure>,
}

/// What went wrong in a [`RoundTrip`].
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RoundTripFailure {
    /// Both transfers succeeded but the items read back differ from those sent
    /// ([`compare_items`]'s description of the first difference).
    #[error("read back differs: {0}")]
    Differs(ItemsDiffer),
    /// The download succeeded without producing items.
    #[error("download produced {0:?}")]
    NotDownloaded(MissionOutcome),
    /// The upload, the download or both failed.
    #[error(
        "upload {} / download {}",
        .upload.as_ref().map_or("ok".into(), |e| e.to_string()),
        .download.as_ref().map_or("ok".into(), |e| e.to_string())
    )]
    Failed {
        /// Why the upload failed (`None`: it succeeded).
        upload: Option<MissionError>,
        /// Why the download failed (`None`: it succeeded).
        download: Option<MissionError>,
    },
}

impl RoundTrip {
    /// Virtual time of upload and download together.
    pub fn elapsed(&self) -> Duration {
        self.upload.elapsed + self.download.elapsed
    }

    /// Restarts of upload and download together.
    pub fn restarts(&self) -> u32 {
        self.upload.restarts + self.download.restarts
    }
}

fn op_name(op: &MissionOp) -> &'static str {
    match op {
        MissionOp::Upload { .. } => "upload",
        MissionOp::Download { .. } => "download",
        MissionOp::Clear { .. } => "clear",
        MissionOp::SetCurrent { .. } => "set current",
    }
}

/// The GCS's mission client, the vehicle's mission server and the network between them, on
/// one virtual clock.
pub struct TransferBench {
    /// The GCS side (default [`MissionConfig`] unless built with [`TransferBench::with_config`]).
    pub client: MissionClient,
    /// The vehicle side (home [`HOME`]).
    pub server: MissionServer,
    /// The network.
    pub net: Net,
    /// The virtual clock: the time of the last event handled.
    pub now: Time,
}

impl TransferBench {
    /// A vehicle running `autopilot`'s mission protocol behind a network with `faults`
    /// seeded with `seed`, and a client with the default [`MissionConfig`].
    pub fn new(autopilot: SimAutopilot, seed: u64, faults: NetFaults) -> TransferBench {
        TransferBench::with_config(autopilot, seed, faults, MissionConfig::default())
    }

    /// As [`TransferBench::new`] with the client's timeouts `cfg`.
    pub fn with_config(
        autopilot: SimAutopilot,
        seed: u64,
        faults: NetFaults,
        cfg: MissionConfig,
    ) -> TransferBench {
        let mut server = MissionServer::new(autopilot, VEHICLE.sysid, VEHICLE.compid);
        server.set_home(Some(HOME));
        let home_item = autopilot == SimAutopilot::ArduPilot;
        TransferBench {
            client: MissionClient::new(Endpoint::gcs(), VEHICLE, home_item, cfg),
            server,
            net: Net::new(seed, faults),
            now: Time::ZERO,
        }
    }

    /// Whether the vehicle keeps home in mission slot 0 (ArduPilot).
    pub fn ardupilot(&self) -> bool {
        self.server.autopilot() == SimAutopilot::ArduPilot
    }

    /// Run one operation to completion in virtual time. A MISSION_SET_CURRENT the vehicle
    /// accepts is confirmed with MISSION_CURRENT at once, as the vehicle logic would.
    pub fn run(&mut self, op: MissionOp) -> Result<Transfer, HarnessError> {
        let name = op_name(&op);
        let budget = MissionClient::budget(self.client.config(), &op);
        let start = self.now;
        let id = self.client.start(op, start);
        let mut restarts = 0;
        loop {
            while let Some(m) = self.client.poll_transmit() {
                self.net.send(m, true, self.now);
            }
            while let Some(m) = self.server.poll_transmit() {
                self.net.send(m, false, self.now);
            }
            while let Some(ev) = self.server.poll_event() {
                if let mission_server::MissionEvent::SetCurrent { seq } = ev {
                    self.server.set_current(seq);
                    let total = self.server.items(MissionType::Mission).len() as u16;
                    let m = MavMessage::MISSION_CURRENT(MISSION_CURRENT_DATA {
                        seq,
                        total,
                        ..Default::default()
                    });
                    self.net.send(m, false, self.now);
                }
            }
            while let Some(ev) = self.client.poll_event() {
                match ev {
                    MissionEvent::Done { id: i, result } if i == id => {
                        return Ok(Transfer {
                            result,
                            elapsed: self.now - start,
                            restarts,
                        });
                    }
                    MissionEvent::Restarted { id: i, .. } if i == id => restarts += 1,
                    _ => {}
                }
            }
            let next = [
                self.client.poll_timeout(),
                self.server.poll_timeout(),
                self.net.next_arrival(),
            ]
            .into_iter()
            .flatten()
            .min();
            let Some(t) = next else {
                return Err(HarnessError::Hang {
                    op: name,
                    elapsed: self.now - start,
                });
            };
            self.now = t.max(self.now);
            if self.now - start > budget {
                return Err(HarnessError::OverBudget { budget });
            }
            while let Some((msg, to_vehicle)) = self.net.poll(self.now) {
                if to_vehicle {
                    self.server.handle_message(&GCS_HEADER, &msg, self.now);
                } else {
                    self.client.handle_message(&VEHICLE_HEADER, &msg, self.now);
                }
            }
            if self.client.poll_timeout().is_some_and(|c| c <= self.now) {
                self.client.handle_timeout(self.now);
            }
            if self.server.poll_timeout().is_some_and(|c| c <= self.now) {
                self.server.handle_timeout(self.now);
            }
        }
    }

    /// Upload `items` as the mission, then download the mission, and compare what came back
    /// with what was sent.
    pub fn round_trip(&mut self, items: &[MissionItem]) -> Result<RoundTrip, HarnessError> {
        let upload = self.run(MissionOp::Upload {
            kind: MissionType::Mission,
            items: items.to_vec(),
            home: None,
        })?;
        let download = self.run(MissionOp::Download {
            kind: MissionType::Mission,
        })?;
        let verdict = match (&upload.result, &download.result) {
            (Ok(_), Ok(MissionOutcome::Downloaded { items: got, .. })) => {
                compare_items(items, got, self.ardupilot()).map_err(RoundTripFailure::Differs)
            }
            (Ok(_), Ok(other)) => Err(RoundTripFailure::NotDownloaded(other.clone())),
            (up, down) => Err(RoundTripFailure::Failed {
                upload: up.as_ref().err().cloned(),
                download: down.as_ref().err().cloned(),
            }),
        };
        Ok(RoundTrip {
            upload,
            download,
            verdict,
        })
    }
}

/// `n` items that list `t` accepts, generated from `seed`: for the mission a takeoff, then
/// waypoints (with hold times of 0–2 s) interleaved with image captures and speed changes,
/// and a DO_JUMP back to item 1 last (when `n` > 4); for the fence one inclusion polygon of
/// `max(n, 3)` vertices; for rally `n` rally points. All around 37.19° N, 80.58° W.
pub fn items_for(t: MissionType, n: usize, seed: u64) -> Vec<MissionItem> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut v = Vec::new();
    match t {
        MissionType::Mission => {
            v.push(MissionItem::takeoff(12.0));
            let mut i = 0;
            while v.len() < n {
                let lat = 37.19 + rng.random_range(0.0..0.01);
                let lon = -80.58 + rng.random_range(0.0..0.01);
                let mut w = MissionItem::waypoint(lat, lon, 10.0 + (i % 7) as f32);
                w.param1 = rng.random_range(0..3) as f32;
                v.push(w);
                match i % 11 {
                    3 => v.push(MissionItem::image_start_capture(0.0, 1)),
                    7 => v.push(MissionItem::change_speed(rng.random_range(1..5) as f32)),
                    _ => {}
                }
                i += 1;
            }
            v.truncate(n);
            if n > 4 {
                v[n - 1] = MissionItem::jump(1, 2);
            }
        }
        MissionType::Fence => {
            let k = n.max(3);
            for j in 0..k {
                let a = j as f64 / k as f64 * std::f64::consts::TAU;
                let mut p =
                    MissionItem::at(5001, 37.19 + 0.001 * a.cos(), -80.58 + 0.001 * a.sin(), 0.0);
                p.param1 = k as f32;
                v.push(p);
            }
        }
        MissionType::Rally => {
            for _ in 0..n {
                v.push(MissionItem::at(
                    5100,
                    37.19 + rng.random_range(0.0..0.01),
                    -80.58 + rng.random_range(0.0..0.01),
                    rng.random_range(10..40) as f32,
                ));
            }
        }
    }
    v
}

/// Round trips of one autopilot at one set of faults, summarised.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TrialSummary {
    /// Round trips run.
    pub trials: u32,
    /// Round trips that ended with the items sent read back.
    pub successes: u32,
    /// Median virtual round-trip time of the successful round trips, seconds (mean of the two
    /// middle ones for an even count); `None` without a success.
    pub median_s: Option<f64>,
    /// 90th percentile (nearest rank) of the same, seconds.
    pub p90_s: Option<f64>,
    /// Longest successful round trip, seconds.
    pub max_s: Option<f64>,
    /// Median virtual time of the upload alone in the successful round trips, seconds.
    pub upload_median_s: Option<f64>,
    /// Median virtual time of the download alone in the successful round trips, seconds.
    pub download_median_s: Option<f64>,
    /// Restarts from scratch ([`MissionEvent::Restarted`]) over all round trips, failed ones
    /// included.
    pub restarts: u32,
    /// Why the first few failed round trips failed (at most 5, with their trial index).
    pub failures: Vec<String>,
}

/// The median of sorted `v` (mean of the two middle values for an even length).
fn median(v: &[f64]) -> Option<f64> {
    let n = v.len();
    match n {
        0 => None,
        _ if n % 2 == 1 => Some(v[n / 2]),
        _ => Some((v[n / 2 - 1] + v[n / 2]) / 2.0),
    }
}

/// The `p`-th percentile (0–100) of sorted `v`, nearest rank.
fn percentile(v: &[f64], p: f64) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    let rank = ((p / 100.0) * v.len() as f64).ceil() as usize;
    Some(v[rank.clamp(1, v.len()) - 1])
}

/// `trials` round trips of an `items`-item mission with `autopilot` over a network with
/// `faults`: trial k uses a fresh vehicle and network seeded with `seed + k` and the mission
/// [`items_for`]`(Mission, items, k)`.
pub fn run_trials(
    autopilot: SimAutopilot,
    faults: NetFaults,
    items: usize,
    trials: u32,
    seed: u64,
) -> Result<TrialSummary, HarnessError> {
    let mut times = Vec::new();
    let mut uploads = Vec::new();
    let mut downloads = Vec::new();
    let mut restarts = 0;
    let mut failures = Vec::new();
    for k in 0..trials {
        let mut bench = TransferBench::new(autopilot, seed.wrapping_add(u64::from(k)), faults);
        let sent = items_for(MissionType::Mission, items, u64::from(k));
        let rt = bench.round_trip(&sent)?;
        restarts += rt.restarts();
        match &rt.verdict {
            Ok(()) => {
                times.push(rt.elapsed().as_secs_f64());
                uploads.push(rt.upload.elapsed.as_secs_f64());
                downloads.push(rt.download.elapsed.as_secs_f64());
            }
            Err(why) if failures.len() < 5 => failures.push(format!(
                "trial {k} (after {:.1} s): {why}",
                rt.elapsed().as_secs_f64()
            )),
            Err(_) => {}
        }
    }
    for v in [&mut times, &mut uploads, &mut downloads] {
        v.sort_by(f64::total_cmp);
    }
    Ok(TrialSummary {
        trials,
        successes: times.len() as u32,
        median_s: median(&times),
        p90_s: percentile(&times, 90.0),
        max_s: times.last().copied(),
        upload_median_s: median(&uploads),
        download_median_s: median(&downloads),
        restarts,
        failures,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_perfect_network_round_trips_at_once_for_both_autopilots() {
        for ap in [SimAutopilot::ArduPilot, SimAutopilot::Px4] {
            let mut b = TransferBench::new(ap, 1, NetFaults::PERFECT);
            let rt = b
                .round_trip(&items_for(MissionType::Mission, 20, 1))
                .expect("no hang");
            assert_eq!(rt.verdict, Ok(()), "{ap:?}");
            assert_eq!(rt.restarts(), 0);
            // Only the client's settle time before each operation: no message waits.
            assert!(rt.elapsed() <= Duration::from_secs(1), "{:?}", rt.elapsed());
        }
    }

    #[test]
    fn percentiles_are_nearest_rank_and_the_median_averages_the_middle() {
        let v: Vec<f64> = (1..=10).map(f64::from).collect();
        assert_eq!(median(&v), Some(5.5));
        assert_eq!(percentile(&v, 90.0), Some(9.0));
        assert_eq!(percentile(&v[..1], 90.0), Some(1.0));
        assert_eq!(median(&[]), None);
    }

    #[test]
    fn trials_are_deterministic() {
        let f = NetFaults {
            loss: 0.3,
            dup: 0.05,
            latency_ms: 20,
            jitter_ms: 0,
        };
        let a = run_trials(SimAutopilot::Px4, f, 30, 3, 7).expect("no hang");
        let b = run_trials(SimAutopilot::Px4, f, 30, 3, 7).expect("no hang");
        assert_eq!(a, b);
        assert_eq!(a.trials, 3);
    }
}
