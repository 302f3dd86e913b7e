//! A single-value channel whose receivers wake in a defined order: the API of
//! `tokio::sync::watch` (the part fleetmap uses), for every watch channel of the station and the
//! simulator.
//!
//! Why not tokio's own: tokio's watch channel spreads its waiting receivers over eight
//! `Notify`s and picks one at random for each wait (`thread_rng_n(8)` in `sync/watch.rs`,
//! tokio 1.54), so that a value sent wakes them in a random order. Nothing else in a
//! current-thread runtime is random (a `select!` is made `biased`), and a run in virtual time
//! (the paused clock of the tests and of `fleetmap experiment runway`) was then a different run
//! at each start of the process: the pilots woken by one change of the run's state claimed
//! their next cells in a different order. Here every receiver waits on one `Notify`, which wakes
//! its waiters in the order they began to wait, so the same run wakes them in the same order.
//!
//! Semantics follow tokio's: a receiver has seen the value it was made with; `changed` returns
//! once a newer one was sent (or with an error once the sender is gone and nothing newer is
//! left); `send` fails, keeping the value it was given, when every receiver is gone;
//! `send_replace`, `send_modify` and `send_if_modified` store whatever the receivers.

use std::fmt;
use std::ops::Deref;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, PoisonError, RwLock, RwLockReadGuard};
use tokio::sync::Notify;

/// The errors of the channel.
pub mod error {
    use std::fmt;

    /// `send` found no receiver; the value is handed back.
    #[derive(PartialEq, Eq, Clone, Copy)]
    pub struct SendError<T>(pub T);

    impl<T> fmt::Debug for SendError<T> {
        fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str("SendError { .. }")
        }
    }

    impl<T> fmt::Display for SendError<T> {
        fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str("channel closed")
        }
    }

    impl<T> std::error::Error for SendError<T> {}

    /// The sender is gone (and no value is left unseen).
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub struct RecvError(pub(super) ());

    impl fmt::Display for RecvError {
        fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str("channel closed")
        }
    }

    impl std::error::Error for RecvError {}
}

use error::{RecvError, SendError};

struct Shared<T> {
    value: RwLock<T>,
    /// Bumped by every value stored.
    version: AtomicU64,
    /// The sender is gone.
    closed: AtomicBool,
    /// Receivers alive.
    receivers: AtomicUsize,
    /// Receivers waiting for a value (or for the sender's end), woken first come, first served.
    to_receivers: Notify,
    /// A sender waiting for the last receiver to go.
    to_sender: Notify,
}

impl<T> Shared<T> {
    fn read(&self) -> RwLockReadGuard<'_, T> {
        self.value.read().unwrap_or_else(PoisonError::into_inner)
    }
}

/// A borrowed value of the channel (holds a read lock: keep it short, never across an await).
pub struct Ref<'a, T>(RwLockReadGuard<'a, T>);

impl<T> Deref for Ref<'_, T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.0
    }
}

impl<T: fmt::Debug> fmt::Debug for Ref<'_, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        (**self).fmt(f)
    }
}

/// The sending half.
pub struct Sender<T> {
    shared: Arc<Shared<T>>,
}

/// A receiving half (clone it for another receiver).
pub struct Receiver<T> {
    shared: Arc<Shared<T>>,
    /// The version this receiver has seen.
    seen: u64,
}

/// A channel holding `init`.
pub fn channel<T>(init: T) -> (Sender<T>, Receiver<T>) {
    let shared = Arc::new(Shared {
        value: RwLock::new(init),
        version: AtomicU64::new(0),
        closed: AtomicBool::new(false),
        receivers: AtomicUsize::new(1),
        to_receivers: Notify::new(),
        to_sender: Notify::new(),
    });
    (
        Sender {
            shared: shared.clone(),
        },
        Receiver { shared, seen: 0 },
    )
}

impl<T> fmt::Debug for Sender<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("watch::Sender")
            .field("version", &self.shared.version.load(Ordering::SeqCst))
            .finish()
    }
}

