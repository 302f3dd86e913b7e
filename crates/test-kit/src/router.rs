//! A MAVLink router as mavlink-router (or MAVProxy with several `--out`s) runs it: every
//! datagram one endpoint sends goes to every other endpoint, unchanged. No routing by system
//! id: the receivers drop what is not for them. A serial end (a pseudo-terminal standing in
//! for a UART) is a byte stream: the router cuts the frames out of it and sends each as one
//! datagram, and writes what the other ends send to it as it comes.

use fleetmap_io::link::codec::Codec;
use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use tokio::io::{AsyncRead, AsyncReadExt, AsyncWrite, AsyncWriteExt};
use tokio::net::UdpSocket;
use tokio::sync::mpsc;

/// A byte stream a serial end can be: a serial port, one end of a pseudo-terminal pair.
pub trait Serial: AsyncRead + AsyncWrite + Send + Unpin + 'static {}

impl<T: AsyncRead + AsyncWrite + Send + Unpin + 'static> Serial for T {}

/// One endpoint of the router.
pub enum End {
    /// A socket the router listens on; it sends back to whoever spoke to it last (a vehicle
    /// configured to send here: SITL's `udpclient`, `fleetmap sim --connect udpout:`).
    Learn(UdpSocket),
    /// An address the router sends to from a socket of its own (a listening GCS or camera).
    Fixed(SocketAddr),
    /// A serial line's end, e.g. the master of a pseudo-terminal pair whose slave a program
    /// opens as its UART.
    Serial(Box<dyn Serial>),
}

/// Where the router sends what one end is to get.
enum Out {
    Udp(Arc<UdpSocket>, Arc<Mutex<Option<SocketAddr>>>),
    Serial(mpsc::UnboundedSender<Vec<u8>>),
}

impl Out {
    async fn send(&self, bytes: &[u8]) {
        match self {
            Out::Udp(sock, peer) => {
                let to = *peer.lock().expect("the router's peer");
                if let Some(to) = to {
                    let _ = sock.send_to(bytes, to).await;
                }
            }
            Out::Serial(tx) => {
                let _ = tx.send(bytes.to_vec());
            }
        }
    }
}

/// Start forwarding between `ends` (in tasks that live as long as the runtime). Returns the
/// local address of each end's socket, in the order of `ends` (`None` for a serial end): the
/// address a GCS behind a [`End::Fixed`] end sends to when it speaks first.
pub async fn spawn(ends: Vec<End>) -> Vec<Option<SocketAddr>> {
    let mut outs = Vec::new();
    let mut ins = Vec::new();
    let mut locals = Vec::new();
    for e in ends {
        match e {
            End::Learn(s) => {
                let (s, peer) = (Arc::new(s), Arc::new(Mutex::new(None)));
                locals.push(s.local_addr().ok());
                outs.push(Out::Udp(s.clone(), peer.clone()));
                ins.push(In::Udp(s, Some(peer)));
            }
            End::Fixed(a) => {
                let s = Arc::new(
                    UdpSocket::bind("127.0.0.1:0")
                        .await
                        .expect("the router's socket"),
                );
                locals.push(s.local_addr().ok());
                outs.push(Out::Udp(s.clone(), Arc::new(Mutex::new(Some(a)))));
                ins.push(In::Udp(s, None));
            }
            End::Serial(line) => {
                let (rd, mut wr) = tokio::io::split(line);
                let (tx, mut rx) = mpsc::unbounded_channel::<Vec<u8>>();
                tokio::spawn(async move {
                    while let Some(b) = rx.recv().await {
                        if wr.write_all(&b).await.is_err() {
                            break;
                        }
                    }
                });
                locals.push(None);
                outs.push(Out::Serial(tx));
                ins.push(In::Serial(rd));
            }
        }
    }
    let outs = Arc::new(outs);
    for (me, input) in ins.into_iter().enumerate() {
        tokio::spawn(input.forward(me, outs.clone()));
    }
    locals
}

/// Where the router reads what one end sends.
enum In {
    /// A socket, and the peer to learn from each datagram's sender (a [`End::Learn`] end).
    Udp(Arc<UdpSocket>, Option<Arc<Mutex<Option<SocketAddr>>>>),
    Serial(tokio::io::ReadHalf<Box<dyn Serial>>),
}

impl In {
    /// Forward what end `me` sends to every other end, until it closes.
    async fn forward(self, me: usize, outs: Arc<Vec<Out>>) {
        let to_others = |bytes: Vec<u8>| {
            let outs = outs.clone();
            async move {
                for (k, out) in outs.iter().enumerate() {
                    if k != me {
                        out.send(&bytes).await;
                    }
                }
            }
        };
        match self {
            In::Udp(sock, learn) => {
                let mut buf = vec![0u8; 65536];
                while let Ok((n, from)) = sock.recv_from(&mut buf).await {
                    if let Some(peer) = &learn {
                        *peer.lock().expect("the router's peer") = Some(from);
                    }
                    to_others(buf[..n].to_vec()).await;
                }
            }
            In::Serial(mut rd) => {
                let mut codec = Codec::new();
                let mut buf = vec![0u8; 4096];
                while let Ok(n) = rd.read(&mut buf).await {
                    if n == 0 {
                        break;
                    }
                    for f in codec.decode(&buf[..n], 0) {
                        to_others(f.raw).await;
                    }
                }
            }
        }
    }
}
