//! Runway pictures classified on board: the definition a camera is given, the computation
//! both the camera and the GCS run, and the two small MAVLink messages that replace the
//! picture on the link.
//!
//! A 480-pixel JPEG is 45–70 kB; through a telemetry radio that carries 1–2 kB/s in all it
//! takes half a minute or more, and a cell needs five. What the GCS takes from a picture is
//! the runway classifier's five black-pixel counts (runway paper §7: centre and the four
//! neighbours) and the cell they are about. A camera that classifies on board sends those
//! in one 84-byte frame instead (the runway paper's own field system classified on board, on
//! an ODROID-XU4 beside the camera).
//!
//! **The definition** ([`RunwaySpec`]): the classifier's parameters ([`RunwayParams`]:
//! threshold, dilations, black fraction), the camera model and the grid the 3 × 3 regions are
//! cut on (origin, UTM zone and hemisphere, cell size). Its [`RunwaySpec::fingerprint`]
//! names it in every result. A camera started with the mission file has all but the grid
//! when the mission's origin is the first vehicle's home (`origin = "vehicle"`): that is
//! known to the GCS only at run time, so the GCS tells it (below) — [`RunwayDefinition`]
//! is what the camera holds meanwhile.
//!
//! **The computation** ([`RunwaySpec::measure`]), from the picture and the pose the camera
//! announces in CAMERA_IMAGE_CAPTURED ([`ShutterPose`]: position, altitude above home,
//! attitude quaternion — the numbers as they travel, so that the GCS recomputes exactly what
//! the camera did): the cell is the one under the camera (its position on the grid), and
//! the picture is resampled into the north-up orthophoto of the 3 × 3 cells centred on that
//! cell's centre ([`crate::vision::geometry::orthophoto`]: the pinhole camera rotated by the
//! attitude, flat ground at home's elevation), then classified with heading 0
//! ([`crate::vision::runway`]). This is the cut the GCS makes itself for a picture over a
//! visited cell (the sanity check only accepts a picture whose position is within a metre
//! of the cell's centre, so the cell under the camera is the visited cell). A camera
//! classifies the picture it would send: its JPEG, decoded — so the GCS, given the same
//! picture and pose, gets bit-identical counts.
//!
//! **The result** (camera → GCS, [`RunwayMeasurement`]): DEBUG_FLOAT_ARRAY (id 350) named
//! `"fm.rwy"`, sent by the camera component right after the CAMERA_IMAGE_CAPTURED of the
//! same picture (which carries the pose, as for every picture):
//!
//! | field | value |
//! |---|---|
//! | `time_usec` | the capture's `time_boot_ms` × 1000 (0: a status, no picture) |
//! | `array_id` | the capture's `image_index`, low 16 bits |
//! | `name` | `"fm.rwy"` |
//! | `data[0]` | format version, 1 |
//! | `data[1]` | the fingerprint of the definition used (24 bits; 0: the camera has no grid yet) |
//! | `data[2]` | the picture's size in bytes (what a DATA_TRANSMISSION_HANDSHAKE asking for it names); 0: a status, no picture |
//! | `data[3]`, `data[4]` | the cell's row and column |
//! | `data[5]`, `data[6]` | width and height of the classified orthophoto, pixels (0: not classified; the picture is kept for the GCS to ask) |
//! | `data[7..12]` | black pixels after the dilations in the centre, top, left, bottom and right regions (the pixels per region follow from the size: [`crate::vision::regions`]) |
//! | `data[12]` | the labels, bits: centre 1, north 2, west 4, south 8, east 16 |
//!
//! Every number is a whole number below 2²⁴, exact in a 32-bit float. With MAVLink 2's
//! truncation of the trailing zero floats it is 84 bytes on the wire (72 of payload). The
//! GCS rebuilds the counts, fractions and labels exactly ([`RunwayMeasurement::reading`]).
//! A camera without the grid still announces each picture (fingerprint 0, not classified),
//! so the GCS asks for the picture; and while it has none it says so every
//! [`STATUS_PERIOD_S`] seconds (a status: `time_usec` 0, size 0), so the GCS tells it the
//! grid before it takes pictures (a camera restarted with its vehicle's battery).
//!
//! **The grid** (GCS → every camera, [`GridAnnouncement`]): DEBUG_FLOAT_ARRAY named
//! `"fm.grid"`, sent untargeted by the GCS: `data[0]` version 1, `data[1]` the fingerprint of
//! the definition the GCS accepts, `data[2..6]` the origin's latitude, `data[6..10]` its
//! longitude and `data[10..14]` the cell size — each the 64 bits of an `f64`, 16 bits per
//! float, most significant first, so the camera's grid is bit for bit the GCS's —,
//! `data[14]` the UTM zone, `data[15]` the hemisphere (0 north, 1 south); 96 bytes on the
//! wire, 92 north of the equator (the trailing 0 is truncated). A camera answers each one with a status carrying the fingerprint it now measures
//! with, which tells the GCS it can stop repeating it.
//!
//! Why DEBUG_FLOAT_ARRAY, as for the green share ([`crate::vision::onboard`]): it is in
//! common.xml, so ArduPilot's router (`MAVLink_routing::check_and_forward`: a message
//! without a target goes to every other channel it has learned a route on) and PX4's
//! forwarding pass it between the GCS's link and a companion computer's port both ways, and
//! any MAVLink library decodes it; it has a timestamp and an id that tie the result to one
//! capture, which NAMED_VALUE_FLOAT has not; CAMERA_IMAGE_CAPTURED has no field for a
//! result; a message of our own dialect would be dropped by routers built without it. Its
//! own name keeps it apart from the green share.

