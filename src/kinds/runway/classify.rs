//! `fleetmap classify IMAGE…`: run the runway sensing model (runway paper §7) on image
//! files, and optionally the green-pixel measurement (bandit paper §V).
//!
//! Output, one line per image in the order given:
//! * with `--json`: `{"image": PATH, "fractions": {"center", "top", "left", "bottom",
//!   "right"}, "labels": {"center", "north", "west", "south", "east"}, "heading_deg": H,
//!   "width": W, "height": H}` — fractions of black pixels in image coordinates, labels
//!   (true = runway) for the grid cells after the heading is applied; with `--green` also
//!   `"green": {"fraction": F, "measurement": B}`. An image that cannot be classified gives
//!   `{"image": PATH, "error": "..."}` and the others are still classified.
//! * without: a readable line per image; errors go to stderr as `fleetmap: PATH: why`.
//!
//! Exit status: 0 when every image was classified, 1 when at least one failed (all images
//! are still processed and printed), 2 for bad arguments (clap).

use anyhow::Context;
use clap::Args;
use fleetmap_core::vision::green::{self, GreenParams};
use fleetmap_core::vision::load::LoadLimits;
use fleetmap_core::vision::runway::{self, RegionReading, RunwayParams};
use fleetmap_core::vision::{VisionError, fast, reference};
use fleetmap_io::files::load_image_file;
use rayon::prelude::*;
use serde_json::json;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Arguments of `fleetmap classify`.
#[derive(Debug, Args)]
pub struct ClassifyArgs {
    /// Image files (PNG or JPEG).
    #[arg(required = true, value_name = "IMAGE")]
    pub images: Vec<PathBuf>,
    /// One JSON object per line.
    #[arg(long)]
    pub json: bool,
    /// Vehicle heading when the images were taken, degrees clockwise from north (rounded to
    /// the nearest quarter turn, ties clockwise).
    #[arg(
        long,
        default_value_t = 0.0,
        value_name = "DEG",
        allow_negative_numbers = true
    )]
    pub heading: f64,
    /// A region is runway when its fraction of black pixels is at least this (0..1).
    #[arg(long, default_value_t = 0.5, value_name = "F")]
    pub threshold: f64,
    /// Grey level threshold: pixels strictly above it are white (paper: 150).
    #[arg(long, default_value_t = 150, value_name = "LEVEL")]
    pub(crate) intensity: u8,
    /// Number of 3×3 dilations (paper: 7).
    #[arg(long, default_value_t = 7, value_name = "N")]
    pub dilations: u32,
    /// Largest accepted image, width × height in pixels (checked from the header).
    #[arg(long, default_value_t = LoadLimits::default().max_pixels, value_name = "PIXELS")]
    pub(crate) max_pixels: u64,
    /// Largest accepted file, bytes.
    #[arg(long, default_value_t = LoadLimits::default().max_file_bytes, value_name = "BYTES")]
    pub max_file_bytes: u64,
    /// Also measure the share of green pixels (bandit paper §V).
    #[arg(long)]
    pub green: bool,
    /// Lower HSV bound of "green", `H,S,V` (OpenCV 8-bit: H 0..180).
    #[arg(long, value_parser = parse_hsv, default_value = "35,60,40", value_name = "H,S,V")]
    pub(crate) green_lower: [u8; 3],
    /// Upper HSV bound of "green", `H,S,V`, inclusive.
    #[arg(long, value_parser = parse_hsv, default_value = "85,255,255", value_name = "H,S,V")]
    pub(crate) green_upper: [u8; 3],
    /// An image is a positive green measurement when its green share is at least this.
    #[arg(long, default_value_t = 0.25, value_name = "F")]
    pub(crate) green_threshold: f64,
    /// Write the intermediate images (grey, binary, dilated, green mask) of each input as
    /// PNG into this directory, named `<index>-<file stem>.<step>.png`.
    #[arg(long, value_name = "DIR")]
    pub(crate) debug_dir: Option<PathBuf>,
}

/// An `H,S,V` argument that does not read (the text given).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum BadHsv {
    /// Not three comma-separated parts.
    #[error("expected three numbers H,S,V, got {0:?}")]
    Parts(String),
    /// A part that is not a number 0..=255.
    #[error("expected numbers 0..=255 in H,S,V, got {0:?}")]
    Number(String),
}

