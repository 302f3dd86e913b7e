//! End-to-end tests of the vision module: golden results on the sample images in
//! `assets/images/`, the `fleetmap classify` command on good and hostile inputs, and the
//! vote book fed by the classifier.
//!
//! `REGENERATE=1 cargo test --test suite vision::` re-renders the sample images from their
//! specifications below and rewrites `assets/images/golden.json`
//! (`scripts/gen-vision-images.sh` does exactly that).

use fleetmap_core::geo::{Cell, Dir4};
use fleetmap_core::time::Time;
use fleetmap_core::vision::camera::CameraModel;
use fleetmap_core::vision::green::{self, GreenParams};
use fleetmap_core::vision::load::{LoadLimits, load_image_bytes};
use fleetmap_core::vision::onboard::{GreenShare, GreenSpec, OnboardMeasurement};
use fleetmap_core::vision::runway::synth::{RunwayScene, RunwayStrip, render_runway};
use fleetmap_core::vision::runway::votes::{CellState, Detection, VoteBook, VoteParams};
use fleetmap_core::vision::runway::{self, RunwayParams};
use fleetmap_core::vision::synth::{self, TileScene};
use fleetmap_core::vision::{VisionError, fast};
use fleetmap_io::files::load_image_file;
use image::RgbImage;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::common;

fn assets() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/images")
}

fn strip(angle_deg: f64, offset_px: f64, width_px: f64) -> RunwayStrip {
    RunwayStrip {
        angle_deg,
        offset_px,
        width_px,
        length_px: None,
        along_px: 0.0,
        markings: false,
    }
}

/// The sample images: name → how to render it.
fn samples() -> Vec<(&'static str, RgbImage)> {
    let g = RunwayScene::grass;
    let runway = |s: RunwayScene| render_runway(&s);
    let tile = |w, h, seed, green, shift, exposure| {
        synth::render_tile(&TileScene {
            width: w,
            height: h,
            seed,
            green,
            shift,
            exposure,
        })
    };
    vec![
        ("grass", runway(g(480, 480, 1))),
        (
            "runway-centre-markings",
            runway(g(480, 480, 2).with_runway(RunwayStrip {
                markings: true,
                ..strip(0.0, 0.0, 200.0)
            })),
        ),
        (
            "runway-edge-30deg",
            runway(g(480, 480, 3).with_runway(strip(30.0, 150.0, 260.0))),
        ),
        (
            "runway-right-half",
            runway(g(480, 480, 4).with_runway(strip(0.0, 200.0, 400.0))),
        ),
        (
            "runway-end-corner",
            runway(g(480, 480, 5).with_runway(RunwayStrip {
                length_px: Some(300.0),
                along_px: 250.0,
                ..strip(90.0, -120.0, 240.0)
            })),
        ),
        (
            "runway-overexposed",
            runway(RunwayScene {
                exposure: 1.9,
                ..g(400, 400, 6).with_runway(strip(0.0, 0.0, 240.0))
            }),
        ),
        (
            "grass-dark",
            runway(RunwayScene {
                exposure: 0.75,
                ..g(400, 400, 7)
            }),
        ),
        (
            "runway-odd-size-75deg",
            runway(g(641, 359, 8).with_runway(RunwayStrip {
                markings: true,
                ..strip(75.0, -40.0, 170.0)
            })),
        ),
        (
            "runway-gravel",
            runway(RunwayScene {
                gravel_density: 0.002,
                ..g(360, 360, 9).with_runway(strip(0.0, 0.0, 300.0))
            }),
        ),
        (
            "runway-wide-gaps",
            runway(RunwayScene {
                gap_density: 0.3,
                gap_radius_px: 9.0,
                ..g(360, 360, 10).with_runway(strip(135.0, 30.0, 160.0))
            }),
        ),
        (
            "tiny-13x11",
            runway(g(13, 11, 11).with_runway(strip(0.0, 3.0, 6.0))),
        ),
        ("tile-green", tile(324, 244, 12, true, 0.0, 1.0)),
        ("tile-grey", tile(324, 244, 13, false, 0.0, 1.0)),
        ("tile-green-shifted", tile(324, 244, 14, true, 0.7, 0.9)),
    ]
}

