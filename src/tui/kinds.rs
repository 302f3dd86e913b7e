//! The mission kinds as the UI sees them, through the registry (`crate::kinds`): how
//! each looks, to draw a model that names its kind only (a replay file records the map's
//! label and the mission's name, not the legend), and each one's built-in sample. The first
//! kind registered is the default: its look before a mission is loaded, its sample without
//! `--sample`.

use crate::app::kind::RunKind;
use crate::kinds::{self, KindVisitor};
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
pub(crate) fn sample_names() -> Vec<(&'static str, &'static str)> {
    looks().iter().map(|l| (l.sample, l.sample_help)).collect()
}

/// The built-in sample named `name` ([`KindLook::sample`]) with `vehicles` drones when it is
/// animated; `None` for a name no kind has.
pub(crate) fn sample(name: &str, vehicles: usize) -> Option<Sample> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinds::bandit::Classification;
    use crate::kinds::runway::Runway;
    use crate::panes::CellState;
    use std::borrow::Cow;

    #[test]
    fn the_kinds_legends_partition_the_cell_states_and_their_names_are_unique() {
        let looks = looks();
        let mut seen: Vec<CellState> = Vec::new();
        for l in &looks {
            assert!(!l.map.legend.is_empty(), "{}", l.map.label);
            for s in l.map.legend.iter() {
                assert!(!seen.contains(s), "{s:?} in two legends");
                seen.push(*s);
            }
        }
        assert_eq!(seen.len(), CellState::ALL.len());
        for (i, a) in looks.iter().enumerate() {
            for b in &looks[i + 1..] {
                assert_ne!(a.map.label, b.map.label);
                assert_ne!(a.mission.name, b.mission.name);
                assert_ne!(a.sample, b.sample);
            }
        }
    }

    /// A replay records the map's label and the mission's name only: it draws as the kind
    /// does, and a map without a kind (no mission; replays before the label was recorded)
    /// as the default kind's, runway mapping's.
    #[test]
    fn recorded_models_look_as_their_kinds() {
        let recorded = |label: &str| MapKind {
            label: Cow::Owned(label.to_string()),
            legend: Cow::Borrowed(&[]),
        };
        assert_eq!(map_look(&recorded("runway")), Runway::LOOK.map);
        assert_eq!(
            map_look(&recorded("classification")),
            Classification::LOOK.map
        );
        assert_eq!(map_look(&recorded("")), Runway::LOOK.map);
        assert_eq!(default_look(), Runway::LOOK);
        let unknown = recorded("crop dusting");
        assert_eq!(map_look(&unknown), unknown);
        let named = |name: &str| MissionKind {
            name: Cow::Owned(name.to_string()),
            epochs: false,
        };
        assert!(counts_epochs(&named("spatial classification")));
        assert!(!counts_epochs(&named("runway mapping")));
        assert!(!counts_epochs(&named("crop dusting")));
    }

    #[test]
    fn every_kind_has_its_sample_by_name() {
        let names: Vec<&str> = sample_names().iter().map(|(n, _)| *n).collect();
        assert_eq!(names, ["runway", "classification"]);
        assert!(matches!(sample("runway", 3), Some(Sample::Animated(_))));
        assert!(matches!(
            sample("classification", 3),
            Some(Sample::Static(_))
        ));
        assert!(sample("crop-dusting", 3).is_none());
    }
}