impl<T> fmt::Debug for Receiver<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("watch::Receiver")
            .field("seen", &self.seen)
            .finish()
    }
}

impl<T> Sender<T> {
    /// Store `value` and wake the receivers; fails (handing it back, the channel unchanged)
    /// when there is no receiver.
    pub fn send(&self, value: T) -> Result<(), SendError<T>> {
        if self.shared.receivers.load(Ordering::SeqCst) == 0 {
            return Err(SendError(value));
        }
        self.send_replace(value);
        Ok(())
    }

    /// Store `value` whether or not anyone receives, wake the receivers; the old value.
    pub fn send_replace(&self, value: T) -> T {
        let old = {
            let mut v = self
                .shared
                .value
                .write()
                .unwrap_or_else(PoisonError::into_inner);
            std::mem::replace(&mut *v, value)
        };
        self.bump();
        old
    }

    /// Change the value in place and wake the receivers.
    pub fn send_modify(&self, modify: impl FnOnce(&mut T)) {
        self.send_if_modified(|v| {
            modify(v);
            true
        });
    }

    /// Change the value in place; the receivers are woken (and the value counts as new) only
    /// when `modify` says it changed it. Returns what `modify` said.
    pub fn send_if_modified(&self, modify: impl FnOnce(&mut T) -> bool) -> bool {
        let changed = {
            let mut v = self
                .shared
                .value
                .write()
                .unwrap_or_else(PoisonError::into_inner);
            modify(&mut v)
        };
        if changed {
            self.bump();
        }
        changed
    }

    fn bump(&self) {
        self.shared.version.fetch_add(1, Ordering::SeqCst);
        self.shared.to_receivers.notify_waiters();
    }

    /// The current value.
    pub fn borrow(&self) -> Ref<'_, T> {
        Ref(self.shared.read())
    }

    /// A new receiver, which has seen the current value.
    pub fn subscribe(&self) -> Receiver<T> {
        self.shared.receivers.fetch_add(1, Ordering::SeqCst);
        Receiver {
            shared: self.shared.clone(),
            seen: self.shared.version.load(Ordering::SeqCst),
        }
    }

    /// Every receiver is gone.
    pub fn is_closed(&self) -> bool {
        self.shared.receivers.load(Ordering::SeqCst) == 0
    }

    /// Returns once every receiver is gone.
    pub async fn closed(&self) {
        loop {
            let gone = self.shared.to_sender.notified();
            tokio::pin!(gone);
            gone.as_mut().enable();
            if self.is_closed() {
                return;
            }
            gone.await;
        }
    }
}

impl<T> Drop for Sender<T> {
    fn drop(&mut self) {
        self.shared.closed.store(true, Ordering::SeqCst);
        self.shared.to_receivers.notify_waiters();
    }
}

impl<T> Receiver<T> {
    /// The current value, not marked as seen.
    pub fn borrow(&self) -> Ref<'_, T> {
        Ref(self.shared.read())
    }

    /// The current value, marked as seen.
    pub fn borrow_and_update(&mut self) -> Ref<'_, T> {
        let guard = self.shared.read();
        // Read under the lock: a value stored later has a later version.
        self.seen = self.shared.version.load(Ordering::SeqCst);
        Ref(guard)
    }

    /// Wait for a value this receiver has not seen and mark it seen; an error once the sender
    /// is gone and every value was seen. Cancel-safe.
    pub async fn changed(&mut self) -> Result<(), RecvError> {
        loop {
            // Registered before the checks: a value sent after them wakes this wait.
            let woken = self.shared.to_receivers.notified();
            tokio::pin!(woken);
            woken.as_mut().enable();
            let now = self.shared.version.load(Ordering::SeqCst);
            if now != self.seen {
                self.seen = now;
                return Ok(());
            }
            if self.shared.closed.load(Ordering::SeqCst) {
                return Err(RecvError(()));
            }
            woken.await;
        }
    }

    /// Wait until the value satisfies `f` (the current one first), marking it seen; an error
    /// when the sender goes before one does.
    pub async fn wait_for(
        &mut self,
        mut f: impl FnMut(&T) -> bool,
    ) -> Result<Ref<'_, T>, RecvError> {
        loop {
            {
                let v = self.borrow_and_update();
                if f(&v) {
                    break;
                }
            }
            self.changed().await?;
        }
        Ok(self.borrow_and_update())
    }
}

