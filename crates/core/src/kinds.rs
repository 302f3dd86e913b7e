//! The mission kinds: the one list a kind is registered in, for every crate of the workspace.
//!
//! A kind is its folders in each layer (its table of the mission file, its on-board
//! measurement and the camera's side of it, its run, its studies) plus one entry in
//! [`for_each_kind!`]. Each layer asks the list for its part and generates from it what
//! names the kinds: the mission file's `MissionKind`, `MissionDef`'s tables and their
//! modules (`mission::definition`), the on-board measurements (`vision::onboard`) and the
//! camera's measurers, the ground station's registry of runs and its studies. A layer's
//! module of a kind is declared by the list too, so a new kind that lacks one does not
//! build.

/// The list of mission kinds, one entry per kind, given to `$callback!` in the shape of one
/// of its parts (each kind's part a bracketed group, in the list's order):
///
/// | `$part` | what `$callback!` gets per kind | used by |
/// |---|---|---|
/// | `file` | `[$(#[doc])*] [Variant "name" module Def]`: the kind's `MissionKind` variant, its name in mission files, its module of `mission::definition` (also its table, `[module]`, and `MissionDef`'s field) and the table's type | `mission::definition` |
/// | `vision` | `[module]` (or `[]`): its module of `vision`, if it has one | `vision` |
/// | `onboard` | `[$(#[doc])*] [Name (Definition) (Message) module]`: its on-board measurement, the variant of `OnboardSpec`, `OnboardKind` and `Onboard`, the definition a camera is given, the message the camera sends, and the camera's module that measures it | `vision::onboard`, the camera |
/// | `run` | `[module Kind]`: its module of the ground station's kinds and its `RunKind` | the ground station's registry |
/// | `study` | `[module]` or `[module module]`: its module of `experiment`, and again if that module has benchmarks | `experiment` |
///
/// The order is the kinds' order everywhere: in messages that list them, in the registry
/// (`fleetmap demo` flies the first unless another kind's flags choose it), in `--help`.
#[macro_export]
macro_rules! for_each_kind {
    ($part:ident => $callback:ident) => {
        $crate::kind_part! { $part $callback
            /// Runway mapping (runway paper): lawnmower sweep, then the multi-robot recursive DFS.
            RunwayMapping = "runway-mapping" { file: runway::RunwayDef, vision: runway, onboard: Runway($crate::vision::runway::onboard::RunwayDefinition, $crate::vision::runway::onboard::RunwayMeasurement) in runway, run: runway::Runway, study: runway }
            /// Spatial classification (bandit paper): UCB bandit + integer-program sorties with
            /// mobile charging stations.
            SpatialClassification = "spatial-classification" { file: classification::ClassificationDef, onboard: Green($crate::vision::onboard::GreenSpec, $crate::vision::onboard::OnboardMeasurement) in green, run: bandit::Classification, study: bandit, bench: bandit }
        }
    };
}

/// [`for_each_kind!`]'s parts: the list read once into bracketed groups, then the part's
/// groups handed on.
#[doc(hidden)]
#[macro_export]
macro_rules! kind_part {
    ($part:ident $callback:ident $(
        $(#[$doc:meta])*
        $variant:ident = $name:literal { file: $file:ident :: $def:ident,
            $(vision: $vision:ident,)?
            onboard: $onboard:ident($spec:path, $msg:path) in $measurer:ident,
            run: $run:ident :: $kind:ident, study: $study:ident $(, bench: $bench:ident)? }
    )+) => {
        $crate::kind_part! { @$part $callback $(
            [$(#[$doc])*]
            [$variant $name $file $def]
            [$($vision)?]
            [$onboard ($spec) ($msg) $measurer]
            [$run $kind]
            [$study $($bench)?]
        )+ }
    };
    (@file $callback:ident $($doc:tt $file:tt $vision:tt $onboard:tt $run:tt $study:tt)+) => {
        $callback! { $($doc $file)+ }
    };
    (@vision $callback:ident $($doc:tt $file:tt $vision:tt $onboard:tt $run:tt $study:tt)+) => {
        $callback! { $($vision)+ }
    };
    (@onboard $callback:ident $($doc:tt $file:tt $vision:tt $onboard:tt $run:tt $study:tt)+) => {
        $callback! { $($doc $onboard)+ }
    };
    (@run $callback:ident $($doc:tt $file:tt $vision:tt $onboard:tt $run:tt $study:tt)+) => {
        $callback! { $($run)+ }
    };
    (@study $callback:ident $($doc:tt $file:tt $vision:tt $onboard:tt $run:tt $study:tt)+) => {
        $callback! { $($study)+ }
    };
}
