//! Per-cell vote fusion of the runway paper, §7:
//!
//! > "we use five images per cell. If three of these images mark a cell as containing the
//! > runway, we treat it as a positive detection. … If a cell is marked as containing the
//! > runway, it will never be reversed later on, even if a future measurement taken from
//! > some other location yields the opposite detection. On the other hand, if a cell is
//! > marked as not containing the runway and a subsequent measurement suggests otherwise,
//! > we will mark it as a positive runway detection."
//!
//! # The rule implemented by [`VoteBook`]
//!
//! * A **visit** is a group of consecutive images taken by one vehicle over one cell; it ends
//!   when it holds `images_per_visit` (5) images, when the same vehicle sends an image taken
//!   over another cell, or when `VoteBook::close_visit` is called (the vehicle moved on).
//!   Each vehicle has at most one open visit. A sixth image over the same cell opens a new
//!   visit: every group of five is a fresh vote.
//! * Every image labels five cells (the cell under the vehicle and its four neighbours,
//!   [`NeighbourLabels`]). Within a visit, each of those five **target** cells collects
//!   one vote per image. The visit's **decision** for a target (a *detection* in the paper's
//!   counting, "483 detections") is positive as soon as `positive_votes` (3) votes are
//!   positive, and negative as soon as a positive decision has become impossible
//!   (more than `images_per_visit − positive_votes` negative votes). A visit cut short
//!   decides its undecided targets negative (they had fewer than 3 positive votes), unless it
//!   holds no image at all. So neighbours are voted on by the images taken at adjacent
//!   cells, exactly like the cell under the vehicle.
//! * A cell's **state** is the fusion of the decisions about it: `Unknown` until the first
//!   decision, `Positive` after any positive decision, never reversed; `Negative` after a
//!   negative decision while not positive, and a later positive decision turns it positive.
//! * Everything is kept ([`Recorded`] images with vehicle, time, position, heading,
//!   fractions, labels; [`Decision`]s; per-cell records) and the book is serialisable
//!   (serde), so it is persisted with the exploration state and false positives / negatives
//!   are counted afterwards against ground truth ([`VoteBook::evaluate`]).

use super::NeighbourLabels;
use crate::geo::{Cell, Dir4};
use crate::time::Time;
use crate::vision::VisionError;
use crate::vision::regions::RegionFractions;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Parameters of the vote (runway paper §7: 3 of 5).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default)]
pub struct VoteParams {
    /// Images per visit (per cell). Paper: 5.
    pub images_per_visit: u32,
    /// Positive images needed for a positive decision. Paper: 3.
    pub positive_votes: u32,
}

impl Default for VoteParams {
    fn default() -> VoteParams {
        VoteParams {
            images_per_visit: 5,
            positive_votes: 3,
        }
    }
}

impl VoteParams {
    /// Check `1 <= positive_votes <= images_per_visit`.
    pub fn validate(&self) -> Result<(), VisionError> {
        if self.positive_votes == 0 || self.positive_votes > self.images_per_visit {
            return Err(VisionError::InvalidParams(format!(
                "positive votes must be between 1 and the images per visit ({}), got {}",
                self.images_per_visit, self.positive_votes
            )));
        }
        Ok(())
    }
}

/// Where a vehicle was when it took an image (WGS84).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GeoPosition {
    /// Latitude, degrees.
    pub lat_deg: f64,
    /// Longitude, degrees.
    pub lon_deg: f64,
    /// Altitude above home, metres.
    pub alt_m: f64,
}

/// One classified image, as given to [`VoteBook::record`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Detection {
    /// Identifier of the image (file name, sequence number …).
    pub image_id: String,
    /// MAVLink system id of the vehicle that took it.
    pub vehicle: u8,
    /// When it was taken.
    pub time: Time,
    /// The grid cell under the vehicle (the centre region).
    pub cell: Cell,
    /// The vehicle's position, when known.
    pub position: Option<GeoPosition>,
    /// The vehicle's heading, degrees clockwise from north.
    pub heading_deg: f64,
    /// Black fractions of the five regions (image coordinates).
    pub fractions: RegionFractions,
    /// Labels of the cell and its neighbours (grid coordinates).
    pub labels: NeighbourLabels,
}

