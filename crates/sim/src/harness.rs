//! The in-process simulator: several vehicles over one world on a virtual clock, each behind
//! its own faulty link, exchanging MAVLink 2 frames (bytes) with whoever drives it.
//!
//! This is what tests, `fleetmap demo` and the socket server ([`crate::server`]) run:
//!
//! ```no_run
//! use fleetmap_sim::harness::{Sim, SimConfig};
//! use fleetmap_core::time::Time;
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let world = fleetmap_io::files::load_world("assets/worlds/runway.toml".as_ref())?;
//! let cfg = SimConfig::from_spec("2xcopter:ardupilot,1xrover:px4", Some(world), None, 42)?;
//! let mut sim = Sim::new(cfg, Time::ZERO)?;
//! sim.advance_to(Time::from_secs(20));             // boot, GPS, position estimate
//! while let Some(frame) = sim.recv_bytes(1) { /* feed your GCS codec */ }
//! sim.send_bytes(1, &[/* a MAVLink frame from the GCS */]);
//! # Ok(()) }
//! ```
//!
//! Each vehicle's link may carry a telemetry radio pair ([`SimConfig::radio`]: a SiK pair's
//! shared budget, buffers, loss and RADIO_STATUS, in simulated time), then its link faults.
//!
//! Vehicle k (1-based, in the order of the spec) gets system id k and the world's default
//! home k (or `--home` plus 3 m east per vehicle). A copter landed within
//! `SimConfig::dock_radius_m` of a rover rides with it and charges (the bandit paper's
//! mobile charging stations).

use crate::fault::{Action, FaultPlan, FaultSpecError, ScheduledFault};
use crate::flavour::{SimFlavour, SimVehicleClass};
use crate::vehicle::{DT, Px4Link, SimVehicle, VehicleConfig, VehicleEvent};
use fleetmap_camera::camera::CapturedImage;
use fleetmap_core::time::Time;
use fleetmap_core::world::{Wind, World};
use fleetmap_io::link::codec::Codec;
use fleetmap_io::link::faults::{FaultError, FaultyChannel, LinkFaults};
use fleetmap_io::link::radio::{End, RadioConfig, RadioPair, RadioStats};
use fleetmap_io::link::signing::{Signing, SigningKey};
use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::{MavHeader, MavlinkVersion};
use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Duration;
use thiserror::Error;

