//! Monte Carlo studies that reproduce the papers' tables and figures (CSV, JSON, PNG).
//!
//! A mission kind's studies live in its folder (`bandit/`, `runway/`), each with its
//! subcommands of `fleetmap experiment` (`cli::Studies`) and of `fleetmap bench`
//! (`bench::Benches`); `kinds!` below makes the lists from the core's list of kinds, and the
//! command line flattens them ([`KindStudies`], [`KindBenches`]) into its own.

pub mod dfs;

/// Print a command's result on stdout, as the command line does (a closed pipe is not an
/// error).
pub(crate) type Emit = fn(&str) -> anyhow::Result<()>;

/// Every kind's folder of studies (`<kind>::cli::Studies`) and, for the kinds that have them,
/// benchmarks (`<kind>::bench::Benches`), from the list of kinds
/// ([`fleetmap_core::for_each_kind!`]'s `study` part), in its order.
macro_rules! kinds {
    ($([$s:ident $($b:ident)?])+) => {
        $(pub mod $s;)+

        /// Every kind's studies, subcommands of `fleetmap experiment`.
        #[derive(Debug, clap::Subcommand)]
        #[allow(non_camel_case_types, missing_docs)]
        pub enum KindStudies {
            $(
                #[command(flatten)]
                $s($s::cli::Studies),
            )+
        }

        impl KindStudies {
            /// Run the study; `emit` prints a result on stdout.
            pub(crate) fn run(self, emit: Emit) -> anyhow::Result<std::process::ExitCode> {
                match self {
                    $(KindStudies::$s(s) => s.run(emit),)+
                }
            }
        }

        /// Every kind's benchmarks, subcommands of `fleetmap bench`.
        #[derive(Debug, clap::Subcommand)]
        #[allow(non_camel_case_types, missing_docs)]
        pub enum KindBenches {
            $($(
                #[command(flatten)]
                $b($b::bench::Benches),
            )?)+
        }

        impl KindBenches {
            /// Run the benchmark; `emit` prints its figures on stdout.
            pub(crate) fn run(self, emit: Emit) -> anyhow::Result<std::process::ExitCode> {
                match self {
                    $($(KindBenches::$b(b) => b.run(emit),)?)+
                }
            }
        }
    };
}

fleetmap_core::for_each_kind!(study => kinds);