impl Detection {
    /// The five (target cell, label) pairs of this image: the centre, then north, west,
    /// south, east.
    pub fn targets(&self) -> [(Cell, bool); 5] {
        let n = |d: Dir4| (self.cell.step(d), self.labels.get(d));
        [
            (self.cell, self.labels.center),
            n(Dir4::North),
            n(Dir4::West),
            n(Dir4::South),
            n(Dir4::East),
        ]
    }
}

/// A detection as stored in the book, with the visit it belongs to.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Recorded {
    /// The visit (see the module docs) the image was counted in.
    pub visit: u64,
    /// The image's detection.
    pub detection: Detection,
}

/// What is known about a cell.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CellState {
    /// No decision yet.
    #[default]
    Unknown,
    /// Decided not runway (may still become positive).
    Negative,
    /// Decided runway (final).
    Positive,
}

/// One visit's decision about one target cell (a "detection" in the paper's counts).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Decision {
    /// The visit that decided.
    pub visit: u64,
    /// The vehicle of the visit.
    pub vehicle: u8,
    /// The cell the images were taken over.
    pub(crate) taken_at: Cell,
    /// The cell decided about (`taken_at` or one of its neighbours).
    pub cell: Cell,
    /// The decision.
    pub positive: bool,
    /// Positive votes when decided.
    pub votes_for: u32,
    /// Negative votes when decided.
    pub votes_against: u32,
    /// Time of the image that settled it (or of the close).
    pub time: Time,
}

/// The fused record of one cell.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct CellRecord {
    /// Current state.
    pub state: CellState,
    /// Number of positive decisions about it.
    pub(crate) positive_decisions: u32,
    /// Number of negative decisions about it.
    pub(crate) negative_decisions: u32,
    /// When it became positive.
    pub(crate) positive_since: Option<Time>,
}

/// A change of a cell's state, returned by [`VoteBook::record`] and `VoteBook::close_visit`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct CellUpdate {
    /// The cell.
    pub cell: Cell,
    /// State before.
    pub from: CellState,
    /// State after.
    pub to: CellState,
    /// When.
    pub time: Time,
}

/// An open visit: the images so far and the vote tallies of its five targets.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct OpenVisit {
    /// Visit id.
    pub id: u64,
    /// The cell under the vehicle.
    pub cell: Cell,
    /// Images counted so far.
    pub images: u32,
    /// Positive votes per target (centre, north, west, south, east).
    pub positive: [u32; 5],
    /// Negative votes per target.
    pub negative: [u32; 5],
    /// Targets already decided.
    pub decided: [bool; 5],
}

impl OpenVisit {
    fn targets(&self) -> [Cell; 5] {
        let c = self.cell;
        [
            c,
            c.step(Dir4::North),
            c.step(Dir4::West),
            c.step(Dir4::South),
            c.step(Dir4::East),
        ]
    }
}

/// Confusion counts against ground truth.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Confusion {
    /// Said runway, is runway.
    pub true_positives: u64,
    /// Said runway, is not.
    pub false_positives: u64,
    /// Said not runway, is not.
    pub true_negatives: u64,
    /// Said not runway, is runway.
    pub false_negatives: u64,
}

impl Confusion {
    fn add(&mut self, said: bool, truth: bool) {
        match (said, truth) {
            (true, true) => self.true_positives += 1,
            (true, false) => self.false_positives += 1,
            (false, false) => self.true_negatives += 1,
            (false, true) => self.false_negatives += 1,
        }
    }

    /// Total number of items counted.
    pub fn total(&self) -> u64 {
        self.true_positives + self.false_positives + self.true_negatives + self.false_negatives
    }
}

/// The book's performance against ground truth.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Evaluation {
    /// Every per-image label (five per image).
    pub image_labels: Confusion,
    /// Every visit decision ("detections" in the paper: 483, 27 false positive, 53 false
    /// negative in the field test).
    pub decisions: Confusion,
    /// The final state of every decided cell (the map).
    pub cells: Confusion,
}

