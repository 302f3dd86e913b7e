//! The terminal UI end to end: snapshots of every pane at 80×24 and 250×70 (ratatui's
//! `TestBackend` + insta, as ratatui's own widget tests do), readability and colour checks,
//! every key of the key map driven through `update`, the confirmation flow, the async shell
//! loop with real channels, the panic hook, the `fleetmap tui` command and a run of the real
//! binary in a pseudo-terminal.

use crossterm::event::{Event as TermEvent, KeyCode, KeyEvent, KeyModifiers};
use fleetmap::panes::*;
use fleetmap::tui::view::help::{self, HelpLine};
use fleetmap::tui::*;
use fleetmap_core::proto::severity::Severity;
use fleetmap_core::time::Time;
use fleetmap_io::clock::MonotonicClock;
use fleetmap_io::watch;
use ratatui::Terminal;
use ratatui::backend::TestBackend;
use ratatui::style::{Color, Modifier};
use std::time::Duration;
use tokio::sync::mpsc;

use crate::common;
use common::pty;

/// The fixtures: the kinds' own (from their folders) and the generated fleet.
mod sample {
    pub(super) use fleetmap::kinds::bandit::sample::fixture as classification_fixture;
    pub(super) use fleetmap::kinds::runway::sample::fixture as runway_fixture;
    pub(super) use fleetmap::tui::sample::generated;
}

// ---------------------------------------------------------------- helpers

fn app_with(model: Model, w: u16, h: u16) -> App {
    let mut app = App::new(
        UiConfig::default(),
        Source::new(SourceKind::Sample, "SAMPLE: test fixture"),
    );
    update(&mut app, Event::Resize(w, h));
    update(&mut app, Event::Tick(model.time));
    update(&mut app, Event::Snapshot(Box::new(model)));
    app
}

fn draw(app: &App, w: u16, h: u16) -> Terminal<TestBackend> {
    let mut t = Terminal::new(TestBackend::new(w, h)).expect("test backend");
    t.draw(|f| view::render(app, f)).expect("draw");
    t
}

/// The screen as plain lines.
fn lines(t: &Terminal<TestBackend>) -> Vec<String> {
    let buf = t.backend().buffer();
    (0..buf.area.height)
        .map(|y| {
            (0..buf.area.width)
                .map(|x| buf[(x, y)].symbol().to_string())
                .collect::<String>()
        })
        .collect()
}

fn text(t: &Terminal<TestBackend>) -> String {
    lines(t).join("\n")
}

fn press(app: &mut App, key: Key) -> Vec<Effect> {
    update(app, Event::Key(key.to_event()))
}

fn ch(c: char) -> Key {
    Key::char(c)
}

/// Position of the first occurrence of `needle` on screen: (x, y) in cells.
fn find(t: &Terminal<TestBackend>, needle: &str) -> Option<(u16, u16)> {
    for (y, line) in lines(t).iter().enumerate() {
        if let Some(byte) = line.find(needle) {
            let x = line[..byte].chars().count();
            return Some((x as u16, y as u16));
        }
    }
    None
}

const SIZES: [(u16, u16); 2] = [(80, 24), (250, 70)];

// ---------------------------------------------------------------- snapshots

#[test]
fn snapshot_every_pane_at_both_sizes() {
    for (w, h) in SIZES {
        let tag = format!("{w}x{h}");
        // Overview: fleet + map (compact) or every pane (wide).
        let app = app_with(sample::runway_fixture(), w, h);
        insta::assert_snapshot!(format!("{tag}_runway_overview"), draw(&app, w, h).backend());

        // Mission and log panes (the compact layout shows them below the fleet on Tab).
        let mut app = app_with(sample::runway_fixture(), w, h);
        press(&mut app, Key::plain(KeyCode::Tab)); // map
        press(&mut app, Key::plain(KeyCode::Tab)); // mission
        assert_eq!(app.focus, Pane::Mission);
        insta::assert_snapshot!(format!("{tag}_runway_mission"), draw(&app, w, h).backend());
        press(&mut app, Key::plain(KeyCode::Tab)); // log
        assert_eq!(app.focus, Pane::Log);
        insta::assert_snapshot!(format!("{tag}_runway_log"), draw(&app, w, h).backend());

        // Spatial classification: keep / reject / obstacle / road and stations.
        let app = app_with(sample::classification_fixture(), w, h);
        insta::assert_snapshot!(
            format!("{tag}_classification_overview"),
            draw(&app, w, h).backend()
        );

        // Map zoomed out to fit, and zoomed in on the selected vehicle.
        let mut app = app_with(sample::runway_fixture(), w, h);
        press(&mut app, ch('f'));
        insta::assert_snapshot!(format!("{tag}_map_fit"), draw(&app, w, h).backend());
        press(&mut app, ch('c'));
        press(&mut app, ch('+'));
        insta::assert_snapshot!(format!("{tag}_map_zoomed_in"), draw(&app, w, h).backend());

        // Overlays.
        let mut app = app_with(sample::runway_fixture(), w, h);
        press(&mut app, ch('?'));
        insta::assert_snapshot!(format!("{tag}_help"), draw(&app, w, h).backend());
        let mut app = app_with(sample::runway_fixture(), w, h);
        press(&mut app, ch('t'));
        insta::assert_snapshot!(format!("{tag}_confirm_rtl"), draw(&app, w, h).backend());
        let mut app = app_with(sample::runway_fixture(), w, h);
        press(&mut app, ch('g'));
        press(&mut app, ch('1'));
        insta::assert_snapshot!(format!("{tag}_prompt"), draw(&app, w, h).backend());

        // Fifty vehicles.
        let app = app_with(sample::generated(50, 1), w, h);
        insta::assert_snapshot!(format!("{tag}_fifty_vehicles"), draw(&app, w, h).backend());

        // Nothing received yet.
        let app = App::new(
            UiConfig::default(),
            Source::new(SourceKind::Live, "LIVE udpin:0.0.0.0:14550"),
        );
        insta::assert_snapshot!(format!("{tag}_empty"), draw(&app, w, h).backend());
    }
    let app = app_with(sample::runway_fixture(), 50, 12);
    insta::assert_snapshot!("50x12_too_small", draw(&app, 50, 12).backend());
}

