//! The mission kinds as the UI sees them, through the registry (`crate::app::kinds`): how
//! each looks, to draw a model that names its kind only (a replay file records the map's
//! label and the mission's name, not the legend), and each one's built-in sample. The first
//! kind registered is the default: its look before a mission is loaded, its sample without
//! `--sample`.

use crate::app::kind::RunKind;
use crate::app::kinds::{self, KindVisitor};
use crate::panes::{KindLook, MapKind, MissionKind, Sample};

/// Every registered kind's look, in registry order.
pub(crate) fn looks() -> Vec<KindLook> {
    struct Look;
    impl KindVisitor for Look {
        type Output = KindLook;
        fn visit<K: RunKind>(self) -> KindLook {
            K::LOOK
        }
    }
    kinds::NAMES
        .iter()
        .filter_map(|name| kinds::by_name(name, Look).ok())
        .collect()
}

/// The look of a map of `kind`: its own when it has a legend; otherwise the registered kind's
/// of the same label, or the default kind's for a map that names no kind (no mission).
pub(crate) fn map_look(kind: &MapKind) -> MapKind {
    if !kind.legend.is_empty() {
        return kind.clone();
    }
    let looks = looks();
    let found = if kind.label.is_empty() {
        looks.first()
    } else {
        looks.iter().find(|l| l.map.label == kind.label)
    };
    found.map_or_else(|| kind.clone(), |l| l.map.clone())
}

/// Whether a mission of `kind` counts epochs: its own word, or the registered kind's of the
/// same name (a recorded model does not say).
pub(crate) fn counts_epochs(kind: &MissionKind) -> bool {
    kind.epochs
        || looks()
            .iter()
            .any(|l| l.mission.name == kind.name && l.mission.epochs)
}

/// The names `fleetmap tui --sample` takes, each with what it shows; the default first.
pub fn sample_names() -> Vec<(&'static str, &'static str)> {
    looks().iter().map(|l| (l.sample, l.sample_help)).collect()
}

/// The built-in sample named `name` ([`KindLook::sample`]) with `vehicles` drones when it is
/// animated; `None` for a name no kind has.
pub fn sample(name: &str, vehicles: usize) -> Option<Sample> {
    struct Named<'a>(&'a str, usize);
    impl KindVisitor for Named<'_> {
        type Output = Option<Sample>;
        fn visit<K: RunKind>(self) -> Option<Sample> {
            (K::LOOK.sample == self.0).then(|| K::sample(self.1))
        }
    }
    kinds::NAMES
        .iter()
        .find_map(|kind| kinds::by_name(kind, Named(name, vehicles)).ok().flatten())
}

/// The default kind's look (the first registered).
pub(crate) fn default_look() -> KindLook {
    looks()
        .into_iter()
        .next()
        .expect("the registry holds at least one kind")
}
