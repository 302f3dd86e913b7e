//! Key bindings: one table of actions (name, context, description, default keys) that both
//! the key handling ([`KeyMap::lookup`]) and the help overlay read, so the help always lists
//! exactly the keys that work.
//!
//! Follows gitui's split (`extrawurst/gitui`, `src/keys/key_list.rs`: a struct of named
//! bindings with built-in defaults, overridable from a file), with two differences: the table
//! is a list of [`Action`]s rather than struct fields, so tests and the help can iterate it,
//! and the override file is TOML (`[keys]` section of the UI config, see [`crate::tui::config`]).
//!
//! Key syntax in the file: a single character (`"q"`, `"T"`, `"?"`, `"+"`), or a name —
//! `space tab backtab enter esc backspace delete insert up down left right home end pageup
//! pagedown f1 … f12` — optionally prefixed by `ctrl-`, `alt-`, `shift-` (e.g. `"ctrl-c"`,
//! `"shift-up"`). Upper-case letters already mean Shift; `"shift-t"` is written `"T"`.

use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::fmt;

/// A key with its modifiers, normalised so that a binding written in the file compares equal
/// to what the terminal reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Key {
    /// The key.
    pub code: KeyCode,
    /// Control / Alt / Shift (Shift only for non-character keys).
    pub mods: KeyModifiers,
}

impl Key {
    /// A key without modifiers.
    pub const fn plain(code: KeyCode) -> Key {
        Key {
            code,
            mods: KeyModifiers::NONE,
        }
    }

    /// A character key without modifiers.
    pub const fn char(c: char) -> Key {
        Key::plain(KeyCode::Char(c))
    }

    /// `ctrl-` + a character.
    pub const fn ctrl(c: char) -> Key {
        Key {
            code: KeyCode::Char(c),
            mods: KeyModifiers::CONTROL,
        }
    }

    /// `shift-` + a non-character key.
    pub const fn shift(code: KeyCode) -> Key {
        Key {
            code,
            mods: KeyModifiers::SHIFT,
        }
    }

    /// Normalise `code` + `mods` the way terminals differ: Shift is implied by the character
    /// for character keys (and by BackTab), and only Control, Alt and Shift matter.
    pub fn new(code: KeyCode, mods: KeyModifiers) -> Key {
        let mut mods = mods & (KeyModifiers::CONTROL | KeyModifiers::ALT | KeyModifiers::SHIFT);
        if matches!(code, KeyCode::Char(_) | KeyCode::BackTab) {
            mods.remove(KeyModifiers::SHIFT);
        }
        // Ctrl+letter arrives lower-case from most terminals; store it that way.
        let code = match code {
            KeyCode::Char(c) if mods.contains(KeyModifiers::CONTROL) => {
                KeyCode::Char(c.to_ascii_lowercase())
            }
            other => other,
        };
        Key { code, mods }
    }

    /// Parse the file syntax (see the module documentation).
    pub fn parse(s: &str) -> Result<Key, KeyMapError> {
        let bad = || KeyMapError::BadKey(s.to_string());
        if s.chars().count() == 1 {
            let c = s.chars().next().ok_or_else(bad)?;
            return Ok(Key::char(c));
        }
        let mut mods = KeyModifiers::NONE;
        let mut rest = s;
        loop {
            let lower = rest.to_ascii_lowercase();
            let (m, n) = if lower.starts_with("ctrl-") {
                (KeyModifiers::CONTROL, 5)
            } else if lower.starts_with("alt-") {
                (KeyModifiers::ALT, 4)
            } else if lower.starts_with("shift-") {
                (KeyModifiers::SHIFT, 6)
            } else {
                break;
            };
            if rest.len() == n {
                return Err(bad());
            }
            mods |= m;
            rest = &rest[n..];
        }
        let code = if rest.chars().count() == 1 {
            KeyCode::Char(rest.chars().next().ok_or_else(bad)?)
        } else {
            match rest.to_ascii_lowercase().as_str() {
                "space" => KeyCode::Char(' '),
                "tab" => KeyCode::Tab,
                "backtab" => KeyCode::BackTab,
                "enter" | "return" => KeyCode::Enter,
                "esc" | "escape" => KeyCode::Esc,
                "backspace" => KeyCode::Backspace,
                "delete" | "del" => KeyCode::Delete,
                "insert" | "ins" => KeyCode::Insert,
                "up" => KeyCode::Up,
                "down" => KeyCode::Down,
                "left" => KeyCode::Left,
                "right" => KeyCode::Right,
                "home" => KeyCode::Home,
                "end" => KeyCode::End,
                "pageup" | "pgup" => KeyCode::PageUp,
                "pagedown" | "pgdn" => KeyCode::PageDown,
                f if f.starts_with('f') => match f[1..].parse::<u8>() {
                    Ok(n @ 1..=12) => KeyCode::F(n),
                    _ => return Err(bad()),
                },
                _ => return Err(bad()),
            }
        };
        // Terminals report Shift+Tab as BackTab.
        let code = if code == KeyCode::Tab && mods.contains(KeyModifiers::SHIFT) {
            mods.remove(KeyModifiers::SHIFT);
            KeyCode::BackTab
        } else {
            code
        };
        if matches!(code, KeyCode::Char(_)) && mods.contains(KeyModifiers::SHIFT) {
            // "shift-t" is "T": refuse rather than silently bind something else.
            return Err(bad());
        }
        Ok(Key::new(code, mods))
    }

