//! Synthetic models: a seeded generator of large fleets (the redraw benchmark,
//! `fleetmap bench tui`). The kinds' own samples (`fleetmap tui --sample`, the snapshot
//! tests' fixtures) are in their folders, reached through the registry (`tui::kinds`).

use super::kinds;
use crate::panes::*;
use fleetmap_core::geo::Cell;
use fleetmap_core::proto::flavour::{Autopilot, VehicleClass};
use fleetmap_core::proto::severity::Severity;
use fleetmap_core::time::Time;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A large generated fleet for benchmarks: `n` vehicles (every tenth a station) with seeded
/// random states over a 60 × 90 grid of the default kind's map (its legend's states, the
/// first two eight times as likely as the third and fourth, the fifth twice).
pub fn generated(n: usize, seed: u64) -> Model {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (rows, cols) = (60u32, 90u32);
    let look = kinds::default_look();
    let legend = look.map.legend.clone();
    let mut map = MapModel::new(look.map, 4.0, Cell::new(-30, -45), rows, cols);
    let sw = map.south_west;
    for r in 0..rows as i32 {
        for c in 0..cols as i32 {
            let i = match rng.random_range(0..20) {
                0..=7 => 0,
                8..=15 => 1,
                16 => 2,
                17 => 3,
                _ => 4,
            };
            let s = legend
                .get(i)
                .or(legend.first())
                .copied()
                .unwrap_or_default();
            map.set(Cell::new(sw.row + r, sw.col + c), s);
        }
    }
    map.home = Some(Cell::new(0, 0));
    let modes = ["AUTO", "GUIDED", "RTL", "LOITER", "LAND"];
    let fixes = [GpsFix::Fix3d, GpsFix::RtkFixed, GpsFix::Dgps, GpsFix::NoFix];
    let vehicles = (0..n)
        .map(|i| {
            let sysid = (i % 250 + 1) as u8;
            let station = i % 10 == 9;
            let cell = Cell::new(
                sw.row + rng.random_range(0..rows as i32),
                sw.col + rng.random_range(0..cols as i32),
            );
            VehicleRow {
                sysid,
                role: if station { Role::Station } else { Role::Drone },
                autopilot: if i % 3 == 0 {
                    Autopilot::Px4
                } else {
                    Autopilot::ArduPilot
                },
                vehicle_type: if station {
                    VehicleClass::Rover
                } else {
                    VehicleClass::Copter
                },
                mode: modes[rng.random_range(0..modes.len())].into(),
                armed: rng.random(),
                battery: Battery {
                    remaining_pct: Some(rng.random_range(5..=100)),
                    voltage_v: Some(rng.random_range(13.0..16.8)),
                    cells: Some(4),
                },
                gps: Gps {
                    fix: fixes[rng.random_range(0..fixes.len())],
                    satellites: Some(rng.random_range(3..25)),
                },
                alt_m: Some(rng.random_range(0.0..40.0)),
                speed_mps: Some(rng.random_range(0.0..8.0)),
                mission: Some(MissionProgress {
                    current: rng.random_range(0..40),
                    total: 40,
                }),
                link: LinkState {
                    quality_pct: Some(rng.random_range(40..=100)),
                    lost: rng.random_range(0..20) == 0,
                    last_heard_s: Some(rng.random_range(0.0..3.0)),
                    ..LinkState::default()
                },
                cell: Some(cell),
                activity: Some(format!("lane {}", i % 17)),
                camera: (!station).then(|| {
                    let heard_s = rng.random_range(0.0..6.0);
                    let pictures = rng.random_range(0..400);
                    CameraHealth {
                        heard_s,
                        silent: heard_s > 3.0,
                        pictures,
                        measurements: pictures.saturating_sub(rng.random_range(0..3)),
                    }
                }),
            }
        })
        .collect();
    let log = (0..200)
        .map(|i| LogEntry {
            time: Time::from_secs(i * 3),
            severity: Severity::from_mav(rng.random_range(0..8)),
            sysid: Some(rng.random_range(1..=n.clamp(1, 250) as u8)),
            text: format!("generated message {i} with some words to wrap in narrow panes"),
        })
        .collect();
    Model {
        time: Time::from_secs(600),
        vehicles,
        map,
        mission: MissionModel {
            name: format!("generated fleet of {n}"),
            kind: Some(look.mission),
            phase: Phase::Dfs,
            status: RunStatus::Running,
            cells_classified: 2000,
            cells_total: Some(rows * cols),
            dfs: Some(DfsProgress {
                explored: 300,
                under_exploration: 40,
                unexplored: 200,
            }),
            ..Default::default()
        },
        log,
        sim_speed: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_is_deterministic() {
        assert_eq!(generated(50, 7), generated(50, 7));
        assert_ne!(generated(50, 7), generated(50, 8));
        assert_eq!(generated(50, 7).vehicles.len(), 50);
    }
}
