//! `fleetmap relay --rate`: a relay limited to 5,000 B/s each way (a 57,600-baud SiK radio)
//! carries a flood of frames at that rate, whole and in order, drops what overflows its queue
//! and counts it, and leaves the other direction free. On tokio's paused clock between two
//! in-process links (exact: the figure does not depend on the machine), and once through the
//! real binary over UDP on the wall clock (margins for a busy machine).
//!
//! `fleetmap relay --radio`: a SiK pair at 2,000 B/s in all shares its air between the two
//! directions, loses 10 % on the air, and writes RADIO_STATUS into both sides; on the
//! vehicles' own time a relay beside a vehicle at ×5 carries five times the bytes per wall
//! second. On tokio's paused clock.

use fleetmap_io::clock::{MonotonicClock, VehicleTime};
use fleetmap_io::link::codec::Codec;
use fleetmap_io::link::radio::RadioConfig;
use fleetmap_io::link::relay::{Relay, RelayOptions, RelayStats};
use fleetmap_io::link::transport::MemoryPort;
use mavlink::dialects::ardupilotmega::{
    ENCAPSULATED_DATA_DATA, GLOBAL_POSITION_INT_DATA, HEARTBEAT_DATA, MavMessage,
    RADIO_STATUS_DATA, SYSTEM_TIME_DATA,
};
use std::time::Duration;

/// The rate under test, bytes per second.
const RATE: f64 = 5000.0;

/// Flood frame `i`: ENCAPSULATED_DATA numbered `i`, 15 to 267 bytes on the wire (its data is
/// non-zero up to a length that varies with `i`, so MAVLink 2 does not trim it).
fn chunk(i: u16) -> MavMessage {
    let n = 1 + (usize::from(i) * 37) % 253;
    let mut data = [0u8; 253];
    for (k, b) in data[..n].iter_mut().enumerate() {
        *b = (k as u8) | 1;
    }
    MavMessage::ENCAPSULATED_DATA(ENCAPSULATED_DATA_DATA { seqnr: i, data })
}

fn ping(ms: u32) -> MavMessage {
    MavMessage::SYSTEM_TIME(SYSTEM_TIME_DATA {
        time_unix_usec: 1,
        time_boot_ms: ms,
    })
}

/// A received datagram or channel item: it must be exactly one whole frame (CRC checked).
/// Returns its message.
fn one_frame(codec: &mut Codec, bytes: &[u8]) -> MavMessage {
    let frames = codec.decode(bytes, 0);
    assert_eq!(frames.len(), 1, "{} bytes are not one frame", bytes.len());
    assert_eq!(frames[0].raw, bytes, "the frame arrived altered");
    frames[0].message.clone().expect("a known message")
}

/// Bytes per second of the frames after the first, between the first and the last arrival:
/// what the queue let out while it was never empty.
fn throughput(arrivals: &[(Duration, usize)]) -> f64 {
    let bytes: usize = arrivals[1..].iter().map(|(_, n)| n).sum();
    let span = arrivals[arrivals.len() - 1].0 - arrivals[0].0;
    bytes as f64 / span.as_secs_f64()
}