    /// Normalised key of a terminal key event.
    pub fn from_event(ev: &KeyEvent) -> Key {
        Key::new(ev.code, ev.modifiers)
    }

    /// A key event that produces this key (for tests and scripted input).
    pub fn to_event(self) -> KeyEvent {
        let mut mods = self.mods;
        if let KeyCode::Char(c) = self.code
            && c.is_ascii_uppercase()
        {
            mods |= KeyModifiers::SHIFT; // what a terminal reports for "T"
        }
        KeyEvent::new(self.code, mods)
    }
}

impl fmt::Display for Key {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.mods.contains(KeyModifiers::CONTROL) {
            f.write_str("ctrl-")?;
        }
        if self.mods.contains(KeyModifiers::ALT) {
            f.write_str("alt-")?;
        }
        if self.mods.contains(KeyModifiers::SHIFT) {
            f.write_str("shift-")?;
        }
        match self.code {
            KeyCode::Char(' ') => f.write_str("space"),
            KeyCode::Char(c) => write!(f, "{c}"),
            KeyCode::Tab => f.write_str("tab"),
            KeyCode::BackTab => f.write_str("backtab"),
            KeyCode::Enter => f.write_str("enter"),
            KeyCode::Esc => f.write_str("esc"),
            KeyCode::Backspace => f.write_str("backspace"),
            KeyCode::Delete => f.write_str("delete"),
            KeyCode::Insert => f.write_str("insert"),
            KeyCode::Up => f.write_str("up"),
            KeyCode::Down => f.write_str("down"),
            KeyCode::Left => f.write_str("left"),
            KeyCode::Right => f.write_str("right"),
            KeyCode::Home => f.write_str("home"),
            KeyCode::End => f.write_str("end"),
            KeyCode::PageUp => f.write_str("pageup"),
            KeyCode::PageDown => f.write_str("pagedown"),
            KeyCode::F(n) => write!(f, "f{n}"),
            other => write!(f, "{other:?}"),
        }
    }
}

/// Where a binding applies. Pane contexts are consulted first when that pane has the
/// focus, then [`Context::Global`]; [`Context::Dialog`] and [`Context::Help`] apply while the
/// confirmation dialog / help overlay is open (and nothing else does, except
/// [`Action::QuitNow`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Context {
    /// Anywhere (unless a pane binding or an overlay takes the key).
    Global,
    /// The fleet pane has the focus.
    Fleet,
    /// The map pane has the focus.
    Map,
    /// The log pane has the focus.
    Log,
    /// A confirmation dialog, the help or the vehicle-id prompt is open.
    Dialog,
    /// The help overlay is open.
    Help,
}

impl Context {
    /// Heading in the help overlay.
    pub fn heading(self) -> &'static str {
        match self {
            Context::Global => "Anywhere",
            Context::Fleet => "Fleet pane focused",
            Context::Map => "Map pane focused",
            Context::Log => "Log pane focused",
            Context::Dialog => "Dialogs and prompts",
            Context::Help => "This help",
        }
    }
}

