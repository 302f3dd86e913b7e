//! Telling the cameras the definition a run accepts of an on-board measurement (pure; the
//! image intake drives it).
//!
//! A camera may not know all of the run's definition when it starts: one given a runway
//! mission whose grid origin is the first vehicle's home cannot cut its pictures on the grid
//! until it knows where that home is. The run then has the GCS announce it (an
//! [`Announcement`]: for the runway, the grid and the fingerprint of the definition it
//! accepts, DEBUG_FLOAT_ARRAY `"fm.grid"`, without a target: the autopilots forward it to
//! their companion ports) when the run starts, and again every [`REPEAT`] while a camera of
//! the run has not confirmed it, at most [`REPEATS`] times in a row. A camera confirms by
//! sending any message of that measurement with that fingerprint — its answer to the
//! announcement, or a picture's result. A camera of the run that says it has no definition
//! (fingerprint 0: restarted with its vehicle) is announced to again at once (at most once
//! per [`MIN_GAP`]) with a fresh budget of repeats; one that sends another fingerprint (an
//! older grid, or another definition: it answers an announcement with it when its
//! classifier or camera differ from the run's) is announced to again within what is left of
//! the budget, so that a camera that cannot agree is not answered forever. A camera that
//! never answers (one that does not measure on board) costs the link [`REPEATS`] frames per
//! start (the runway's grid: at most 96 bytes each), no more; cameras of vehicles not in the
//! run are not listened to.

use fleetmap_core::time::Time;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::collections::BTreeSet;
use std::time::Duration;

/// Time between two announcements while a camera has not confirmed (fleet clock).
pub(crate) const REPEAT: Duration = Duration::from_secs(3);
/// Announcements in a row without every camera confirming, after which the GCS waits for a
/// camera to speak.
pub(crate) const REPEATS: u32 = 10;
/// Shortest time between two announcements.
pub(crate) const MIN_GAP: Duration = Duration::from_secs(1);

/// The definition a run accepts on-board results of, for one measurement.
#[derive(Clone, Debug, PartialEq)]
pub struct OnboardAccept {
    /// The definition's fingerprint (what the results carry).
    pub fingerprint: u32,
    /// What to tell the cameras until each confirms the fingerprint (`None`: nothing, they
    /// were given the whole definition).
    pub announce: Option<Announcement>,
}

/// A message announcing the run's definition, and the cameras that should confirm it.
#[derive(Clone, Debug, PartialEq)]
pub struct Announcement {
    /// The message, sent untargeted (the runway's grid announcement).
    pub message: MavMessage,
    /// System ids of the vehicles whose cameras should confirm it (the run's drones).
    pub cameras: Vec<u8>,
}

/// The state of the announcements of one run's definition.
#[derive(Debug)]
pub(crate) struct Announcer {
    /// The fingerprint the cameras should confirm.
    pub(crate) fingerprint: u32,
    message: MavMessage,
    /// The cameras expected to confirm it.
    cameras: Vec<u8>,
    /// Cameras that confirmed the fingerprint.
    confirmed: BTreeSet<u8>,
    /// When to announce next (`None`: not until a camera speaks).
    next: Option<Time>,
    /// Announcements left before waiting for a camera to speak.
    left: u32,
    /// When it was last announced.
    last: Option<Time>,
    /// Announcements sent.
    pub(crate) sent: u64,
}

impl Announcer {
    /// Announce `a`, for the definition of `fingerprint`, from `now` on.
    pub(crate) fn new(fingerprint: u32, a: Announcement, now: Time) -> Announcer {
        Announcer {
            fingerprint,
            message: a.message,
            cameras: a.cameras,
            confirmed: BTreeSet::new(),
            next: Some(now),
            left: REPEATS,
            last: None,
            sent: 0,
        }
    }

    /// Whether the camera of `sysid` confirmed the definition.
    pub(crate) fn is_confirmed(&self, sysid: u8) -> bool {
        self.confirmed.contains(&sysid)
    }