/// Errors building a simulation.
#[derive(Debug, Error)]
pub enum SimError {
    /// The `--vehicles` spec is malformed.
    #[error("invalid vehicle spec {spec:?}: {reason}")]
    Spec {
        /// The spec.
        spec: String,
        /// Why.
        reason: String,
    },
    /// A vehicle has no start position.
    #[error("vehicle {0} has no home: the world defines none for it; give --home LAT,LON")]
    NoHome(usize),
    /// A link fault setting is invalid.
    #[error(transparent)]
    Faults(#[from] FaultError),
    /// A scheduled fault names a vehicle (or a camera) the simulation does not have.
    #[error(transparent)]
    Fault(#[from] FaultSpecError),
    /// Two vehicles share a system id (and [`SimConfig::shared_sysids`] does not allow it).
    #[error("system id {0} is used twice")]
    DuplicateSysid(u8),
    /// A vehicle to give another system id is not in the spec.
    #[error("no vehicle {0} to give a system id (vehicles are numbered from 1)")]
    NoVehicle(usize),
}

/// One entry of a `--vehicles` spec: how many, which flavour, and for PX4 which MAVLink
/// instance the GCS talks to ([`Px4Link`]: `@net`, the default, `@telem1`, or `@sitl`: the
/// SITL's UDP GCS link, to compare with PX4 SITL).
type SpecEntry = (usize, SimFlavour, Option<Px4Link>);

/// Parse `3xcopter:ardupilot,1xrover:px4,copter:px4@sitl` into entries (a missing `N x`
/// means one).
pub(crate) fn parse_vehicle_spec(spec: &str) -> Result<Vec<SpecEntry>, SimError> {
    let err = |reason: String| SimError::Spec {
        spec: spec.to_string(),
        reason,
    };
    let mut out = Vec::new();
    for part in spec.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (n, rest) = match part.split_once(['x', 'X']) {
            Some((n, rest)) if !n.is_empty() && n.chars().all(|c| c.is_ascii_digit()) => {
                (n.parse::<usize>().map_err(|e| err(e.to_string()))?, rest)
            }
            _ => (1, part),
        };
        if n == 0 || n > 250 {
            return Err(err(format!("{part:?}: count must be 1–250")));
        }
        let (rest, link) = match rest.split_once('@') {
            Some((r, l)) => (r, Some(l.trim().to_ascii_lowercase())),
            None => (rest, None),
        };
        let f = rest.parse::<SimFlavour>().map_err(|e| err(e.to_string()))?;
        let link = match link.as_deref() {
            None => None,
            Some(_) if f.is_ardupilot() => {
                return Err(err(format!("{part:?}: @LINK is for PX4 vehicles only")));
            }
            Some("net") => Some(Px4Link::NETWORK),
            Some("telem1") => Some(Px4Link::TELEM1),
            Some("sitl") => Some(Px4Link::SITL_UDP),
            Some(other) => {
                return Err(err(format!(
                    "{part:?}: unknown PX4 link {other:?} (net, telem1 or sitl)"
                )));
            }
        };
        out.push((n, f, link));
    }
    if out.is_empty() {
        return Err(err("no vehicles".into()));
    }
    if out.iter().map(|(n, _, _)| n).sum::<usize>() > 250 {
        return Err(err("at most 250 vehicles".into()));
    }
    Ok(out)
}

/// Everything a simulation needs.
#[derive(Clone, Debug)]
pub struct SimConfig {
    /// The vehicles, in system-id order.
    pub vehicles: Vec<VehicleConfig>,
    /// The world (ground truth for images), if any.
    pub world: Option<Arc<World>>,
    /// Faults GCS → vehicle, one per vehicle (missing entries: perfect).
    pub(crate) uplink: Vec<LinkFaults>,
    /// Faults vehicle → GCS, one per vehicle (missing entries: perfect).
    pub downlink: Vec<LinkFaults>,
    /// A copter landed within this distance of a rover rides with it and charges, metres.
    pub(crate) dock_radius_m: f64,
    /// Seed of the links.
    pub seed: u64,
    /// MAVLink 2 signing key of every ArduPilot vehicle (None: unsigned, until a GCS sends
    /// SETUP_SIGNING). With a key, vehicles sign what they send and ignore unsigned frames,
    /// as ArduPilot does once signing is set up. PX4 vehicles never sign (PX4 v1.16 has no
    /// MAVLink signing).
    pub signing_key: Option<SigningKey>,
    /// Wall-clock microseconds since the Unix epoch at simulation time 0 (signature
    /// timestamps); fixed by default so runs stay reproducible.
    pub unix_epoch_us: u64,
    /// A telemetry radio pair between every vehicle and the GCS (each vehicle its own), its
    /// budget, buffers and loss counted in simulated time ([`RadioPair`]); the link faults
    /// apply after the air. `None`: the vehicles' links carry whatever they send.
    pub radio: Option<RadioConfig>,
    /// Faults scheduled in simulated time since the start ([`crate::fault`]): outages of the
    /// links, a battery that drops, a camera that fails or slows, a vehicle stuck.
    pub faults: Vec<ScheduledFault>,
    /// Allow two vehicles with the same system id: two autopilots left at the same
    /// `SYSID_THISMAV` / `MAV_SYS_ID`, as two SITLs sending to one GCS port are. Each keeps
    /// its own endpoint; address them by index ([`Sim::send_bytes_at`], [`Sim::recv_bytes_at`])
    /// — the `sysid` methods reach the first. Set by [`SimConfig::with_sysid`].
    pub shared_sysids: bool,
}

/// The default `SimConfig::unix_epoch_us`: 2025-01-01T00:00:00Z.
pub const DEFAULT_EPOCH_US: u64 = 1_735_689_600_000_000;

impl SimConfig {
    /// Vehicles from a `--vehicles` spec at the world's default homes (or at `home` plus
    /// 3 m east per vehicle), seeded from `seed`, with the world's wind and ground elevation.
    pub fn from_spec(
        spec: &str,
        world: Option<World>,
        home: Option<(f64, f64)>,
        seed: u64,
    ) -> Result<SimConfig, SimError> {
        let kinds = parse_vehicle_spec(spec)?;
        let world = world.map(Arc::new);
        let mut vehicles = Vec::new();
        let mut k = 0usize;
        for (n, flavour, link) in kinds {
            for _ in 0..n {
                k += 1;
                let start = match home {
                    Some((lat, lon)) => {
                        fleetmap_core::geo::local::offset(lat, lon, 0.0, 3.0 * (k - 1) as f64)
                    }
                    None => world
                        .as_ref()
                        .and_then(|w| w.default_home(k))
                        .ok_or(SimError::NoHome(k))?,
                };
                let mut v = VehicleConfig::new(k as u8, flavour, start);
                if let Some(l) = link {
                    v.px4_link = l;
                }
                v.seed = seed
                    .wrapping_mul(0x9E37_79B9_7F4A_7C15)
                    .wrapping_add(k as u64);
                v.gps_common_seed = seed ^ 0x6A09_E667_F3BC_C908;
                if let Some(w) = &world {
                    v.reference = w.reference;
                    v.ground_alt_amsl_m = w.ground_alt_amsl_m;
                    v.wind = w.wind;
                }
                vehicles.push(v);
            }
        }
        if world.is_none()
            && let Some(first) = vehicles.first().map(|v| v.start)
        {
            for v in &mut vehicles {
                v.reference = first;
            }
        }
        Ok(SimConfig {
            vehicles,
            world,
            uplink: Vec::new(),
            downlink: Vec::new(),
            dock_radius_m: 1.5,
            seed,
            signing_key: None,
            unix_epoch_us: DEFAULT_EPOCH_US,
            radio: None,
            faults: Vec::new(),
            shared_sysids: false,
        })
    }

