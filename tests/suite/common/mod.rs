//! What several modules of the test suite share and only this suite needs (it names the ground
//! station's own types): worlds, missions, simulators, pseudo-terminals, run drivers. What the
//! camera's tests need as well (process guards, the binaries, the router, a test GCS) is in
//! the `fleetmap-test-kit` crate.

pub mod bandit;
pub mod drive;
pub mod pty;
pub mod runway;

/// The name libtest knows a test of this binary by (`MODULE::test`), for a test that runs
/// another of its tests as a child process (`--exact NAME`): `module_path` is the caller's
/// `module_path!()`, whose first segment (the crate, `suite`) libtest leaves out.
pub fn test_name(module_path: &str, test: &str) -> String {
    match module_path.split_once("::") {
        Some((_, module)) => format!("{module}::{test}"),
        None => test.to_string(),
    }
}

/// The events of the journal of the run in `dir`, in order (`E`: the mission kind's event
/// type); the test fails if the run or its journal does not load.
pub fn journal<E: serde::de::DeserializeOwned>(dir: &std::path::Path) -> Vec<E> {
    fleetmap::store::RunDir::open(dir)
        .expect("the run directory opens")
        .read_events::<E>()
        .expect("the journal reads")
        .events
        .into_iter()
        .map(|l| l.event)
        .collect()
}

/// A new run as a test starts one ([`bandit::new_run`], [`runway::new_run`]): the mission's
/// first state, the run directory as created, its path (`run` in the temporary directory) and
/// the temporary directory (removed when dropped).
pub type NewRun<S> = (
    S,
    fleetmap::store::RunDir,
    std::path::PathBuf,
    tempfile::TempDir,
);

/// A take-off to 10 m, then `waypoints` waypoints for vehicle `k` near 37.1968° N,
/// 80.5781° W: northward 1e-5° apart, vehicle `k` 1e-5° × `k` east, at 10 to 14 m.
pub fn spread_mission(k: u8, waypoints: u32) -> Vec<fleetmap_core::mission::item::MissionItem> {
    use fleetmap_core::mission::item::MissionItem;
    let mut v = vec![MissionItem::takeoff(10.0)];
    for i in 0..waypoints {
        v.push(MissionItem::waypoint(
            37.1968 + f64::from(i) * 1e-5,
            -80.5781 + f64::from(k) * 1e-5,
            10.0 + (i % 5) as f32,
        ));
    }
    v
}

/// Vehicle `k` of fleet `f` acknowledges a command (MAV_CMD_REQUEST_MESSAGE for its
/// HOME_POSITION), takes the mission `items` and gives it back unchanged; the test fails
/// naming the vehicle otherwise.
pub async fn command_and_mission_round_trip(
    f: &fleetmap::fleet::FleetHandle,
    k: u8,
    items: Vec<fleetmap_core::mission::item::MissionItem>,
) {
    use fleetmap_core::mission::item::MissionType;
    use fleetmap_core::proto::{Endpoint, command::Command};
    use mavlink::dialects::ardupilotmega::MavCmd;
    f.command(Command::long(
        Endpoint::new(k, 1),
        MavCmd::MAV_CMD_REQUEST_MESSAGE,
        [242.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], // HOME_POSITION
    ))
    .await
    .unwrap_or_else(|e| panic!("vehicle {k}: {e}"));
    f.upload_mission(k, MissionType::Mission, items.clone())
        .await
        .unwrap_or_else(|e| panic!("vehicle {k} upload: {e}"));
    let (back, _) = f
        .download_mission(k, MissionType::Mission)
        .await
        .unwrap_or_else(|e| panic!("vehicle {k} download: {e}"));
    fleetmap_core::mission::wire::compare_items(&items, &back, true)
        .unwrap_or_else(|d| panic!("vehicle {k}: {d}"));
}

/// The `fleetmap` binary under test: `$FLEETMAP_BIN` when set (a build made elsewhere), else
/// the one cargo built for this test run.
pub fn fleetmap() -> fleetmap_test_kit::Bin {
    fleetmap_test_kit::Bin::built("FLEETMAP_BIN", env!("CARGO_BIN_EXE_fleetmap"))
}

