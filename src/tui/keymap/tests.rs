use super::*;
use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};

#[test]
fn parse_and_display_round_trip() {
    for s in [
        "q",
        "T",
        "?",
        "+",
        "-",
        "space",
        "tab",
        "backtab",
        "esc",
        "enter",
        "up",
        "pageup",
        "f5",
        "ctrl-c",
        "alt-x",
        "shift-up",
        "ctrl-alt-d",
        "\"",
        "\\",
    ] {
        let k = Key::parse(s).unwrap_or_else(|e| panic!("{s}: {e}"));
        assert_eq!(Key::parse(&k.to_string()), Ok(k), "{s}");
    }
    assert_eq!(Key::parse("ctrl-C"), Ok(Key::ctrl('c')));
    assert_eq!(Key::parse("Space"), Ok(Key::char(' ')));
    assert_eq!(Key::parse("shift-tab"), Ok(Key::plain(KeyCode::BackTab)));
    for bad in ["", "ctrl-", "shift-t", "f13", "f0", "hyper-x", "upp"] {
        assert!(Key::parse(bad).is_err(), "{bad:?} should not parse");
    }
}

#[test]
fn terminal_events_normalise_like_the_file() {
    // A terminal reports 'T' with SHIFT, BackTab with SHIFT, Ctrl-C as ('c', CONTROL).
    let t = KeyEvent::new(KeyCode::Char('T'), KeyModifiers::SHIFT);
    assert_eq!(Key::from_event(&t), Key::char('T'));
    let bt = KeyEvent::new(KeyCode::BackTab, KeyModifiers::SHIFT);
    assert_eq!(Key::from_event(&bt), Key::plain(KeyCode::BackTab));
    let cc = KeyEvent::new(
        KeyCode::Char('C'),
        KeyModifiers::CONTROL | KeyModifiers::SHIFT,
    );
    assert_eq!(Key::from_event(&cc), Key::ctrl('c'));
    let su = KeyEvent::new(KeyCode::Up, KeyModifiers::SHIFT);
    assert_eq!(Key::from_event(&su), Key::shift(KeyCode::Up));
    for k in [Key::char('T'), Key::ctrl('c'), Key::plain(KeyCode::BackTab)] {
        assert_eq!(Key::from_event(&k.to_event()), k);
    }
}

#[test]
fn default_map_is_valid_and_complete() {
    let m = KeyMap::default();
    m.validate().expect("defaults are consistent");
    for &a in ALL_ACTIONS {
        assert!(!m.keys(a).is_empty(), "{} has no default key", a.name());
        assert_eq!(Action::from_name(&a.name()), Some(a));
    }
}

#[test]
fn conflicts_are_reported() {
    let mut m = KeyMap::default();
    m.set(Action::Land, vec![Key::char('t')]);
    let err = m.validate().unwrap_err();
    assert!(
        matches!(&err, KeyMapError::Conflict { key, .. } if key == "t"),
        "{err}"
    );
    let mut m = KeyMap::default();
    m.set(Action::PanNorth, vec![Key::ctrl('c')]);
    assert!(m.validate().is_err());
    let mut m = KeyMap::default();
    m.set(Action::Cancel, vec![]);
    assert_eq!(m.validate(), Err(KeyMapError::Unbound("cancel".into())));
}
