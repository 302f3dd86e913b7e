//! What a sortie meets late or not at all, in flight and after it: a station stuck on its way
//! to the rendezvous, pictures still on their way after the landings.

use super::*;
use crate::app::error::RunnerResult;

impl Runner {
    /// Follow a station driving to its rendezvous: one that has not moved
    /// [`STATION_PROGRESS_M`] in [`STATION_STUCK_S`] of the fleet's clock while its mission
    /// runs (a rover stuck in mud, on a kerb, with a wheel failed) is stuck — it is stopped
    /// (HOLD), its leg ends where it stands, the drones waiting for it land on it there rather
    /// than hover until their batteries run out, it goes out of the run for a sortie, and the
    /// rest of the epoch is planned with it held on its cell
    /// ([`ClassificationState::on_station_stuck`]). The operator is told.
    pub(super) async fn watch_station(
        &self,
        sysid: u8,
        v: &VehicleSnapshot,
        moved: &mut BTreeMap<u8, (crate::fleet::GeoPoint, fleetmap_core::time::Time)>,
    ) -> RunnerResult<()> {
        let Some(p) = v.position else {
            return Ok(());
        };
        let now = self.fleet().clock().now();
        let (from, since) = *moved.entry(sysid).or_insert((p, now));
        if local::distance(from.lat, from.lon, p.lat, p.lon) >= STATION_PROGRESS_M {
            moved.insert(sysid, (p, now));
            return Ok(());
        }
        let still = now.saturating_since(since).as_secs_f64();
        if still < STATION_STUCK_S {
            return Ok(());
        }
        moved.remove(&sysid);
        let reason = format!(
            "stuck on its way to the rendezvous: moved less than {STATION_PROGRESS_M:.0} m in \
             {still:.0} s with its mission running (mode {}, at item {})",
            v.mode,
            v.mission_current
                .map(|i| i.to_string())
                .unwrap_or_else(|| "?".into())
        );
        if let Err(e) = flight::hold_here(self.fleet(), sysid).await {
            tracing::warn!("station {sysid}: stopping it: {e}");
        }
        let epoch = self.shared.read(|s| s.bandit.epoch).await;
        self.shared
            .commit(|s| {
                s.on_station_stuck(sysid, reason.clone())?;
                let fix = s.out.get(&sysid).and_then(|o| o.fix.clone());
                Ok((
                    (),
                    vec![BanditEvent::VehicleOut {
                        sysid,
                        role: Role::Station,
                        reason: reason.clone(),
                        fix,
                        epoch,
                    }],
                ))
            })
            .await?;
        self.say(
            Progress::warning(format!(
                "station {sysid}: {reason}. Its drones land on it where it stands; the rest of \
                 the epoch is planned with it held there, and it is tried again after a sortie"
            ))
            .about(sysid),
        );
        Ok(())
    }

    /// Wait for the pictures still on their way after the drones landed, while they flow: until
    /// every capture visit has its B images, or no camera of the sortie's drones has sent
    /// anything of a picture for [`PICTURE_STALL_S`] of the fleet's clock (lost pictures
    /// stay lost), or [`PICTURE_WAIT_MAX_S`] in all. A camera slower than the samples asked
    /// (whole pictures over a radio or a slow serial port: tens of seconds each) delivers
    /// them after the landing; finishing the sortie before they arrive would drop them (they
    /// no longer match a flying sortie) and, epoch after epoch, end the run with "no
    /// measurement" while pictures were arriving. The operator is told what is awaited.
    pub(super) async fn wait_for_pictures(&self, cycle: &fleetmap_core::planner::sortie::CycleRun) {
        let drones: Vec<u8> = cycle
            .drones
            .iter()
            .filter(|d| d.flies)
            .map(|d| d.sysid)
            .collect();
        let clock = self.fleet().clock();
        let start = clock.now();
        let stall = Duration::from_secs_f64(PICTURE_STALL_S);
        let mut told = None::<fleetmap_core::time::Time>;
        loop {
            let left = self.shared.read(|s| s.captures_left()).await;
            if left == 0 {
                return;
            }
            let now = clock.now();
            let flowing: Vec<u8> = drones
                .iter()
                .copied()
                .filter(|&d| {
                    self.shared
                        .hub
                        .last_picture_traffic(d)
                        .is_some_and(|t| now.saturating_since(t) < stall)
                })
                .collect();
            let waited = now.saturating_since(start);
            if flowing.is_empty() || waited.as_secs_f64() >= PICTURE_WAIT_MAX_S {
                return;
            }
            if told.is_none_or(|t| now.saturating_since(t) >= Duration::from_secs(60)) {
                told = Some(now);
                let list: Vec<String> = flowing.iter().map(u8::to_string).collect();
                self.say(Progress::info(format!(
                    "{left} capture visit(s) short of their images after the landing: waiting \
                     while drone(s) {} still send pictures ({:.0} s so far)",
                    list.join(", "),
                    waited.as_secs_f64()
                )));
            }
            tokio::time::sleep(self.shared.patience.secs(1.0)).await;
        }
    }
}

/// A driving station must move at least this far, metres, every [`STATION_STUCK_S`]
/// ([`Runner::watch_station`]).
pub(super) const STATION_PROGRESS_M: f64 = 1.0;

/// A station that has not moved [`STATION_PROGRESS_M`] in this long (seconds of the fleet's
/// clock) with its mission running is stuck: a station mission is waypoints only (no waits),
/// and a rover at the paper's speeds covers several metres a second.
pub(super) const STATION_STUCK_S: f64 = 45.0;

/// A camera that sent nothing of a picture for this long (seconds of the fleet's clock) has
/// nothing more on its way: ten seconds cover an image receiver's requests for the missing
/// packets of a picture and the camera's answer over a lossy radio.
pub(super) const PICTURE_STALL_S: f64 = 10.0;

/// The longest a sortie waits for pictures still arriving after its drones landed, seconds
/// of the fleet's clock (30 minutes: four cells of 30 pictures of 55 kB at 5 kB/s take 22).
pub(super) const PICTURE_WAIT_MAX_S: f64 = 1800.0;