use super::{NeighbourLabels, RegionReading, RunwayParams, analyse, reading_from_counts};
use crate::geo::{Cell, Grid, Hemisphere, LatLon};
use crate::vision::VisionError;
use crate::vision::camera::CameraModel;
use crate::vision::fingerprint24;
use crate::vision::geometry::{OrthoRequest, attitude_of_quaternion, orthophoto};
use crate::vision::regions::{Region, RegionCounts, RegionGrid};
use image::RgbImage;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use nalgebra::UnitQuaternion;
use serde::{Deserialize, Serialize};

/// DEBUG_FLOAT_ARRAY.name of a runway result or a camera's status.
pub(crate) const RUNWAY_NAME: &str = "fm.rwy";
/// DEBUG_FLOAT_ARRAY.name of the GCS's grid announcement.
pub(crate) const GRID_NAME: &str = "fm.grid";
/// Version of both layouts (module documentation).
const FORMAT_VERSION: f32 = 1.0;
/// Seconds between two statuses of a camera that has no grid (on its own clock).
pub const STATUS_PERIOD_S: f64 = 10.0;
/// Largest whole number a 32-bit float holds exactly with all smaller ones: 2²⁴.
const EXACT_MAX: f32 = 16_777_216.0;

/// Where and how a picture was taken, as CAMERA_IMAGE_CAPTURED carries it: the numbers both
/// the camera and the GCS compute the cut from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShutterPose {
    /// Latitude, degrees (`lat` degE7 × 1e-7).
    pub lat_deg: f64,
    /// Longitude, degrees (`lon` degE7 × 1e-7).
    pub lon_deg: f64,
    /// Altitude above home, metres (`relative_alt` mm / 1000).
    pub alt_rel_m: f64,
    /// Attitude at the shutter, `[w, x, y, z]`, body → NED (`q`).
    pub q: [f32; 4],
}

impl ShutterPose {
    /// The pose in a CAMERA_IMAGE_CAPTURED, converted as the GCS's image intake converts it.
    pub fn of_captured(c: &mav::CAMERA_IMAGE_CAPTURED_DATA) -> ShutterPose {
        ShutterPose {
            lat_deg: f64::from(c.lat) * 1e-7,
            lon_deg: f64::from(c.lon) * 1e-7,
            alt_rel_m: f64::from(c.relative_alt) / 1000.0,
            q: c.q,
        }
    }
}

/// How the runway mission classifies a picture on board: the classifier, the camera and the
/// grid (see the module documentation).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunwaySpec {
    /// Threshold, dilations and black fraction (the mission's `[runway]`).
    pub params: RunwayParams,
    /// The camera's optics and resolution (the mission's `[camera]`).
    pub camera: CameraModel,
    /// The run's grid.
    pub grid: Grid,
}