/// Expected results of one sample image.
#[derive(Debug, PartialEq, Serialize, Deserialize)]
struct Golden {
    width: u32,
    height: u32,
    counts: fleetmap_core::vision::regions::RegionCounts,
    fractions: fleetmap_core::vision::regions::RegionFractions,
    labels_heading_0: runway::NeighbourLabels,
    labels_heading_90: runway::NeighbourLabels,
    green_fraction: f64,
    green_measurement: bool,
}

fn golden_of(img: &RgbImage) -> Golden {
    let p = RunwayParams::default();
    let c0 = runway::classify(img, 0.0, &p).expect("sample images are at least 3×3");
    let c90 = runway::classify(img, 90.0, &p).expect("sample images are at least 3×3");
    let gp = GreenParams::default();
    Golden {
        width: img.width(),
        height: img.height(),
        counts: c0.counts,
        fractions: c0.fractions,
        labels_heading_0: c0.labels,
        labels_heading_90: c90.labels,
        green_fraction: green::green_fraction(img, &gp),
        green_measurement: green::measure(img, &gp),
    }
}

/// Lossless PNG at the best compression (the samples live in the repository).
fn save_png_best(img: &RgbImage, path: &Path) {
    use image::ImageEncoder;
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    let mut bytes = Vec::new();
    PngEncoder::new_with_quality(&mut bytes, CompressionType::Best, FilterType::Adaptive)
        .write_image(
            img.as_raw(),
            img.width(),
            img.height(),
            image::ExtendedColorType::Rgb8,
        )
        .expect("encode sample image");
    fleetmap_io::files::atomic_write(path, &bytes).expect("write sample image");
}

#[test]
fn golden_sample_images() {
    let dir = assets();
    let golden_path = dir.join("golden.json");
    let regenerate = std::env::var_os("REGENERATE").is_some_and(|v| v == "1");
    let mut goldens = BTreeMap::new();
    for (name, rendered) in samples() {
        let path = dir.join(format!("{name}.png"));
        if regenerate {
            save_png_best(&rendered, &path);
        }
        let img = load_image_file(&path, &LoadLimits::default())
            .unwrap_or_else(|e| panic!("{}: {e} (REGENERATE=1 makes it)", path.display()));
        assert!(
            img == rendered,
            "{name}: the committed image differs from its specification; \
             REGENERATE=1 cargo test --test suite vision:: rewrites it"
        );
        // The fast path and the reference agree on every sample.
        let p = RunwayParams::default();
        assert_eq!(
            runway::analyse(&img, &p).unwrap(),
            runway::analyse_reference(&img, &p).unwrap(),
            "{name}"
        );
        goldens.insert(name.to_string(), golden_of(&img));
    }
    if regenerate {
        let json = serde_json::to_string_pretty(&goldens).unwrap() + "\n";
        fleetmap_io::files::atomic_write(&golden_path, json.as_bytes()).unwrap();
    }
    let text = std::fs::read_to_string(&golden_path)
        .unwrap_or_else(|e| panic!("{}: {e} (REGENERATE=1 makes it)", golden_path.display()));
    let expected: BTreeMap<String, Golden> = serde_json::from_str(&text).unwrap();
    assert_eq!(
        expected.keys().collect::<Vec<_>>(),
        goldens.keys().collect::<Vec<_>>()
    );
    for (name, want) in &expected {
        // Exact: serde_json is built with float_roundtrip, so the file reads back bit for bit.
        assert_eq!(&goldens[name], want, "{name}");
    }
}

/// The samples say what they were made to say.
#[test]
fn samples_are_classified_as_designed() {
    let load = |n: &str| {
        load_image_file(&assets().join(format!("{n}.png")), &LoadLimits::default()).unwrap()
    };
    let p = RunwayParams::default();
    let c = |n: &str, h: f64| runway::classify(&load(n), h, &p).unwrap();

    let grass = c("grass", 0.0);
    assert!(grass.fractions.center < 0.05, "{:?}", grass.fractions);
    assert!(!grass.labels.center && !grass.labels.north);

    let centre = c("runway-centre-markings", 0.0);
    assert!(centre.labels.center && centre.labels.north && centre.labels.south);
    assert!(!centre.labels.east && !centre.labels.west);
    // Heading east: the runway (image top-bottom) runs east-west on the ground.
    let east = c("runway-centre-markings", 90.0);
    assert!(east.labels.center && east.labels.east && east.labels.west);
    assert!(!east.labels.north && !east.labels.south);

    let right = c("runway-right-half", 0.0);
    assert!(right.labels.east && !right.labels.west && right.fractions.right > 0.9);

    // Over-exposure washes the asphalt out (a false negative); a dark day makes grass look
    // like asphalt (false positives) — the failure modes the paper's votes absorb.
    assert!(!c("runway-overexposed", 0.0).labels.center);
    assert!(c("grass-dark", 0.0).labels.center);

    let g = GreenParams::default();
    assert!(green::measure(&load("tile-green"), &g));
    assert!(!green::measure(&load("tile-grey"), &g));
    let shifted = green::green_fraction(&load("tile-green-shifted"), &g);
    assert!(shifted > 0.2 && shifted < 0.4, "{shifted}");
}

