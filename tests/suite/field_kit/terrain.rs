//! Terrain (docs/terrain.md) on the command line: the real `fleetmap` binary.

use fleetmap_core::terrain::hgt::{SRTM3_SIDE, Tile, TileId};

use crate::common;

/// Run the binary with `args` to its end: (success, stdout, stderr).
fn run(args: &[&str]) -> (bool, String, String) {
    let (code, stdout, stderr) = common::fleetmap().run(args);
    (code == 0, stdout, stderr)
}

/// The three plans shaped like QGroundControl's ArduCopter test plans (`tests/plans/`) are
/// refused when read, naming item 6 and its altitude mode, before any connection: nothing
/// listens on the port given.
#[test]
fn plans_with_uncomputed_terrain_altitudes_are_refused_before_upload() {
    let port = fleetmap_test_kit::free_udp_port();
    let conn = format!("udpin:127.0.0.1:{port}");
    for home in ["cmac", "zurich", "issaquah"] {
        let file = format!(
            "{}/tests/plans/arducopter-mixed-altitudes-{home}.plan",
            env!("CARGO_MANIFEST_DIR")
        );
        for cmd in ["upload", "fly"] {
            let (ok, _, err) = run(&[
                "mission",
                cmd,
                "--connect",
                &conn,
                "--sysid",
                "1",
                "--wait",
                "1",
                &file,
            ]);
            assert!(!ok, "{home} {cmd}: {err}");
            assert!(err.contains("mission item 6:"), "{home} {cmd}: {err}");
            assert!(err.contains("calculated above terrain"), "{err}");
            assert!(
                !err.contains("heartbeat"),
                "refused before connecting: {err}"
            );
        }
    }
}

/// `fleetmap mission fly --terrain DIR` against `fleetmap sim` (an ArduCopter that asks for
/// the squares of its block and refuses to arm without them while its mission flies in the
/// terrain frame): with an empty folder it names the missing tile before take-off; with the
/// tile it serves all 56 squares, the vehicle reports them loaded, and the mission is flown.
#[test]
fn terrain_is_served_from_tiles_and_a_missing_tile_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("empty");
    let tiles = dir.path().join("tiles");
    std::fs::create_dir_all(&empty).unwrap();
    std::fs::create_dir_all(&tiles).unwrap();
    // a flat tile at 584 m under the simulator's home (synthetic, as every test tile)
    let id = TileId { lat: -36, lon: 149 };
    let tile = Tile::from_samples(id, SRTM3_SIDE, vec![584; SRTM3_SIDE * SRTM3_SIDE]).unwrap();
    std::fs::write(tiles.join(id.file_name()), tile.to_hgt()).unwrap();
    let mission = dir.path().join("terrain.waypoints");
    std::fs::write(
        &mission,
        "QGC WPL 110\n\
         0\t1\t0\t16\t0\t0\t0\t0\t-35.363261\t149.165230\t584\t1\n\
         1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t10\t1\n\
         2\t0\t10\t16\t0\t0\t0\t0\t-35.363000\t149.165230\t12\t1\n\
         3\t0\t10\t16\t0\t0\t0\t0\t-35.363000\t149.165500\t12\t1\n",
    )
    .unwrap();
    let port = fleetmap_test_kit::free_udp_port();
    let _sim = common::fleetmap().quiet(&[
        "sim",
        "--vehicles",
        "1xcopter:ardupilot",
        "--connect",
        &format!("udpout:127.0.0.1:{port}"),
        "--home=-35.363261,149.16523",
        "--speedup",
        "20",
        "--duration",
        "6000",
    ]);
    let conn = format!("udpin:127.0.0.1:{port}");
    let fly = |terrain: &std::path::Path| {
        run(&[
            "mission",
            "fly",
            "--connect",
            &conn,
            "--sysid",
            "1",
            "--wait",
            "20",
            "--timeout",
            "120",
            "--terrain",
            terrain.to_str().unwrap(),
            mission.to_str().unwrap(),
        ])
    };
    let (ok, out, err) = fly(&empty);
    assert!(!ok, "{out}{err}");
    assert!(
        err.contains("vehicle 1 waits for terrain at -35.") && err.contains("no tile S36E149.hgt"),
        "{out}{err}"
    );
    assert!(!out.contains("arming"), "refused before take-off: {out}");
    let (ok, out, err) = fly(&tiles);
    assert!(ok, "{out}{err}");
    assert!(
        out.contains("terrain: 0 squares pending, 56 loaded"),
        "{out}"
    );
    assert!(out.contains("every mission item flown"), "{out}");
    assert!(out.contains("landed and disarmed"), "{out}");
}