/// Where one picture is cut: the cell under the camera and the orthophoto around its centre.
#[derive(Clone, Debug, PartialEq)]
pub struct RunwayCut {
    /// The cell under the camera.
    pub cell: Cell,
    /// Attitude at the shutter, body → NED.
    pub attitude: UnitQuaternion<f64>,
    /// Height above flat ground at home's elevation, metres.
    pub altitude_m: f64,
    /// The orthophoto: centred on the cell's centre, north-up on the grid.
    pub request: OrthoRequest,
}

/// One picture classified with a [`RunwaySpec`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunwayResult {
    /// The cell it is about (the centre region).
    pub cell: Cell,
    /// Size of the classified orthophoto, pixels (width, height).
    pub size: (u32, u32),
    /// Counts, fractions and labels (heading 0: the orthophoto is north-up).
    pub reading: RegionReading,
}

impl RunwaySpec {
    /// A 24-bit fingerprint of the definition (FNV-1a over every field, folded; never 0,
    /// which the messages keep for "no definition"): equal definitions give equal
    /// fingerprints, and neither [`crate::vision::onboard::GreenSpec`]'s layout nor its name
    /// can be mistaken for this one.
    pub fn fingerprint(&self) -> u32 {
        let mut b = Vec::with_capacity(80);
        b.extend_from_slice(RUNWAY_NAME.as_bytes());
        b.push(self.params.intensity_threshold);
        b.extend_from_slice(&self.params.dilation_iterations.to_le_bytes());
        b.extend_from_slice(&self.params.black_fraction_threshold.to_bits().to_le_bytes());
        b.extend_from_slice(&self.camera.hfov_deg.to_bits().to_le_bytes());
        b.extend_from_slice(&self.camera.width_px.to_le_bytes());
        b.extend_from_slice(&self.camera.height_px.to_le_bytes());
        let o = self.grid.origin();
        b.extend_from_slice(&o.lat.to_bits().to_le_bytes());
        b.extend_from_slice(&o.lon.to_bits().to_le_bytes());
        b.extend_from_slice(&self.grid.cell_size().to_bits().to_le_bytes());
        b.push(self.grid.zone());
        b.push(u8::from(self.grid.hemisphere() == Hemisphere::South));
        fingerprint24(&b).max(1)
    }

    /// Where a picture taken at `pose` is cut. Errors: no attitude (`q` is not a rotation),
    /// a position off the grid's zone.
    pub fn cut(&self, pose: &ShutterPose) -> Result<RunwayCut, VisionError> {
        let attitude = attitude_of_quaternion(pose.q).ok_or_else(|| {
            VisionError::InvalidParams("the capture has no attitude quaternion".into())
        })?;
        let here = LatLon::new(pose.lat_deg, pose.lon_deg);
        let (e, n) = self.grid.to_xy(here).map_err(|e| {
            VisionError::InvalidParams(format!("the capture position is not on the grid: {e}"))
        })?;
        let cell = self.grid.cell_of_xy(e, n);
        let s = self.grid.cell_size();
        let centre = (f64::from(cell.col) * s, f64::from(cell.row) * s);
        Ok(RunwayCut {
            cell,
            attitude,
            altitude_m: pose.alt_rel_m,
            request: OrthoRequest {
                cell_m: s,
                centre_east_north_m: (centre.0 - e, centre.1 - n),
                grid_north_deg: self
                    .grid
                    .convergence_and_scale(here)
                    .map(|(g, _)| g)
                    .unwrap_or(0.0),
            },
        })
    }

    /// Classify `img` taken at `pose`: the same computation on board and on the GCS.
    /// Errors: as [`RunwaySpec::cut`], an altitude not above the ground, a bad camera model
    /// or parameters, an image smaller than 3 × 3.
    pub fn measure(&self, img: &RgbImage, pose: &ShutterPose) -> Result<RunwayResult, VisionError> {
        let cut = self.cut(pose)?;
        let o = orthophoto(
            img,
            &self.camera,
            &cut.attitude,
            cut.altitude_m,
            &cut.request,
        )?;
        let counts = analyse(&o.image, &self.params)?;
        Ok(RunwayResult {
            cell: cut.cell,
            size: o.image.dimensions(),
            reading: reading_from_counts(counts, 0.0, &self.params)?,
        })
    }

    /// The grid announcement the GCS sends every camera for this definition.
    pub fn announcement(&self) -> GridAnnouncement {
        GridAnnouncement {
            spec: self.fingerprint(),
            grid: self.grid.clone(),
        }
    }
}