    /// The camera of vehicle `sysid` said at `now` that it classifies with fingerprint `spec`
    /// (0: it has no grid).
    pub(crate) fn heard(&mut self, sysid: u8, spec: u32, now: Time) {
        if !self.cameras.contains(&sysid) {
            return;
        }
        if spec == self.fingerprint {
            self.confirmed.insert(sysid);
            return;
        }
        self.confirmed.remove(&sysid);
        if spec == 0 {
            self.left = REPEATS;
        }
        if self.left == 0 {
            return;
        }
        let soonest = self.last.map_or(now, |t| (t + MIN_GAP).max(now));
        self.next = Some(self.next.map_or(soonest, |n| n.min(soonest)));
    }

    /// When [`Announcer::handle_timeout`] has something to do.
    pub(crate) fn poll_timeout(&self) -> Option<Time> {
        self.next
    }

    /// At `now`: the announcement, when one is due.
    pub(crate) fn handle_timeout(&mut self, now: Time) -> Option<MavMessage> {
        if self.next.is_none_or(|t| t > now) {
            return None;
        }
        let waiting = self.cameras.iter().any(|s| !self.confirmed.contains(s));
        if !waiting || self.left == 0 {
            self.next = None;
            return None;
        }
        self.left -= 1;
        self.last = Some(now);
        self.next = Some(now + REPEAT);
        self.sent += 1;
        Some(self.message.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fleetmap_core::geo::{Grid, LatLon};
    use fleetmap_core::vision::camera::CameraModel;
    use fleetmap_core::vision::runway::RunwayParams;
    use fleetmap_core::vision::runway::onboard::RunwaySpec;

    /// The runway's grid, announced to cameras 1 and 2.
    fn announcer(now: Time) -> Announcer {
        let spec = RunwaySpec {
            params: RunwayParams::default(),
            camera: CameraModel::paper(),
            grid: Grid::new(LatLon::new(37.0, -80.0), 4.0).unwrap(),
        };
        let a = Announcement {
            message: spec.announcement().to_message(),
            cameras: vec![1, 2],
        };
        Announcer::new(spec.fingerprint(), a, now)
    }

    fn run(a: &mut Announcer, from: u64, to: u64) -> Vec<u64> {
        let mut sent = Vec::new();
        for ms in (from..=to).step_by(100) {
            if a.handle_timeout(Time::from_millis(ms)).is_some() {
                sent.push(ms);
            }
        }
        sent
    }

    /// Announced at once and every 3 s until both cameras confirm; at most ten times in a
    /// row; again at once (after the minimum gap) when a camera says it has another
    /// definition.
    #[test]
    fn announces_until_every_camera_confirms() {
        let mut a = announcer(Time::ZERO);
        let fp = a.fingerprint;
        assert_eq!(run(&mut a, 0, 6_000), vec![0, 3_000, 6_000]);
        a.heard(1, fp, Time::from_millis(6_500));
        assert_eq!(run(&mut a, 6_100, 9_000), vec![9_000]);
        a.heard(2, fp, Time::from_millis(9_500));
        assert!(a.is_confirmed(2));
        assert_eq!(run(&mut a, 9_100, 30_000), Vec::<u64>::new());
        assert_eq!(a.poll_timeout(), None);
        // camera 2 rebooted and has no grid: at once
        a.heard(2, 0, Time::from_millis(40_000));
        assert!(!a.is_confirmed(2));
        assert_eq!(run(&mut a, 40_000, 43_000), vec![40_000, 43_000]);
        // heard again right after an announcement: not before the minimum gap
        a.heard(2, 0, Time::from_millis(43_200));
        assert_eq!(a.poll_timeout(), Some(Time::from_millis(44_000)));
        // a camera that never answers: ten announcements, then silence
        let mut b = announcer(Time::ZERO);
        assert_eq!(run(&mut b, 0, 100_000).len() as u32, REPEATS);
        assert_eq!(b.sent, u64::from(REPEATS));
        // one that answers every announcement with another definition: within the budget
        let mut c = announcer(Time::ZERO);
        let mut sent = 0;
        for ms in (0..100_000u64).step_by(100) {
            if c.handle_timeout(Time::from_millis(ms)).is_some() {
                sent += 1;
                c.heard(1, 12_345, Time::from_millis(ms + 50));
            }
        }
        assert_eq!(sent, REPEATS);
        // a vehicle that is not in the run is not listened to
        c.heard(9, 0, Time::from_secs(200));
        assert_eq!(c.poll_timeout(), None);
    }
}
