//! What a run directory remembers of its connections.

use crate::store::RunDir;
use fleetmap_io::link::ConnSpec;

/// The connections `run.json` remembers, parsed.
pub(crate) fn remembered_connections(run: &RunDir) -> anyhow::Result<Vec<ConnSpec>> {
    run.meta()
        .connections
        .iter()
        .map(|c| {
            c.parse::<ConnSpec>()
                .map_err(|e| anyhow::anyhow!("{c}: {e}"))
        })
        .collect()
}

/// The connections as one label ("LIVE udpin:…, tcp:…").
pub(crate) fn connections_label(conns: &[ConnSpec]) -> String {
    conns
        .iter()
        .map(|c| c.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}
