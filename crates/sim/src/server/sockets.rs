//! Opening the simulator's sockets: every vehicle's UDP socket or TCP listener, the tasks
//! that read them into one channel and the one that writes to every TCP client.

use super::{Bound, ServerError, for_vehicle};
use fleetmap_io::link::ConnSpec;
use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, UdpSocket};
use tokio::sync::mpsc;

/// A vehicle's endpoint as the serve loops use it: a UDP socket and the peer it answers,
/// or the sender to every TCP client.
pub(super) enum Io {
    Udp {
        sock: Arc<UdpSocket>,
        peer: Arc<Mutex<Option<SocketAddr>>>,
    },
    Tcp {
        out: mpsc::UnboundedSender<Vec<u8>>,
    },
}

/// A [`ServerError::Io`] naming `what`.
pub(super) fn io_err(what: String) -> impl FnOnce(std::io::Error) -> ServerError {
    move |source| ServerError::Io { what, source }
}

/// The first address of `host`:`port`; `what` names the connection in errors.
async fn resolve(host: &str, port: u16, what: &ConnSpec) -> Result<SocketAddr, ServerError> {
    tokio::net::lookup_host((host, port))
        .await
        .map_err(io_err(what.to_string()))?
        .next()
        .ok_or_else(|| ServerError::Io {
            what: what.to_string(),
            source: std::io::Error::new(std::io::ErrorKind::NotFound, "no address for the host"),
        })
}

/// What an endpoint received: (vehicle index, bytes, the UDP sender's address; None for TCP).
pub(super) type Received = (usize, Vec<u8>, Option<SocketAddr>);

/// Open every vehicle's endpoint. Returns the bound sockets (for printing) and the I/O
/// plumbing; received datagrams / TCP bytes arrive on `rx` as [`Received`].
pub(super) async fn open(
    sysids: &[u8],
    endpoints: &[ConnSpec],
    tx: mpsc::Sender<Received>,
) -> Result<(Vec<Bound>, Vec<Io>), ServerError> {
    let n = sysids.len();
    if endpoints.len() != 1 && endpoints.len() != n {
        return Err(ServerError::Count {
            endpoints: endpoints.len(),
            vehicles: n,
        });
    }
    let mut bound = Vec::new();
    let mut ios = Vec::new();
    for (k, &sysid) in sysids.iter().enumerate() {
        let ep = if endpoints.len() == 1 {
            for_vehicle(&endpoints[0], k)?
        } else {
            for_vehicle(&endpoints[k], 0)?
        };
        match &ep {
            ConnSpec::UdpOut { host, port } | ConnSpec::UdpIn { host, port } => {
                let target = resolve(host, *port, &ep).await?;
                let fixed = matches!(ep, ConnSpec::UdpOut { .. });
                let (bind, peer) = if fixed {
                    (
                        fleetmap_io::link::transport::local_for(target),
                        Some(target),
                    )
                } else {
                    (target, None)
                };
                let sock = Arc::new(
                    UdpSocket::bind(bind)
                        .await
                        .map_err(io_err(ep.to_string()))?,
                );
                fleetmap_io::link::transport::enlarge_recv_buffer(&sock);
                let local = sock.local_addr().map_err(io_err(ep.to_string()))?;
                let peer = Arc::new(Mutex::new(peer));
                let (s2, p2, tx2) = (sock.clone(), peer.clone(), tx.clone());
                tokio::spawn(async move {
                    let mut buf = vec![0u8; 65536];
                    loop {
                        match s2.recv_from(&mut buf).await {
                            Ok((len, from)) => {
                                if !fixed && let Ok(mut p) = p2.lock() {
                                    *p = Some(from);
                                }
                                if tx2
                                    .send((k, buf[..len].to_vec(), Some(from)))
                                    .await
                                    .is_err()
                                {
                                    return;
                                }
                            }
                            // ICMP port unreachable on Linux surfaces here; keep listening
                            Err(_) => tokio::task::yield_now().await,
                        }
                    }
                });
                bound.push(Bound {
                    sysid,
                    endpoint: ep.clone(),
                    local,
                });
                ios.push(Io::Udp { sock, peer });
            }
            ConnSpec::TcpIn { host, port } => {
                let addr = resolve(host, *port, &ep).await?;
                let listener = TcpListener::bind(addr)
                    .await
                    .map_err(io_err(ep.to_string()))?;
                let local = listener.local_addr().map_err(io_err(ep.to_string()))?;
                let (out_tx, mut out_rx) = mpsc::unbounded_channel::<Vec<u8>>();
                let (client_tx, mut client_rx) = mpsc::unbounded_channel();
                let tx2 = tx.clone();
                tokio::spawn(async move {
                    loop {
                        let Ok((stream, _)) = listener.accept().await else {
                            continue;
                        };
                        let _ = stream.set_nodelay(true);
                        let (mut r, w) = stream.into_split();
                        if client_tx.send(w).is_err() {
                            return;
                        }
                        let tx3 = tx2.clone();
                        tokio::spawn(async move {
                            let mut buf = vec![0u8; 8192];
                            loop {
                                match r.read(&mut buf).await {
                                    Ok(0) | Err(_) => return,
                                    Ok(n) => {
                                        if tx3.send((k, buf[..n].to_vec(), None)).await.is_err() {
                                            return;
                                        }
                                    }
                                }
                            }
                        });
                    }
                });
                tokio::spawn(async move {
                    let mut clients: Vec<tokio::net::tcp::OwnedWriteHalf> = Vec::new();
                    loop {
                        tokio::select! {
                            c = client_rx.recv() => match c {
                                Some(c) => clients.push(c),
                                None => return,
                            },
                            d = out_rx.recv() => {
                                let Some(d) = d else { return };
                                let mut alive = Vec::new();
                                for mut c in clients.drain(..) {
                                    if c.write_all(&d).await.is_ok() {
                                        alive.push(c);
                                    }
                                }
                                clients = alive;
                            }
                        }
                    }
                });
                bound.push(Bound {
                    sysid,
                    endpoint: ep.clone(),
                    local,
                });
                ios.push(Io::Tcp { out: out_tx });
            }
            // refused by `for_vehicle`
            ConnSpec::Tcp { .. } | ConnSpec::Serial { .. } | ConnSpec::Memory { .. } => {
                return Err(ServerError::NotServed(ep.to_string()));
            }
        }
    }
    Ok((bound, ios))
}