/// What a camera given a runway mission holds: everything of the definition but, until the
/// GCS announces it, the grid (a mission whose origin is the first vehicle's home).
#[derive(Clone, Debug, PartialEq)]
pub struct RunwayDefinition {
    /// Threshold, dilations and black fraction.
    pub params: RunwayParams,
    /// The camera.
    pub camera: CameraModel,
    /// The mission's cell size, metres (the announced grid's replaces it).
    pub cell_m: f64,
    /// The grid: the mission file's when its origin is fixed, else the GCS's once announced.
    pub grid: Option<Grid>,
}

impl RunwayDefinition {
    /// The whole definition, once the grid is known.
    pub fn spec(&self) -> Option<RunwaySpec> {
        self.grid.as_ref().map(|grid| RunwaySpec {
            params: self.params,
            camera: self.camera,
            grid: grid.clone(),
        })
    }

    /// Take the GCS's grid (the GCS credits the cells, so its grid wins over the mission
    /// file's). Returns the fingerprint the camera now measures with: the announcement's
    /// when the rest of the definition is the GCS's too, another one otherwise (the GCS then
    /// asks for the pictures).
    pub fn adopt(&mut self, a: &GridAnnouncement) -> u32 {
        self.cell_m = a.grid.cell_size();
        self.grid = Some(a.grid.clone());
        self.spec().map_or(0, |s| s.fingerprint())
    }
}

/// The GCS's announcement of the run's grid (`GRID_NAME`, module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct GridAnnouncement {
    /// Fingerprint of the definition the GCS accepts ([`RunwaySpec::fingerprint`]).
    pub spec: u32,
    /// The run's grid.
    pub grid: Grid,
}

/// The four 16-bit quarters of `x`'s bits, most significant first, as floats.
fn f64_to_floats(x: f64) -> [f32; 4] {
    let b = x.to_bits();
    [48, 32, 16, 0].map(|s| ((b >> s) & 0xffff) as f32)
}

/// The `f64` whose bits [`f64_to_floats`] gave; `None` unless each is a whole 16-bit number.
fn f64_of_floats(f: &[f32]) -> Option<f64> {
    let mut b = 0u64;
    for &x in f.get(..4)? {
        if !(x.is_finite() && (0.0..=65_535.0).contains(&x) && x.fract() == 0.0) {
            return None;
        }
        b = (b << 16) | x as u64;
    }
    Some(f64::from_bits(b))
}

/// The NUL-terminated name of a DEBUG_FLOAT_ARRAY.
fn name_of(d: &mav::DEBUG_FLOAT_ARRAY_DATA) -> String {
    d.name
        .iter()
        .map(|&b| b as char)
        .take_while(|&c| c != '\0')
        .collect()
}

/// A whole number in `0..=max` (finite, exact in a float).
fn whole(x: f32, max: f32) -> Option<u32> {
    (x.is_finite() && (0.0..=max).contains(&x) && x.fract() == 0.0).then_some(x as u32)
}

/// A whole signed number of magnitude at most 2²⁴.
fn whole_signed(x: f32) -> Option<i32> {
    (x.is_finite() && x.abs() <= EXACT_MAX && x.fract() == 0.0).then_some(x as i32)
}

impl GridAnnouncement {
    /// The DEBUG_FLOAT_ARRAY that carries it (sent untargeted: every camera hears it).
    pub fn to_message(&self) -> MavMessage {
        let mut data = [0f32; 58];
        data[0] = FORMAT_VERSION;
        data[1] = self.spec as f32;
        let o = self.grid.origin();
        data[2..6].copy_from_slice(&f64_to_floats(o.lat));
        data[6..10].copy_from_slice(&f64_to_floats(o.lon));
        data[10..14].copy_from_slice(&f64_to_floats(self.grid.cell_size()));
        data[14] = f32::from(self.grid.zone());
        data[15] = f32::from(u8::from(self.grid.hemisphere() == Hemisphere::South));
        MavMessage::DEBUG_FLOAT_ARRAY(mav::DEBUG_FLOAT_ARRAY_DATA {
            time_usec: 0,
            array_id: 0,
            name: GRID_NAME.into(),
            data,
        })
    }

