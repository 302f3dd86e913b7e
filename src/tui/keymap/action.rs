//! The action table: every action a key can trigger, where it applies ([`Context`]), its
//! name in the config file, its help text and its default keys.

use super::Key;
use crossterm::event::KeyCode;

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
    pub(crate) fn from_name(name: &str) -> Option<Action> {
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
    pub(crate) fn default_keys(self) -> Vec<Key> {
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
    pub(super) fn required(self) -> bool {
        matches!(
            self,
            Action::Help | Action::Confirm | Action::Cancel | Action::QuitNow
        )
    }
}