/// A PNG whose header claims `w × h` pixels (valid signature and IHDR CRC), with a tiny
/// IDAT and IEND.
fn png_header_only(w: u32, h: u32) -> Vec<u8> {
    fn crc32(bytes: &[u8]) -> u32 {
        let mut c = 0xFFFF_FFFFu32;
        for &b in bytes {
            c ^= u32::from(b);
            for _ in 0..8 {
                c = if c & 1 != 0 {
                    0xEDB8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
            }
        }
        !c
    }
    fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
        out.extend((data.len() as u32).to_be_bytes());
        let mut body = kind.to_vec();
        body.extend_from_slice(data);
        out.extend(&body);
        out.extend(crc32(&body).to_be_bytes());
    }
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = Vec::new();
    ihdr.extend(w.to_be_bytes());
    ihdr.extend(h.to_be_bytes());
    ihdr.extend([8, 2, 0, 0, 0]); // 8-bit RGB
    chunk(&mut out, b"IHDR", &ihdr);
    chunk(
        &mut out,
        b"IDAT",
        &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01],
    );
    chunk(&mut out, b"IEND", &[]);
    out
}

/// A baseline JPEG header claiming `w × h` pixels (SOI, DQT, SOF0, DHT, SOS, no data).
fn jpeg_header_only(w: u16, h: u16) -> Vec<u8> {
    let mut out = vec![0xFF, 0xD8];
    // DQT: one table of ones.
    out.extend([0xFF, 0xDB, 0x00, 0x43, 0x00]);
    out.extend([1u8; 64]);
    // SOF0: 8-bit, h, w, 1 component.
    out.extend([0xFF, 0xC0, 0x00, 0x0B, 0x08]);
    out.extend(h.to_be_bytes());
    out.extend(w.to_be_bytes());
    out.extend([0x01, 0x01, 0x11, 0x00]);
    // DHT: a DC table with one code.
    out.extend([0xFF, 0xC4, 0x00, 0x14, 0x00, 1]);
    out.extend([0u8; 15]);
    out.push(0);
    // SOS
    out.extend([0xFF, 0xDA, 0x00, 0x08, 0x01, 0x01, 0x00, 0x00, 0x3F, 0x00]);
    out.extend([0xFF, 0xD9]);
    out
}

#[test]
fn hostile_images_are_errors_not_crashes() {
    let l = LoadLimits::default();
    let big_png = png_header_only(30000, 30000);
    match load_image_bytes(&big_png, &l) {
        Err(VisionError::TooManyPixels {
            width: 30000,
            height: 30000,
            ..
        }) => {}
        other => panic!("30000×30000 PNG: {other:?}"),
    }
    let big_jpeg = jpeg_header_only(30000, 30000);
    match load_image_bytes(&big_jpeg, &l) {
        Err(VisionError::TooManyPixels {
            width: 30000,
            height: 30000,
            ..
        }) => {}
        other => panic!("30000×30000 JPEG: {other:?}"),
    }
    // Over the per-side limit of the decoder too.
    let wide = png_header_only(2_000_000_000, 1);
    assert!(load_image_bytes(&wide, &l).is_err());
    let good = std::fs::read(assets().join("grass.png")).unwrap();
    for cut in [8, 33, 100, good.len() / 3, good.len() - 20] {
        assert!(load_image_bytes(&good[..cut], &l).is_err(), "cut at {cut}");
    }
    let mut corrupt = good.clone();
    for b in corrupt.iter_mut().skip(200).step_by(97) {
        *b ^= 0x5A;
    }
    assert!(load_image_bytes(&corrupt, &l).is_err());
    assert!(matches!(
        load_image_bytes(b"BM\x3a\0\0\0\0\0\0\0", &l),
        Err(VisionError::UnsupportedFormat(_))
    ));
    assert!(matches!(
        load_image_bytes(b"GIF89a\x01\0\x01\0", &l),
        Err(VisionError::UnsupportedFormat(_))
    ));
    let tight = LoadLimits {
        max_file_bytes: 1000,
        ..l
    };
    assert!(matches!(
        load_image_bytes(&good, &tight),
        Err(VisionError::FileTooLarge { .. })
    ));
}