/// Everything a key can do.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Action {
    /// Show / hide the help overlay.
    Help,
    /// Quit (asks for confirmation: the vehicles keep flying their missions).
    Quit,
    /// Quit without asking.
    QuitNow,
    /// Focus the next pane.
    FocusNext,
    /// Focus the previous pane.
    FocusPrev,
    /// Select the next vehicle.
    NextVehicle,
    /// Select the previous vehicle.
    PrevVehicle,
    /// Select the vehicle with system id 1–9.
    SelectNumber(u8),
    /// Ask for a system id and select that vehicle.
    SelectById,
    /// Map: zoom in.
    ZoomIn,
    /// Map: zoom out.
    ZoomOut,
    /// Map: fit the whole grid.
    ZoomFit,
    /// Map: keep the selected vehicle centred.
    FollowSelected,
    /// Map: pan north.
    PanNorth,
    /// Map: pan south.
    PanSouth,
    /// Map: pan west.
    PanWest,
    /// Map: pan east.
    PanEast,
    /// Fleet pane: select the previous vehicle (arrow key).
    FleetUp,
    /// Fleet pane: select the next vehicle (arrow key).
    FleetDown,
    /// Log: one line older.
    LogUp,
    /// Log: one line newer.
    LogDown,
    /// Log: one page older.
    LogPageUp,
    /// Log: one page newer.
    LogPageDown,
    /// Log: jump to the newest line and follow.
    LogLatest,
    /// Log: jump to the oldest line.
    LogOldest,
    /// Start the mission (confirm).
    Start,
    /// Pause the mission: every vehicle holds (no confirmation: it is the safe action).
    PauseAll,
    /// The selected vehicle holds (no confirmation).
    HoldVehicle,
    /// Resume the paused mission (confirm).
    Resume,
    /// Selected vehicle returns to launch (confirm).
    RtlVehicle,
    /// Every vehicle returns to launch (confirm).
    RtlAll,
    /// Selected vehicle lands where it is (confirm).
    Land,
    /// Arm the selected vehicle (confirm).
    Arm,
    /// Disarm the selected vehicle (confirm; motors stop, even in the air).
    Disarm,
    /// The selected vehicle's battery was swapped: resume it (confirm).
    BatterySwapped,
    /// Dialog: yes.
    Confirm,
    /// Dialog: no / close the help / cancel the prompt.
    Cancel,
    /// Help: scroll up.
    HelpUp,
    /// Help: scroll down.
    HelpDown,
}

/// The whole table, in help order. [`Action::SelectNumber`] appears once per digit.
pub const ALL_ACTIONS: &[Action] = &[
    Action::Help,
    Action::Quit,
    Action::QuitNow,
    Action::FocusNext,
    Action::FocusPrev,
    Action::NextVehicle,
    Action::PrevVehicle,
    Action::SelectNumber(1),
    Action::SelectNumber(2),
    Action::SelectNumber(3),
    Action::SelectNumber(4),
    Action::SelectNumber(5),
    Action::SelectNumber(6),
    Action::SelectNumber(7),
    Action::SelectNumber(8),
    Action::SelectNumber(9),
    Action::SelectById,
    Action::Start,
    Action::PauseAll,
    Action::HoldVehicle,
    Action::Resume,
    Action::RtlVehicle,
    Action::RtlAll,
    Action::Land,
    Action::Arm,
    Action::Disarm,
    Action::BatterySwapped,
    Action::ZoomIn,
    Action::ZoomOut,
    Action::ZoomFit,
    Action::FollowSelected,
    Action::FleetUp,
    Action::FleetDown,
    Action::PanNorth,
    Action::PanSouth,
    Action::PanWest,
    Action::PanEast,
    Action::LogUp,
    Action::LogDown,
    Action::LogPageUp,
    Action::LogPageDown,
    Action::LogLatest,
    Action::LogOldest,
    Action::Confirm,
    Action::Cancel,
    Action::HelpUp,
    Action::HelpDown,
];