/// 60 s of virtual time: the GCS offers a frame every 10 ms (about 14 kB/s, nearly three
/// times the rate) through a relay at 5,000 B/s, while the vehicle sends a small frame every
/// second the other way. The flood arrives at 5,000 B/s within 2 % (exactly, but for tokio's
/// 1 ms timer), whole and in order, what overflowed the 1850-byte queue is counted, and the
/// vehicle's frames cross the idle direction in their own transmission time.
#[tokio::test(start_paused = true)]
async fn rate_5000_carries_5000_bytes_per_second_one_way() {
    let opts = RelayOptions {
        radio: RadioConfig::per_direction(5000),
        ..RelayOptions::default()
    };
    let (relay, gcs, vehicle) = Relay::memory("radio", opts);
    let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
    let relay = tokio::spawn(relay.run(Duration::from_secs(3600), |_| {}, async move {
        let _ = stop_rx.await;
    }));
    // on each end, `to_gcs` goes into the relay and `from_gcs` comes out of it
    let MemoryPort {
        from_gcs: at_gcs,
        to_gcs: gcs_tx,
    } = gcs;
    let MemoryPort {
        from_gcs: at_vehicle,
        to_gcs: vehicle_tx,
    } = vehicle;
    let t0 = tokio::time::Instant::now();
    // what arrives on each side, with its (virtual) time since t0
    let collect = |mut rx: tokio::sync::mpsc::UnboundedReceiver<Vec<u8>>| {
        tokio::spawn(async move {
            let mut got = Vec::new();
            while let Ok(Some(b)) = tokio::time::timeout(Duration::from_secs(3), rx.recv()).await {
                got.push((t0.elapsed(), b));
            }
            got
        })
    };
    let up_rx = collect(at_vehicle);
    let down_rx = collect(at_gcs);
    let (mut gc, mut vc) = (Codec::new(), Codec::new());
    let n: u16 = 6000;
    let mut offered = 0usize;
    let mut pings = Vec::new();
    for i in 0..n {
        let bytes = gc.encode(255, 190, &chunk(i), 0);
        offered += bytes.len();
        gcs_tx.send(bytes).unwrap();
        if i % 100 == 0 {
            let p = vc.encode(1, 1, &ping(u32::from(i)), 0);
            pings.push((t0.elapsed(), p.len()));
            vehicle_tx.send(p).unwrap();
        }
        tokio::time::sleep_until(t0 + Duration::from_millis(10 * (u64::from(i) + 1))).await;
    }
    let up = up_rx.await.unwrap();
    let down = down_rx.await.unwrap();
    let _ = stop_tx.send(());
    let stats = relay.await.unwrap();

    // whole and in order
    let mut rx = Codec::new();
    let mut last = None;
    let mut arrivals = Vec::new();
    for (t, bytes) in &up {
        let MavMessage::ENCAPSULATED_DATA(d) = one_frame(&mut rx, bytes) else {
            panic!("not a flood frame");
        };
        assert!(last < Some(d.seqnr), "{:?} then {}", last, d.seqnr);
        last = Some(d.seqnr);
        arrivals.push((*t, bytes.len()));
    }
    // from the second frame on: the first (15 bytes) leaves 7 ms before the next arrives,
    // the only time the radio is idle
    let rate = throughput(&arrivals[1..]);
    let carried: usize = arrivals.iter().map(|(_, n)| n).sum();
    eprintln!(
        "offered {offered} B in {:.1} s ({:.0} B/s); carried {carried} B in {} of {n} frames \
         at {rate:.1} B/s; {} dropped on a full queue, queue peak {} B",
        f64::from(n) / 100.0,
        offered as f64 / (f64::from(n) / 100.0),
        up.len(),
        stats.up.rate_dropped,
        stats.up.peak_queue_bytes
    );
    assert!((rate - RATE).abs() < 0.02 * RATE, "{rate:.1} B/s");
    // the counts
    assert_eq!(stats.up.frames_in, u64::from(n));
    assert_eq!(stats.up.bytes_in, offered as u64);
    assert_eq!(stats.up.frames_out, up.len() as u64);
    assert_eq!(stats.up.bytes_out, carried as u64);
    assert_eq!(stats.up.frames_out + stats.up.rate_dropped, u64::from(n));
    assert!(stats.up.rate_dropped > 0);
    let cap = u64::from(RadioConfig::SIK_BUFFER_BYTES);
    assert!(
        stats.up.peak_queue_bytes <= cap && stats.up.peak_queue_bytes > cap - 267,
        "queue peak {}",
        stats.up.peak_queue_bytes
    );
    // the other direction is a radio of its own: nothing waits, nothing is dropped
    assert_eq!(down.len(), pings.len());
    assert_eq!(stats.down.rate_dropped, 0);
    for ((sent, len), (got, bytes)) in pings.iter().zip(&down) {
        assert!(matches!(
            one_frame(&mut rx, bytes),
            MavMessage::SYSTEM_TIME(_)
        ));
        let wire = Duration::from_secs_f64(*len as f64 / RATE);
        assert!(
            *got >= *sent + wire && *got <= *sent + wire + Duration::from_millis(2),
            "sent at {sent:?}, {len} B, arrived at {got:?}"
        );
    }
}

