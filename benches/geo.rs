//! Speed of the mission-grid conversions (`cargo bench --bench geo`).

use criterion::{Criterion, criterion_group, criterion_main};
use fleetmap_core::geo::{Cell, Grid, LatLon, utm};
use std::hint::black_box;

fn conversions(c: &mut Criterion) {
    let p = LatLon::new(37.1968, -80.5781);
    let u = utm::to_utm(p).expect("in UTM");
    c.bench_function("utm::to_utm", |b| b.iter(|| utm::to_utm(black_box(p))));
    c.bench_function("utm::from_utm", |b| b.iter(|| utm::from_utm(black_box(&u))));
    let g = Grid::new(p, 4.0).expect("grid");
    c.bench_function("Grid::cell_of", |b| {
        b.iter(|| g.cell_of(black_box(LatLon::new(37.1971, -80.5779))))
    });
    c.bench_function("Grid::cell_center", |b| {
        b.iter(|| g.cell_center(black_box(Cell::new(-3, 7))))
    });
}

/// A rectangle `len` × `width` metres rotated by 30°, centred 5 m east of the origin.
fn rotated(g: &Grid, len: f64, width: f64) -> Vec<LatLon> {
    let (s, c) = 30f64.to_radians().sin_cos();
    [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)]
        .iter()
        .map(|&(u, v)| {
            let (x, y) = (u * len, v * width);
            g.from_xy(5.0 + x * c - y * s, x * s + y * c)
                .expect("in UTM")
        })
        .collect()
}

fn coverage(c: &mut Criterion) {
    let g = Grid::new(LatLon::new(37.1968, -80.5781), 4.0).expect("grid");
    let runway = rotated(&g, 92.0, 21.0);
    c.bench_function("polygon_coverage 92x21 m, 4 m cells", |b| {
        b.iter(|| g.polygon_coverage(black_box(&runway)))
    });
    let field = rotated(&g, 1000.0, 400.0);
    let mut group = c.benchmark_group("large");
    group.sample_size(10);
    group.bench_function("polygon_coverage 1000x400 m, 4 m cells", |b| {
        b.iter(|| g.polygon_coverage(black_box(&field)))
    });
    group.finish();
}

criterion_group!(benches, conversions, coverage);
criterion_main!(benches);
