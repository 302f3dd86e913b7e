//! The socket (or serial port, or in-process channel) a link owns, as its two halves: the
//! [`Reader`] waits for the next bytes, a connection or a disconnection; the [`Writer`] holds
//! what a frame is sent to (one fixed peer, every UDP sender heard, every TCP client).

use super::super::peers::PeerTable;
use crate::clock::MonotonicClock;
use fleetmap_core::time::Time;
use std::collections::HashMap;
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;
use tokio::io::AsyncReadExt;
use tokio::net::{TcpListener, TcpStream, UdpSocket};
use tokio::sync::mpsc;

/// What a TCP server's per-client reader task reports.
pub(super) enum ClientRead {
    Data(u64, Vec<u8>),
    Closed(u64, String),
}

/// Aborts a task when dropped (a TCP client's reader, when the client or the link goes).
pub(super) struct AbortOnDrop(pub(super) tokio::task::AbortHandle);

impl Drop for AbortOnDrop {
    fn drop(&mut self) {
        self.0.abort();
    }
}

pub(super) enum Reader {
    Udp(Arc<UdpSocket>),
    TcpClient {
        addr: String,
        half: Option<tokio::net::tcp::OwnedReadHalf>,
        backoff: Duration,
        /// The connection attempt in flight: a task of its own, so that the link's
        /// `select!` (which drops this future whenever a message is sent) cannot cancel a
        /// half-open connection.
        pending: Option<tokio::task::JoinHandle<std::io::Result<TcpStream>>>,
        /// Earliest time of the next attempt after a failure, on `clock`.
        retry_at: Option<Time>,
        /// The clock of `retry_at` (wall time).
        clock: MonotonicClock,
    },
    TcpServer {
        listener: TcpListener,
        next_client: u64,
        /// Every client's reader task sends here.
        from_clients: mpsc::Receiver<ClientRead>,
        to_link: mpsc::Sender<ClientRead>,
    },
    Serial(tokio::io::ReadHalf<tokio_serial::SerialStream>),
    Memory(mpsc::UnboundedReceiver<Vec<u8>>),
}

pub(super) enum Writer {
    /// `udpout`: one fixed peer.
    UdpOut {
        sock: Arc<UdpSocket>,
        peer: SocketAddr,
    },
    /// `udpin`: every sender heard is a peer (`LinkTask::peers`).
    UdpIn(Arc<UdpSocket>),
    /// `tcp`: the connection, while there is one.
    Tcp(Option<tokio::net::tcp::OwnedWriteHalf>),
    /// `tcpin`: every client connected (`LinkTask::peers` routes among them).
    TcpServer(HashMap<u64, (tokio::net::tcp::OwnedWriteHalf, AbortOnDrop)>),
    Serial(tokio::io::WriteHalf<tokio_serial::SerialStream>),
    Memory(mpsc::UnboundedSender<Vec<u8>>),
}

pub(super) enum ReadOutcome {
    /// `n` bytes in the read buffer, from a UDP sender when the link serves several.
    Data(usize, Option<SocketAddr>),
    /// Bytes from a TCP server's client.
    ClientData(u64, Vec<u8>),
    /// The TCP client link connected.
    Connected(tokio::net::tcp::OwnedWriteHalf, String),
    /// The TCP server accepted a client.
    Accepted(
        u64,
        tokio::net::tcp::OwnedWriteHalf,
        AbortOnDrop,
        SocketAddr,
    ),
    /// A TCP server's client went away.
    ClientClosed(u64, String),
    Disconnected(String),
}