/// What came out of one side of a relay: (virtual time since the start, bytes).
type Arrivals = Vec<(Duration, Vec<u8>)>;

/// Run `opts` (on `clock`, if given) between two in-process ends for `secs` of virtual
/// time; `drive(k, gcs, vehicle)` is called every 10 ms (`k` counts from 0) to send into
/// either side. Returns what arrived at the GCS, at the vehicle, and the relay's counts.
async fn drive_relay(
    opts: RelayOptions,
    clock: Option<MonotonicClock>,
    secs: u64,
    mut drive: impl FnMut(u64, &dyn Fn(Vec<u8>), &dyn Fn(Vec<u8>)),
) -> (Arrivals, Arrivals, RelayStats) {
    let (relay, gcs, vehicle) = Relay::memory("radio", opts);
    let relay = match clock {
        Some(c) => relay.with_clock(c),
        None => relay,
    };
    let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
    let relay = tokio::spawn(relay.run(Duration::from_secs(3600), |_| {}, async move {
        let _ = stop_rx.await;
    }));
    let t0 = tokio::time::Instant::now();
    let collect = |mut rx: tokio::sync::mpsc::UnboundedReceiver<Vec<u8>>| {
        tokio::spawn(async move {
            let mut got = Vec::new();
            while let Ok(Some(b)) = tokio::time::timeout(Duration::from_secs(3), rx.recv()).await {
                got.push((t0.elapsed(), b));
            }
            got
        })
    };
    let at_gcs = collect(gcs.from_gcs);
    let at_vehicle = collect(vehicle.from_gcs);
    let (gtx, vtx) = (gcs.to_gcs, vehicle.to_gcs);
    for k in 0..secs * 100 {
        drive(
            k,
            &|b| {
                let _ = gtx.send(b);
            },
            &|b| {
                let _ = vtx.send(b);
            },
        );
        tokio::time::sleep_until(t0 + Duration::from_millis(10 * (k + 1))).await;
    }
    let _ = stop_tx.send(());
    let stats = relay.await.unwrap();
    (at_gcs.await.unwrap(), at_vehicle.await.unwrap(), stats)
}

/// The RADIO_STATUS reports among `arrivals` (system 51, component 68), decoded, and the
/// bytes of everything else.
fn split_reports(arrivals: &Arrivals) -> (Vec<RADIO_STATUS_DATA>, u64) {
    let mut reports = Vec::new();
    let mut other = 0;
    for (_, bytes) in arrivals {
        let frames = Codec::new().decode(bytes, 0);
        assert_eq!(frames.len(), 1, "{} bytes are not one frame", bytes.len());
        let f = &frames[0];
        match f.message.as_ref().expect("a known message") {
            MavMessage::RADIO_STATUS(r) => {
                assert_eq!((f.sysid(), f.compid()), (51, 68));
                reports.push(r.clone());
            }
            _ => other += bytes.len() as u64,
        }
    }
    (reports, other)
}

fn heartbeat() -> MavMessage {
    MavMessage::HEARTBEAT(HEARTBEAT_DATA::default())
}

