use super::*;
use tokio::net::UdpSocket;

/// The links' UDP sockets get the receive buffer asked for, up to what the kernel allows
/// (`net.core.rmem_max` on Linux).
#[tokio::test]
async fn udp_sockets_get_the_larger_receive_buffer() {
    let sock = UdpSocket::bind("127.0.0.1:0").await.unwrap();
    let before = socket2::SockRef::from(&sock).recv_buffer_size().unwrap();
    let granted = enlarge_recv_buffer(&sock).expect("SO_RCVBUF accepted");
    let cap = std::fs::read_to_string("/proc/sys/net/core/rmem_max")
        .ok()
        .and_then(|s| s.trim().parse::<usize>().ok());
    if let Some(cap) = cap {
        assert!(
            granted >= UDP_RECV_BUFFER.min(cap),
            "asked {UDP_RECV_BUFFER}, allowed {cap}, got {granted} (was {before})"
        );
    } else {
        assert!(granted > 0);
    }
}
