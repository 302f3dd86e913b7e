//! `fleetmap grid …`: convert between mission-grid cells and GPS coordinates.
//!
//! ```text
//! fleetmap grid --origin LAT,LON --cell-size M to-gps ROW COL
//! fleetmap grid --origin LAT,LON --cell-size M from-gps LAT LON
//! fleetmap grid --origin LAT,LON --cell-size M export --rows A:B --cols C:D [--format geojson|kml]
//! ```
//!
//! `to-gps` and `from-gps` print one JSON object
//! `{"row","col","lat","lon","easting","northing","zone","hemisphere"}` where lat/lon and
//! easting/northing are the centre of the cell (for `from-gps`: of the cell that contains the
//! point), in the grid's UTM zone, and `hemisphere` is `"N"` or `"S"`. Numbers are printed as
//! the shortest text that reads back as the same f64 (up to 17 significant digits).
//!
//! Arguments are parsed here rather than by clap's typed parsers so that every bad argument
//! gives one line (`fleetmap: …`) and exit status 1. Negative numbers work as plain
//! arguments (`to-gps -3 -7`, `--origin -33.9,151.2`).

use anyhow::{Context, anyhow, bail};
use clap::{Args, Subcommand, ValueEnum};
use fleetmap_core::geo::{Cell, Grid, Hemisphere, LatLon, export};
use serde::Serialize;
use std::process::ExitCode;

/// Arguments of `fleetmap grid`.
#[derive(Debug, Args)]
pub struct GridArgs {
    /// Grid origin `LAT,LON` in degrees (WGS84): the centre of cell (0, 0).
    #[arg(long, value_name = "LAT,LON", allow_hyphen_values = true)]
    pub origin: Option<String>,
    /// Cell size in metres (UTM grid metres; 0.001 to 100000).
    #[arg(long, value_name = "M", allow_hyphen_values = true)]
    pub cell_size: Option<String>,
    /// Force the UTM zone, e.g. `32` or `32N` (default: the origin's standard zone and
    /// hemisphere, Norway/Svalbard exceptions included).
    #[arg(long, value_name = "ZONE[N|S]")]
    pub zone: Option<String>,
    /// What to convert.
    #[command(subcommand)]
    pub what: Option<GridCommand>,
}

/// The `fleetmap grid` actions.
#[derive(Debug, Subcommand)]
pub enum GridCommand {
    /// The centre of cell (ROW, COL) in GPS and UTM coordinates (rows grow north, columns
    /// east; negative indices are fine).
    ToGps {
        /// Row index (northward).
        #[arg(allow_hyphen_values = true)]
        row: Option<String>,
        /// Column index (eastward).
        #[arg(allow_hyphen_values = true)]
        col: Option<String>,
    },
    /// The cell that contains the point (LAT, LON); prints the centre of that cell.
    FromGps {
        /// Latitude in degrees.
        #[arg(allow_hyphen_values = true)]
        lat: Option<String>,
        /// Longitude in degrees.
        #[arg(allow_hyphen_values = true)]
        lon: Option<String>,
    },
    /// The cells of a block of rows and columns as GeoJSON or KML (Google Earth, QGIS).
    Export {
        /// Rows `FIRST:LAST` (inclusive), e.g. `-2:5`.
        #[arg(long, allow_hyphen_values = true)]
        rows: Option<String>,
        /// Columns `FIRST:LAST` (inclusive).
        #[arg(long, allow_hyphen_values = true)]
        cols: Option<String>,
        /// Output format.
        #[arg(long, value_enum, default_value_t = ExportFormat::Geojson)]
        format: ExportFormat,
    },
}

/// Output format of `fleetmap grid export`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ExportFormat {
    /// RFC 7946 GeoJSON FeatureCollection.
    Geojson,
    /// KML 2.2 document.
    Kml,
}

/// The JSON object printed by `to-gps` and `from-gps`.
#[derive(Debug, Serialize)]
pub(crate) struct CellReport {
    /// Row index.
    pub row: i32,
    /// Column index.
    pub col: i32,
    /// Latitude of the cell centre, degrees.
    pub lat: f64,
    /// Longitude of the cell centre, degrees.
    pub lon: f64,
    /// Easting of the cell centre in the grid's zone, metres.
    pub easting: f64,
    /// Northing of the cell centre in the grid's zone and hemisphere, metres.
    pub northing: f64,
    /// The grid's UTM zone.
    pub zone: u8,
    /// The grid's hemisphere, "N" or "S".
    pub hemisphere: Hemisphere,
}

/// Most cells `export` writes.
const MAX_EXPORT_CELLS: i64 = 1_000_000;

fn required<'a>(v: &'a Option<String>, what: &str) -> anyhow::Result<&'a str> {
    v.as_deref()
        .ok_or_else(|| anyhow!("missing {what}"))
        .map(str::trim)
}

fn parse_f64(s: &str, what: &str) -> anyhow::Result<f64> {
    let v: f64 = s
        .parse()
        .map_err(|_| anyhow!("{what} {s:?} is not a number"))?;
    if !v.is_finite() {
        bail!("{what} must be a finite number, got {s:?}");
    }
    Ok(v)
}

fn parse_i32(s: &str, what: &str) -> anyhow::Result<i32> {
    s.parse()
        .map_err(|_| anyhow!("{what} {s:?} is not an integer between -2147483648 and 2147483647"))
}