/// An asphalt strip of five by three 4 m cells (20 m × 12 m) and a 0.25 m margin on every side
/// (20.5 m × 12.5 m), with the default homes 12 m south of its centre.
///
/// On a grid whose origin is the strip's centre ([`STRIP_CENTRE`]) every cell is either
/// wholly runway or at most 7 % runway (the 0.25 m margin, plus a little from the 0.25° between
/// grid north and true north there), so no cell's label depends on where exactly an image was
/// taken: the margin is wider than the classifier's 7 dilations eat into the runway
/// (7 px at 40 px/m = 0.18 m for the 480 px camera at 12 m), and an image's footprint would
/// have to move about 2 m (1.2 m along both axes for a corner cell) to carry a cell across
/// the 0.5 black fraction, against a simulated GPS error of σ ≈ 0.4 m. With
/// `origin = "vehicle"` the grid starts instead at the home the simulated GPS reports, about
/// a metre off, and the strip's edge cells are only partly runway.
pub const WORLD: &str = r#"
name = "strip"
description = "A 20.5 m x 12.5 m asphalt strip: 5 x 3 grid cells and a 0.25 m margin (test world)"
background = "grass"
ground_alt_amsl_m = 600.0

[[region]]
name = "strip"
surface = "asphalt"
rectangle = { center = [37.196800, -80.578100], length_m = 20.5, width_m = 12.5, heading_deg = 90.0 }
markings = false

[homes]
reference = [37.196800, -80.578100]
first_north_m = -12.0
first_east_m = 0.0
step_north_m = 0.0
step_east_m = 3.0
"#;

/// The strip's centre in [`WORLD`] (latitude, longitude, degrees): the grid origin that puts
/// its edges 0.25 m outside cell boundaries.
pub const STRIP_CENTRE: (f64, f64) = (37.196800, -80.578100);

/// The runway field-test mission (`missions/runway-field-test.toml`) on a grid anchored at
/// [`STRIP_CENTRE`] instead of the vehicle's first position, so that the map does not depend on
/// where the simulated GPS puts home.
pub fn strip_mission() -> String {
    let field_test = fleetmap::kinds::runway::demo::RUNWAY_MISSION;
    let (lat, lon) = STRIP_CENTRE;
    let fixed = field_test.replacen(
        "\norigin = \"vehicle\"",
        &format!("\norigin = {{ lat = {lat}, lon = {lon} }}"),
        1,
    );
    assert_ne!(
        fixed, field_test,
        "the field-test mission's origin line moved"
    );
    fixed
}

/// A simulator served at up to `ceiling`× to a GCS listening on `gcs` (every vehicle from its
/// own socket, `udpout`), from a thread of its own whose single-threaded runtime gives it one
/// turn between two calls of `hold` (which keeps the thread busy or blocked: a starved
/// machine). A fleet in the test follows its time ([`StarvedSim::time`]).
pub struct StarvedSim {
    /// The simulator's published time.
    pub time: fleetmap_io::clock::SimTime,
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
    thread: std::thread::JoinHandle<fleetmap_sim::harness::Sim>,
}

impl StarvedSim {
    /// Serve `cfg` as described on [`StarvedSim`].
    pub async fn start(
        cfg: fleetmap_sim::harness::SimConfig,
        ceiling: f64,
        gcs: std::net::SocketAddr,
        hold: fn(),
    ) -> StarvedSim {
        use fleetmap_sim::server::{GcsClock, ServeOptions, parse_connection, spawn};
        use std::sync::atomic::Ordering;
        let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let stop_sim = stop.clone();
        let (time_tx, time_rx) = tokio::sync::oneshot::channel();
        let thread = std::thread::spawn(move || {
            let rt = tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()
                .unwrap();
            rt.block_on(async move {
                let sim = fleetmap_sim::harness::Sim::new(cfg, fleetmap_core::time::Time::ZERO);
                let h = spawn(
                    sim.unwrap(),
                    ServeOptions {
                        endpoints: vec![parse_connection(&format!("udpout:{gcs}")).unwrap()],
                        speed: fleetmap_sim::pace::Speed::Times(ceiling),
                        gcs: GcsClock::Simulator,
                        image_dir: None,
                        duration_s: None,
                    },
                )
                .await
                .unwrap();
                let _ = time_tx.send(h.time.clone());
                while !stop_sim.load(Ordering::Relaxed) {
                    hold();
                    tokio::task::yield_now().await;
                }
                h.stop().await.unwrap()
            })
        });
        let time = time_rx.await.expect("the simulator's time");
        StarvedSim { time, stop, thread }
    }

    /// Stop serving; the simulation as it ended.
    pub fn stop(self) -> fleetmap_sim::harness::Sim {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
        self.thread.join().expect("the simulator's thread")
    }
}