/// Two minutes of virtual time through `--radio 2000 --loss 0.1`, both sides offering
/// about 7 kB/s (a frame every 20 ms) and a heartbeat a second: the air is busy all the
/// time and carries 2,000 B/s in all, half each way; 10 % of the frames are lost on it; each
/// side gets RADIO_STATUS from its own radio after its heartbeats, whose receive errors
/// count the frames its radio missed and whose txbuf shows a nearly full buffer; every frame
/// arrives whole, and the counts add up.
#[tokio::test(start_paused = true)]
async fn radio_2000_shares_its_air_between_the_two_directions() {
    let opts = RelayOptions {
        radio: RadioConfig {
            loss: 0.1,
            ..RadioConfig::radio(2000)
        },
        seed: 11,
        ..RelayOptions::default()
    };
    let secs = 120u64;
    let (mut gc, mut vc) = (Codec::new(), Codec::new());
    let (at_gcs, at_vehicle, stats) = drive_relay(opts, None, secs, |k, gcs, vehicle| {
        if k % 2 == 0 {
            let i = (k / 2) as u16;
            gcs(gc.encode(255, 190, &chunk(i), 0));
            vehicle(vc.encode(1, 1, &chunk(i.wrapping_add(7)), 0));
        }
        if k % 100 == 0 {
            gcs(gc.encode(255, 190, &heartbeat(), 0));
        }
        if k % 100 == 50 {
            vehicle(vc.encode(1, 1, &heartbeat(), 0));
        }
    })
    .await;
    let (to_gcs, down_bytes) = split_reports(&at_gcs);
    let (to_vehicle, up_bytes) = split_reports(&at_vehicle);
    let (up, down) = (&stats.up, &stats.down);
    let elapsed = stats.clock_us as f64;
    eprintln!(
        "{:.1} s: up {} B ({:.0} B/s, {:.1} s of air, {} lost, {} dropped), down {} B ({:.0} \
         B/s, {:.1} s of air, {} lost, {} dropped); RADIO_STATUS {} to the GCS, {} to the \
         vehicle",
        elapsed / 1e6,
        up.bytes_out,
        up.bytes_out as f64 / elapsed * 1e6,
        up.air_us as f64 / 1e6,
        up.lost,
        up.rate_dropped,
        down.bytes_out,
        down.bytes_out as f64 / elapsed * 1e6,
        down.air_us as f64 / 1e6,
        down.lost,
        down.rate_dropped,
        to_gcs.len(),
        to_vehicle.len()
    );
    // what the sides received is what the relay counts
    assert_eq!(up_bytes, up.bytes_out);
    assert_eq!(down_bytes, down.bytes_out);
    // one air: busy all the time, never more
    // (the frame on the air at the end counts all its airtime: 267 bytes, 133.5 ms)
    let air = (up.air_us + down.air_us) as f64;
    assert!(
        air <= elapsed + 133_500.0 && air > 0.99 * elapsed,
        "{air} µs of air in {elapsed}"
    );
    assert!(
        ((up.bytes_out + down.bytes_out) as f64) < 2000.0 * elapsed / 1e6,
        "more than the budget"
    );
    // each direction half of it
    assert!((up.air_us as f64 / air - 0.5).abs() < 0.01);
    // 10 % lost on the air, as the other radio's receive errors
    for (d, errors) in [
        (up, stats.vehicle_radio.rx_errors),
        (down, stats.gcs_radio.rx_errors),
    ] {
        let lost = d.lost as f64 / (d.lost + d.frames_out) as f64;
        assert!((lost - 0.1).abs() < 0.03, "lost {lost}");
        assert_eq!(u64::from(errors), d.lost);
        assert!(d.rate_dropped > 0);
        // what is left was still in the radio (4 kB: frames of 15 bytes or more)
        assert!(d.frames_in - d.frames_out - d.lost - d.rate_dropped <= 4096 / 15 + 1);
    }
    // reports from each side's own radio
    assert_eq!(to_gcs.len() as u64, stats.gcs_radio.radio_status);
    assert_eq!(to_vehicle.len() as u64, stats.vehicle_radio.radio_status);
    for (reports, errors) in [
        (&to_gcs, stats.gcs_radio.rx_errors),
        (&to_vehicle, stats.vehicle_radio.rx_errors),
    ] {
        assert!(reports.len() >= 10, "{} reports", reports.len());
        assert!(reports.windows(2).all(|w| w[0].rxerrors <= w[1].rxerrors));
        let last = reports.last().unwrap();
        assert!(last.rxerrors <= errors && last.rxerrors > 0);
        assert!(reports.iter().all(|r| r.txbuf <= 100 && r.remrssi == 100));
        assert!(
            reports.iter().any(|r| r.txbuf < 20),
            "a flooded buffer shows"
        );
    }
}