/// Votes, decisions and cell states of a mapping run (see the module docs for the rule).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VoteBook {
    params: VoteParams,
    next_visit: u64,
    detections: Vec<Recorded>,
    decisions: Vec<Decision>,
    open: BTreeMap<u8, OpenVisit>,
    #[serde(with = "cell_map")]
    cells: BTreeMap<Cell, CellRecord>,
}

mod cell_map {
    //! JSON object keys must be strings: store the map as a list of (cell, record).
    use super::{Cell, CellRecord};
    use serde::{Deserialize, Deserializer, Serialize, Serializer};
    use std::collections::BTreeMap;

    pub(super) fn serialize<S: Serializer>(
        m: &BTreeMap<Cell, CellRecord>,
        s: S,
    ) -> Result<S::Ok, S::Error> {
        m.iter().collect::<Vec<_>>().serialize(s)
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(
        d: D,
    ) -> Result<BTreeMap<Cell, CellRecord>, D::Error> {
        Ok(Vec::<(Cell, CellRecord)>::deserialize(d)?
            .into_iter()
            .collect())
    }
}

impl VoteBook {
    /// An empty book.
    pub fn new(params: VoteParams) -> Result<VoteBook, VisionError> {
        params.validate()?;
        Ok(VoteBook {
            params,
            next_visit: 0,
            detections: Vec::new(),
            decisions: Vec::new(),
            open: BTreeMap::new(),
            cells: BTreeMap::new(),
        })
    }

    /// The parameters.
    pub fn params(&self) -> VoteParams {
        self.params
    }

    /// Count one classified image; returns the cells whose state changed.
    pub fn record(&mut self, det: Detection) -> Vec<CellUpdate> {
        let mut updates = Vec::new();
        let vehicle = det.vehicle;
        let time = det.time;
        if self.open.get(&vehicle).is_some_and(|v| v.cell != det.cell) {
            updates.extend(self.close_visit(vehicle, time));
        }
        let next_visit = &mut self.next_visit;
        let visit = self.open.entry(vehicle).or_insert_with(|| {
            let id = *next_visit;
            *next_visit += 1;
            OpenVisit {
                id,
                cell: det.cell,
                images: 0,
                positive: [0; 5],
                negative: [0; 5],
                decided: [false; 5],
            }
        });
        visit.images += 1;
        let (n, p) = (self.params.images_per_visit, self.params.positive_votes);
        let mut settled = Vec::new();
        for (i, (cell, label)) in det.targets().into_iter().enumerate() {
            if label {
                visit.positive[i] += 1;
            } else {
                visit.negative[i] += 1;
            }
            if visit.decided[i] {
                continue;
            }
            let decision = if visit.positive[i] >= p {
                Some(true)
            } else if visit.negative[i] > n - p {
                Some(false)
            } else {
                None
            };
            if let Some(positive) = decision {
                visit.decided[i] = true;
                settled.push(Decision {
                    visit: visit.id,
                    vehicle,
                    taken_at: visit.cell,
                    cell,
                    positive,
                    votes_for: visit.positive[i],
                    votes_against: visit.negative[i],
                    time,
                });
            }
        }
        let visit_id = visit.id;
        let full = visit.images >= n;
        self.detections.push(Recorded {
            visit: visit_id,
            detection: det,
        });
        for d in settled {
            updates.extend(self.apply(d));
        }
        if full {
            updates.extend(self.close_visit(vehicle, time));
        }
        updates
    }

    /// End `vehicle`'s open visit (it left the cell): its undecided targets are decided
    /// negative. Returns the cells whose state changed.
    pub(crate) fn close_visit(&mut self, vehicle: u8, now: Time) -> Vec<CellUpdate> {
        let Some(visit) = self.open.remove(&vehicle) else {
            return Vec::new();
        };
        let mut updates = Vec::new();
        if visit.images == 0 {
            return updates;
        }
        for (i, cell) in visit.targets().into_iter().enumerate() {
            if visit.decided[i] {
                continue;
            }
            let d = Decision {
                visit: visit.id,
                vehicle,
                taken_at: visit.cell,
                cell,
                positive: visit.positive[i] >= self.params.positive_votes,
                votes_for: visit.positive[i],
                votes_against: visit.negative[i],
                time: now,
            };
            updates.extend(self.apply(d));
        }
        updates
    }