impl Reader {
    pub(super) async fn read(&mut self, buf: &mut [u8]) -> ReadOutcome {
        match self {
            Reader::Udp(s) => match s.recv_from(buf).await {
                Ok((n, from)) => ReadOutcome::Data(n, Some(from)),
                // ICMP port unreachable surfaces as an error on some systems: keep going.
                Err(e) => ReadOutcome::Disconnected(e.to_string()),
            },
            Reader::TcpClient {
                addr,
                half,
                backoff,
                pending,
                retry_at,
                clock,
            } => match half {
                Some(h) => match h.read(buf).await {
                    Ok(0) => {
                        *half = None;
                        ReadOutcome::Disconnected("peer closed the connection".into())
                    }
                    Ok(n) => ReadOutcome::Data(n, None),
                    Err(e) => {
                        *half = None;
                        ReadOutcome::Disconnected(e.to_string())
                    }
                },
                None => loop {
                    // Every await below is cancel-safe: state lives in `pending` and
                    // `retry_at`, so a dropped future resumes where it was.
                    if let Some(t) = *retry_at {
                        tokio::time::sleep(clock.wall_until(t)).await;
                        *retry_at = None;
                    }
                    let task = pending.get_or_insert_with(|| {
                        let a = addr.clone();
                        tokio::spawn(async move { TcpStream::connect(a.as_str()).await })
                    });
                    let result = task.await;
                    *pending = None;
                    match result {
                        Ok(Ok(s)) => {
                            let _ = s.set_nodelay(true);
                            let peer = s.peer_addr().map(|a| a.to_string()).unwrap_or_default();
                            let (r, w) = s.into_split();
                            *half = Some(r);
                            *backoff = Duration::from_millis(500);
                            return ReadOutcome::Connected(w, peer);
                        }
                        _ => {
                            *retry_at = Some(clock.now() + *backoff);
                            *backoff = (*backoff * 2).min(Duration::from_secs(5));
                        }
                    }
                },
            },
            Reader::TcpServer {
                listener,
                next_client,
                from_clients,
                to_link,
            } => {
                // Both branches are cancel-safe (`accept`, `recv`).
                tokio::select! {
                    accepted = listener.accept() => match accepted {
                        Ok((s, from)) => {
                            let _ = s.set_nodelay(true);
                            let (mut r, w) = s.into_split();
                            let id = *next_client;
                            *next_client += 1;
                            let tx = to_link.clone();
                            let task = tokio::spawn(async move {
                                let mut buf = vec![0u8; 8192];
                                let why = loop {
                                    match r.read(&mut buf).await {
                                        Ok(0) => break "client closed the connection".to_string(),
                                        Ok(n) => {
                                            if tx.send(ClientRead::Data(id, buf[..n].to_vec())).await.is_err() {
                                                return;
                                            }
                                        }
                                        Err(e) => break e.to_string(),
                                    }
                                };
                                let _ = tx.send(ClientRead::Closed(id, why)).await;
                            });
                            ReadOutcome::Accepted(id, w, AbortOnDrop(task.abort_handle()), from)
                        }
                        Err(e) => {
                            tokio::time::sleep(Duration::from_millis(200)).await;
                            ReadOutcome::Disconnected(e.to_string())
                        }
                    },
                    r = from_clients.recv() => match r {
                        Some(ClientRead::Data(id, bytes)) => ReadOutcome::ClientData(id, bytes),
                        Some(ClientRead::Closed(id, why)) => ReadOutcome::ClientClosed(id, why),
                        // `to_link` lives here too: never closed while the link runs.
                        None => std::future::pending().await,
                    },
                }
            }
            Reader::Memory(rx) => match rx.recv().await {
                Some(bytes) => {
                    let n = bytes.len().min(buf.len());
                    buf[..n].copy_from_slice(&bytes[..n]);
                    ReadOutcome::Data(n, None)
                }
                None => {
                    // The peer is gone: nothing will ever arrive again.
                    std::future::pending::<()>().await;
                    ReadOutcome::Data(0, None)
                }
            },
            Reader::Serial(r) => match r.read(buf).await {
                Ok(0) => {
                    tokio::time::sleep(Duration::from_millis(10)).await;
                    ReadOutcome::Data(0, None)
                }
                Ok(n) => ReadOutcome::Data(n, None),
                Err(e) => {
                    tokio::time::sleep(Duration::from_millis(200)).await;
                    ReadOutcome::Disconnected(e.to_string())
                }
            },
        }
    }
}

impl Writer {
    /// Whether the link can send now: connected (TCP), or with at least one peer.
    pub(super) fn up(&self, peers: &PeerTable) -> bool {
        match self {
            Writer::UdpOut { .. } | Writer::Serial(_) => true,
            Writer::UdpIn(_) => !peers.is_empty(),
            Writer::Tcp(w) => w.is_some(),
            Writer::TcpServer(clients) => !clients.is_empty(),
            Writer::Memory(tx) => !tx.is_closed(),
        }
    }
}