    /// Read a DEBUG_FLOAT_ARRAY: `None` unless it is a grid announcement of a known layout
    /// whose grid is valid (a position, a cell size and a zone [`Grid`] accepts).
    pub fn from_message(d: &mav::DEBUG_FLOAT_ARRAY_DATA) -> Option<GridAnnouncement> {
        if name_of(d) != GRID_NAME || d.data[0] != FORMAT_VERSION {
            return None;
        }
        let spec = whole(d.data[1], EXACT_MAX - 1.0)?;
        let lat = f64_of_floats(&d.data[2..6])?;
        let lon = f64_of_floats(&d.data[6..10])?;
        let cell = f64_of_floats(&d.data[10..14])?;
        let zone = u8::try_from(whole(d.data[14], 60.0)?).ok()?;
        let hemisphere = match whole(d.data[15], 1.0)? {
            0 => Hemisphere::North,
            _ => Hemisphere::South,
        };
        let grid = Grid::new_in_zone(LatLon::new(lat, lon), cell, zone, hemisphere).ok()?;
        Some(GridAnnouncement { spec, grid })
    }
}

/// A runway picture's result as the camera sends it (or a status: no picture).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunwayMeasurement {
    /// The capture's time since the vehicle booted, ms (0 in a status).
    pub time_boot_ms: u32,
    /// The capture's image index, low 16 bits.
    pub image_index_lo: u16,
    /// [`RunwaySpec::fingerprint`] of the definition used; 0: the camera has no grid.
    pub spec: u32,
    /// Size of the picture, bytes (what to ask for to get it); 0: a status, no picture.
    pub picture_bytes: u32,
    /// The reading; `None`: the picture was not classified (no grid, or no pose to
    /// cut it by): the GCS asks for it.
    pub regions: Option<OnboardRegions>,
}

/// The reading of one picture as it travels: enough to rebuild it exactly.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OnboardRegions {
    /// The cell under the camera.
    pub cell: Cell,
    /// Size of the classified orthophoto, pixels (width, height).
    pub size: (u32, u32),
    /// Black pixels per region: centre, top, left, bottom, right.
    pub black: [u32; 5],
    /// The labels the camera gave.
    pub labels: NeighbourLabels,
}

/// Labels as bits: centre 1, north 2, west 4, south 8, east 16.
fn label_bits(l: &NeighbourLabels) -> u32 {
    [l.center, l.north, l.west, l.south, l.east]
        .iter()
        .enumerate()
        .map(|(i, &b)| u32::from(b) << i)
        .sum()
}

fn labels_of_bits(b: u32) -> NeighbourLabels {
    let bit = |i: u32| b & (1 << i) != 0;
    NeighbourLabels {
        center: bit(0),
        north: bit(1),
        west: bit(2),
        south: bit(3),
        east: bit(4),
    }
}

impl OnboardRegions {
    /// What travels of `r`; `None` when a number does not fit a float exactly (a cell
    /// index beyond 2²⁴, an orthophoto larger than 2²⁴ pixels a side).
    pub fn of(r: &RunwayResult) -> Option<OnboardRegions> {
        let fits = |v: i64| v.unsigned_abs() <= EXACT_MAX as u64;
        let c = &r.reading.counts;
        let ok = fits(i64::from(r.cell.row))
            && fits(i64::from(r.cell.col))
            && fits(i64::from(r.size.0))
            && fits(i64::from(r.size.1))
            && c.black.iter().all(|&b| b <= EXACT_MAX as u64);
        ok.then(|| OnboardRegions {
            cell: r.cell,
            size: r.size,
            black: c.black.map(|b| b as u32),
            labels: r.reading.labels,
        })
    }
}

impl RunwayMeasurement {
    /// Whether this is a status (no picture).
    pub fn is_status(&self) -> bool {
        self.picture_bytes == 0
    }

    /// The capture it is about: (time_boot_ms, image index's low 16 bits); `None`: a status.
    pub fn capture(&self) -> Option<(u32, u16)> {
        (!self.is_status()).then_some((self.time_boot_ms, self.image_index_lo))
    }

    /// Whether the GCS can use it instead of the picture: the camera classified it.
    pub fn has_result(&self) -> bool {
        self.regions.is_some()
    }

