//! Connection strings, as MAVProxy writes them (`mavproxy.py --master/--out`, pymavlink
//! `mavutil.mavlink_connection`):
//!
//! | string | meaning |
//! |---|---|
//! | `udpin:HOST:PORT` | listen on HOST:PORT; answer every sender, each system at the address it speaks from (`udp:` is a synonym) |
//! | `udpout:HOST:PORT` | send to HOST:PORT from an ephemeral port (on loopback for a loopback HOST), receive its answers |
//! | `tcp:HOST:PORT` | connect; reconnect with backoff when the peer goes away |
//! | `tcpin:HOST:PORT` | listen for TCP connections; serve every client, each system on the connection it speaks on |
//! | `serial:PATH:BAUD` | a serial port (e.g. `serial:/dev/ttyUSB0:57600`; `PATH,BAUD` as MAVProxy also works) |
//!
//! HOST may be a name, an IPv4 address or a bracketed IPv6 address (`[::1]`).

use std::fmt;
use std::str::FromStr;

/// A parsed connection string.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ConnSpec {
    /// Listen for UDP datagrams; answer every sender.
    UdpIn {
        /// Host to bind.
        host: String,
        /// Port.
        port: u16,
    },
    /// Send UDP datagrams to a fixed peer.
    UdpOut {
        /// Peer host.
        host: String,
        /// Peer port.
        port: u16,
    },
    /// TCP client with reconnection.
    Tcp {
        /// Server host.
        host: String,
        /// Server port.
        port: u16,
    },
    /// TCP server.
    TcpIn {
        /// Host to bind.
        host: String,
        /// Port.
        port: u16,
    },
    /// Serial port.
    Serial {
        /// Device path.
        path: String,
        /// Baud rate.
        baud: u32,
    },
    /// An in-process channel to a peer in the same program (the embedded simulator on a
    /// virtual clock); made by `link::transport::open_memory_link`, never parsed.
    Memory {
        /// A name for logs.
        name: String,
    },
}

/// A malformed connection string.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "bad connection string {input:?}: {why} (expected udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT, tcpin:HOST:PORT or serial:PATH:BAUD)"
)]
pub struct ConnSpecError {
    /// The string.
    pub input: String,
    /// What is wrong.
    pub why: String,
}

fn host_port(input: &str, rest: &str) -> Result<(String, u16), ConnSpecError> {
    let err = |why: String| ConnSpecError {
        input: input.to_string(),
        why,
    };
    let (host, port) = if let Some(r) = rest.strip_prefix('[') {
        let (h, p) = r
            .split_once("]:")
            .ok_or_else(|| err("an IPv6 host must be written [ADDR]:PORT".into()))?;
        (h.to_string(), p)
    } else {
        let (h, p) = rest
            .rsplit_once(':')
            .ok_or_else(|| err("missing :PORT".into()))?;
        (h.to_string(), p)
    };
    if host.is_empty() {
        return Err(err("missing host".into()));
    }
    let port: u16 = port
        .parse()
        .map_err(|_| err(format!("port {port:?} is not a number from 0 to 65535")))?;
    Ok((host, port))
}

impl FromStr for ConnSpec {
    type Err = ConnSpecError;

    fn from_str(s: &str) -> Result<ConnSpec, ConnSpecError> {
        let err = |why: &str| ConnSpecError {
            input: s.to_string(),
            why: why.to_string(),
        };
        let (scheme, rest) = s.split_once(':').ok_or_else(|| err("missing scheme"))?;
        match scheme.to_ascii_lowercase().as_str() {
            "udpin" | "udp" => {
                let (host, port) = host_port(s, rest)?;
                Ok(ConnSpec::UdpIn { host, port })
            }
            "udpout" => {
                let (host, port) = host_port(s, rest)?;
                if port == 0 {
                    return Err(err("udpout needs a non-zero port"));
                }
                Ok(ConnSpec::UdpOut { host, port })
            }
            "tcp" => {
                let (host, port) = host_port(s, rest)?;
                if port == 0 {
                    return Err(err("tcp needs a non-zero port"));
                }
                Ok(ConnSpec::Tcp { host, port })
            }
            "tcpin" => {
                let (host, port) = host_port(s, rest)?;
                Ok(ConnSpec::TcpIn { host, port })
            }
            "serial" => {
                let (path, baud) = rest
                    .rsplit_once(':')
                    .or_else(|| rest.rsplit_once(','))
                    .ok_or_else(|| err("missing :BAUD"))?;
                if path.is_empty() {
                    return Err(err("missing device path"));
                }
                let baud: u32 = baud
                    .parse()
                    .ok()
                    .filter(|b| *b > 0)
                    .ok_or_else(|| err("the baud rate must be a positive number"))?;
                Ok(ConnSpec::Serial {
                    path: path.to_string(),
                    baud,
                })
            }
            other => Err(err(&format!("unknown scheme {other:?}"))),
        }
    }
}

impl fmt::Display for ConnSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let hp = |h: &str, p: u16| {
            if h.contains(':') {
                format!("[{h}]:{p}")
            } else {
                format!("{h}:{p}")
            }
        };
        match self {
            ConnSpec::UdpIn { host, port } => write!(f, "udpin:{}", hp(host, *port)),
            ConnSpec::UdpOut { host, port } => write!(f, "udpout:{}", hp(host, *port)),
            ConnSpec::Tcp { host, port } => write!(f, "tcp:{}", hp(host, *port)),
            ConnSpec::TcpIn { host, port } => write!(f, "tcpin:{}", hp(host, *port)),
            ConnSpec::Serial { path, baud } => write!(f, "serial:{path}:{baud}"),
            ConnSpec::Memory { name } => write!(f, "memory:{name}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_mavproxy_strings() {
        assert_eq!(
            "udpin:0.0.0.0:14550".parse(),
            Ok(ConnSpec::UdpIn {
                host: "0.0.0.0".into(),
                port: 14550
            })
        );
        assert_eq!(
            "udp:127.0.0.1:14550"
                .parse::<ConnSpec>()
                .unwrap()
                .to_string(),
            "udpin:127.0.0.1:14550"
        );
        assert_eq!(
            "tcp:localhost:5760".parse(),
            Ok(ConnSpec::Tcp {
                host: "localhost".into(),
                port: 5760
            })
        );
        assert_eq!(
            "udpout:[::1]:14551".parse(),
            Ok(ConnSpec::UdpOut {
                host: "::1".into(),
                port: 14551
            })
        );
        assert_eq!(
            "serial:/dev/ttyUSB0:57600".parse(),
            Ok(ConnSpec::Serial {
                path: "/dev/ttyUSB0".into(),
                baud: 57600
            })
        );
        assert_eq!(
            "serial:/dev/ttyACM0,115200".parse::<ConnSpec>().unwrap(),
            ConnSpec::Serial {
                path: "/dev/ttyACM0".into(),
                baud: 115200
            }
        );
        for bad in [
            "14550",
            "udpin:14550",
            "udpout:host:0",
            "tcp:host:port",
            "serial:/dev/x:fast",
            "carrier:pigeon:1",
        ] {
            let e = bad.parse::<ConnSpec>().unwrap_err();
            assert!(e.to_string().contains("expected udpin"), "{e}");
        }
    }
}