#[test]
fn any_terminal_size_renders_without_panicking() {
    let mut states = Vec::new();
    for model in [
        sample::runway_fixture(),
        sample::classification_fixture(),
        Model::default(),
    ] {
        let base = app_with(model, 80, 24);
        for keys in [
            &[][..],
            &['?'][..],
            &['t'][..],
            &['g', '1'][..],
            &['\t', '\t', '\t'][..],
            &['f', '-', '-', '-'][..],
            &['c', '+', '+', '+', '+'][..],
        ] {
            let mut app = base.clone();
            for &k in keys {
                let key = if k == '\t' {
                    Key::plain(KeyCode::Tab)
                } else {
                    ch(k)
                };
                press(&mut app, key);
            }
            states.push(app);
        }
    }
    for w in [
        1u16, 2, 10, 59, 60, 61, 79, 80, 81, 120, 159, 160, 161, 200, 250, 400,
    ] {
        for h in [1u16, 2, 5, 15, 16, 17, 23, 24, 39, 40, 41, 70, 120] {
            for app in &states {
                let mut app = app.clone();
                update(&mut app, Event::Resize(w, h));
                // Keys that depend on the size (zoom, pan, page) must not panic either.
                for k in [
                    Key::char('+'),
                    Key::plain(KeyCode::PageUp),
                    Key::plain(KeyCode::Up),
                ] {
                    press(&mut app, k);
                }
                draw(&app, w, h);
            }
        }
    }
}

// ---------------------------------------------------------------- readability

#[test]
fn headers_and_values_are_readable_at_both_sizes() {
    for (w, h) in SIZES {
        let app = app_with(sample::runway_fixture(), w, h);
        let t = draw(&app, w, h);
        let s = text(&t);
        for header in [
            "Fleet", " ID", "MODE", "BATTERY", "GPS", "ALT m", "GS m/s", "WP", "LINK",
        ] {
            assert!(
                s.contains(header),
                "{w}x{h}: header {header:?} missing\n{s}"
            );
        }
        // Every vehicle has a row starting with its id, and the lost link says so in words.
        for id in [" 1 ", " 2 ", " 3 "] {
            assert!(
                lines(&t).iter().any(|l| l.contains(&format!("║{id}"))
                    || l.contains(&format!(">{id}"))
                    || l.contains(&format!("  {}", id.trim()))),
                "{w}x{h}: row {id}"
            );
        }
        assert!(s.contains("LOST"), "{w}x{h}: lost link shown in words");
        // The camera's health: its column, and a silent camera in words.
        assert!(s.contains("CAM"), "{w}x{h}: camera column\n{s}");
        assert!(
            s.contains("OFF"),
            "{w}x{h}: silent camera shown in words\n{s}"
        );
        assert!(
            s.contains("RUNNING"),
            "{w}x{h}: run status in the title bar"
        );
        assert!(s.contains("DFS"), "{w}x{h}: phase in the title bar");
        assert!(s.contains("north up"), "{w}x{h}: map orientation");
        assert!(s.contains("explored"), "{w}x{h}: legend");
        // Full battery values, not cut: "14%  13.7V".
        assert!(s.contains(" 14% 13.7V"), "{w}x{h}: battery of #3\n{s}");
        assert!(s.contains(" 27% 14.3V"), "{w}x{h}: battery of #2");
    }
    // The wide layout shows every pane at once, with their headers.
    let app = app_with(sample::runway_fixture(), 250, 70);
    let s = text(&draw(&app, 250, 70));
    for needle in [
        "Map",
        "Mission",
        "Log",
        "Legend",
        "AUTOPILOT",
        "ArduPilot copter",
        "ACTIVITY",
        "battery swap",
        "Battery 1 is critical 13.8V",
        "vehicle 3: no heartbeat for 5 s (link lost)",
        "9 explored, 1 in progress, 3 unexplored",
        "148/240 classified",
        "Swaps 2",
    ] {
        assert!(s.contains(needle), "250x70: {needle:?} missing");
    }
}

#[test]
fn compact_log_wraps_long_lines_instead_of_cutting_them() {
    let mut model = sample::runway_fixture();
    let long = "PreArm: Compass not calibrated, GPS horizontal error 3.2 m above the limit of 2 m for AUTO";
    model.log.push(LogEntry {
        time: Time::from_secs(753),
        severity: Severity::Error,
        sysid: Some(2),
        text: long.into(),
    });
    let mut app = app_with(model, 80, 24);
    app.lower = Pane::Log;
    let t = draw(&app, 80, 24);
    let joined: String = lines(&t)
        .iter()
        .map(|l| l.trim_matches(|c| c == '│' || c == ' ').to_string())
        .collect::<Vec<_>>()
        .join(" ");
    let squashed = |s: &str| s.split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(
        squashed(&joined).contains(&squashed(long)),
        "the whole message is on screen:\n{}",
        text(&t)
    );
}