    /// Give vehicle `vehicle` (1-based, in the spec's order) system id `sysid`, also one
    /// another vehicle has (see [`SimConfig::shared_sysids`]).
    pub fn with_sysid(mut self, vehicle: usize, sysid: u8) -> Result<SimConfig, SimError> {
        let v = vehicle
            .checked_sub(1)
            .and_then(|k| self.vehicles.get_mut(k))
            .ok_or(SimError::NoVehicle(vehicle))?;
        v.sysid = sysid;
        self.shared_sysids = true;
        Ok(self)
    }

    /// Put every vehicle behind its own telemetry radio pair of `radio` (see
    /// [`SimConfig::radio`]).
    pub fn with_radio(mut self, radio: RadioConfig) -> SimConfig {
        self.radio = Some(radio);
        self
    }

    /// Apply the same faults to every link, both directions.
    pub fn with_faults(mut self, faults: LinkFaults) -> SimConfig {
        let n = self.vehicles.len();
        self.uplink = vec![faults.clone(); n];
        self.downlink = vec![faults; n];
        self
    }

    /// Add `faults` to the schedule ([`SimConfig::faults`]).
    pub fn with_scheduled_faults(
        mut self,
        faults: impl IntoIterator<Item = ScheduledFault>,
    ) -> SimConfig {
        self.faults.extend(faults);
        self
    }

    /// Set the wind for every vehicle.
    pub fn with_wind(mut self, wind: Option<Wind>) -> SimConfig {
        for v in &mut self.vehicles {
            v.wind = wind;
        }
        self
    }
}

#[derive(Debug)]
struct Slot {
    v: SimVehicle,
    key: Option<SigningKey>,
    codec: Codec,
    gcs_codec: Codec,
    up: FaultyChannel,
    down: FaultyChannel,
    delivered: VecDeque<Vec<u8>>,
    /// The vehicle's radio pair, when the links carry radios: what the GCS sends goes into
    /// its GCS end, what the vehicle sends into its vehicle end, and what comes out of either
    /// end goes on through the link's faults.
    radio: Option<RadioPair>,
}

impl Slot {
    /// Bytes from the GCS, sent at `t`.
    fn carry_from_gcs(&mut self, bytes: Vec<u8>, t: Time) {
        match &mut self.radio {
            Some(r) => {
                r.push(End::Gcs, bytes, t);
            }
            None => self.up.push(bytes, t),
        }
    }

