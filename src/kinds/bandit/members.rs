//! Members out of the run (a drone that could not take off, a station that could not drive:
//! [`fleetmap_core::planner::sortie::Sidelined`]): taking them back once their telemetry says
//! they are ready, and waiting for them when the run cannot go on without them.

use super::error::BanditError;
use super::pilot::dock;
use super::*;
use crate::app::error::RunnerResult;

impl Runner {
    /// Whether member `sysid` is ready to take part again, by its telemetry: heard, booted,
    /// ready to arm (or armed), and — a drone — standing on a station's cell.
    pub(super) async fn ready_again(&self, sysid: u8) -> bool {
        let Some(v) = self.fleet().vehicle(sysid) else {
            return false;
        };
        let now = self.fleet().clock().now();
        let on_station = self
            .shared
            .read(|s| {
                let i = s.drones.iter().position(|m| m.sysid == sysid);
                i.is_none_or(|i| {
                    s.config
                        .drones
                        .get(i)
                        .is_some_and(|c| s.config.stations.contains(c))
                })
            })
            .await;
        v.alive && !v.booting && (v.armed || v.arm_blockers(now).is_empty()) && on_station
    }

    /// A drone out that stands off every station (its autopilot's failsafe landed it where it
    /// was, [`DronePilot::taken_home`]) and is ready to fly again with the charge a sortie
    /// needs (its battery swapped): fly it to the nearest station with a free charger and land
    /// it there, so that it can be planned again (every sensing cycle starts on a station,
    /// 9d). Returns whether it now stands on a station, ready.
    pub(super) async fn fly_to_a_station(&self, sysid: u8) -> RunnerResult<bool> {
        let Some(v) = self.fleet().vehicle(sysid) else {
            return Ok(false);
        };
        let now = self.fleet().clock().now();
        let (off_station, need, alt, stations, capacity) = self
            .shared
            .read(|s| {
                let i = s.drones.iter().position(|m| m.sysid == sysid);
                let need = charge_needed_pct(s, observed_sortie_s(s));
                let alt = i.map_or(10.0, |i| s.drones[i].altitude_m);
                // (station, its cell, drones on it)
                let stations: Vec<(u8, Cell, usize)> = s
                    .stations
                    .iter()
                    .zip(&s.config.stations)
                    .filter(|(m, _)| !s.is_out(m.sysid))
                    .map(|(m, &c)| {
                        (
                            m.sysid,
                            c,
                            s.config.drones.iter().filter(|&&d| d == c).count(),
                        )
                    })
                    .collect();
                let off = i.is_some_and(|i| {
                    s.config
                        .drones
                        .get(i)
                        .is_some_and(|c| !s.config.stations.contains(c))
                });
                (off, need, alt, stations, s.params.capacity)
            })
            .await;
        let ready = v.alive
            && !v.booting
            && !v.armed
            && v.arm_blockers(now).is_empty()
            && v.flavour.flies()
            && v.battery_pct.is_some_and(|p| f64::from(p) >= need);
        if !ready || !off_station {
            return Ok(false);
        }
        // the nearest station in the run with a free charger
        let free = |st: u8| {
            stations
                .iter()
                .any(|&(s, _, n)| s == st && capacity.is_none_or(|c| n < c))
        };
        let Some((station, cell, taken)) = self
            .nearest_station_to(sysid, free)
            .await
            .and_then(|(_, st)| stations.iter().find(|(s, _, _)| *s == st).copied())
        else {
            return Ok(false);
        };
        self.say(
            Progress::notice(format!(
                "drone {sysid}: ready again ({} %), off every station: flying it to station \
                 {station}",
                v.battery_pct.unwrap_or(0)
            ))
            .about(sysid),
        );
        let slot = (taken, capacity.unwrap_or(taken + 1).max(taken + 1));
        let flown = async {
            flight::ensure_airborne(self.fleet(), sysid, alt as f32, self.shared.patience).await?;
            dock(&self.shared, sysid, station, alt, slot).await
        }
        .await;
        if let Err(e) = flown {
            self.say(
                Progress::warning(format!(
                    "drone {sysid}: flying it to station {station}: {}",
                    crate::app::error::chain(&e)
                ))
                .about(sysid),
            );
            return Ok(false);
        }
        self.shared
            .commit(|s| {
                s.relocate_drone(sysid, cell)?;
                Ok(((), Vec::new()))
            })
            .await?;
        Ok(self.ready_again(sysid).await)
    }