fn parse_range(s: &str, what: &str) -> anyhow::Result<(i32, i32)> {
    let (a, b) = s
        .split_once(':')
        .ok_or_else(|| anyhow!("{what} {s:?} must be FIRST:LAST, e.g. -2:5"))?;
    let (a, b) = (parse_i32(a.trim(), what)?, parse_i32(b.trim(), what)?);
    if a > b {
        bail!("{what} {s:?}: FIRST must not be greater than LAST");
    }
    Ok((a, b))
}

fn parse_zone(s: &str, origin: LatLon) -> anyhow::Result<(u8, Hemisphere)> {
    let s = s.trim();
    let (num, hem) = match s.chars().last() {
        Some(c) if c.is_ascii_alphabetic() => (
            &s[..s.len() - 1],
            c.to_string()
                .parse::<Hemisphere>()
                .map_err(|_| anyhow!("zone {s:?}: the hemisphere letter must be N or S"))?,
        ),
        _ => (s, Hemisphere::of_lat(origin.lat)),
    };
    let zone: u8 = num
        .parse()
        .ok()
        .filter(|z| (1..=60).contains(z))
        .ok_or_else(|| anyhow!("zone {s:?} must be 1..60, optionally followed by N or S"))?;
    Ok((zone, hem))
}

/// Build the grid from `--origin`, `--cell-size` and `--zone`.
pub(crate) fn grid_from_args(args: &GridArgs) -> anyhow::Result<Grid> {
    let origin: LatLon = required(&args.origin, "--origin LAT,LON")?
        .parse()
        .context("bad --origin")?;
    let size = parse_f64(required(&args.cell_size, "--cell-size M")?, "cell size")?;
    let grid = match &args.zone {
        None => Grid::new(origin, size),
        Some(z) => {
            let (zone, hem) = parse_zone(z, origin)?;
            Grid::new_in_zone(origin, size, zone, hem)
        }
    };
    grid.context("cannot make the grid")
}

/// The report for cell `c` of `grid` (its centre), or an error if the centre is outside UTM.
pub(crate) fn cell_report(grid: &Grid, c: Cell) -> anyhow::Result<CellReport> {
    let p = grid
        .checked_cell_center(c)
        .with_context(|| format!("cell {c} has no GPS position"))?;
    let u = grid.cell_center_utm(c);
    Ok(CellReport {
        row: c.row,
        col: c.col,
        lat: p.lat,
        lon: p.lon,
        easting: u.easting,
        northing: u.northing,
        zone: u.zone,
        hemisphere: u.hemisphere,
    })
}

/// Run `fleetmap grid`.
pub fn run(args: GridArgs) -> anyhow::Result<ExitCode> {
    let Some(what) = &args.what else {
        bail!(
            "missing action: to-gps ROW COL, from-gps LAT LON or export (see fleetmap grid --help)"
        );
    };
    let grid = grid_from_args(&args)?;
    match what {
        GridCommand::ToGps { row, col } => {
            let row = parse_i32(required(row, "ROW")?, "row")?;
            let col = parse_i32(required(col, "COL")?, "column")?;
            let r = cell_report(&grid, Cell::new(row, col))?;
            println!("{}", serde_json::to_string(&r)?);
        }
        GridCommand::FromGps { lat, lon } => {
            let lat = parse_f64(required(lat, "LAT")?, "latitude")?;
            let lon = parse_f64(required(lon, "LON")?, "longitude")?;
            let c = grid
                .cell_of(LatLon::new(lat, lon))
                .with_context(|| format!("point {lat},{lon}"))?;
            let r = cell_report(&grid, c)?;
            println!("{}", serde_json::to_string(&r)?);
        }
        GridCommand::Export { rows, cols, format } => {
            let (r0, r1) = parse_range(required(rows, "--rows FIRST:LAST")?, "rows")?;
            let (c0, c1) = parse_range(required(cols, "--cols FIRST:LAST")?, "cols")?;
            let n = (i64::from(r1) - i64::from(r0) + 1) * (i64::from(c1) - i64::from(c0) + 1);
            if n > MAX_EXPORT_CELLS {
                bail!("export of {n} cells asked, at most {MAX_EXPORT_CELLS}");
            }
            let mut cells = Vec::with_capacity(n as usize);
            for r in r0..=r1 {
                for c in c0..=c1 {
                    let cell = Cell::new(r, c);
                    if !grid.cell_in_domain(cell) {
                        bail!("cell {cell} is outside UTM (80°S..84°N, within 15° of the zone)");
                    }
                    cells.push(cell);
                }
            }
            match format {
                ExportFormat::Geojson => {
                    let cells: Vec<_> = cells
                        .into_iter()
                        .map(|c| (c, serde_json::Value::Null))
                        .collect();
                    let v = export::cells_geojson(&grid, &cells, &[]);
                    println!("{}", serde_json::to_string(&v)?);
                }
                ExportFormat::Kml => {
                    let colour = export::kml_colour(255, 140, 0, 0x80);
                    let cells: Vec<_> = cells
                        .into_iter()
                        .map(|c| (c, format!("{},{}", c.row, c.col), colour.clone()))
                        .collect();
                    print!("{}", export::cells_kml(&grid, &cells, &[]));
                }
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}