#[test]
fn classify_command_reports_each_image() {
    let tmp = tempfile::tempdir().unwrap();
    let write = |name: &str, bytes: &[u8]| {
        let p = tmp.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    };
    let good = assets().join("runway-centre-markings.png");
    let good_bytes = std::fs::read(&good).unwrap();
    let bad = [
        write("empty.png", b""),
        write("truncated.png", &good_bytes[..good_bytes.len() / 2]),
        write("huge.png", &png_header_only(30000, 30000)),
        write("huge.jpg", &jpeg_header_only(30000, 30000)),
        write("text.png", b"not an image at all"),
        write("tiny.png", &{
            let mut v = Vec::new();
            RgbImage::new(2, 2)
                .write_to(&mut std::io::Cursor::new(&mut v), image::ImageFormat::Png)
                .unwrap();
            v
        }),
        tmp.path().join("missing.png"),
        tmp.path().to_path_buf(),
    ];
    let mut args: Vec<PathBuf> = vec![good.clone()];
    args.extend(bad.iter().cloned());
    args.push(assets().join("grass.png"));
    let out = common::fleetmap()
        .command()
        .arg("classify")
        .arg("--json")
        .arg("--heading")
        .arg("90")
        .args(&args)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1), "some images failed → exit 1");
    let stdout = String::from_utf8(out.stdout).unwrap();
    let lines: Vec<serde_json::Value> = stdout
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), args.len());
    for (line, path) in lines.iter().zip(&args) {
        assert_eq!(line["image"], path.display().to_string());
    }
    let first = &lines[0];
    let want = runway::classify(
        &load_image_file(&good, &LoadLimits::default()).unwrap(),
        90.0,
        &RunwayParams::default(),
    )
    .unwrap();
    for (k, v) in [
        ("center", want.fractions.center),
        ("top", want.fractions.top),
        ("left", want.fractions.left),
        ("bottom", want.fractions.bottom),
        ("right", want.fractions.right),
    ] {
        assert_eq!(first["fractions"][k].as_f64(), Some(v), "{k}");
    }
    for d in Dir4::ALL {
        let k = serde_json::to_value(d).unwrap();
        assert_eq!(
            first["labels"][k.as_str().unwrap()].as_bool(),
            Some(want.labels.get(d))
        );
    }
    assert_eq!(first["labels"]["center"].as_bool(), Some(true));
    for line in &lines[1..lines.len() - 1] {
        let e = line["error"].as_str().unwrap_or_else(|| panic!("{line}"));
        assert!(!e.is_empty());
        assert!(line.get("fractions").is_none());
    }
    assert!(lines[3]["error"].as_str().unwrap().contains("30000×30000"));
    assert!(lines[4]["error"].as_str().unwrap().contains("30000×30000"));
    assert!(lines[6]["error"].as_str().unwrap().contains("3×3"));
    assert!(lines.last().unwrap()["fractions"].is_object());

    // Without --json: a line per good image on stdout, one per bad image on stderr.
    let out = common::fleetmap()
        .command()
        .arg("classify")
        .args([&good, &bad[0]])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(String::from_utf8_lossy(&out.stdout).lines().count(), 1);
    assert!(String::from_utf8_lossy(&out.stderr).contains("empty.png"));

    // All good → exit 0; bad arguments → a one-line error.
    let ok = common::fleetmap()
        .command()
        .args(["classify", "--green", "--json"])
        .arg(&good)
        .output()
        .unwrap();
    assert!(ok.status.success());
    let v: serde_json::Value = serde_json::from_slice(&ok.stdout).unwrap();
    assert!(v["green"]["fraction"].is_f64());
    let bad_arg = common::fleetmap()
        .command()
        .args(["classify", "--threshold", "2"])
        .arg(&good)
        .output()
        .unwrap();
    assert!(!bad_arg.status.success());
    assert_eq!(
        String::from_utf8_lossy(&bad_arg.stderr)
            .trim()
            .lines()
            .count(),
        1
    );
}

