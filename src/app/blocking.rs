//! Blocking work (decoding and classifying an image, reading and writing a run directory)
//! run off the async reactor, for every layer of the application.

use crate::app::error::BlockingError;

/// Run `f` (CPU-heavy or file work, a few milliseconds) off the reactor: on a blocking thread
/// in a multi-threaded runtime; inline in a current-thread one (the virtual-clock tests, where
/// a blocking thread would let virtual time run on while it works).
pub(crate) async fn run_blocking<T: Send + 'static>(
    f: impl FnOnce() -> T + Send + 'static,
) -> Result<T, BlockingError> {
    match tokio::runtime::Handle::current().runtime_flavor() {
        tokio::runtime::RuntimeFlavor::CurrentThread => Ok(f()),
        _ => tokio::task::spawn_blocking(f).await.map_err(BlockingError),
    }
}