    /// Whether this is the result of the capture (`time_boot_ms`, `image_index`).
    pub fn is_of(&self, time_boot_ms: u32, image_index: i32) -> bool {
        !self.is_status()
            && self.time_boot_ms == time_boot_ms
            && self.image_index_lo == image_index as u16
    }

    /// A status: the camera measures with the definition of fingerprint `spec` (0: it has
    /// no grid).
    pub fn status(spec: u32) -> RunwayMeasurement {
        RunwayMeasurement {
            time_boot_ms: 0,
            image_index_lo: 0,
            spec,
            picture_bytes: 0,
            regions: None,
        }
    }

    /// The reading the camera made, rebuilt with `params` (the definition's, which the
    /// fingerprint vouches for): counts, fractions and labels exactly as
    /// [`RunwaySpec::measure`] gave them. Errors: no reading, counts that do not fit
    /// the orthophoto's size, labels that do not follow from the counts.
    pub fn reading(&self, params: &RunwayParams) -> Result<RegionReading, VisionError> {
        let r = self.regions.ok_or_else(|| {
            VisionError::InvalidParams("the camera did not classify this picture".into())
        })?;
        let grid = RegionGrid::new(r.size.0, r.size.1);
        let mut counts = RegionCounts::default();
        for (i, region) in Region::ALL.into_iter().enumerate() {
            let (rows, cols) = grid.bounds(region);
            let pixels = u64::from(rows.end - rows.start) * u64::from(cols.end - cols.start);
            if u64::from(r.black[i]) > pixels {
                return Err(VisionError::InvalidParams(format!(
                    "the camera counted {} black pixels in a region of {pixels}",
                    r.black[i]
                )));
            }
            counts.black[region as usize] = u64::from(r.black[i]);
            counts.pixels[region as usize] = pixels;
        }
        let c = reading_from_counts(counts, 0.0, params)?;
        if c.labels != r.labels {
            return Err(VisionError::InvalidParams(format!(
                "the camera's labels {:?} do not follow from its counts ({:?})",
                r.labels, c.labels
            )));
        }
        Ok(c)
    }

    /// The DEBUG_FLOAT_ARRAY that carries it (layout in the module documentation).
    pub fn to_message(&self) -> MavMessage {
        let mut data = [0f32; 58];
        data[0] = FORMAT_VERSION;
        data[1] = self.spec as f32;
        data[2] = self.picture_bytes as f32;
        if let Some(r) = &self.regions {
            data[3] = r.cell.row as f32;
            data[4] = r.cell.col as f32;
            data[5] = r.size.0 as f32;
            data[6] = r.size.1 as f32;
            for (d, &b) in data[7..12].iter_mut().zip(&r.black) {
                *d = b as f32;
            }
            data[12] = label_bits(&r.labels) as f32;
        }
        MavMessage::DEBUG_FLOAT_ARRAY(mav::DEBUG_FLOAT_ARRAY_DATA {
            time_usec: u64::from(self.time_boot_ms) * 1000,
            array_id: self.image_index_lo,
            name: RUNWAY_NAME.into(),
            data,
        })
    }