    /// Drop every open visit without deciding anything more: the targets its pictures had
    /// not settled stay as they were (a run that gives up labels nothing for it). The
    /// detections counted so far stay in the record. Returns the vehicles whose visit was
    /// dropped.
    pub(crate) fn drop_open_visits(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.open).into_keys().collect()
    }

    /// Close every open visit.
    pub fn close_all(&mut self, now: Time) -> Vec<CellUpdate> {
        let vehicles: Vec<u8> = self.open.keys().copied().collect();
        vehicles
            .into_iter()
            .flat_map(|v| self.close_visit(v, now))
            .collect()
    }

    fn apply(&mut self, d: Decision) -> Option<CellUpdate> {
        let rec = self.cells.entry(d.cell).or_default();
        let from = rec.state;
        if d.positive {
            rec.positive_decisions += 1;
            if rec.state != CellState::Positive {
                rec.state = CellState::Positive;
                rec.positive_since = Some(d.time);
            }
        } else {
            rec.negative_decisions += 1;
            if rec.state == CellState::Unknown {
                rec.state = CellState::Negative;
            }
        }
        let to = rec.state;
        let time = d.time;
        let cell = d.cell;
        self.decisions.push(d);
        (from != to).then_some(CellUpdate {
            cell,
            from,
            to,
            time,
        })
    }

    /// The state of `cell`.
    pub fn state(&self, cell: Cell) -> CellState {
        self.cells
            .get(&cell)
            .map_or(CellState::Unknown, |r| r.state)
    }

    /// The record of `cell`, if any decision was made about it.
    pub fn cell(&self, cell: Cell) -> Option<&CellRecord> {
        self.cells.get(&cell)
    }

    /// Every decided cell and its record, in cell order.
    pub fn cells(&self) -> impl Iterator<Item = (Cell, &CellRecord)> {
        self.cells.iter().map(|(c, r)| (*c, r))
    }

    /// The cells decided positive (the map), in cell order.
    pub fn positive_cells(&self) -> Vec<Cell> {
        self.cells
            .iter()
            .filter(|(_, r)| r.state == CellState::Positive)
            .map(|(c, _)| *c)
            .collect()
    }

    /// Every image counted so far, in order.
    pub fn detections(&self) -> &[Recorded] {
        &self.detections
    }

    /// Every decision so far, in order.
    pub fn decisions(&self) -> &[Decision] {
        &self.decisions
    }

    /// The open visit of `vehicle`, if any.
    pub fn open_visit(&self, vehicle: u8) -> Option<&OpenVisit> {
        self.open.get(&vehicle)
    }