#[test]
fn warnings_use_colour_and_selection_uses_reverse_video() {
    let app = app_with(sample::runway_fixture(), 250, 70);
    let t = draw(&app, 250, 70);
    let buf = t.backend().buffer();
    let (x, y) = find(&t, " 14% 13.7V").expect("battery of #3");
    assert_eq!(buf[(x + 1, y)].bg, Color::Red, "critical battery is red");
    let (x, y) = find(&t, " 27% 14.3V").expect("battery of #2");
    assert_eq!(buf[(x + 1, y)].bg, Color::Yellow, "low battery is yellow");
    let (x, y) = find(&t, "LOST").expect("lost link");
    assert_eq!(buf[(x, y)].bg, Color::Red);
    let (x, y) = find(&t, ">  1").expect("selected row marker");
    assert!(
        buf[(x + 2, y)].modifier.contains(Modifier::REVERSED),
        "selected row reversed"
    );
    // No dim text anywhere.
    for cell in buf.content() {
        assert!(!cell.modifier.contains(Modifier::DIM));
        assert_ne!(cell.fg, Color::DarkGray);
    }
    // Map colours: a positive cell is black on yellow.
    let (x, y) = find(&t, "++").expect("a positive cell on the map");
    assert_eq!(
        (buf[(x, y)].fg, buf[(x, y)].bg),
        (Color::Black, Color::Yellow)
    );
}

#[test]
fn battery_thresholds_are_configurable() {
    let cfg = UiConfig::from_toml_str("[thresholds]\nbattery_warn_pct = 10\nbattery_crit_pct = 5\ncell_warn_v = 3.0\ncell_crit_v = 2.9\n")
        .expect("valid config");
    let mut app = App::new(cfg, Source::new(SourceKind::Sample, "SAMPLE"));
    update(&mut app, Event::Resize(250, 70));
    update(
        &mut app,
        Event::Snapshot(Box::new(sample::runway_fixture())),
    );
    let t = draw(&app, 250, 70);
    let (x, y) = find(&t, " 27% 14.3V").expect("battery of #2");
    assert_ne!(
        t.backend().buffer()[(x + 1, y)].bg,
        Color::Yellow,
        "27% is fine above 10%"
    );
}

// ---------------------------------------------------------------- keys

/// Set `app` up so that the binding of `action` is the one a key reaches.
fn prepare(app: &mut App, action: Action) {
    match action.context() {
        Context::Global => app.focus = Pane::Mission, // no pane keys there
        Context::Fleet => app.focus = Pane::Fleet,
        Context::Map => {
            app.focus = Pane::Map;
            app.lower = Pane::Map;
        }
        Context::Log => {
            app.focus = Pane::Log;
            app.lower = Pane::Log;
            app.log_scroll = 4;
        }
        Context::Dialog => {
            press(app, ch('l')); // land: opens a confirmation
            assert!(matches!(app.overlay, Overlay::Confirm { .. }));
        }
        Context::Help => app.overlay = Overlay::Help { scroll: 2 },
    }
}

/// Check that `action` did what the help says, comparing `before` with `app`.
fn check(action: Action, before: &App, app: &App, effects: &[Effect]) {
    let name = action.name();
    let asked = |target: Target, command: Command| {
        assert_eq!(
            app.overlay,
            Overlay::Confirm {
                pending: Pending::Command { target, command },
                opened_at: before.now
            },
            "{name}: asks for confirmation"
        );
        assert!(
            effects.is_empty(),
            "{name}: nothing sent before confirmation"
        );
    };
    let vp = |a: &App| view::map::current_viewport(a);
    match action {
        Action::Help => assert_eq!(app.overlay, Overlay::Help { scroll: 0 }, "{name}"),
        Action::Quit => {
            assert!(
                matches!(
                    app.overlay,
                    Overlay::Confirm {
                        pending: Pending::Quit,
                        ..
                    }
                ),
                "{name}"
            );
            assert!(effects.is_empty());
        }
        Action::QuitNow => assert_eq!(effects, [Effect::Quit], "{name}"),
        Action::FocusNext => assert_eq!(app.focus, Pane::Log, "{name}"),
        Action::FocusPrev => assert_eq!(app.focus, Pane::Map, "{name}"),
        Action::NextVehicle | Action::FleetDown => assert_eq!(app.selected, Some(2), "{name}"),
        Action::PrevVehicle | Action::FleetUp => assert_eq!(app.selected, Some(3), "{name}"),
        Action::SelectNumber(n) if n <= 3 => assert_eq!(app.selected, Some(n), "{name}"),
        Action::SelectNumber(n) => {
            assert_eq!(app.selected, Some(1), "{name}");
            let last = app.ui_log.last().expect("a warning");
            assert_eq!(last.text, format!("no vehicle with system id {n}"));
        }
        Action::SelectById => assert_eq!(
            app.overlay,
            Overlay::Prompt {
                text: String::new()
            }
        ),
        Action::ZoomIn => assert_eq!(vp(app).zoom, vp(before).zoom + 1, "{name}"),
        Action::ZoomOut => assert_eq!(vp(app).zoom, vp(before).zoom - 1, "{name}"),
        Action::ZoomFit => assert_eq!(app.map.mode, MapMode::Fit, "{name}"),
        Action::FollowSelected => assert_eq!(app.map.mode, MapMode::Follow, "{name}"),
        Action::PanNorth => assert!(vp(app).centre.row > vp(before).centre.row, "{name}"),
        Action::PanSouth => assert!(vp(app).centre.row < vp(before).centre.row, "{name}"),
        Action::PanWest => assert!(vp(app).centre.col < vp(before).centre.col, "{name}"),
        Action::PanEast => assert!(vp(app).centre.col > vp(before).centre.col, "{name}"),
        Action::LogUp => assert_eq!(app.log_scroll, 5, "{name}"),
        Action::LogDown => assert_eq!(app.log_scroll, 3, "{name}"),
        Action::LogPageUp => assert!(app.log_scroll > 5, "{name}"),
        Action::LogPageDown => assert_eq!(app.log_scroll, 0, "{name}: clamped at the newest"),
        Action::LogLatest => assert_eq!(app.log_scroll, 0, "{name}"),
        Action::LogOldest => {
            assert_eq!(
                app.log_scroll,
                app.model.log.len() + app.ui_log.len() - 1,
                "{name}"
            )
        }
        Action::Start => asked(Target::All, Command::Start),
        Action::Resume => asked(Target::All, Command::Resume),
        Action::RtlAll => asked(Target::All, Command::Rtl),
        Action::RtlVehicle => asked(Target::Vehicle(1), Command::Rtl),
        Action::Land => asked(Target::Vehicle(1), Command::Land),
        Action::Arm => asked(Target::Vehicle(1), Command::Arm),
        Action::Disarm => asked(Target::Vehicle(1), Command::Disarm),
        Action::BatterySwapped => asked(Target::Vehicle(1), Command::BatterySwapped),
        Action::PauseAll => match effects {
            [Effect::Command(r)] => {
                assert_eq!(
                    (r.target, r.command),
                    (Target::All, Command::Hold),
                    "{name}"
                )
            }
            other => panic!("{name}: {other:?}"),
        },
        Action::HoldVehicle => match effects {
            [Effect::Command(r)] => {
                assert_eq!(
                    (r.target, r.command),
                    (Target::Vehicle(1), Command::Hold),
                    "{name}"
                )
            }
            other => panic!("{name}: {other:?}"),
        },
        Action::Confirm => match effects {
            [Effect::Command(r)] => {
                assert_eq!(
                    (r.target, r.command),
                    (Target::Vehicle(1), Command::Land),
                    "{name}"
                );
                assert_eq!(app.overlay, Overlay::None);
            }
            other => panic!("{name}: {other:?}"),
        },
        Action::Cancel => {
            assert_eq!(app.overlay, Overlay::None, "{name}");
            assert!(effects.is_empty());
        }
        Action::HelpUp => assert_eq!(app.overlay, Overlay::Help { scroll: 1 }, "{name}"),
        Action::HelpDown => assert_eq!(app.overlay, Overlay::Help { scroll: 3 }, "{name}"),
    }
}

