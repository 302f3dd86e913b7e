//! The mission kinds a mission file may name (`MissionKind`, made by `kinds!` below from the
//! list of kinds, [`crate::for_each_kind!`]) and what a kind's file supplies, [`KindSection`]: its table of the mission file, read and
//! checked by the kind's own module. The generic reader and checks loop over the list and
//! name no kind.

use super::reader::Ctx;
use super::validate::Checker;
use super::*;
use toml::de::DeTable;

/// One mission kind's part of the mission file, written in the kind's module: its table
/// (`[runway]`, `[classification]`), read and checked there.
pub(super) trait KindSection: Sync {
    /// Read the kind's table from the file's root table into `def` (left `None` when the
    /// file has none), reporting structural problems to `ctx`. Every kind's table is read,
    /// whatever the file's `kind`: a table of another kind is a validation problem.
    fn read(&self, ctx: &mut Ctx<'_>, root: &DeTable<'_>, def: &mut MissionDef);

    /// Give a definition of this kind the defaults of an absent table, if the kind has them
    /// (what [`MissionDef::fill_defaults`] does).
    fn fill_default(&self, _def: &mut MissionDef) {}

    /// Step 3 for a definition of this kind: the kind's own values and the rules the kind
    /// puts on the common parts (its team, its area), in the order they are reported.
    fn check(&self, c: &mut Checker, def: &MissionDef);

    /// Whether the kind's missions have charging stations, and with them start cells, a
    /// bounded search area and roads (messages of the other kinds name these kinds).
    fn has_stations(&self) -> bool;
}

/// From the list's `file` part: for each kind its variant of [`MissionKind`], its name in
/// mission files, and the one name of its module here, its table in the file and its field of [`MissionDef`]
/// (the module holds `Section`, its [`KindSection`]). The first kind stands in for the kind
/// of a file whose `kind` is missing or wrong (validation then drops the rules that depend
/// on the kind).
macro_rules! kinds {
    ($([$(#[$doc:meta])*] [$variant:ident $name:literal $module:ident $def:ident])+) => {
        /// Which field mission a definition describes.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
        pub enum MissionKind {
            $($(#[$doc])* #[serde(rename = $name)] $variant,)+
        }

        impl MissionKind {
            /// Every kind, in the list's order: the order their tables are read and named.
            pub(super) const ALL: &[MissionKind] = &[$(MissionKind::$variant),+];

            /// The spelling used in mission files (`"runway-mapping"`,
            /// `"spatial-classification"`).
            pub fn as_str(self) -> &'static str {
                match self {
                    $(MissionKind::$variant => $name,)+
                }
            }

            /// The kind's table in a mission file (`runway`), also its field of [`MissionDef`].
            pub(super) fn table(self) -> &'static str {
                match self {
                    $(MissionKind::$variant => stringify!($module),)+
                }
            }

            /// The kind's section: how its table is read and a definition of it checked.
            pub(super) fn section(self) -> &'static dyn KindSection {
                match self {
                    $(MissionKind::$variant => &$module::Section,)+
                }
            }

            /// Whether `def` has this kind's table.
            pub(super) fn has_table(self, def: &MissionDef) -> bool {
                match self {
                    $(MissionKind::$variant => def.$module.is_some(),)+
                }
            }
        }

        impl MissionDef {
            /// A definition of the common parts with no kind's table and no `link`: what the
            /// reader fills in.
            #[allow(clippy::too_many_arguments)]
            pub(super) fn without_sections(
                name: String,
                kind: MissionKind,
                description: Option<String>,
                grid: GridDef,
                flight: FlightDef,
                camera: CameraModel,
                battery: BatteryDef,
                vehicles: Vec<VehicleDef>,
                area: AreaDef,
            ) -> MissionDef {
                MissionDef {
                    name,
                    kind,
                    description,
                    grid,
                    flight,
                    camera,
                    battery,
                    vehicles,
                    area,
                    $($module: None,)+
                    link: None,
                }
            }
        }
    };
}

crate::for_each_kind!(file => kinds);

impl fmt::Display for MissionKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl MissionKind {
    /// `kinds` as messages list them, joined by " or ": quoted as in a file
    /// (`"runway-mapping"`) or bare (`runway-mapping`).
    pub(super) fn names(kinds: impl Iterator<Item = MissionKind>, quoted: bool) -> String {
        kinds
            .map(|k| {
                if quoted {
                    format!("{:?}", k.as_str())
                } else {
                    k.as_str().to_string()
                }
            })
            .collect::<Vec<_>>()
            .join(" or ")
    }

    /// The kinds whose missions have charging stations ([`KindSection::has_stations`]), as
    /// [`MissionKind::names`] lists them.
    pub(super) fn with_stations(quoted: bool) -> String {
        let kinds = MissionKind::ALL.iter().copied();
        MissionKind::names(kinds.filter(|k| k.section().has_stations()), quoted)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A valid file of each kind, with its table, as lines: its own lines after the
    /// common tables.
    fn examples() -> Vec<MissionDef> {
        let common = [
            "[grid]",
            "origin = \"vehicle\"",
            "cell_size_m = 4.0",
            "[flight]",
            "altitude_m = 12.0",
            "speed_m_s = 1.0",
        ];
        let files = [
            vec![
                "[[vehicles]]",
                "sysid = 1",
                "role = \"drone\"",
                "[runway.sweep]",
                "north_m = [0.0, 8.0]",
                "east_m = [0.0, 8.0]",
            ],
            vec![
                "[[vehicles]]",
                "sysid = 1",
                "role = \"drone\"",
                "start = [0, 0]",
                "[[vehicles]]",
                "sysid = 2",
                "role = \"station\"",
                "start = [0, 0]",
                "[area]",
                "rows = 2",
                "cols = 2",
                "[classification]",
                "theta = 0.5",
            ],
        ];
        MissionKind::ALL
            .iter()
            .zip(files)
            .map(|(k, own)| {
                let root = [format!("name = \"{k}\""), format!("kind = \"{k}\"")];
                let lines = root.iter().map(String::as_str).chain(common).chain(own);
                let text = lines.collect::<Vec<_>>().join("\n");
                MissionDef::parse(&text, "t.toml").unwrap_or_else(|e| panic!("{e}\n{text}"))
            })
            .collect()
    }

    #[test]
    fn a_kind_has_one_name_in_files_serde_and_messages() {
        for &k in MissionKind::ALL {
            let json = serde_json::to_value(k).unwrap();
            assert_eq!(json, serde_json::Value::from(k.as_str()));
            assert_eq!(k.to_string(), k.as_str());
        }
        assert_eq!(
            MissionKind::names(MissionKind::ALL.iter().copied(), true),
            "\"runway-mapping\" or \"spatial-classification\""
        );
        assert_eq!(MissionKind::with_stations(false), "spatial-classification");
    }

    #[test]
    fn a_kinds_table_is_its_field_of_the_definition_and_only_its_own() {
        let defs = examples();
        assert_eq!(defs.len(), MissionKind::ALL.len());
        for def in &defs {
            let json = serde_json::to_value(def).unwrap();
            for &k in MissionKind::ALL {
                let own = k == def.kind;
                assert_eq!(k.has_table(def), own, "{k} table in a {} file", def.kind);
                assert_eq!(json.get(k.table()).is_some(), own, "{k} in {json}");
            }
        }
    }
}