    /// Read a DEBUG_FLOAT_ARRAY: `None` when it is not a runway result of a known layout or
    /// its numbers are out of range.
    pub fn from_message(d: &mav::DEBUG_FLOAT_ARRAY_DATA) -> Option<RunwayMeasurement> {
        if name_of(d) != RUNWAY_NAME || d.data[0] != FORMAT_VERSION {
            return None;
        }
        let spec = whole(d.data[1], EXACT_MAX - 1.0)?;
        let picture_bytes = whole(d.data[2], EXACT_MAX)?;
        let (w, h) = (whole(d.data[5], EXACT_MAX)?, whole(d.data[6], EXACT_MAX)?);
        let regions = if w == 0 || h == 0 {
            None
        } else {
            let mut black = [0u32; 5];
            for (b, &x) in black.iter_mut().zip(&d.data[7..12]) {
                *b = whole(x, EXACT_MAX)?;
            }
            Some(OnboardRegions {
                cell: Cell::new(whole_signed(d.data[3])?, whole_signed(d.data[4])?),
                size: (w, h),
                black,
                labels: labels_of_bits(whole(d.data[12], 31.0)?),
            })
        };
        Some(RunwayMeasurement {
            time_boot_ms: u32::try_from(d.time_usec / 1000).ok()?,
            image_index_lo: d.array_id,
            spec,
            picture_bytes,
            regions,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::synth::{RunwayScene, RunwayStrip, render_runway};
    use super::*;
    use crate::vision::geometry::attitude_from_euler_deg;
    use proptest::prelude::*;

    pub(crate) fn spec() -> RunwaySpec {
        RunwaySpec {
            params: RunwayParams::default(),
            camera: CameraModel::paper(),
            grid: Grid::new(LatLon::new(37.1968, -80.5781), 4.0).unwrap(),
        }
    }

    fn q_of(roll: f64, pitch: f64, yaw: f64) -> [f32; 4] {
        let c = attitude_from_euler_deg(roll, pitch, yaw).coords;
        [c.w as f32, c.x as f32, c.y as f32, c.z as f32]
    }

    fn scene(seed: u64, angle: f64) -> RgbImage {
        render_runway(&RunwayScene::grass(96, 96, seed).with_runway(RunwayStrip {
            angle_deg: angle,
            offset_px: 8.0,
            width_px: 30.0,
            length_px: None,
            along_px: 0.0,
            markings: false,
        }))
    }

    #[test]
    fn fingerprints_tell_definitions_apart() {
        let a = spec();
        let mut b = spec();
        b.params.black_fraction_threshold = 0.4;
        let mut c = spec();
        c.grid = Grid::new(LatLon::new(37.1968, -80.57810001), 4.0).unwrap();
        let mut d = spec();
        d.camera.width_px = 481;
        assert_eq!(a.fingerprint(), spec().fingerprint());
        for other in [&b, &c, &d] {
            assert_ne!(a.fingerprint(), other.fingerprint());
        }
        for s in [a, b, c, d] {
            let f = s.fingerprint();
            assert!(f > 0 && f < 1 << 24);
            assert_eq!(f as f32 as u32, f);
        }
    }

    #[test]
    fn the_grid_announcement_carries_the_grid_bit_for_bit() {
        let s = spec();
        let a = s.announcement();
        let MavMessage::DEBUG_FLOAT_ARRAY(d) = a.to_message() else {
            unreachable!()
        };
        let back = GridAnnouncement::from_message(&d).unwrap();
        assert_eq!(back, a);
        let mut def = RunwayDefinition {
            params: s.params,
            camera: s.camera,
            cell_m: 5.0,
            grid: None,
        };
        assert_eq!(def.spec(), None);
        assert_eq!(def.adopt(&back), s.fingerprint());
        assert_eq!(def.spec(), Some(s));
        // not a grid: other names, versions, bits that are not 16-bit quarters, bad zones
        let mut other = d.clone();
        other.name = "fm.rwy".into();
        assert_eq!(GridAnnouncement::from_message(&other), None);
        let mut bits = d.clone();
        bits.data[3] = 0.5;
        assert_eq!(GridAnnouncement::from_message(&bits), None);
        let mut zone = d.clone();
        zone.data[14] = 0.0;
        assert_eq!(GridAnnouncement::from_message(&zone), None);
        let mut nan = d;
        nan.data[2..6].copy_from_slice(&f64_to_floats(f64::NAN));
        assert_eq!(GridAnnouncement::from_message(&nan), None);
    }

    #[test]
    fn a_picture_is_cut_around_the_cell_under_the_camera() {
        let s = spec();
        // 1.3 m east and 0.6 m south of cell (2, -1)'s centre, level, facing east
        let p = s.grid.from_xy(-4.0 + 1.3, 8.0 - 0.6).unwrap();
        let pose = ShutterPose {
            lat_deg: p.lat,
            lon_deg: p.lon,
            alt_rel_m: 12.0,
            q: q_of(0.0, 0.0, 90.0),
        };
        let cut = s.cut(&pose).unwrap();
        assert_eq!(cut.cell, Cell::new(2, -1));
        let (ce, cn) = cut.request.centre_east_north_m;
        assert!(
            (ce + 1.3).abs() < 1e-6 && (cn - 0.6).abs() < 1e-6,
            "{ce} {cn}"
        );
        // no attitude: no cut
        let none = ShutterPose {
            q: [0.0; 4],
            ..pose
        };
        assert!(s.cut(&none).is_err());
        assert!(s.measure(&scene(1, 0.0), &none).is_err());
    }

    #[test]
    fn other_arrays_and_bad_numbers_are_not_runway_results() {
        let m = RunwayMeasurement {
            time_boot_ms: 10,
            image_index_lo: 1,
            spec: 5,
            picture_bytes: 100,
            regions: Some(OnboardRegions {
                cell: Cell::new(-3, 4),
                size: (9, 9),
                black: [9, 0, 3, 9, 1],
                labels: NeighbourLabels {
                    center: true,
                    south: true,
                    ..NeighbourLabels::default()
                },
            }),
        };
        let MavMessage::DEBUG_FLOAT_ARRAY(good) = m.to_message() else {
            unreachable!()
        };
        assert_eq!(RunwayMeasurement::from_message(&good), Some(m));
        let c = m.reading(&RunwayParams::default()).unwrap();
        assert_eq!(c.counts.pixels, [9; 5]);
        assert_eq!(c.fractions.left, 3.0 / 9.0);
        let mut green = good.clone();
        green.name = "fm.green".into();
        assert_eq!(RunwayMeasurement::from_message(&green), None);
        for (i, bad) in [(1, f32::NAN), (0, 2.0), (7, 1.5), (12, 32.0), (3, 1e9)] {
            let mut d = good.clone();
            d.data[i] = bad;
            assert_eq!(
                RunwayMeasurement::from_message(&d),
                None,
                "data[{i}] = {bad}"
            );
        }
        // more black pixels than the region holds, or labels the counts do not give
        let mut too_many = m;
        too_many.regions.as_mut().unwrap().black[0] = 10;
        assert!(too_many.reading(&RunwayParams::default()).is_err());
        let mut wrong = m;
        wrong.regions.as_mut().unwrap().labels.north = true;
        assert!(wrong.reading(&RunwayParams::default()).is_err());
        // a status ties to no capture
        let st = RunwayMeasurement::status(7);
        assert!(st.is_status() && !st.is_of(0, 0));
        assert!(m.is_of(10, 1) && !m.is_of(10, 2));
        assert!(st.reading(&RunwayParams::default()).is_err());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        /// The camera's computation, sent through the message and rebuilt by the GCS, is
        /// bit for bit the GCS's own on the same picture and pose.
        #[test]
        fn the_gcs_rebuilds_exactly_what_the_camera_computed(
            seed in 0u64..1000,
            angle in 0.0f64..180.0,
            de in -1.9f64..1.9,
            dn in -1.9f64..1.9,
            row in -20i32..20,
            col in -20i32..20,
            alt in 10.0f64..16.0,
            roll in -8.0f64..8.0,
            pitch in -8.0f64..8.0,
            yaw in 0.0f64..360.0,
        ) {
            let s = spec();
            let cm = s.grid.cell_size();
            let p = s.grid.from_xy(f64::from(col) * cm + de, f64::from(row) * cm + dn).unwrap();
            // the pose as it travels in CAMERA_IMAGE_CAPTURED
            let c = mav::CAMERA_IMAGE_CAPTURED_DATA {
                lat: (p.lat * 1e7).round() as i32,
                lon: (p.lon * 1e7).round() as i32,
                relative_alt: (alt * 1000.0).round() as i32,
                q: q_of(roll, pitch, yaw),
                ..Default::default()
            };
            let pose = ShutterPose::of_captured(&c);
            let img = scene(seed, angle);
            let camera = s.measure(&img, &pose).unwrap();
            let gcs = s.measure(&img, &pose).unwrap();
            prop_assert_eq!(camera, gcs);
            // the cell under the camera
            prop_assert_eq!(camera.cell, s.grid.cell_of(LatLon::new(pose.lat_deg, pose.lon_deg)).unwrap());
            let m = RunwayMeasurement {
                time_boot_ms: 1_000,
                image_index_lo: 3,
                spec: s.fingerprint(),
                picture_bytes: 40_000,
                regions: OnboardRegions::of(&camera),
            };
            let MavMessage::DEBUG_FLOAT_ARRAY(d) = m.to_message() else { unreachable!() };
            let back = RunwayMeasurement::from_message(&d).unwrap();
            prop_assert_eq!(back, m);
            let rebuilt = back.reading(&s.params).unwrap();
            prop_assert_eq!(rebuilt, gcs.reading);
            prop_assert_eq!(back.regions.unwrap().cell, gcs.cell);
        }
    }
}