#[test]
fn every_key_in_the_key_map_does_what_the_help_says() {
    let keymap = KeyMap::default();
    let mut tested = 0;
    for (action, keys) in keymap.bindings() {
        assert!(!keys.is_empty(), "{} has a key", action.name());
        for &key in keys {
            let mut app = app_with(sample::runway_fixture(), 80, 24);
            prepare(&mut app, action);
            let before = app.clone();
            let effects = press(&mut app, key);
            check(action, &before, &app, &effects);
            tested += 1;
        }
    }
    assert!(tested >= ALL_ACTIONS.len());
}

#[test]
fn the_help_lists_every_binding_from_the_key_map() {
    // Rebind a few keys: the help must follow.
    let cfg = UiConfig::from_toml_str("[keys]\nland = \"L\"\nrtl_all = [\"T\", \"ctrl-r\"]\n")
        .expect("valid");
    let mut app = App::new(cfg.clone(), Source::new(SourceKind::Sample, "SAMPLE"));
    update(
        &mut app,
        Event::Snapshot(Box::new(sample::runway_fixture())),
    );
    press(&mut app, ch('?'));
    let s = text(&draw(&app, 250, 70));
    for line in help::lines(&cfg.keys) {
        if let HelpLine::Entry { keys, desc, .. } = line {
            let row = format!("{keys}  {desc}");
            assert!(s.contains(&row), "help shows {row:?}\n{s}");
        }
    }
    assert!(s.contains("L  LAND selected vehicle"));
    assert!(s.contains("T ctrl-r  RTL ALL vehicles"));
    // And the rebound key works while the old one no longer does.
    let mut app = app_with(sample::runway_fixture(), 80, 24);
    app.config = cfg;
    press(&mut app, ch('l'));
    assert_eq!(app.overlay, Overlay::None, "l is unbound now");
    press(&mut app, ch('L'));
    assert!(matches!(
        app.overlay,
        Overlay::Confirm {
            pending: Pending::Command {
                command: Command::Land,
                ..
            },
            ..
        }
    ));
}

#[test]
fn help_scrolls_through_every_line_at_80x24() {
    let keys = KeyMap::default();
    let all = help::lines(&keys);
    let mut app = app_with(sample::runway_fixture(), 80, 24);
    press(&mut app, ch('?'));
    let mut seen = String::new();
    for _ in 0..all.len() {
        seen.push_str(&text(&draw(&app, 80, 24)));
        press(&mut app, Key::plain(KeyCode::Down));
    }
    for line in all {
        if let HelpLine::Entry { desc, .. } = line {
            assert!(seen.contains(&desc), "{desc:?} reachable by scrolling");
        }
    }
    press(&mut app, Key::plain(KeyCode::Esc));
    assert_eq!(app.overlay, Overlay::None);
}

// ---------------------------------------------------------------- confirmation

#[test]
fn dangerous_commands_need_y_and_n_or_esc_cancel() {
    let mut app = app_with(sample::runway_fixture(), 80, 24);
    // n cancels.
    assert!(press(&mut app, ch('t')).is_empty());
    assert!(matches!(app.overlay, Overlay::Confirm { .. }));
    assert!(press(&mut app, ch('n')).is_empty());
    assert_eq!(app.overlay, Overlay::None);
    assert!(
        app.ui_log
            .last()
            .is_some_and(|e| e.text.starts_with("cancelled"))
    );
    // Esc cancels.
    press(&mut app, ch('T'));
    assert!(press(&mut app, Key::plain(KeyCode::Esc)).is_empty());
    assert_eq!(app.overlay, Overlay::None);
    // Other keys are ignored while the dialog is open (even other commands).
    press(&mut app, ch('D'));
    for k in [
        ch('x'),
        ch('s'),
        ch('t'),
        Key::plain(KeyCode::Enter),
        ch(' '),
    ] {
        assert!(press(&mut app, k).is_empty(), "{k} ignored");
    }
    assert!(matches!(
        app.overlay,
        Overlay::Confirm {
            pending: Pending::Command {
                command: Command::Disarm,
                ..
            },
            ..
        }
    ));
    // y sends it, once.
    let effects = press(&mut app, ch('y'));
    let req = match effects.as_slice() {
        [Effect::Command(r)] => *r,
        other => panic!("{other:?}"),
    };
    assert_eq!(
        (req.target, req.command),
        (Target::Vehicle(1), Command::Disarm)
    );
    assert_eq!(app.pending, vec![req]);
    assert!(press(&mut app, ch('y')).is_empty(), "y alone does nothing");
    // The result comes back later and clears the pending command.
    update(
        &mut app,
        Event::JobResult(JobResult {
            id: req.id,
            outcome: Err(CommandError::Vehicles(vec!["COMMAND_ACK: denied".into()])),
        }),
    );
    assert!(app.pending.is_empty());
    let last = app.ui_log.last().expect("result logged");
    assert_eq!(last.severity, Severity::Error);
    assert!(
        last.text
            .contains("DISARM (vehicle 1) FAILED: COMMAND_ACK: denied"),
        "{}",
        last.text
    );
}