/// On the vehicles' own time: a vehicle at ×5 (its `time_boot_ms` runs five times faster
/// than the virtual wall clock) floods a `--radio 2000` relay; the relay's clock follows it,
/// so the radio carries 2,000 B/s of the vehicle's time, 10,000 B/s of wall time.
#[tokio::test(start_paused = true)]
async fn radio_counts_bytes_in_the_vehicles_time() {
    let opts = RelayOptions {
        radio: RadioConfig::radio(2000),
        ..RelayOptions::default()
    };
    let vt = VehicleTime::new();
    let secs = 30u64;
    let (mut gc, mut vc) = (Codec::new(), Codec::new());
    let (at_gcs, _, stats) = drive_relay(
        opts,
        Some(MonotonicClock::vehicles(&vt)),
        secs,
        |k, gcs, vehicle| {
            // 5 × 10 ms of the vehicle's time per step; about 24 kB/s of wall time offered
            let pos = MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
                time_boot_ms: 100_000 + 50 * k as u32,
                lat: 1,
                ..GLOBAL_POSITION_INT_DATA::default()
            });
            vehicle(vc.encode(1, 1, &pos, 0));
            vehicle(vc.encode(1, 1, &chunk(200 + (k % 50) as u16), 0));
            if k % 20 == 0 {
                gcs(gc.encode(255, 190, &heartbeat(), 0));
            }
        },
    )
    .await;
    assert!((vt.rate() - 5.0).abs() < 0.01, "rate {}", vt.rate());
    let ratio = stats.clock_us as f64 / stats.wall_us as f64;
    assert!((ratio - 5.0).abs() < 0.1, "{ratio}");
    // after the first seconds (wall time until the rate is measured)
    let bytes: usize = at_gcs
        .iter()
        .filter(|(t, _)| *t >= Duration::from_secs(2))
        .map(|(_, b)| b.len())
        .sum();
    let span = at_gcs.last().unwrap().0.as_secs_f64() - 2.0;
    let wall_rate = bytes as f64 / span;
    eprintln!(
        "{wall_rate:.0} B/s of wall time, {:.0} B/s of vehicle time",
        wall_rate / 5.0
    );
    assert!((wall_rate - 10_000.0).abs() < 300.0, "{wall_rate:.0} B/s");
}