    /// Confusion counts of the image labels, the decisions and the final cell states
    /// against `truth(cell)` (true = runway).
    pub fn evaluate(&self, truth: impl Fn(Cell) -> bool) -> Evaluation {
        let mut e = Evaluation::default();
        for r in &self.detections {
            for (cell, label) in r.detection.targets() {
                e.image_labels.add(label, truth(cell));
            }
        }
        for d in &self.decisions {
            e.decisions.add(d.positive, truth(d.cell));
        }
        for (cell, r) in &self.cells {
            match r.state {
                CellState::Positive => e.cells.add(true, truth(*cell)),
                CellState::Negative => e.cells.add(false, truth(*cell)),
                CellState::Unknown => {}
            }
        }
        e
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn det(vehicle: u8, cell: Cell, t: u64, labels: NeighbourLabels) -> Detection {
        Detection {
            image_id: format!("img{t}"),
            vehicle,
            time: Time::from_secs(t),
            cell,
            position: None,
            heading_deg: 0.0,
            fractions: RegionFractions::default(),
            labels,
        }
    }

    fn centre(v: bool) -> NeighbourLabels {
        NeighbourLabels {
            center: v,
            ..NeighbourLabels::default()
        }
    }

    #[test]
    fn three_of_five_makes_a_positive_as_soon_as_the_third_arrives() {
        let mut b = VoteBook::new(VoteParams::default()).unwrap();
        let c = Cell::new(0, 0);
        assert!(b.record(det(1, c, 1, centre(true))).is_empty());
        assert!(b.record(det(1, c, 2, centre(false))).is_empty());
        // The third image settles the neighbours: three negative votes out of five.
        let u = b.record(det(1, c, 3, centre(true)));
        assert_eq!(u.len(), 4);
        assert!(u.iter().all(|u| u.to == CellState::Negative && u.cell != c));
        let u = b.record(det(1, c, 4, centre(true)));
        assert_eq!(
            u,
            [CellUpdate {
                cell: c,
                from: CellState::Unknown,
                to: CellState::Positive,
                time: Time::from_secs(4)
            }]
        );
        assert_eq!(b.state(c), CellState::Positive);
        b.record(det(1, c, 5, centre(false)));
        // The visit is closed after five images; neighbours were decided negative.
        assert!(b.open_visit(1).is_none());
        assert_eq!(b.state(c.step(Dir4::North)), CellState::Negative);
        assert_eq!(b.decisions().len(), 5);
        assert_eq!(b.detections().len(), 5);
    }

    #[test]
    fn positive_is_never_reversed_negative_can_turn() {
        let mut b = VoteBook::new(VoteParams::default()).unwrap();
        let c = Cell::new(2, -1);
        for t in 0..5 {
            b.record(det(1, c, t, centre(t < 2)));
        }
        assert_eq!(b.state(c), CellState::Negative);
        // A later visit from the south neighbour sees it as its northern neighbour.
        let below = c.step(Dir4::South);
        let north = NeighbourLabels {
            north: true,
            ..NeighbourLabels::default()
        };
        for t in 10..13 {
            b.record(det(2, below, t, north));
        }
        assert_eq!(b.state(c), CellState::Positive);
        // A third visit votes it negative again: it stays positive.
        for t in 20..25 {
            b.record(det(1, c, t, centre(false)));
        }
        assert_eq!(b.state(c), CellState::Positive);
        let r = b.cell(c).unwrap();
        assert_eq!((r.positive_decisions, r.negative_decisions), (1, 2));
        assert_eq!(r.positive_since, Some(Time::from_secs(12)));
    }

    #[test]
    fn leaving_the_cell_closes_the_visit() {
        let mut b = VoteBook::new(VoteParams::default()).unwrap();
        let c = Cell::new(0, 0);
        b.record(det(1, c, 0, centre(true)));
        b.record(det(1, c, 1, centre(true)));
        // A different vehicle does not interfere.
        b.record(det(2, Cell::new(5, 5), 2, centre(true)));
        assert_eq!(b.state(c), CellState::Unknown);
        // Vehicle 1 moves on with only two images: the visit decides negative.
        b.record(det(1, Cell::new(0, 1), 3, centre(false)));
        assert_eq!(b.state(c), CellState::Negative);
        assert_eq!(b.open_visit(1).unwrap().cell, Cell::new(0, 1));
        b.close_all(Time::from_secs(9));
        assert!(b.open_visit(1).is_none() && b.open_visit(2).is_none());
    }

    #[test]
    fn evaluation_and_serde_round_trip() {
        let mut b = VoteBook::new(VoteParams::default()).unwrap();
        let c = Cell::new(0, 0);
        for t in 0..5 {
            b.record(det(1, c, t, centre(true)));
        }
        let truth = |cell: Cell| cell == Cell::new(0, 1);
        let e = b.evaluate(truth);
        assert_eq!(e.image_labels.total(), 25);
        assert_eq!(e.image_labels.false_positives, 5);
        assert_eq!(e.image_labels.false_negatives, 5); // east neighbour, said negative
        assert_eq!(e.decisions.false_positives, 1);
        assert_eq!(e.decisions.false_negatives, 1);
        assert_eq!(e.cells.total(), 5);
        let json = serde_json::to_string(&b).unwrap();
        let back: VoteBook = serde_json::from_str(&json).unwrap();
        assert_eq!(back, b);
        assert!(
            VoteBook::new(VoteParams {
                images_per_visit: 2,
                positive_votes: 3
            })
            .is_err()
        );
    }
}