impl Action {
    /// The name used in the key map file.
    pub fn name(self) -> String {
        let s = match self {
            Action::SelectNumber(n) => return format!("select_{n}"),
            Action::Help => "help",
            Action::Quit => "quit",
            Action::QuitNow => "quit_now",
            Action::FocusNext => "focus_next",
            Action::FocusPrev => "focus_prev",
            Action::NextVehicle => "next_vehicle",
            Action::PrevVehicle => "prev_vehicle",
            Action::SelectById => "select_by_id",
            Action::ZoomIn => "zoom_in",
            Action::ZoomOut => "zoom_out",
            Action::ZoomFit => "zoom_fit",
            Action::FollowSelected => "follow_selected",
            Action::PanNorth => "pan_north",
            Action::PanSouth => "pan_south",
            Action::PanWest => "pan_west",
            Action::PanEast => "pan_east",
            Action::FleetUp => "fleet_up",
            Action::FleetDown => "fleet_down",
            Action::LogUp => "log_up",
            Action::LogDown => "log_down",
            Action::LogPageUp => "log_page_up",
            Action::LogPageDown => "log_page_down",
            Action::LogLatest => "log_latest",
            Action::LogOldest => "log_oldest",
            Action::Start => "start",
            Action::PauseAll => "pause_all",
            Action::HoldVehicle => "hold_vehicle",
            Action::Resume => "resume",
            Action::RtlVehicle => "rtl_vehicle",
            Action::RtlAll => "rtl_all",
            Action::Land => "land",
            Action::Arm => "arm",
            Action::Disarm => "disarm",
            Action::BatterySwapped => "battery_swapped",
            Action::Confirm => "confirm",
            Action::Cancel => "cancel",
            Action::HelpUp => "help_up",
            Action::HelpDown => "help_down",
        };
        s.to_string()
    }

    /// The action a key map file name stands for.
    pub fn from_name(name: &str) -> Option<Action> {
        ALL_ACTIONS.iter().copied().find(|a| a.name() == name)
    }

    /// Where the binding applies.
    pub fn context(self) -> Context {
        match self {
            Action::FleetUp | Action::FleetDown => Context::Fleet,
            Action::PanNorth | Action::PanSouth | Action::PanWest | Action::PanEast => Context::Map,
            Action::LogUp
            | Action::LogDown
            | Action::LogPageUp
            | Action::LogPageDown
            | Action::LogLatest
            | Action::LogOldest => Context::Log,
            Action::Confirm | Action::Cancel => Context::Dialog,
            Action::HelpUp | Action::HelpDown => Context::Help,
            _ => Context::Global,
        }
    }

    /// One line for the help overlay.
    pub fn description(self) -> String {
        let s = match self {
            Action::SelectNumber(n) => return format!("select vehicle with system id {n}"),
            Action::Help => "show / hide this help",
            Action::Quit => "quit (asks; vehicles keep flying)",
            Action::QuitNow => "quit without asking",
            Action::FocusNext => "focus next pane",
            Action::FocusPrev => "focus previous pane",
            Action::NextVehicle => "select next vehicle",
            Action::PrevVehicle => "select previous vehicle",
            Action::SelectById => "select vehicle by system id…",
            Action::ZoomIn => "map: zoom in",
            Action::ZoomOut => "map: zoom out",
            Action::ZoomFit => "map: fit the whole grid",
            Action::FollowSelected => "map: follow selected vehicle",
            Action::PanNorth => "pan north",
            Action::PanSouth => "pan south",
            Action::PanWest => "pan west",
            Action::PanEast => "pan east",
            Action::FleetUp => "select previous vehicle",
            Action::FleetDown => "select next vehicle",
            Action::LogUp => "one line older",
            Action::LogDown => "one line newer",
            Action::LogPageUp => "one page older",
            Action::LogPageDown => "one page newer",
            Action::LogLatest => "newest, follow",
            Action::LogOldest => "oldest",
            Action::Start => "START mission (confirm)",
            Action::PauseAll => "PAUSE: all vehicles hold",
            Action::HoldVehicle => "HOLD selected vehicle",
            Action::Resume => "RESUME mission (confirm)",
            Action::RtlVehicle => "RTL selected vehicle (confirm)",
            Action::RtlAll => "RTL ALL vehicles (confirm)",
            Action::Land => "LAND selected vehicle (confirm)",
            Action::Arm => "ARM selected vehicle (confirm)",
            Action::Disarm => "DISARM selected vehicle (confirm)",
            Action::BatterySwapped => "battery swapped: resume selected (confirm)",
            Action::Confirm => "yes, do it",
            Action::Cancel => "no / close",
            Action::HelpUp => "scroll up",
            Action::HelpDown => "scroll down",
        };
        s.to_string()
    }

