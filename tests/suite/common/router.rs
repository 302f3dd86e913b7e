//! A MAVLink router as mavlink-router (or MAVProxy with several `--out`s) runs it: every
//! datagram one endpoint sends goes to every other endpoint, unchanged. Raw UDP: no parsing,
//! no routing by system id — the receivers drop what is not for them.

use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use tokio::net::UdpSocket;

/// One endpoint of the router.
pub enum End {
    /// A socket the router listens on; it sends back to whoever spoke to it last (a vehicle
    /// configured to send here: SITL's `udpclient`, `fleetmap sim --connect udpout:`).
    Learn(UdpSocket),
    /// An address the router sends to from a socket of its own (a listening GCS or camera).
    Fixed(SocketAddr),
}

/// Start forwarding between `ends` (in tasks that live as long as the runtime).
pub async fn spawn(ends: Vec<End>) {
    let mut socks = Vec::new();
    let mut peers: Vec<Arc<Mutex<Option<SocketAddr>>>> = Vec::new();
    let mut learns = Vec::new();
    for e in ends {
        match e {
            End::Learn(s) => {
                socks.push(Arc::new(s));
                peers.push(Arc::new(Mutex::new(None)));
                learns.push(true);
            }
            End::Fixed(a) => {
                socks.push(Arc::new(UdpSocket::bind("127.0.0.1:0").await.unwrap()));
                peers.push(Arc::new(Mutex::new(Some(a))));
                learns.push(false);
            }
        }
    }
    for (me, sock) in socks.iter().enumerate() {
        let (sock, socks, peers, learn) = (sock.clone(), socks.clone(), peers.clone(), learns[me]);
        tokio::spawn(async move {
            let mut buf = vec![0u8; 65536];
            while let Ok((n, from)) = sock.recv_from(&mut buf).await {
                if learn {
                    *peers[me].lock().unwrap() = Some(from);
                }
                for (k, s) in socks.iter().enumerate() {
                    let to = *peers[k].lock().unwrap();
                    if let (true, Some(to)) = (k != me, to) {
                        let _ = s.send_to(&buf[..n], to).await;
                    }
                }
            }
        });
    }
}