#[test]
fn an_unanswered_confirmation_expires() {
    let mut app = app_with(sample::runway_fixture(), 80, 24);
    let t0 = app.now;
    press(&mut app, ch('s'));
    update(&mut app, Event::Tick(t0 + Duration::from_secs(10)));
    assert!(
        matches!(app.overlay, Overlay::Confirm { .. }),
        "still open at 10 s"
    );
    update(&mut app, Event::Tick(t0 + Duration::from_secs(16)));
    assert_eq!(app.overlay, Overlay::None);
    assert!(
        app.ui_log
            .last()
            .is_some_and(|e| e.text.contains("expired"))
    );
    assert!(press(&mut app, ch('y')).is_empty());
}

#[test]
fn quit_asks_and_ctrl_c_does_not() {
    let mut app = app_with(sample::runway_fixture(), 80, 24);
    assert!(press(&mut app, ch('q')).is_empty());
    assert_eq!(press(&mut app, ch('y')), vec![Effect::Quit]);
    assert!(app.quit);
    let mut app = app_with(sample::runway_fixture(), 80, 24);
    press(&mut app, ch('t'));
    assert_eq!(
        press(&mut app, Key::ctrl('c')),
        vec![Effect::Quit],
        "even from a dialog"
    );
}

#[test]
fn commands_without_a_selected_vehicle_explain_why() {
    let mut app = App::new(UiConfig::default(), Source::new(SourceKind::Live, "LIVE"));
    assert!(press(&mut app, ch('t')).is_empty());
    assert_eq!(app.overlay, Overlay::None);
    assert_eq!(
        app.ui_log.last().map(|e| e.text.as_str()),
        Some("no vehicle selected")
    );
}

#[test]
fn select_by_id_prompt() {
    let mut app = app_with(sample::generated(50, 3), 80, 24);
    for k in [
        ch('g'),
        ch('4'),
        ch('9'),
        ch('9'),
        Key::plain(KeyCode::Backspace),
        Key::plain(KeyCode::Enter),
    ] {
        press(&mut app, k);
    }
    assert_eq!(app.selected, Some(49));
    for k in [ch('g'), ch('0'), Key::plain(KeyCode::Enter)] {
        press(&mut app, k);
    }
    assert_eq!(app.selected, Some(49));
    assert!(
        app.ui_log
            .last()
            .is_some_and(|e| e.text.contains("not a system id"))
    );
    for k in [ch('g'), ch('7'), ch('7'), Key::plain(KeyCode::Enter)] {
        press(&mut app, k);
    }
    assert_eq!(
        app.ui_log.last().map(|e| e.text.as_str()),
        Some("no vehicle with system id 77")
    );
    press(&mut app, ch('g'));
    press(&mut app, Key::plain(KeyCode::Esc));
    assert_eq!(app.overlay, Overlay::None);
}

#[test]
fn snapshots_keep_the_selection_and_mark_stale_data() {
    let mut app = app_with(sample::runway_fixture(), 80, 24);
    press(&mut app, ch('3'));
    let mut m = sample::runway_fixture();
    m.vehicles.reverse();
    update(&mut app, Event::Snapshot(Box::new(m.clone())));
    assert_eq!(
        app.selected,
        Some(3),
        "selection follows the system id, not the row"
    );
    m.vehicles.retain(|v| v.sysid != 3);
    update(&mut app, Event::Snapshot(Box::new(m)));
    assert_eq!(
        app.selected,
        Some(2),
        "a vanished selection falls back to the first row"
    );
    // No snapshot for longer than the threshold: the title bar says so.
    let t = app.now;
    update(&mut app, Event::Tick(t + Duration::from_secs(2)));
    assert!(app.stale_for().is_none());
    assert!(!text(&draw(&app, 80, 24)).contains("NO DATA"));
    update(&mut app, Event::Tick(t + Duration::from_secs(9)));
    assert!(text(&draw(&app, 80, 24)).contains("NO DATA 9s"));
}

// ---------------------------------------------------------------- shell

fn key_event(c: char) -> TermEvent {
    TermEvent::Key(Key::char(c).to_event())
}

