//! Criterion benchmarks of the bandit planner's IP: per-epoch solve time of the fast
//! model on the 10×10 default (Nd = 10, Nc = 5, Td = 8, Tc = 4, D = 8, 16 obstacles), on epochs
//! produced by Algorithm 1 itself (the team carried over between epochs), and the fast model
//! against the paper's plain model on the 6×6 hardware layout.
//!
//! Run: `cargo bench --bench planner`. Quantiles over many epochs: `fleetmap bench plan`.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use fleetmap::experiment::bandit::{Field, StudyConfig, run_trial};
use fleetmap_core::planner::ip::{Model, PlanOptions, solve_instance};
use fleetmap_core::planner::scenario::{Instance, Scenario};
use fleetmap_io::clock::stopwatch;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;

fn scenario(name: &str) -> Instance {
    let path = format!("{}/tests/scenarios/{name}", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).expect("shipped scenario");
    Scenario::from_json(&text)
        .expect("valid JSON")
        .instance()
        .expect("valid scenario")
}

/// Epochs 0, 10, 20, 30 and 40 of one run of Algorithm 1 on the 10×10 default.
fn default_epochs() -> Vec<(usize, Instance)> {
    let cfg = StudyConfig {
        max_epochs: 41,
        ..StudyConfig::default()
    };
    let mut rng = ChaCha8Rng::seed_from_u64(2024);
    let world = Field::default_10x10(cfg.mu_worst, cfg.theta, &mut rng);
    let mut all = Vec::new();
    run_trial(&cfg, &world, "bench", 0, 2024, 7, |inst, _| {
        all.push(inst.clone())
    });
    all.into_iter()
        .enumerate()
        .filter(|(p, _)| p % 10 == 0)
        .collect()
}

fn bench_planner(c: &mut Criterion) {
    let fast = PlanOptions::default();
    let plain = PlanOptions {
        model: Model::Plain,
        ..PlanOptions::default()
    };
    let mut g = c.benchmark_group("ip_fast_10x10_default");
    g.sample_size(20);
    for (p, inst) in default_epochs() {
        g.bench_with_input(BenchmarkId::new("epoch", p), &inst, |b, inst| {
            b.iter(|| black_box(solve_instance(inst, &fast, &stopwatch())))
        });
    }
    let first = scenario("sim-10x10.json");
    g.bench_function("scenario_file", |b| {
        b.iter(|| black_box(solve_instance(&first, &fast, &stopwatch())))
    });
    g.finish();
    let hw = scenario("hardware-6x6.json");
    let mut g = c.benchmark_group("ip_6x6_hardware");
    g.sample_size(10);
    g.bench_function("fast", |b| {
        b.iter(|| black_box(solve_instance(&hw, &fast, &stopwatch())))
    });
    g.bench_function("plain_K4", |b| {
        b.iter(|| black_box(solve_instance(&hw, &plain, &stopwatch())))
    });
    g.finish();
}

criterion_group!(benches, bench_planner);
criterion_main!(benches);