#[test]
fn bench_classify_prints_images_per_second() {
    let out = common::fleetmap().ok(&[
        "bench",
        "classify",
        "--width",
        "96",
        "--height",
        "64",
        "--images",
        "3",
        "--seconds",
        "0.05",
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["images_per_second"].as_f64().unwrap() > 0.0);
    assert!(v["images_per_second_parallel"].as_f64().unwrap() > 0.0);
    assert_eq!(v["width"], 96);
}

/// A drone flies along a row of cells over a synthetic runway, five images per cell, with
/// the camera classifying each image; the vote book ends with the runway cells positive.
#[test]
fn votes_from_classified_images_map_a_runway() {
    // Ground truth: cells with col in 0..=1 are runway (a north-south strip two cells wide).
    let truth = |c: Cell| (0..=1).contains(&c.col);
    let mut book = VoteBook::new(VoteParams::default()).unwrap();
    let params = RunwayParams::default();
    let mut ws = fast::Workspace::default();
    let mut t = 0;
    for col in -2..=3 {
        let cell = Cell::new(0, col);
        for shot in 0..5u64 {
            // The image shows the cell and its neighbours: 120 px per cell, 360 px image;
            // the strip covers image columns of runway cells (cols 0 and 1).
            let left_px = (f64::from(0 - col) + 1.0) * 120.0;
            let centre = left_px + 120.0 - 180.0;
            let scene = RunwayScene::grass(360, 360, (col as u64).wrapping_mul(31) + shot)
                .with_runway(strip(0.0, centre, 240.0));
            let img = render_runway(&scene);
            let counts = runway::analyse_in(&mut ws, &img, &params).unwrap();
            let c = runway::reading_from_counts(counts, 0.0, &params).unwrap();
            book.record(Detection {
                image_id: format!("{col}-{shot}"),
                vehicle: 1,
                time: Time::from_secs(t),
                cell,
                position: None,
                heading_deg: 0.0,
                fractions: c.fractions,
                labels: c.labels,
            });
            t += 1;
        }
    }
    book.close_all(Time::from_secs(t));
    for col in -3..=4 {
        let cell = Cell::new(0, col);
        let want = if truth(cell) {
            CellState::Positive
        } else {
            CellState::Negative
        };
        assert_eq!(book.state(cell), want, "{cell}");
    }
    let e = book.evaluate(truth);
    assert_eq!(e.cells.false_positives + e.cells.false_negatives, 0);
    assert_eq!(e.image_labels.total(), 6 * 5 * 5);
    let json = serde_json::to_string(&book).unwrap();
    let back: VoteBook = serde_json::from_str(&json).unwrap();
    assert_eq!(back, book);
}

/// JPEG camera images load and classify like their lossless originals (JPEG decoders
/// differ by a grey level here and there, so only the labels are compared).
#[test]
fn jpeg_images_classify_like_png() {
    use image::codecs::jpeg::JpegEncoder;
    let p = RunwayParams::default();
    for name in ["runway-centre-markings", "runway-right-half", "grass"] {
        let png = load_image_file(
            &assets().join(format!("{name}.png")),
            &LoadLimits::default(),
        )
        .unwrap();
        let mut jpeg = Vec::new();
        JpegEncoder::new_with_quality(&mut jpeg, 95)
            .encode_image(&png)
            .unwrap();
        let img = load_image_bytes(&jpeg, &LoadLimits::default()).unwrap();
        assert_eq!(img.dimensions(), png.dimensions());
        let a = runway::classify(&png, 0.0, &p).unwrap();
        let b = runway::classify(&img, 0.0, &p).unwrap();
        assert_eq!(a.labels, b.labels, "{name}");
        assert!(
            (a.fractions.center - b.fractions.center).abs() < 0.05,
            "{name}"
        );
    }
}

/// An on-board green-share measurement ([`fleetmap_core::vision::onboard`]) through the GCS's
/// MAVLink codec: 52 bytes on the wire (trailing zeros truncated), decoded back to the same
/// measurement, tied to its capture by boot time and image index.
#[test]
fn onboard_measurement_round_trips_through_a_mavlink_frame() {
    let spec = GreenSpec {
        green: GreenParams::default(),
        camera: CameraModel::paper(),
        cell_m: 5.0,
        crop_fraction: 0.6,
    };
    let m = OnboardMeasurement {
        time_boot_ms: 1_234_567,
        image_index_lo: 70_000u32 as u16,
        spec: spec.fingerprint(),
        picture_bytes: 53_872,
        value: GreenShare {
            share: 0.375,
            pixels: 14_400,
        },
    };
    let mut codec = fleetmap_io::link::codec::Codec::new();
    let buf = codec.encode(1, 100, &m.to_message(), 0);
    // small on the wire: trailing zeros of the 58 floats are truncated
    assert_eq!(buf.len(), 52, "12 bytes of framing and 40 of payload");
    let frames = codec.decode(&buf, 0);
    let Ok(mavlink::dialects::ardupilotmega::MavMessage::DEBUG_FLOAT_ARRAY(d)) = &frames[0].message
    else {
        panic!("{frames:?}")
    };
    assert_eq!(OnboardMeasurement::from_message(d), Some(m));
    assert!(m.is_of(1_234_567, 70_000));
    assert!(!m.is_of(1_234_567, 70_001));
}

/// A runway result and the grid announcement ([`fleetmap_core::vision::runway::onboard`])
/// through the GCS's MAVLink codec: at most 84 bytes for a result (fewer when its last
/// numbers are zeros: a picture of grass), 92 for a grid north of the equator, both decoded
/// back to what was sent.
#[test]
fn onboard_runway_messages_round_trip_through_mavlink_frames() {
    use fleetmap_core::geo::{Cell, Grid, LatLon};
    use fleetmap_core::vision::runway::NeighbourLabels;
    use fleetmap_core::vision::runway::onboard::{
        GridAnnouncement, OnboardRegions, RunwayMeasurement, RunwaySpec,
    };
    use mavlink::dialects::ardupilotmega::MavMessage;
    let decode = |m: &MavMessage| {
        let mut codec = fleetmap_io::link::codec::Codec::new();
        let buf = codec.encode(1, 100, m, 0);
        let frames = codec.decode(&buf, 0);
        let Ok(MavMessage::DEBUG_FLOAT_ARRAY(d)) = &frames[0].message else {
            panic!("{frames:?}")
        };
        (buf.len(), d.clone())
    };
    let m = RunwayMeasurement {
        time_boot_ms: 2_345_678,
        image_index_lo: 65_535,
        spec: 0x00ab_cdef,
        picture_bytes: 71_234,
        regions: Some(OnboardRegions {
            cell: Cell::new(-31, 12),
            size: (480, 480),
            black: [25_600, 0, 17, 12_000, 3],
            labels: NeighbourLabels {
                center: true,
                south: true,
                ..NeighbourLabels::default()
            },
        }),
    };
    let (len, d) = decode(&m.to_message());
    assert_eq!(len, 84, "12 bytes of framing and 72 of payload");
    assert_eq!(RunwayMeasurement::from_message(&d), Some(m));
    // grass: no black pixel, no label — the zeros at the end are not sent
    let grass = RunwayMeasurement {
        regions: Some(OnboardRegions {
            black: [0; 5],
            labels: NeighbourLabels::default(),
            ..m.regions.unwrap()
        }),
        ..m
    };
    let (len, d) = decode(&grass.to_message());
    assert_eq!(len, 60);
    assert_eq!(RunwayMeasurement::from_message(&d), Some(grass));
    let spec = RunwaySpec {
        params: RunwayParams::default(),
        camera: CameraModel::paper(),
        grid: Grid::new(LatLon::new(37.1965120, -80.5783029), 4.0).unwrap(),
    };
    let a = spec.announcement();
    let (len, d) = decode(&a.to_message());
    assert_eq!(len, 92);
    assert_eq!(GridAnnouncement::from_message(&d), Some(a));
    let south = RunwaySpec {
        grid: Grid::new(LatLon::new(-35.363261, 149.165230), 4.0).unwrap(),
        ..spec
    };
    let (len, d) = decode(&south.announcement().to_message());
    assert_eq!(len, 96);
    assert_eq!(
        GridAnnouncement::from_message(&d).map(|g| g.grid),
        Some(south.grid.clone())
    );
}