#[tokio::test]
async fn the_shell_loop_routes_snapshots_keys_commands_and_results() {
    let (snap_tx, snap_rx) = watch::channel(Model::default());
    let (cmd_tx, mut cmd_rx) = mpsc::channel(8);
    let (result_tx, result_rx) = mpsc::channel(8);
    let (input_tx, input_rx) = mpsc::channel(8);
    let io = ShellIo {
        snapshots: snap_rx,
        job_results: result_rx,
        commands: cmd_tx,
    };
    let options = ShellOptions {
        tick: Duration::from_millis(20),
        clock: MonotonicClock::new(),
    };
    let app = App::new(
        UiConfig::default(),
        Source::new(SourceKind::Live, "LIVE test"),
    );
    let ui = tokio::spawn(async move {
        let mut terminal = Terminal::new(TestBackend::new(80, 24)).expect("backend");
        let app = run_loop(&mut terminal, app, input_rx, io, options).await;
        (app, lines(&terminal))
    });
    snap_tx.send_replace(sample::runway_fixture());
    // A key release must be ignored (only presses and repeats count).
    let mut release = KeyEvent::new(KeyCode::Char('t'), KeyModifiers::NONE);
    release.kind = crossterm::event::KeyEventKind::Release;
    input_tx
        .send(TermEvent::Key(release))
        .await
        .expect("ui alive");
    input_tx.send(key_event('2')).await.expect("ui alive");
    input_tx.send(key_event('t')).await.expect("ui alive");
    input_tx.send(key_event('y')).await.expect("ui alive");
    let req = tokio::time::timeout(Duration::from_secs(30), cmd_rx.recv())
        .await
        .expect("the command arrives")
        .expect("channel open");
    assert_eq!(
        (req.target, req.command),
        (Target::Vehicle(2), Command::Rtl)
    );
    result_tx
        .send(JobResult {
            id: req.id,
            outcome: Ok("COMMAND_ACK accepted".into()),
        })
        .await
        .expect("ui alive");
    // Hold: sent without confirmation. Then close the command channel: the next command
    // must be reported as not sent instead of blocking.
    input_tx.send(key_event('p')).await.expect("ui alive");
    let hold = tokio::time::timeout(Duration::from_secs(30), cmd_rx.recv())
        .await
        .expect("hold arrives")
        .expect("channel open");
    assert_eq!((hold.target, hold.command), (Target::All, Command::Hold));
    drop(cmd_rx);
    input_tx.send(key_event('h')).await.expect("ui alive");
    input_tx
        .send(TermEvent::Resize(100, 30))
        .await
        .expect("ui alive");
    input_tx.send(key_event('q')).await.expect("ui alive");
    input_tx.send(key_event('y')).await.expect("ui alive");
    let (app, _screen) = tokio::time::timeout(Duration::from_secs(30), ui)
        .await
        .expect("the loop ends on quit")
        .expect("no panic");
    let app = app.expect("no error");
    assert!(app.quit);
    assert_eq!(app.size, (100, 30));
    let log: Vec<&str> = app.ui_log.iter().map(|e| e.text.as_str()).collect();
    assert!(
        log.contains(&"RETURN TO LAUNCH (vehicle 2): accepted, COMMAND_ACK accepted"),
        "{log:?}"
    );
    assert!(
        log.iter().any(|l| l.contains("HOLD (vehicle 2) FAILED: nothing is executing commands, not sent")),
        "{log:?}"
    );
    assert_eq!(
        app.pending.len(),
        1,
        "the hold sent before closing has no result yet"
    );
}

/// Frames the shell loop draws in `secs` seconds of virtual time (tokio's paused clock) with
/// the default tick, while `feed` sends a new model every `every` from `phase` on (never when
/// `every` is `None`); then `q`, `y` quit (the `q` dialog is one more frame).
async fn frames_drawn(secs: f64, feed: Option<(Duration, Duration)>) -> usize {
    let (snap_tx, snap_rx) = watch::channel(sample::runway_fixture());
    let (cmd_tx, _cmd_rx) = mpsc::channel(8);
    let (_result_tx, result_rx) = mpsc::channel(8);
    let (input_tx, input_rx) = mpsc::channel(8);
    let io = ShellIo {
        snapshots: snap_rx,
        job_results: result_rx,
        commands: cmd_tx,
    };
    let options = ShellOptions::default();
    assert_eq!(options.tick, REFRESH);
    let app = App::new(
        UiConfig::default(),
        Source::new(SourceKind::Live, "LIVE test"),
    );
    let feeder = tokio::spawn(async move {
        let Some((every, phase)) = feed else {
            return snap_tx;
        };
        tokio::time::sleep(phase).await;
        let mut model = sample::runway_fixture();
        loop {
            model.time += every;
            snap_tx.send_replace(model.clone());
            tokio::time::sleep(every).await;
        }
    });
    let quitter = tokio::spawn(async move {
        tokio::time::sleep(Duration::from_secs_f64(secs)).await;
        input_tx.send(key_event('q')).await.expect("ui alive");
        input_tx.send(key_event('y')).await.expect("ui alive");
        input_tx
    });
    let mut terminal = Terminal::new(TestBackend::new(250, 70)).expect("backend");
    run_loop(&mut terminal, app, input_rx, io, options)
        .await
        .expect("no error");
    feeder.abort();
    drop(quitter.await);
    terminal.get_frame().count()
}

/// The screen redraws at least 10 times a second. Counted in virtual time, not
/// timed: with no new data the tick redraws (the stale-data and confirmation countdowns move
/// on) 10 times a second; with a model every 100 ms (the live session's cadence) each model
/// is drawn at once and the ticks in between draw nothing more, so the screen does not cost
/// two frames per period.
#[tokio::test(start_paused = true)]
async fn the_shell_redraws_ten_times_a_second_with_or_without_new_data() {
    // 1 first frame + 100 ticks + the quit dialog
    let idle = frames_drawn(10.05, None).await;
    assert_eq!(idle, 102, "frames in 10 s without new data");
    // 1 first frame + 100 models (at 50, 150, … 9 950 ms; every tick in between skipped) +
    // the quit dialog
    let fed = frames_drawn(
        10.02,
        Some((Duration::from_millis(100), Duration::from_millis(50))),
    )
    .await;
    assert_eq!(fed, 102, "frames in 10 s with a model every 100 ms");
    // Models 4 times a second (the old cadence): each model is drawn and takes the place of
    // the next tick's frame, so still 1 + 100 + 1, whichever of a model and a tick due at the
    // same instant comes first.
    let slow = frames_drawn(
        10.02,
        Some((Duration::from_millis(250), Duration::from_millis(50))),
    )
    .await;
    assert_eq!(slow, 102, "frames in 10 s with 4 models a second");
}