    /// The built-in keys.
    pub fn default_keys(self) -> Vec<Key> {
        use KeyCode as K;
        match self {
            Action::Help => vec![Key::char('?'), Key::plain(K::F(1))],
            Action::Quit => vec![Key::char('q')],
            Action::QuitNow => vec![Key::ctrl('c')],
            Action::FocusNext => vec![Key::plain(K::Tab)],
            Action::FocusPrev => vec![Key::plain(K::BackTab)],
            Action::NextVehicle => vec![Key::char('j'), Key::char('n')],
            Action::PrevVehicle => vec![Key::char('k'), Key::char('N')],
            Action::SelectNumber(n) => {
                vec![Key::char(char::from_digit(u32::from(n), 10).unwrap_or('?'))]
            }
            Action::SelectById => vec![Key::char('g')],
            Action::ZoomIn => vec![Key::char('+'), Key::char('=')],
            Action::ZoomOut => vec![Key::char('-')],
            Action::ZoomFit => vec![Key::char('f')],
            Action::FollowSelected => vec![Key::char('c')],
            Action::PanNorth => vec![Key::plain(K::Up)],
            Action::PanSouth => vec![Key::plain(K::Down)],
            Action::PanWest => vec![Key::plain(K::Left)],
            Action::PanEast => vec![Key::plain(K::Right)],
            Action::FleetUp => vec![Key::plain(K::Up)],
            Action::FleetDown => vec![Key::plain(K::Down)],
            Action::LogUp => vec![Key::plain(K::Up)],
            Action::LogDown => vec![Key::plain(K::Down)],
            Action::LogPageUp => vec![Key::plain(K::PageUp)],
            Action::LogPageDown => vec![Key::plain(K::PageDown)],
            Action::LogLatest => vec![Key::plain(K::End)],
            Action::LogOldest => vec![Key::plain(K::Home)],
            Action::Start => vec![Key::char('s')],
            Action::PauseAll => vec![Key::char('p'), Key::char(' ')],
            Action::HoldVehicle => vec![Key::char('h')],
            Action::Resume => vec![Key::char('r')],
            Action::RtlVehicle => vec![Key::char('t')],
            Action::RtlAll => vec![Key::char('T')],
            Action::Land => vec![Key::char('l')],
            Action::Arm => vec![Key::char('a')],
            Action::Disarm => vec![Key::char('D')],
            Action::BatterySwapped => vec![Key::char('b')],
            Action::Confirm => vec![Key::char('y')],
            Action::Cancel => vec![Key::char('n'), Key::plain(K::Esc)],
            Action::HelpUp => vec![Key::plain(K::Up), Key::char('k')],
            Action::HelpDown => vec![Key::plain(K::Down), Key::char('j')],
        }
    }

    /// Actions that must keep at least one key (or the UI could not be left or confirmed).
    fn required(self) -> bool {
        matches!(
            self,
            Action::Help | Action::Confirm | Action::Cancel | Action::QuitNow
        )
    }
}

/// A problem with a key map file.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum KeyMapError {
    /// Not a key in the file syntax.
    #[error(
        "{0:?} is not a key (expected one character, or a name such as space, tab, esc, enter, up, pageup, f1, with optional ctrl-/alt-/shift- prefixes)"
    )]
    BadKey(String),
    /// Not an action name.
    #[error("{0:?} is not an action (run `fleetmap tui --print-config` for the list)")]
    UnknownAction(String),
    /// Two actions that can be active at the same time share a key.
    #[error("key {key} is bound to both {first} and {second} ({context})")]
    Conflict {
        /// The key.
        key: String,
        /// One action.
        first: String,
        /// The other.
        second: String,
        /// Where they collide.
        context: String,
    },
    /// An action that must have a key was left without one.
    #[error("{0} must keep at least one key")]
    Unbound(String),
}

/// The key map: for every action in [`ALL_ACTIONS`], its keys.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct KeyMap {
    bindings: Vec<(Action, Vec<Key>)>,
}

impl Default for KeyMap {
    fn default() -> Self {
        KeyMap {
            bindings: ALL_ACTIONS.iter().map(|&a| (a, a.default_keys())).collect(),
        }
    }
}

/// One action's keys in the file: a key or a list of keys.
#[derive(Debug, Deserialize)]
#[serde(untagged)]
pub(crate) enum KeysValue {
    One(String),
    Many(Vec<String>),
}

