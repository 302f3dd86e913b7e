//! The mission kinds this build flies (async shell), each one folder, and their registry:
//! the folders' `mod` lines, the registry (`registry!` below) and the kinds' own commands are
//! generated from the core's list of kinds ([`fleetmap_core::for_each_kind!`];
//! CONTRIBUTING.md, "Adding a mission kind").
//!
//! | module | what |
//! |---|---|
//! | [`runway`] | the runway-mapping run (sweep, confirmation, DFS, battery swaps, resume): events, pilot, intake, sweep, runner; its report and GeoJSON / KML / PNG exports, IoU against a simulated world |
//! | [`bandit`] | the spatial-classification run (epochs, sorties with charging rovers, measurements, resume): events, runner, sortie, pilot, intake, upload; its report (keep / reject / errors, per-epoch figures) and the progress PNG (Fig. 4) |
//!
//! Code that works on "a run of whatever kind" is written once, generic over
//! [`RunKind`], as a `KindVisitor`; `by_name` and `of_mission` call it with the kind
//! a run directory or a mission file names. With the simulator, every kind is also a
//! `crate::launch::demo::DemoKind`: `fleetmap demo` takes each kind's flags
//! (`DemoFlags`) and flies the demo they choose.

use crate::app::kind::RunKind;
use fleetmap_core::mission::definition::MissionDef;

/// Work written once for every kind: [`KindVisitor::visit`] is called with the kind found.
pub(crate) trait KindVisitor {
    /// What the work returns.
    type Output;
    /// Do the work for kind `K`.
    fn visit<K: RunKind>(self) -> Self::Output;
}

/// A kind name (`run.json`'s or a mission file's) this build does not fly.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("a {name} run; this build knows {known}")]
pub(crate) struct UnknownKind {
    /// The name asked for.
    pub name: String,
    /// The kinds this build flies, listed for the message.
    pub known: String,
}

/// The list of kinds' demo flags for `registry!`: `KindFlags<K1, KindFlags<K2, … NoFlags>>`.
#[cfg(feature = "sim")]
macro_rules! demo_flags {
    ($kind:ty) => {
        crate::launch::demo::KindFlags<$kind, crate::launch::demo::NoFlags>
    };
    ($kind:ty, $($rest:ty),+) => {
        crate::launch::demo::KindFlags<$kind, demo_flags!($($rest),+)>
    };
}

/// The registration: every kind, once. `by_name` tries them in this order; `fleetmap demo`
/// flies the first unless another kind's flags choose it.
macro_rules! registry {
    ($($kind:ty),+ $(,)?) => {
        /// The names ([`RunKind::KIND`]) of every kind this build flies.
        pub(crate) const NAMES: &[&str] = &[$(<$kind as RunKind>::KIND),+];

        /// Call `v` with the kind named `name` (`run.json`'s `kind`, or a mission file's).
        pub(crate) fn by_name<V: KindVisitor>(name: &str, v: V) -> Result<V::Output, UnknownKind> {
            $(
                if name == <$kind as RunKind>::KIND {
                    return Ok(v.visit::<$kind>());
                }
            )+
            Err(UnknownKind {
                name: name.to_string(),
                known: NAMES.join(" and "),
            })
        }

        /// Every kind's own flags of `fleetmap demo`, in this order.
        #[cfg(feature = "sim")]
        pub(crate) type DemoFlags = demo_flags!($($kind),+);
    };
}

/// Every kind's module and its [`RunKind`], from the list of kinds
/// ([`fleetmap_core::for_each_kind!`]'s `run` part), with the registration and the kinds'
/// own subcommands (`<kind>::commands`).
macro_rules! kinds {
    ($([$module:ident $kind:ident])+) => {
        $(pub mod $module;)+

        registry!($($module::$kind),+);

        /// Every kind's own subcommands of `fleetmap` (`fleetmap classify`, `fleetmap plan`).
        #[derive(Debug, clap::Subcommand)]
        #[allow(non_camel_case_types, missing_docs)]
        pub enum KindCommands {
            $(
                #[command(flatten)]
                $module($module::commands::Commands),
            )+
        }

        impl KindCommands {
            /// Run the command.
            pub(crate) fn run(self) -> anyhow::Result<std::process::ExitCode> {
                match self {
                    $(KindCommands::$module(c) => c.run(),)+
                }
            }
        }

        /// Every kind's own subcommands of `fleetmap bench` that need no simulator (the
        /// studies' benchmarks are `crate::experiment::KindBenches`).
        #[derive(Debug, clap::Subcommand)]
        #[allow(non_camel_case_types, missing_docs)]
        pub enum KindBenchCommands {
            $(
                #[command(flatten)]
                $module($module::commands::BenchCommands),
            )+
        }

        impl KindBenchCommands {
            /// Run the benchmark.
            pub(crate) fn run(self) -> anyhow::Result<std::process::ExitCode> {
                match self {
                    $(KindBenchCommands::$module(c) => c.run(),)+
                }
            }
        }
    };
}

fleetmap_core::for_each_kind!(run => kinds);

/// Write `text` to stdout, as the kinds' commands and studies print their results; a closed
/// pipe (`fleetmap plan … | head`) is not an error.
pub(crate) fn emit(text: &str) -> anyhow::Result<()> {
    use std::io::Write as _;
    let mut stdout = std::io::stdout().lock();
    match stdout
        .write_all(text.as_bytes())
        .and_then(|_| stdout.flush())
    {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(e.into()),
        _ => Ok(()),
    }
}

/// Call `v` with the kind of the mission `def`.
pub(crate) fn of_mission<V: KindVisitor>(def: &MissionDef, v: V) -> Result<V::Output, UnknownKind> {
    by_name(def.kind.as_str(), v)
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Name;
    impl KindVisitor for Name {
        type Output = &'static str;
        fn visit<K: RunKind>(self) -> &'static str {
            K::KIND
        }
    }

    #[test]
    fn every_mission_file_kind_has_a_runner_and_unknown_names_are_refused() {
        use fleetmap_core::mission::definition::MissionKind;
        for k in [
            MissionKind::RunwayMapping,
            MissionKind::SpatialClassification,
        ] {
            assert_eq!(by_name(k.as_str(), Name), Ok(k.as_str()));
        }
        let e = by_name("crop-dusting", Name).unwrap_err();
        assert_eq!(e.name, "crop-dusting");
        assert!(
            e.to_string()
                .contains("runway-mapping and spatial-classification")
        );
    }
}