#[test]
fn the_panic_hook_restores_first_and_the_restore_sequence_is_right() {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicUsize, Ordering};
    let calls = Arc::new(AtomicUsize::new(0));
    let c = calls.clone();
    install_panic_hook(move || {
        c.fetch_add(1, Ordering::SeqCst);
    });
    let result = std::panic::catch_unwind(|| panic!("test panic inside the UI"));
    assert!(result.is_err());
    assert!(
        calls.load(Ordering::SeqCst) >= 1,
        "the hook ran the restore function"
    );
    let mut out = Vec::new();
    write_restore_sequence(&mut out).expect("write");
    let s = String::from_utf8_lossy(&out);
    assert!(
        s.contains("\x1b[?1049l"),
        "leaves the alternate screen: {s:?}"
    );
    assert!(s.contains("\x1b[?25h"), "shows the cursor: {s:?}");
}

/// Child half of the test below: enters UI mode on a real (pseudo-)terminal and panics.
/// Does nothing unless started by that test.
#[test]
#[ignore = "child process of the_panic_hook_restores_the_real_terminal"]
fn pty_child_panics_inside_the_ui() {
    if std::env::var_os("FLEETMAP_PTY_CHILD").is_none() {
        return;
    }
    let _guard = TerminalGuard::enter().expect("a terminal");
    panic!("deliberate panic inside the UI");
}

/// A panic while the UI owns a real terminal leaves the alternate screen before the panic
/// message is printed, and turns raw mode off (`stty` shows canonical mode and echo again).
#[test]
fn the_panic_hook_restores_the_real_terminal() {
    if std::process::Command::new("script")
        .arg("--version")
        .output()
        .is_err()
    {
        eprintln!("skipped: util-linux `script` is not installed");
        return;
    }
    let exe = std::env::current_exe().expect("test binary");
    let cmd = format!(
        "stty cols 80 rows 24; stty -a | head -c 0; FLEETMAP_PTY_CHILD=1 {} --ignored --exact {} --nocapture --test-threads=1; echo; echo AFTER; stty -a",
        exe.display(),
        common::test_name(module_path!(), "pty_child_panics_inside_the_ui")
    );
    let out = std::process::Command::new("script")
        .args(["-qfec", &cmd, "/dev/null"])
        .env("TERM", "xterm-256color")
        .stdin(std::process::Stdio::null())
        .output()
        .expect("script runs");
    let s = String::from_utf8_lossy(&out.stdout);
    let entered = s.find("\x1b[?1049h").expect("entered the alternate screen");
    let left = s.find("\x1b[?1049l").expect("left the alternate screen");
    let message = s
        .find("deliberate panic inside the UI")
        .expect("the panic message");
    assert!(
        entered < left && left < message,
        "restore happens before the message:\n{s:?}"
    );
    let after = &s[s.find("AFTER").expect("stty ran after the child")..];
    assert!(
        after.contains(" icanon") && after.contains(" echo"),
        "raw mode is off: {after}"
    );
}

/// A replay records the map's label and the mission's name, not the kind's look: every
/// fixture read back from a replay file draws exactly as the fixture itself, and a frame in
/// the spelling of replays recorded before the kinds supplied their panes (an empty map
/// without `kind`, the mission's `"spatial_classification"`) draws as that kind's.
#[test]
fn replayed_models_draw_as_their_kinds() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("fixtures.jsonl");
    // No epoch done yet: the pane still counts them (the kind says it has epochs).
    let mut idle = serde_json::to_value(sample::classification_fixture()).expect("serialize");
    idle["mission"]["epochs_done"] = 0.into();
    let idle: Model = serde_json::from_value(idle).expect("a model");
    let models = [
        sample::runway_fixture(),
        sample::classification_fixture(),
        idle,
        sample::generated(50, 1),
        Model::default(),
    ];
    let recorded: String = models
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let frame = replay::ReplayFrame {
                t_ms: i as u64,
                model: m.clone(),
            };
            serde_json::to_string(&frame).expect("a frame serializes") + "\n"
        })
        .collect();
    std::fs::write(&path, recorded).expect("write");
    let frames = replay::read_replay(&path).expect("valid replay");
    for (m, f) in models.iter().zip(&frames) {
        for (w, h) in SIZES {
            assert_eq!(
                text(&draw(&app_with(f.model.clone(), w, h), w, h)),
                text(&draw(&app_with(m.clone(), w, h), w, h)),
                "{} at {w}x{h}",
                m.mission.name
            );
        }
    }

    let old = r#"{"t_ms": 0, "model": {"map": {"rows": ["?K", "x@"]}, "mission": {"name": "old", "kind": "spatial_classification"}}}"#;
    std::fs::write(&path, old).expect("write");
    let frames = replay::read_replay(&path).expect("an old replay reads");
    let s = text(&draw(&app_with(frames[0].model.clone(), 250, 70), 250, 70));
    assert!(s.contains("(spatial classification)"), "{s}");
    assert!(s.contains("Epochs   0 done"), "{s}");
    assert!(
        s.contains(" runway · north up"),
        "a map without a kind: {s}"
    );
}

// ---------------------------------------------------------------- the command

/// The binary under test ([`common::fleetmap`]: `$FLEETMAP_BIN` when set, else cargo's).
fn bin() -> std::process::Command {
    common::fleetmap().command()
}