/// The real binary, `fleetmap relay --rate 5000 --json`, between two UDP sockets on the wall
/// clock: 4 s of a flood at about 14 kB/s arrive at 5,000 B/s (between 85 % and 105 %: a
/// busy machine can stall the sender, which only lowers the figure, or delay the first
/// arrival, which raises it a little; the exact figure is the paused-clock test's), whole
/// and in order, and the JSON counts add up with what arrived.
#[test]
fn cli_relay_rate_5000_over_udp() {
    use std::net::UdpSocket;
    use std::time::Instant;
    let vehicle = UdpSocket::bind("127.0.0.1:0").unwrap();
    vehicle
        .set_read_timeout(Some(Duration::from_millis(1500)))
        .unwrap();
    let vport = vehicle.local_addr().unwrap().port();
    let gport = fleetmap_test_kit::free_udp_port();
    let mut child = fleetmap_test_kit::Guard::spawn(
        crate::common::fleetmap()
            .command()
            .args([
                "relay",
                "--gcs",
                &format!("udpin:127.0.0.1:{gport}"),
                "--vehicle",
                &format!("udpout:127.0.0.1:{vport}"),
                "--rate",
                "5000",
                "--report-every",
                "0",
                "--duration",
                "120",
                "--json",
            ])
            .stdout(std::process::Stdio::piped()),
    );
    let gcs = UdpSocket::bind("127.0.0.1:0").unwrap();
    let mut c = Codec::new();
    let mut rx = Codec::new();
    let mut buf = [0u8; 600];
    // the relay is up when a probe comes through
    vehicle
        .set_read_timeout(Some(Duration::from_millis(50)))
        .unwrap();
    let mut probes = 0u64;
    let start = Instant::now();
    loop {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "the relay never started"
        );
        gcs.send_to(&c.encode(255, 190, &ping(0), 0), ("127.0.0.1", gport))
            .unwrap();
        probes += 1;
        if let Ok(n) = vehicle.recv(&mut buf) {
            assert!(matches!(
                one_frame(&mut rx, &buf[..n]),
                MavMessage::SYSTEM_TIME(_)
            ));
            break;
        }
    }
    vehicle
        .set_read_timeout(Some(Duration::from_millis(1500)))
        .unwrap();
    let receiver = std::thread::spawn(move || {
        let mut got = Vec::new();
        let mut buf = [0u8; 600];
        while let Ok(n) = vehicle.recv(&mut buf) {
            got.push((Instant::now(), buf[..n].to_vec()));
        }
        got
    });
    let n: u16 = 400;
    let t0 = Instant::now();
    for i in 0..n {
        gcs.send_to(&c.encode(255, 190, &chunk(i), 0), ("127.0.0.1", gport))
            .unwrap();
        let next = t0 + Duration::from_millis(10 * (u64::from(i) + 1));
        std::thread::sleep(next.saturating_duration_since(Instant::now()));
    }
    let got = receiver.join().unwrap();
    child.signal("INT");
    let mut out = String::new();
    std::io::Read::read_to_string(child.stdout.as_mut().unwrap(), &mut out).unwrap();
    assert!(child.wait().unwrap().success());

    let mut last = None;
    let mut arrivals = Vec::new();
    let mut late_probes = 0u64;
    for (t, bytes) in &got {
        match one_frame(&mut rx, bytes) {
            MavMessage::ENCAPSULATED_DATA(d) => {
                assert!(last < Some(d.seqnr), "{:?} then {}", last, d.seqnr);
                last = Some(d.seqnr);
                arrivals.push((t.duration_since(t0), bytes.len()));
            }
            MavMessage::SYSTEM_TIME(_) => late_probes += 1,
            m => panic!("unexpected {m:?}"),
        }
    }
    let rate = throughput(&arrivals[1..]); // as above: from the second frame on
    eprintln!(
        "CLI over UDP: {} of {n} frames at {rate:.1} B/s; stats {}",
        arrivals.len(),
        out.trim()
    );
    assert!(
        rate > 0.85 * RATE && rate < 1.05 * RATE,
        "{rate:.1} B/s over UDP"
    );
    let stats: serde_json::Value = serde_json::from_str(out.lines().last().unwrap()).unwrap();
    let up = &stats["up"];
    let count = |k: &str| up[k].as_u64().unwrap();
    // every probe that reached the relay came through (its queue was empty then)
    assert!(late_probes < probes);
    assert_eq!(count("frames_in"), 1 + late_probes + u64::from(n));
    assert_eq!(count("frames_out"), 1 + late_probes + arrivals.len() as u64);
    assert_eq!(
        count("frames_out") + count("rate_dropped"),
        count("frames_in")
    );
    assert!(count("rate_dropped") > 0);
    assert!(count("peak_queue_bytes") <= u64::from(RadioConfig::SIK_BUFFER_BYTES));
}