impl<T> Clone for Receiver<T> {
    fn clone(&self) -> Self {
        self.shared.receivers.fetch_add(1, Ordering::SeqCst);
        Receiver {
            shared: self.shared.clone(),
            seen: self.seen,
        }
    }
}

impl<T> Drop for Receiver<T> {
    fn drop(&mut self) {
        if self.shared.receivers.fetch_sub(1, Ordering::SeqCst) == 1 {
            self.shared.to_sender.notify_waiters();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    #[tokio::test(flavor = "current_thread")]
    async fn receivers_see_the_newest_value_and_the_senders_end() {
        let (tx, mut rx) = channel(0u32);
        assert_eq!(*rx.borrow(), 0);
        tx.send(1).unwrap();
        rx.changed().await.unwrap();
        assert_eq!(*rx.borrow_and_update(), 1);
        tx.send_modify(|v| *v += 1);
        tx.send_replace(3);
        rx.changed().await.unwrap();
        assert_eq!(*rx.borrow(), 3);
        let late = tx.subscribe();
        assert!(!tx.send_if_modified(|_| false));
        drop(tx);
        let mut late = late;
        assert!(late.changed().await.is_err());
        assert!(rx.changed().await.is_err());
        // A value sent before the end is still seen once.
        let (tx, mut rx) = channel(0u32);
        tx.send(5).unwrap();
        drop(tx);
        assert!(rx.changed().await.is_ok());
        assert!(rx.changed().await.is_err());
    }

    #[tokio::test(flavor = "current_thread")]
    async fn send_fails_without_receivers_and_closed_returns() {
        let (tx, rx) = channel(0u32);
        let rx2 = rx.clone();
        drop(rx);
        assert!(!tx.is_closed());
        tx.send(1).unwrap();
        drop(rx2);
        assert!(tx.is_closed());
        tx.closed().await;
        assert_eq!(tx.send(2).unwrap_err().0, 2);
        assert_eq!(*tx.borrow(), 1);
        assert_eq!(tx.send_replace(4), 1);
    }

    #[tokio::test(flavor = "current_thread")]
    async fn wait_for_returns_the_first_value_that_satisfies() {
        let (tx, mut rx) = channel(0u32);
        let t = tokio::spawn(async move {
            for k in 1..=5 {
                tx.send(k).unwrap();
                tokio::task::yield_now().await;
            }
        });
        assert_eq!(*rx.wait_for(|v| *v >= 3).await.unwrap(), 3);
        t.await.unwrap();
        assert!(rx.wait_for(|v| *v > 10).await.is_err());
    }

    /// The point of the channel: receivers wake in the order they began to wait, every time.
    #[test]
    fn receivers_wake_in_the_order_they_waited() {
        for _ in 0..20 {
            let rt = tokio::runtime::Builder::new_current_thread()
                .build()
                .unwrap();
            let order = Arc::new(Mutex::new(Vec::new()));
            rt.block_on(async {
                let (tx, rx) = channel(0u32);
                let mut tasks = Vec::new();
                for k in 0..16 {
                    let mut rx = rx.clone();
                    let order = order.clone();
                    tasks.push(tokio::spawn(async move {
                        rx.changed().await.unwrap();
                        order.lock().unwrap().push(k);
                    }));
                }
                // every task waits
                for _ in 0..4 {
                    tokio::task::yield_now().await;
                }
                tx.send(1).unwrap();
                for t in tasks {
                    t.await.unwrap();
                }
            });
            assert_eq!(*order.lock().unwrap(), (0..16).collect::<Vec<_>>());
        }
    }
}