#[test]
fn tui_snapshot_replay_config_and_errors_from_the_command_line() {
    let dir = tempfile::tempdir().expect("tempdir");
    // --snapshot on the sample says SAMPLE.
    let out = bin()
        .args(["tui", "--snapshot", "80x24", "--at", "60"])
        .output()
        .expect("run");
    assert!(out.status.success());
    let s = String::from_utf8_lossy(&out.stdout);
    assert!(s.contains("SAMPLE"), "{s}");
    assert_eq!(s.lines().count(), 24);

    // Export the sample as a replay, then replay it.
    let replay = dir.path().join("run.jsonl");
    let out = bin()
        .args(["tui", "--export-sample"])
        .arg(&replay)
        .output()
        .expect("run");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let frames = replay::read_replay(&replay).expect("valid replay");
    assert!(frames.len() > 100);
    assert_eq!(
        frames.last().map(|f| f.model.mission.status),
        Some(RunStatus::Done)
    );
    let out = bin()
        .args(["tui", "--snapshot", "250x70", "--replay"])
        .arg(&replay)
        .output()
        .expect("run");
    assert!(out.status.success());
    let s = String::from_utf8_lossy(&out.stdout);
    assert!(
        s.contains("REPLAY run.jsonl (recorded, no vehicles connected)"),
        "{s}"
    );
    assert!(s.contains("DONE"));

    // --print-config parses back to the defaults.
    let out = bin().args(["tui", "--print-config"]).output().expect("run");
    assert!(out.status.success());
    let printed = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        UiConfig::from_toml_str(&printed).expect("parses"),
        UiConfig::default()
    );

    // A bad config: one line, exit 1.
    let bad = dir.path().join("keys.toml");
    std::fs::write(&bad, "[keys]\nland = \"s\"\n").expect("write");
    let out = bin()
        .args(["tui", "--snapshot", "80x24", "--config"])
        .arg(&bad)
        .output()
        .expect("run");
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("key s is bound to both start and land"),
        "{err}"
    );

    // A bad replay: the line number.
    let broken = dir.path().join("broken.jsonl");
    std::fs::write(
        &broken,
        "{\"t_ms\":0,\"model\":{}}\n{\"t_ms\":5,\"model\":{\"map\":{\"rows\":[\"..\",\"Z.\"]}}}\n",
    )
    .expect("write");
    let out = bin()
        .args(["tui", "--snapshot", "80x24", "--replay"])
        .arg(&broken)
        .output()
        .expect("run");
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("broken.jsonl:2: not a replay frame"), "{err}");

    // Without a terminal the UI refuses instead of garbling the output.
    let out = bin()
        .args(["tui"])
        .stdin(std::process::Stdio::null())
        .output()
        .expect("run");
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("needs an interactive terminal"));

    for bad in [
        ["--snapshot", "80"],
        ["--speed", "0"],
        ["--vehicles", "0"],
        ["--snapshot=80x24", "--at=-3"],
    ] {
        let out = bin().arg("tui").args(bad).output().expect("run");
        assert_eq!(out.status.code(), Some(1), "{bad:?}");
    }
}

#[test]
fn bench_tui_reports_frames_per_second() {
    let out = bin()
        .args([
            "bench",
            "tui",
            "--vehicles",
            "50",
            "--frames",
            "20",
            "--json",
        ])
        .output()
        .expect("run");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    assert_eq!(v["vehicles"], 50);
    assert_eq!(v["frames"], 20);
    assert!(v["frames_per_second"].as_f64().is_some_and(|f| f > 0.0));
}

/// The real binary in a pseudo-terminal (util-linux `script`): it enters the alternate
/// screen, shows the help, quits on `q` `y`, and leaves the terminal as it found it.
#[test]
fn the_binary_runs_in_a_pty_and_restores_the_terminal() {
    use std::time::Instant;
    if !pty::have_script() {
        eprintln!("skipped: util-linux `script` is not installed");
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let log = dir.path().join("tui.log");
    let shell = format!(
        "{} --log-file {} tui --speed 20",
        common::fleetmap().path().display(),
        log.display()
    );
    let (mut child, mut keys, mut term) = pty::spawn(&shell, 100, 30, &log);
    let step = || Instant::now() + Duration::from_secs(60);
    term.wait_raw(b"\x1b[?1049h", step()); // entered the alternate screen
    term.wait_screen("SAMPLE", step()); // drew the first frame
    keys.press(b"?");
    term.wait_screen("every key", step());
    // `?` closes the help (Esc would work too, but a following key could make it Alt-q).
    keys.press(b"?q");
    term.wait_screen("QUIT fleetmap?", step());
    keys.press(b"y");
    let status = pty::wait_exit(&mut child, &mut term, Duration::from_secs(60));
    assert!(status.success(), "exit status {status:?}");
    let all = String::from_utf8_lossy(&term.raw);
    let left = all.rfind("\x1b[?1049l").expect("left alt screen");
    let shown = all.rfind("\x1b[?25h").expect("cursor shown");
    assert!(
        shown > all.rfind("\x1b[?25l").unwrap_or(0),
        "cursor visible at the end"
    );
    assert!(left > all.rfind("\x1b[?1049h").unwrap_or(0));
    // Logs went to the file, not over the screen.
    assert!(log.exists(), "log file created");
}

#[test]
fn the_uis_own_lines_keep_their_place_in_the_log_whatever_its_clock() {
    // Live, the UI's timers run on the wall clock from the UI's start while the model's log
    // runs on the fleet's clock, which started before (connecting, the fleet check): the
    // UI's lines are stamped on the model's clock, so they come after what preceded them.
    let model = sample::runway_fixture();
    let latest = model.log.iter().map(|e| e.time).max().expect("fixture log");
    let mut app = app_with(model, 80, 24);
    update(&mut app, Event::Tick(Time::from_secs(3)));
    app.log(Severity::Error, "START mission FAILED: not started");
    let line = app.ui_log.last().expect("the UI's line");
    assert!(
        line.time >= latest,
        "{:?} before the model's {latest:?}",
        line.time
    );
}