impl KeyMap {
    /// The defaults with the file's `[keys]` entries replacing those actions' keys.
    pub(crate) fn with_overrides(
        overrides: &BTreeMap<String, KeysValue>,
    ) -> Result<KeyMap, KeyMapError> {
        let mut map = KeyMap::default();
        for (name, value) in overrides {
            let action =
                Action::from_name(name).ok_or_else(|| KeyMapError::UnknownAction(name.clone()))?;
            let texts = match value {
                KeysValue::One(s) => vec![s.as_str()],
                KeysValue::Many(v) => v.iter().map(String::as_str).collect(),
            };
            let keys = texts
                .into_iter()
                .map(Key::parse)
                .collect::<Result<Vec<_>, _>>()?;
            map.set(action, keys);
        }
        map.validate()?;
        Ok(map)
    }

    /// Replace the keys of `action` (call [`KeyMap::validate`] afterwards).
    pub fn set(&mut self, action: Action, keys: Vec<Key>) {
        if let Some(b) = self.bindings.iter_mut().find(|(a, _)| *a == action) {
            b.1 = keys;
        }
    }

    /// Check that no key is ambiguous: within one context, and between a pane context and
    /// the global keys that stay active under it only where the pane binding would hide a
    /// required action. Required actions must keep a key.
    pub fn validate(&self) -> Result<(), KeyMapError> {
        for (a, keys) in &self.bindings {
            if a.required() && keys.is_empty() {
                return Err(KeyMapError::Unbound(a.name()));
            }
        }
        let mut seen: BTreeMap<(Context, String), Action> = BTreeMap::new();
        for (a, keys) in &self.bindings {
            for k in keys {
                let slot = (a.context(), k.to_string());
                if let Some(prev) = seen.get(&slot)
                    && prev != a
                {
                    return Err(KeyMapError::Conflict {
                        key: k.to_string(),
                        first: prev.name(),
                        second: a.name(),
                        context: a.context().heading().to_string(),
                    });
                }
                seen.insert(slot, *a);
            }
        }
        // quit_now works everywhere, so nothing may shadow it.
        for k in self.keys(Action::QuitNow) {
            for (a, keys) in &self.bindings {
                if *a != Action::QuitNow && keys.contains(k) {
                    return Err(KeyMapError::Conflict {
                        key: k.to_string(),
                        first: Action::QuitNow.name(),
                        second: a.name(),
                        context: "quit_now works everywhere".to_string(),
                    });
                }
            }
        }
        Ok(())
    }

    /// The keys bound to `action`.
    pub fn keys(&self, action: Action) -> &[Key] {
        self.bindings
            .iter()
            .find(|(a, _)| *a == action)
            .map(|(_, k)| k.as_slice())
            .unwrap_or(&[])
    }

    /// Every binding, in table order.
    pub fn bindings(&self) -> impl Iterator<Item = (Action, &[Key])> {
        self.bindings.iter().map(|(a, k)| (*a, k.as_slice()))
    }

    /// The action bound to `key` in `context` (only that context; see [`Context`] for the
    /// order in which the app consults them).
    pub fn lookup(&self, context: Context, key: Key) -> Option<Action> {
        self.bindings
            .iter()
            .find(|(a, keys)| a.context() == context && keys.contains(&key))
            .map(|(a, _)| *a)
    }

    /// The keys of `action` as the help shows them (`"j n"`), or `"(unbound)"`.
    pub fn keys_label(&self, action: Action) -> String {
        let keys = self.keys(action);
        if keys.is_empty() {
            "(unbound)".to_string()
        } else {
            keys.iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join(" ")
        }
    }

    /// The `[keys]` section of a config file listing every binding, with its description as
    /// a comment (what `fleetmap tui --print-config` prints).
    pub fn to_toml(&self) -> String {
        let mut out = String::from("[keys]\n");
        let mut context = None;
        for (a, keys) in &self.bindings {
            if context != Some(a.context()) {
                context = Some(a.context());
                out.push_str(&format!("# -- {} --\n", a.context().heading()));
            }
            let list = keys
                .iter()
                .map(|k| toml_string(&k.to_string()))
                .collect::<Vec<_>>()
                .join(", ");
            out.push_str(&format!(
                "{} = [{}]  # {}\n",
                a.name(),
                list,
                a.description()
            ));
        }
        out
    }
}

fn toml_string(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