fn parse_hsv(s: &str) -> Result<[u8; 3], BadHsv> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(BadHsv::Parts(s.to_string()));
    }
    let mut out = [0u8; 3];
    for (o, p) in out.iter_mut().zip(&parts) {
        *o = p.parse().map_err(|_| BadHsv::Number(p.to_string()))?;
    }
    Ok(out)
}

/// What one image gave.
struct Outcome {
    reading: RegionReading,
    width: u32,
    height: u32,
    green: Option<(f64, bool)>,
}

/// Run `fleetmap classify`.
pub fn run(args: ClassifyArgs) -> anyhow::Result<ExitCode> {
    let params = RunwayParams {
        intensity_threshold: args.intensity,
        dilation_iterations: args.dilations,
        black_fraction_threshold: args.threshold,
    };
    params.validate().context("bad runway parameters")?;
    if !args.heading.is_finite() {
        anyhow::bail!("--heading must be a finite number of degrees");
    }
    let green_params = GreenParams {
        lower: args.green_lower,
        upper: args.green_upper,
        min_fraction: args.green_threshold,
    };
    if args.green {
        green_params.validate().context("bad green parameters")?;
    }
    let limits = LoadLimits {
        max_pixels: args.max_pixels,
        max_file_bytes: args.max_file_bytes,
        ..LoadLimits::default()
    };
    if let Some(dir) = &args.debug_dir {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create debug directory {}", dir.display()))?;
    }
    let results: Vec<Result<Outcome, ClassifyError>> = args
        .images
        .par_iter()
        .enumerate()
        .map_init(fast::Workspace::default, |ws, (i, path)| {
            classify_one(ws, i, path, &args, &params, &green_params, &limits)
        })
        .collect();

    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    let mut failed = 0usize;
    for (path, result) in args.images.iter().zip(results) {
        let shown = path.display().to_string();
        match result {
            Ok(o) => {
                if args.json {
                    let mut v = json!({
                        "image": shown,
                        "fractions": o.reading.fractions,
                        "labels": o.reading.labels,
                        "heading_deg": o.reading.heading_deg,
                        "width": o.width,
                        "height": o.height,
                    });
                    if let Some((fraction, measurement)) = o.green {
                        v["green"] = json!({"fraction": fraction, "measurement": measurement});
                    }
                    writeln!(out, "{v}")?;
                } else {
                    writeln!(out, "{}", human_line(&shown, &o))?;
                }
            }
            Err(e) => {
                failed += 1;
                if args.json {
                    writeln!(out, "{}", json!({"image": shown, "error": e.to_string()}))?;
                } else {
                    out.flush()?;
                    eprintln!("fleetmap: {shown}: {e}");
                }
            }
        }
    }
    out.flush()?;
    Ok(if failed == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// Why one image of `fleetmap classify` has no classification.
#[derive(Debug, thiserror::Error)]
enum ClassifyError {
    /// The image does not load, or the classifier refuses it or the parameters.
    #[error(transparent)]
    Vision(#[from] VisionError),
    /// The debug images could not be written (`--debug-dir`).
    #[error("cannot write debug images: {0:#}")]
    Debug(anyhow::Error),
}

fn classify_one(
    ws: &mut fast::Workspace,
    index: usize,
    path: &Path,
    args: &ClassifyArgs,
    params: &RunwayParams,
    green_params: &GreenParams,
    limits: &LoadLimits,
) -> Result<Outcome, ClassifyError> {
    let img = load_image_file(path, limits)?;
    let counts = runway::analyse_in(ws, &img, params)?;
    let reading = runway::reading_from_counts(counts, args.heading, params)?;
    let green = args.green.then(|| {
        let f = green::green_fraction(&img, green_params);
        (f, f >= green_params.min_fraction)
    });
    if let Some(dir) = &args.debug_dir {
        write_debug(
            dir,
            index,
            path,
            &img,
            params,
            args.green.then_some(green_params),
        )
        .map_err(ClassifyError::Debug)?;
    }
    Ok(Outcome {
        reading,
        width: img.width(),
        height: img.height(),
        green,
    })
}

fn write_debug(
    dir: &Path,
    index: usize,
    path: &Path,
    img: &image::RgbImage,
    params: &RunwayParams,
    green_params: Option<&GreenParams>,
) -> anyhow::Result<()> {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "image".to_string());
    let steps =
        fast::run_with_intermediates(img, params.intensity_threshold, params.dilation_iterations);
    let mut images = vec![
        ("gray", reference::gray(img)),
        ("binary", steps.binary.to_gray_image()),
        ("dilated", steps.dilated.to_gray_image()),
    ];
    if let Some(g) = green_params {
        images.push(("green", green::green_mask(img, g)));
    }
    for (step, gray) in images {
        let mut bytes = Vec::new();
        gray.write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )?;
        let file = dir.join(format!("{index}-{stem}.{step}.png"));
        fleetmap_io::files::atomic_write(&file, &bytes)
            .with_context(|| format!("cannot write {}", file.display()))?;
    }
    Ok(())
}

fn human_line(path: &str, o: &Outcome) -> String {
    let f = &o.reading.fractions;
    let l = &o.reading.labels;
    let mark = |b: bool| if b { "runway" } else { "-" };
    let mut s = format!(
        "{path}: black center {:.4} top {:.4} left {:.4} bottom {:.4} right {:.4} | \
         cell {} north {} west {} south {} east {}",
        f.center,
        f.top,
        f.left,
        f.bottom,
        f.right,
        mark(l.center),
        mark(l.north),
        mark(l.west),
        mark(l.south),
        mark(l.east)
    );
    if let Some((fraction, m)) = o.green {
        s.push_str(&format!(
            " | green {fraction:.4} {}",
            if m { "positive" } else { "negative" }
        ));
    }
    s
}

/// Arguments of `fleetmap bench classify`: images per second of the runway classifier
/// (grey → threshold → dilation → region counts; decoding excluded), single-threaded and
/// on all cores.
#[derive(Debug, Args)]
pub struct BenchClassifyArgs {
    /// Width of the synthetic images, pixels.
    #[arg(long, default_value_t = 1920)]
    pub width: u32,
    /// Height of the synthetic images, pixels.
    #[arg(long, default_value_t = 1080)]
    pub height: u32,
    /// Number of distinct synthetic images (runway scenes at various angles, positions and
    /// exposures); each round classifies all of them.
    #[arg(long, default_value_t = 16)]
    pub images: usize,
    /// Seed of the synthetic images.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Measure each figure for at least this many seconds.
    #[arg(long, default_value_t = 2.0, value_name = "S")]
    pub seconds: f64,
    /// Also time the plain reference implementation (slow).
    #[arg(long)]
    pub reference: bool,
    /// Code path: `best` (AVX2, then SSSE3/SSE4, chosen at run time), `x86-v2` (at most
    /// SSSE3/SSE4) or `portable` (baseline instruction set).
    #[arg(long, value_enum, default_value_t = PathArg::Best)]
    pub(crate) code_path: PathArg,
    /// Write the synthetic images as PNG into this directory (`bench-000.png` …), e.g. to
    /// time OpenCV on the same pixels (`scripts/bench-vs-opencv.py`).
    #[arg(long, value_name = "DIR")]
    pub(crate) write_images: Option<PathBuf>,
    /// Time these image files instead of synthetic images.
    #[arg(value_name = "IMAGE")]
    pub files: Vec<PathBuf>,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// `--code-path` of `fleetmap bench classify`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum PathArg {
    /// The best the CPU offers.
    Best,
    /// At most the x86-64-v2 kernel.
    #[value(name = "x86-v2")]
    X86V2,
    /// The portable code.
    Portable,
}

/// The synthetic runway scenes of `fleetmap bench classify` (image `i` of `n`).
pub fn bench_scene(
    width: u32,
    height: u32,
    seed: u64,
    i: usize,
) -> fleetmap_core::vision::runway::synth::RunwayScene {
    use fleetmap_core::vision::runway::synth::{RunwayScene, RunwayStrip};
    let side = f64::from(width.min(height));
    let k = i as f64;
    let mut scene = RunwayScene::grass(
        width,
        height,
        seed.wrapping_mul(1000).wrapping_add(i as u64),
    );
    scene.exposure = [1.0, 0.8, 1.2, 0.9][i % 4];
    if i % 5 != 4 {
        scene = scene.with_runway(RunwayStrip {
            angle_deg: (k * 37.0) % 180.0,
            offset_px: ((k * 0.29) % 1.0 - 0.5) * side,
            width_px: side * (0.35 + 0.1 * ((k * 0.43) % 1.0)),
            length_px: None,
            along_px: 0.0,
            markings: i.is_multiple_of(2),
        });
    }
    scene
}

/// Run `fleetmap bench classify`.
pub fn bench(args: BenchClassifyArgs) -> anyhow::Result<ExitCode> {
    use std::hint::black_box;
    use std::time::Instant;
    if !(args.seconds.is_finite() && args.seconds > 0.0) {
        anyhow::bail!("--seconds must be a positive number");
    }
    let params = RunwayParams::default();
    let images: Vec<image::RgbImage> = if args.files.is_empty() {
        if args.images == 0 || args.width < 3 || args.height < 3 {
            anyhow::bail!("need at least one image of at least 3×3 pixels");
        }
        let limits = LoadLimits::default();
        if u64::from(args.width) * u64::from(args.height) > limits.max_pixels {
            anyhow::bail!(
                "{}×{} is more than {} pixels",
                args.width,
                args.height,
                limits.max_pixels
            );
        }
        (0..args.images)
            .into_par_iter()
            .map(|i| {
                fleetmap_core::vision::runway::synth::render_runway(&bench_scene(
                    args.width,
                    args.height,
                    args.seed,
                    i,
                ))
            })
            .collect()
    } else {
        args.files
            .iter()
            .map(|p| {
                load_image_file(p, &LoadLimits::default())
                    .with_context(|| format!("cannot load {}", p.display()))
            })
            .collect::<anyhow::Result<_>>()?
    };
    if let Some(dir) = &args.write_images {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        images
            .par_iter()
            .enumerate()
            .try_for_each(|(i, img)| -> anyhow::Result<()> {
                let mut bytes = Vec::new();
                img.write_to(
                    &mut std::io::Cursor::new(&mut bytes),
                    image::ImageFormat::Png,
                )?;
                let file = dir.join(format!("bench-{i:03}.png"));
                fleetmap_io::files::atomic_write(&file, &bytes)
                    .with_context(|| format!("cannot write {}", file.display()))
            })?;
    }
    for img in &images {
        runway::analyse(img, &params).context("image cannot be classified")?;
    }
    let budget = args.seconds;
    let path = match args.code_path {
        PathArg::Best => fast::CodePath::Best,
        PathArg::X86V2 => fast::CodePath::X86V2,
        PathArg::Portable => fast::CodePath::Portable,
    };
    let analyse = |ws: &mut fast::Workspace, img: &image::RgbImage| {
        fast::region_counts_on(
            path,
            ws,
            img,
            params.intensity_threshold,
            params.dilation_iterations,
        )
    };
    // Single-threaded: one workspace, images one after the other.
    let single = {
        let mut ws = fast::Workspace::default();
        let start = Instant::now();
        let mut done = 0u64;
        loop {
            for img in &images {
                black_box(analyse(&mut ws, black_box(img)));
            }
            done += images.len() as u64;
            if start.elapsed().as_secs_f64() >= budget {
                break;
            }
        }
        done as f64 / start.elapsed().as_secs_f64()
    };
    // All cores: rayon across images, one workspace per worker.
    let threads = rayon::current_num_threads();
    let parallel = {
        let start = Instant::now();
        let mut done = 0u64;
        loop {
            images
                .par_iter()
                .for_each_init(fast::Workspace::default, |ws, img| {
                    black_box(analyse(ws, black_box(img)));
                });
            done += images.len() as u64;
            if start.elapsed().as_secs_f64() >= budget {
                break;
            }
        }
        done as f64 / start.elapsed().as_secs_f64()
    };
    let reference_ips = args.reference.then(|| {
        let start = Instant::now();
        let mut done = 0u64;
        loop {
            for img in &images {
                black_box(runway::analyse_reference(black_box(img), &params).ok());
                done += 1;
                if start.elapsed().as_secs_f64() >= budget {
                    break;
                }
            }
            if start.elapsed().as_secs_f64() >= budget {
                break;
            }
        }
        done as f64 / start.elapsed().as_secs_f64()
    });
    let (w, h) = images
        .first()
        .map(|i| i.dimensions())
        .unwrap_or((args.width, args.height));
    if args.json {
        let mut v = json!({
            "images_per_second": single,
            "images_per_second_parallel": parallel,
            "threads": threads,
            "width": w,
            "height": h,
            "images": images.len(),
            "pipeline": "gray>150, 7x 3x3 dilation, 5 region counts (decoding excluded)",
            "code_path": path,
        });
        if let Some(r) = reference_ips {
            v["reference_images_per_second"] = json!(r);
        }
        println!("{v}");
    } else {
        println!(
            "classify {w}×{h}, {} images: {single:.1} images/s single-threaded ({:.2} ms/image), \
             {parallel:.1} images/s on {threads} threads",
            images.len(),
            1000.0 / single
        );
        if let Some(r) = reference_ips {
            println!("reference implementation: {r:.1} images/s single-threaded");
        }
    }
    Ok(ExitCode::SUCCESS)
}
