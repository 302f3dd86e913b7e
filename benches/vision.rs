//! Criterion benchmarks of the vision module at 1920×1080 (a full-HD camera frame, the reference size):
//! the whole runway pipeline (fast path, reference path, and rayon across a batch), its
//! steps, and the green-pixel measurement. Throughput is reported in images per second
//! ("elem/s"). `scripts/bench-vs-opencv.py` runs OpenCV's pipeline on the same images in the
//! same run for the comparison.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use fleetmap::kinds::runway::classify::bench_scene;
use fleetmap_core::vision::fast;
use fleetmap_core::vision::green::{self, GreenParams};
use fleetmap_core::vision::runway::{self, RunwayParams, synth};
use rayon::prelude::*;
use std::hint::black_box;

const W: u32 = 1920;
const H: u32 = 1080;

fn images(n: usize) -> Vec<image::RgbImage> {
    (0..n)
        .into_par_iter()
        .map(|i| synth::render_runway(&bench_scene(W, H, 1, i)))
        .collect()
}

fn pipeline(c: &mut Criterion) {
    let imgs = images(8);
    let params = RunwayParams::default();
    let mut g = c.benchmark_group("runway_1920x1080");
    g.throughput(Throughput::Elements(1));
    let mut ws = fast::Workspace::default();
    let mut i = 0;
    g.bench_function("fast_single_thread", |b| {
        b.iter(|| {
            i = (i + 1) % imgs.len();
            black_box(runway::analyse_in(&mut ws, black_box(&imgs[i]), &params).ok())
        })
    });
    g.bench_function("threshold_only", |b| {
        b.iter(|| black_box(fast::threshold_bits(black_box(&imgs[0]), 150)))
    });
    let bits = fast::threshold_bits(&imgs[0], 150);
    g.bench_function("dilate_15x15_only", |b| {
        b.iter(|| black_box(fast::dilate_bits(black_box(&bits), 7)))
    });
    let gp = GreenParams::default();
    g.bench_function("green_fraction", |b| {
        b.iter(|| black_box(green::green_fraction(black_box(&imgs[0]), &gp)))
    });
    g.sample_size(10);
    g.bench_function("reference_single_thread", |b| {
        b.iter(|| black_box(runway::analyse_reference(black_box(&imgs[0]), &params).ok()))
    });
    g.finish();

    let mut g = c.benchmark_group("runway_1920x1080_batch");
    g.throughput(Throughput::Elements(imgs.len() as u64));
    g.bench_with_input(
        BenchmarkId::new("rayon", rayon::current_num_threads()),
        &imgs,
        |b, imgs| {
            b.iter(|| {
                imgs.par_iter()
                    .map_init(fast::Workspace::default, |ws, img| {
                        runway::analyse_in(ws, img, &params).ok()
                    })
                    .collect::<Vec<_>>()
            })
        },
    );
    g.finish();
}

criterion_group!(benches, pipeline);
criterion_main!(benches);