    /// A frame from the vehicle, sent at `t`.
    fn carry_from_vehicle(&mut self, frame: Vec<u8>, t: Time) {
        match &mut self.radio {
            Some(r) => {
                r.push(End::Vehicle, frame, t);
            }
            None => self.down.push(frame, t),
        }
    }

    /// What came out of the radio's ends by `t`: on into the links' faults.
    fn radio_out(&mut self, t: Time) {
        let Some(r) = &mut self.radio else {
            return;
        };
        while let Some(d) = r.poll(t) {
            match d.to {
                End::Vehicle => self.up.push(d.frame, d.at),
                End::Gcs => self.down.push(d.frame, d.at),
            }
        }
    }
}

/// The in-process simulation. See the module documentation.
#[derive(Debug)]
pub struct Sim {
    now: Time,
    slots: Vec<Slot>,
    world: Option<Arc<World>>,
    dock_radius_m: f64,
    images: VecDeque<(u8, CapturedImage)>,
    events: VecDeque<(u8, VehicleEvent)>,
    epoch_us: u64,
    /// The scheduled faults still to start or end.
    faults: FaultPlan,
}

/// What a scheduled fault does to vehicle `v`.
fn apply_fault(v: &mut SimVehicle, a: Action) {
    match a {
        Action::Battery(p) => v.drop_battery_to(p),
        Action::CameraFailed(f) => v.set_camera_failed(f),
        Action::CameraRate(r) => v.set_camera_transfer_rate(r),
        Action::CameraInterval(i) => v.set_camera_min_interval(i),
        Action::Stuck(s) => v.set_stuck(s),
    }
}

fn vehicle_codec(key: &Option<SigningKey>) -> Codec {
    match key {
        Some(k) => Codec::with_signing(Signing::new(k.clone(), 0)),
        None => Codec::new(),
    }
}

/// Decode a datagram for a vehicle: frames that fail signing are dropped by the codec;
/// SETUP_SIGNING addressed to a disarmed ArduPilot vehicle installs (or, all zeros, removes)
/// its key; armed, it is refused with ArduPilot's warning.
/// PX4 v1.16 has no MAVLink signing (its mavlink module has no SETUP_SIGNING handler and
/// never signs), so a simulated PX4 ignores it.
fn receive(s: &mut Slot, bytes: &[u8], t: Time, unix_us: u64) {
    let signs = s.v.config().flavour.is_ardupilot();
    for f in s.codec.decode(bytes, unix_us) {
        let Ok(m) = f.message else { continue };
        if let MavMessage::SETUP_SIGNING(ss) = &m
            && signs
        {
            if ss.target_system == s.v.sysid() && s.v.armed() {
                // ArduPilot will not change its key while armed (GCS_Signing.cpp).
                s.v.refuse_signing_setup();
            } else if ss.target_system == s.v.sysid() {
                let key = if ss.secret_key.iter().all(|b| *b == 0) {
                    None
                } else {
                    Some(SigningKey(ss.secret_key))
                };
                s.codec
                    .set_signing(key.as_ref().map(|k| Signing::new(k.clone(), 0)));
                s.key = key;
            }
            continue;
        }
        s.v.handle_message(&f.header, &m, t);
    }
}

impl Sim {
    /// Power up every vehicle at `start`.
    pub fn new(cfg: SimConfig, start: Time) -> Result<Sim, SimError> {
        let cameras: Vec<bool> = cfg.vehicles.iter().map(|v| v.camera.is_some()).collect();
        let faults = FaultPlan::new(&cfg.faults, &cameras, start)?;
        let mut seen = std::collections::HashSet::new();
        let mut slots = Vec::new();
        for (i, vc) in cfg.vehicles.into_iter().enumerate() {
            if !seen.insert(vc.sysid) && !cfg.shared_sysids {
                return Err(SimError::DuplicateSysid(vc.sysid));
            }
            let mut up_f = cfg.uplink.get(i).cloned().unwrap_or_default();
            let mut down_f = cfg.downlink.get(i).cloned().unwrap_or_default();
            // a scheduled outage darkens both directions
            up_f.blackouts.extend(faults.outages(i));
            down_f.blackouts.extend(faults.outages(i));
            up_f.validate()?;
            down_f.validate()?;
            let seed = cfg.seed ^ (u64::from(vc.sysid) << 32);
            // PX4 v1.16 does not sign (see `receive`).
            let signing_key = cfg
                .signing_key
                .clone()
                .filter(|_| vc.flavour.is_ardupilot());
            slots.push(Slot {
                v: SimVehicle::new(vc, cfg.world.clone(), start),
                key: signing_key.clone(),
                codec: vehicle_codec(&signing_key),
                gcs_codec: Codec::new(),
                up: FaultyChannel::new(up_f, seed ^ 0x0055),
                down: FaultyChannel::new(down_f, seed ^ 0x00AA),
                delivered: VecDeque::new(),
                radio: cfg.radio.clone().map(|r| RadioPair::new(r, seed ^ 0x0F0F)),
            });
        }
        let mut sim = Sim {
            now: start,
            slots,
            world: cfg.world,
            dock_radius_m: cfg.dock_radius_m,
            images: VecDeque::new(),
            events: VecDeque::new(),
            epoch_us: cfg.unix_epoch_us,
            faults,
        };
        if sim.faults.due(start) {
            sim.apply_faults(start);
        }
        sim.collect_outputs(start);
        Ok(sim)
    }

