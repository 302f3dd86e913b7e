//! Full-frame redraw time of the terminal UI (the goal: with 50 simulated vehicles the screen
//! must still redraw at least 10 times a second, i.e. a frame well under 100 ms).
//!
//! Each iteration renders the whole screen into ratatui's `TestBackend` (layout, every pane,
//! the buffer diff and the backend write), alternating between two different snapshots of a
//! generated 50-vehicle fleet so that the diff is never empty.

use criterion::{Criterion, criterion_group, criterion_main};
use fleetmap::tui::{App, Event, Source, SourceKind, UiConfig, sample, update, view};
use ratatui::Terminal;
use ratatui::backend::TestBackend;
use std::hint::black_box;

fn app_with(n: usize, seed: u64, w: u16, h: u16) -> App {
    let mut app = App::new(
        UiConfig::default(),
        Source::new(SourceKind::Bench, "BENCH generated"),
    );
    update(&mut app, Event::Resize(w, h));
    update(
        &mut app,
        Event::Snapshot(Box::new(sample::generated(n, seed))),
    );
    app
}

fn redraw(c: &mut Criterion) {
    let mut group = c.benchmark_group("tui_full_frame");
    for &(w, h) in &[(250u16, 70u16), (80, 24)] {
        for &n in &[3usize, 50] {
            let apps = [app_with(n, 1, w, h), app_with(n, 2, w, h)];
            let mut terminal = Terminal::new(TestBackend::new(w, h)).expect("test backend");
            let mut i = 0usize;
            group.bench_function(format!("{n}_vehicles_{w}x{h}"), |b| {
                b.iter(|| {
                    i += 1;
                    let app = &apps[i % 2];
                    terminal
                        .draw(|f| view::render(black_box(app), f))
                        .expect("draw");
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, redraw);
criterion_main!(benches);
