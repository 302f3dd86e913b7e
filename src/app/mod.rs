//! Mission runners that tie the layers together: the runway-mapping run, the bandit sortie
//! run and resuming a run directory (async shell).