    /// The simulation time.
    pub fn now(&self) -> Time {
        self.now
    }

    /// The world.
    pub fn world(&self) -> Option<&World> {
        self.world.as_deref()
    }

    /// System ids in order (the index of each is its endpoint's).
    pub fn sysids(&self) -> Vec<u8> {
        self.slots.iter().map(|s| s.v.sysid()).collect()
    }

    fn slot(&self, sysid: u8) -> Option<&Slot> {
        self.slots.iter().find(|s| s.v.sysid() == sysid)
    }

    fn slot_mut(&mut self, sysid: u8) -> Option<&mut Slot> {
        self.slots.iter_mut().find(|s| s.v.sysid() == sysid)
    }

    /// A vehicle, by system id.
    pub fn vehicle(&self, sysid: u8) -> Option<&SimVehicle> {
        self.slot(sysid).map(|s| &s.v)
    }

    /// A vehicle, mutable.
    pub fn vehicle_mut(&mut self, sysid: u8) -> Option<&mut SimVehicle> {
        self.slot_mut(sysid).map(|s| &mut s.v)
    }

    /// Bytes (one datagram: whole frames) sent by the GCS to vehicle `sysid`'s endpoint now.
    pub fn send_bytes(&mut self, sysid: u8, bytes: &[u8]) {
        let now = self.now;
        if let Some(s) = self.slot_mut(sysid) {
            s.carry_from_gcs(bytes.to_vec(), now);
        }
    }

    /// Bytes sent by the GCS to the endpoint of vehicle `k` (index in [`Sim::sysids`]) now.
    pub fn send_bytes_at(&mut self, k: usize, bytes: &[u8]) {
        let now = self.now;
        if let Some(s) = self.slots.get_mut(k) {
            s.carry_from_gcs(bytes.to_vec(), now);
        }
    }

    /// The next datagram vehicle `k` (index in [`Sim::sysids`]) delivered to the GCS by now.
    pub fn recv_bytes_at(&mut self, k: usize) -> Option<Vec<u8>> {
        self.slots.get_mut(k).and_then(|s| s.delivered.pop_front())
    }

    /// Encode and send one message from the GCS (`header` is the GCS's) to vehicle `sysid`.
    pub fn send(&mut self, sysid: u8, header: &MavHeader, msg: &MavMessage) {
        let frame =
            fleetmap_io::link::codec::encode_frame(header, msg, MavlinkVersion::V2, None, 0);
        self.send_bytes(sysid, &frame);
    }

    /// The next datagram vehicle `sysid` delivered to the GCS by now.
    pub fn recv_bytes(&mut self, sysid: u8) -> Option<Vec<u8>> {
        self.slot_mut(sysid).and_then(|s| s.delivered.pop_front())
    }