    /// Take back the members out whose wait is over and that are ready again (journalled,
    /// told); returns how many.
    pub(super) async fn members_back(&self) -> RunnerResult<usize> {
        let eligible = self.shared.read(|s| s.eligible()).await;
        let mut back = 0;
        for sysid in eligible {
            if !self.ready_again(sysid).await && !self.fly_to_a_station(sysid).await? {
                continue;
            }
            let was = self
                .shared
                .commit(|s| {
                    let was = s
                        .out
                        .get(&sysid)
                        .map(|o| o.reason.clone())
                        .unwrap_or_default();
                    s.reinstate(sysid);
                    Ok((was.clone(), vec![BanditEvent::VehicleBack { sysid, was }]))
                })
                .await?;
            back += 1;
            self.say(
                Progress::notice(format!(
                    "vehicle {sysid} is ready again and rejoins the run (it was out: {was})"
                ))
                .about(sysid),
            );
        }
        Ok(back)
    }

    /// Every drone is out: no sortie can fly. Wait for those a retry may bring back; stop
    /// when a person must fix every one of them.
    pub(super) async fn need_a_drone(&self) -> RunnerResult<()> {
        if self.shared.read(|s| s.active_drones().is_empty()).await {
            self.wait_for_members("no drone can fly").await?;
        }
        Ok(())
    }

    /// The run cannot go on without members that are out (`why`): wait for them — every
    /// member out is tried again, with a back-off of 5 s doubling to 80 s, for at most 20
    /// tries (about 20 minutes of the fleet's time, scaled by the patience) — until one
    /// rejoins. Stops at once, saying what to fix, when a person must fix every one of them,
    /// and after the last try.
    pub(super) async fn wait_for_members(&self, why: &str) -> RunnerResult<()> {
        const TRIES: u32 = 20;
        for attempt in 0..TRIES {
            let outs: Vec<(u8, Sidelined)> = self
                .shared
                .read(|s| s.out.iter().map(|(k, v)| (*k, v.clone())).collect())
                .await;
            let list = || {
                outs.iter()
                    .map(|(sysid, o)| {
                        format!(
                            "{} {sysid}: {}",
                            o.role,
                            o.fix.as_deref().unwrap_or(&o.reason)
                        )
                    })
                    .collect::<Vec<_>>()
                    .join("; ")
            };
            if outs.iter().all(|(_, o)| o.fix.is_some()) {
                return Err(BanditError::MembersNeedPerson {
                    why: why.to_string(),
                    members: list(),
                }
                .into());
            }
            // Every member out may be tried now.
            self.shared
                .commit(|s| {
                    for o in s.out.values_mut() {
                        o.wait_sorties = 0;
                    }
                    Ok(((), Vec::new()))
                })
                .await?;
            if self.members_back().await? > 0 {
                return Ok(());
            }
            let wait = self
                .shared
                .patience
                .secs(5.0 * f64::from(1u32 << attempt.min(4)));
            if attempt == 0 {
                self.say(Progress::warning(format!(
                    "{why}: waiting for {} to be ready again",
                    list()
                )));
            }
            tokio::time::sleep(wait).await;
        }
        let outs: Vec<String> = self
            .shared
            .read(|s| {
                s.out
                    .iter()
                    .map(|(k, o)| format!("{} {k}: {}", o.role, o.reason))
                    .collect()
            })
            .await;
        Err(BanditError::MembersNotReady {
            why: why.to_string(),
            tries: TRIES,
            members: outs.join("; "),
        }
        .into())
    }
}
