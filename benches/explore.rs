//! Benchmarks of the exploration module: one Algorithm 1 run on a random ROI (the unit of
//! `fleetmap experiment dfs`), the explorer's per-call cost, and lawnmower planning.

use criterion::{Criterion, criterion_group, criterion_main};
use fleetmap_core::explore::dfs::Sharing;
use fleetmap_core::explore::lawnmower::{HeadingPolicy, LawnmowerConfig, LocalBox, plan};
use fleetmap_core::explore::simulate::{SimConfig, random_roi, simulate};
use fleetmap_core::vision::camera::CameraModel;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;

fn dfs(c: &mut Criterion) {
    let (roi, start) = random_roi(&mut ChaCha8Rng::seed_from_u64(3), 120);
    for (name, robots, sharing) in [
        ("dfs_120_cells_1_robot_gcs", 1, Sharing::Gcs),
        ("dfs_120_cells_20_robots_gcs", 20, Sharing::Gcs),
        ("dfs_120_cells_20_robots_meet", 20, Sharing::Meet),
    ] {
        let cfg = SimConfig {
            robots,
            sharing,
            roi_velocity: (0.0, 0.4),
            ..SimConfig::default()
        };
        c.bench_function(name, |b| {
            b.iter(|| simulate(black_box(&roi), start, &cfg).unwrap().cost)
        });
    }
    let (big, bstart) = random_roi(&mut ChaCha8Rng::seed_from_u64(4), 2000);
    let cfg = SimConfig {
        robots: 32,
        ..SimConfig::default()
    };
    c.bench_function("dfs_2000_cells_32_robots_gcs", |b| {
        b.iter(|| simulate(black_box(&big), bstart, &cfg).unwrap().cost)
    });
}

fn lawnmower(c: &mut Criterion) {
    let cfg = LawnmowerConfig {
        area: LocalBox {
            east_min: -200.0,
            east_max: 200.0,
            north_min: -100.0,
            north_max: 300.0,
        },
        camera: CameraModel::paper(),
        altitudes_m: vec![12.0, 14.0, 16.0],
        speed_mps: 1.0,
        heading: HeadingPolicy::Any,
        position_tolerance_m: 1.0,
        lane_spacing_m: None,
        hold_s: 0.0,
        return_to_launch: true,
    };
    c.bench_function("lawnmower_400m_box_3_robots", |b| {
        b.iter(|| {
            plan(black_box(&cfg), |e, n| {
                Ok::<_, std::convert::Infallible>(fleetmap_core::geo::local::offset(
                    37.0, -80.0, n, e,
                ))
            })
            .unwrap()
            .len()
        })
    });
}

criterion_group!(benches, dfs, lawnmower);
criterion_main!(benches);