    /// The next message vehicle `sysid` delivered to the GCS by now (decoded; frames with a
    /// bad CRC are dropped as a GCS would).
    pub fn recv(&mut self, sysid: u8) -> Option<(MavHeader, MavMessage)> {
        let s = self.slot_mut(sysid)?;
        loop {
            if let Some(f) = s.gcs_codec.poll_frame(0) {
                if let Ok(m) = f.message {
                    return Some((f.header, m));
                }
                continue;
            }
            let d = s.delivered.pop_front()?;
            s.gcs_codec.push(&d);
        }
    }

    /// The next captured image (vehicle sysid, image).
    pub fn poll_image(&mut self) -> Option<(u8, CapturedImage)> {
        self.images.pop_front()
    }

    /// The next vehicle event (vehicle sysid, event).
    pub fn poll_event(&mut self) -> Option<(u8, VehicleEvent)> {
        self.events.pop_front()
    }

    /// Set every vehicle's [`VehicleConfig::gcs_time_scale`]: simulated seconds per second
    /// of the GCS's clock (the socket server sets it to its speed-up over a GCS's).
    pub(crate) fn set_gcs_time_scale(&mut self, scale: f64) {
        for s in &mut self.slots {
            s.v.set_gcs_time_scale(scale);
        }
    }

    /// What vehicle `sysid`'s radio pair carried so far, when the links carry radios.
    pub fn radio_stats(&self, sysid: u8) -> Option<RadioStats> {
        self.slot(sysid)?.radio.as_ref().map(RadioPair::stats)
    }

    /// When something next happens: the next 20 Hz tick, or sooner a frame a radio lets out
    /// (a radio's frames arrive when their last byte has crossed, between ticks too).
    pub fn poll_timeout(&self) -> Time {
        let tick = self.now + Duration::from_secs_f64(DT);
        self.slots
            .iter()
            .filter_map(|s| s.radio.as_ref()?.poll_timeout())
            .fold(tick, Time::min)
            .max(self.now)
    }

    /// Run the simulation up to `t` in 20 Hz steps, then deliver (both ways) what is due by
    /// `t` — also when `t` is the current time: frames sent at `now` over a link without
    /// latency are due at `now`, and a vehicle answers a message as soon as it gets it (a
    /// mission request, a command ACK), not at its next tick. The socket server calls this
    /// right after passing on what it received, often within the same microsecond of its
    /// clock; before, such frames waited for the next tick (25 ms on average), which made
    /// a 200-item upload over loopback take 4.5 s.
    pub fn advance_to(&mut self, t: Time) {
        let dt = Duration::from_secs_f64(DT);
        while self.now + dt <= t {
            let next = self.now + dt;
            self.tick(next);
        }
        if t >= self.now {
            // deliver what arrived between the last tick and t
            self.now = t;
            self.deliver(t);
        }
    }

    /// Run for `d`.
    pub fn advance(&mut self, d: Duration) {
        let t = self.now + d;
        self.advance_to(t);
    }

    fn unix_us(&self, t: Time) -> u64 {
        self.epoch_us + t.as_micros()
    }

    fn deliver(&mut self, t: Time) {
        let unix = self.unix_us(t);
        for s in &mut self.slots {
            s.radio_out(t);
            while let Some(bytes) = s.up.poll(t) {
                receive(s, &bytes, t, unix);
            }
            while let Some(d) = s.down.poll(t) {
                s.delivered.push_back(d);
            }
        }
        self.collect_outputs(t);
        for s in &mut self.slots {
            s.radio_out(t);
            while let Some(d) = s.down.poll(t) {
                s.delivered.push_back(d);
            }
        }
    }

    fn tick(&mut self, t: Time) {
        self.now = t;
        if self.faults.due(t) {
            self.apply_faults(t);
        }
        // uplink deliveries first: commands act at this tick
        let unix = self.unix_us(t);
        for s in &mut self.slots {
            s.radio_out(t);
            while let Some(bytes) = s.up.poll(t) {
                receive(s, &bytes, t, unix);
            }
        }
        // step: rovers first, so copters standing on them ride along
        let before: Vec<(f64, f64, f64)> = self.slots.iter().map(|s| s.v.true_local()).collect();
        let order: Vec<usize> = (0..self.slots.len())
            .filter(|&i| self.slots[i].v.config().flavour.kind == SimVehicleClass::Rover)
            .chain(
                (0..self.slots.len())
                    .filter(|&i| self.slots[i].v.config().flavour.kind != SimVehicleClass::Rover),
            )
            .collect();
        for &i in &order {
            self.slots[i].v.step(t);
        }
        self.dock(&before);
        self.collect_outputs(t);
        for s in &mut self.slots {
            s.radio_out(t);
            while let Some(d) = s.down.poll(t) {
                s.delivered.push_back(d);
            }
        }
    }

    /// The scheduled faults that start or end by `t`: applied to their vehicles, announced
    /// as events.
    fn apply_faults(&mut self, t: Time) {
        let (actions, events) = self.faults.step(t);
        for (i, a) in actions {
            if let Some(s) = self.slots.get_mut(i) {
                apply_fault(&mut s.v, a);
            }
        }
        for (i, tr) in events {
            if let Some(s) = self.slots.get(i) {
                let ev = if tr.started {
                    VehicleEvent::FaultStarted(tr.fault)
                } else {
                    VehicleEvent::FaultEnded(tr.fault)
                };
                self.events.push_back((s.v.sysid(), ev));
            }
        }
    }

    fn dock(&mut self, before: &[(f64, f64, f64)]) {
        // (rover position before this step, after it)
        type Move = ((f64, f64), (f64, f64));
        let rovers: Vec<Move> = self
            .slots
            .iter()
            .enumerate()
            .filter(|(_, s)| s.v.config().flavour.kind == SimVehicleClass::Rover)
            .map(|(i, s)| {
                let (e, n, _) = s.v.true_local();
                ((before[i].0, before[i].1), (e, n))
            })
            .collect();
        if rovers.is_empty() {
            return;
        }
        for (slot, b) in self.slots.iter_mut().zip(before) {
            let v = &mut slot.v;
            if v.config().flavour.kind != SimVehicleClass::Copter || !v.landed() || !v.powered() {
                continue;
            }
            // carried by the rover it stood on before this step
            let on = rovers
                .iter()
                .find(|(rb, _)| (rb.0 - b.0).hypot(rb.1 - b.1) <= self.dock_radius_m);
            if let Some((rb, ra)) = on {
                let (de, dn) = (ra.0 - rb.0, ra.1 - rb.1);
                if de != 0.0 || dn != 0.0 {
                    v.carry(de, dn);
                }
                v.charge(DT);
            }
        }
    }

    fn collect_outputs(&mut self, t: Time) {
        let unix = self.unix_us(t);
        for s in &mut self.slots {
            while let Some(img) = s.v.poll_image() {
                self.images.push_back((s.v.sysid(), img));
            }
            while let Some(ev) = s.v.poll_event() {
                if matches!(ev, VehicleEvent::Booted { boot } if boot > 1) {
                    // a power cycle: the link restarts with the vehicle (the signing key
                    // is kept in persistent storage, as ArduPilot keeps it)
                    s.codec = vehicle_codec(&s.key);
                }
                self.events.push_back((s.v.sysid(), ev));
            }
            while let Some((h, m)) = s.v.poll_transmit() {
                let frame = s.codec.encode_with_header(&h, &m, MavlinkVersion::V2, unix);
                s.carry_from_vehicle(frame, t);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spec_parsing() {
        let v = parse_vehicle_spec("3xcopter:ardupilot, 1xrover:ardupilot,copter:px4").unwrap();
        assert_eq!(v.len(), 3);
        assert_eq!(v[0], (3, SimFlavour::ARDU_COPTER, None));
        assert_eq!(v[2], (1, SimFlavour::PX4_COPTER, None));
        let v = parse_vehicle_spec("2xcopter:px4@sitl,rover:px4@TELEM1").unwrap();
        assert_eq!(v[0], (2, SimFlavour::PX4_COPTER, Some(Px4Link::SITL_UDP)));
        assert_eq!(v[1], (1, SimFlavour::PX4_ROVER, Some(Px4Link::TELEM1)));
        assert!(parse_vehicle_spec("copter:ardupilot@sitl").is_err());
        assert!(parse_vehicle_spec("copter:px4@wifi").is_err());
        assert!(parse_vehicle_spec("0xcopter:px4").is_err());
        assert!(parse_vehicle_spec("2xplane:px4").is_err());
        assert!(parse_vehicle_spec("").is_err());
    }
}
