//! A discrete-event run of an [`Explorer`] on a known ROI with a perfect sensor: the model of
//! the paper's §6 simulations (unit cells, unit footprint, robots at speed S_r relative to
//! the ground, ROI translating at a constant velocity, every move charged at its relative
//! speed, see [`super::motion`]). It drives the explorer exactly as a runner would — one
//! `next_action` per robot, `arrived` after each flight, `observe` with the image's labels —
//! so it also exercises the sans-IO interface.
//!
//! The cost is the time at which the last robot is back at the start (Problem 1).

use super::ExploreError;
use super::dfs::{Action, Allocation, Explorer, ExplorerConfig, RobotId, Sharing};
use super::motion::RoiMotion;
use crate::geo::{Cell, Dir4};
use crate::time::Time;
use std::cmp::{Ordering, Reverse};
use std::collections::{BinaryHeap, HashSet};

/// Simulation parameters (lengths in cells, times in the unit that makes S_r cells per unit).
#[derive(Clone, Debug, PartialEq)]
pub struct SimConfig {
    /// Number of robots R (1..=255).
    pub robots: usize,
    /// How vertex states are shared.
    pub sharing: Sharing,
    /// How the robots at a vertex are allocated (Algorithm 1's split or nearest frontier).
    pub allocation: Allocation,
    /// S_r, cells per time unit (relative to the ground).
    pub robot_speed: f64,
    /// The ROI's velocity (east, north), cells per time unit; |v| = S_p < S_r.
    pub roi_velocity: (f64, f64),
    /// Time to take an image at a cell (the paper's model: 0).
    pub observe_time: f64,
    /// Keep every robot's sequence of cells in the outcome.
    pub record_paths: bool,
    /// Direct transit ([`ExplorerConfig::direct_transit`]): a move may pass several imaged
    /// vertices, flown straight (charged at its straight length); a robot whose tour ends
    /// away from the start flies straight back to it (the cost is still everyone at the
    /// start). Off in the paper's model.
    pub direct_transit: bool,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            robots: 1,
            sharing: Sharing::Gcs,
            allocation: Allocation::default(),
            robot_speed: 1.0,
            roi_velocity: (0.0, 0.0),
            observe_time: 0.0,
            record_paths: false,
            direct_transit: false,
        }
    }
}

/// What a simulated exploration did.
#[derive(Clone, Debug)]
pub struct SimOutcome {
    /// ALG: when the last robot was back at the start.
    pub cost: f64,
    /// Cells in the tree (C, with a perfect sensor).
    pub tree_cells: usize,
    /// d_max of the built tree.
    pub d_max: u32,
    /// Unit tree edges flown by each robot.
    pub moves: Vec<u64>,
    /// Moves of each robot onto a cell no robot had reached before (they sum to C − 1 with
    /// a perfect sensor): the moves that open the ROI, the others are transit.
    pub opening_moves: Vec<u64>,
    /// Time each robot spent flying (the rest of `cost` it waited or was home already).
    pub flight_time: Vec<f64>,
    /// Each robot's cells in the order it reached them (when `record_paths`).
    pub paths: Vec<Vec<Cell>>,
    /// The final explorer.
    pub explorer: Explorer,
    /// Events processed.
    pub events: u64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Poll,
    Arrive(Cell),
}

/// An event of the run. Events are ordered by time (quantised to 10⁻⁹ time units, so that
/// robots whose float travel times differ only by rounding are simultaneous), then by
/// `class`, then by creation order: at one instant every arrival is processed first, then
/// every image, then every decision, so a decision at time t uses everything the team
/// learned at t (what "the robots at v" and the shared states mean in continuous time).
#[derive(Clone, Copy, Debug)]
struct Event {
    time: f64,
    tick: i64,
    class: u8,
    seq: u64,
    robot: usize,
    kind: Kind,
}

impl PartialEq for Event {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Event {}
impl PartialOrd for Event {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Event {
    fn cmp(&self, o: &Self) -> Ordering {
        self.tick
            .cmp(&o.tick)
            .then(self.class.cmp(&o.class))
            .then(self.seq.cmp(&o.seq))
    }
}

/// Run Algorithm 1 on the ROI `roi` (the set of ROI cells, ROI frame) from `start` (an ROI
/// cell) with a perfect sensor.
pub fn simulate(
    roi: &HashSet<Cell>,
    start: Cell,
    cfg: &SimConfig,
) -> Result<SimOutcome, ExploreError> {
    simulate_sensed(roi, start, cfg, &mut |c: Cell| {
        Dir4::ALL.map(|d| roi.contains(&c.step(d)))
    })
}

/// [`simulate`] with a given sensor: `sense(cell)` returns the labels of an image taken at
/// `cell` (north, west, south, east, as [`Explorer::observe`] takes them). It may lie (a
/// noisy classifier); the explorer then maps the cells it was told about (a false positive
/// is kept, a false negative is overridden by a later positive, §7).
pub fn simulate_sensed(
    roi: &HashSet<Cell>,
    start: Cell,
    cfg: &SimConfig,
    sense: &mut dyn FnMut(Cell) -> [bool; 4],
) -> Result<SimOutcome, ExploreError> {
    let n = cfg.robots;
    if n == 0 {
        return Err(ExploreError::NoRobots);
    }
    if n > 255 {
        return Err(ExploreError::Simulation(format!(
            "{n} robots: at most 255 are supported"
        )));
    }
    if !roi.contains(&start) {
        return Err(ExploreError::Simulation(format!(
            "the start {start} is not an ROI cell"
        )));
    }
    let motion = RoiMotion::new(cfg.roi_velocity.0, cfg.roi_velocity.1, Time::ZERO);
    motion.relative_speed(cfg.robot_speed, 1.0, 0.0)?;
    let ids: Vec<RobotId> = (1..=n).map(|i| RobotId(i as u8)).collect();
    let mut ex = Explorer::new(
        ExplorerConfig {
            sharing: cfg.sharing,
            allocation: cfg.allocation,
            direct_transit: cfg.direct_transit,
        },
        start,
        &ids,
    )?;
    let mut pos = vec![start; n];
    let mut done = vec![None::<f64>; n];
    let mut paths: Vec<Vec<Cell>> = vec![Vec::new(); n];
    let mut heap = BinaryHeap::new();
    let mut seq = 0u64;
    // Class of a poll: 1 if the robot stands at a vertex not yet imaged (it will observe),
    // 2 otherwise (it will decide); arrivals are class 0.
    let poll_class = |ex: &Explorer, id: RobotId| -> u8 {
        match ex.robot(id) {
            Ok(r) => {
                let real = ex.tree().real_of(r.node);
                if ex.tree().node(real).observed { 2 } else { 1 }
            }
            Err(_) => 2,
        }
    };
    let mut push = |heap: &mut BinaryHeap<Reverse<Event>>, time: f64, robot, kind, class| {
        heap.push(Reverse(Event {
            time,
            tick: (time * 1e9).round() as i64,
            class,
            seq,
            robot,
            kind,
        }));
        seq += 1;
    };
    // Everyone starts at the start cell.
    for (r, &id) in ids.iter().enumerate() {
        match ex.next_action(id)? {
            Action::Rejoin(c) if c == start => ex.arrived(id, start)?,
            other => {
                return Err(ExploreError::Simulation(format!(
                    "robot {id} began with {other:?} instead of rejoining the start"
                )));
            }
        }
        if cfg.record_paths {
            paths[r].push(start);
        }
        push(&mut heap, 0.0, r, Kind::Poll, poll_class(&ex, id));
    }
    let mut waiting: Vec<usize> = Vec::new();
    let mut seen: HashSet<Cell> = HashSet::from([start]);
    let mut opening_moves = vec![0u64; n];
    let mut flight = vec![0.0f64; n];
    let mut events = 0u64;
    let limit = 200_000u64 + 50_000 * (roi.len() as u64) * (n as u64);
    while let Some(Reverse(ev)) = heap.pop() {
        events += 1;
        if events > limit {
            return Err(ExploreError::Simulation(format!(
                "no end after {events} events"
            )));
        }
        let (t, r, id) = (ev.time, ev.robot, ids[ev.robot]);
        let progressed = match ev.kind {
            Kind::Arrive(c) => {
                ex.arrived(id, c)?;
                pos[r] = c;
                if cfg.record_paths {
                    paths[r].push(c);
                }
                if seen.insert(c) {
                    opening_moves[r] += 1;
                }
                push(&mut heap, t, r, Kind::Poll, poll_class(&ex, id));
                true
            }
            Kind::Poll => match ex.next_action(id)? {
                Action::MoveTo(c) => {
                    if pos[r].manhattan(c) != 1 && !cfg.direct_transit {
                        return Err(ExploreError::Simulation(format!(
                            "robot {id} sent from {} to non-adjacent {c}",
                            pos[r]
                        )));
                    }
                    let dt = motion.travel_time(pos[r], c, 1.0, cfg.robot_speed)?;
                    flight[r] += dt;
                    push(&mut heap, t + dt, r, Kind::Arrive(c), 0);
                    true
                }
                Action::Rejoin(c) => {
                    let dt = motion.travel_time(pos[r], c, 1.0, cfg.robot_speed)?;
                    flight[r] += dt;
                    push(&mut heap, t + dt, r, Kind::Arrive(c), 0);
                    true
                }
                Action::Observe => {
                    let c = pos[r];
                    ex.observe(id, c, sense(c))?;
                    let t2 = t + cfg.observe_time;
                    push(&mut heap, t2, r, Kind::Poll, poll_class(&ex, id));
                    true
                }
                Action::Wait => {
                    waiting.push(r);
                    false
                }
                Action::Done => {
                    // Direct transit ends a tour where the robot is: fly it to the start.
                    let back = if pos[r] == start {
                        0.0
                    } else {
                        motion.travel_time(pos[r], start, 1.0, cfg.robot_speed)?
                    };
                    flight[r] += back;
                    if back > 0.0 && cfg.record_paths {
                        paths[r].push(start);
                    }
                    done[r] = Some(t + back);
                    true
                }
                Action::ReturnHome => {
                    return Err(ExploreError::Simulation(format!(
                        "robot {id} was paused, which the simulation never does"
                    )));
                }
            },
        };
        if progressed {
            for w in waiting.drain(..) {
                push(&mut heap, t, w, Kind::Poll, poll_class(&ex, ids[w]));
            }
        }
    }
    if !waiting.is_empty() || done.iter().any(Option::is_none) || !ex.is_finished() {
        return Err(ExploreError::Simulation(format!(
            "stalled: {} robots waiting, {} not done, finished = {}",
            waiting.len(),
            done.iter().filter(|d| d.is_none()).count(),
            ex.is_finished()
        )));
    }
    let done_times = done.into_iter().map(|d| d.unwrap_or(0.0));
    Ok(SimOutcome {
        cost: done_times.fold(0.0, f64::max),
        tree_cells: ex.tree().real_count(),
        d_max: ex.d_max(),
        moves: ex.robots().iter().map(|r| r.moves).collect(),
        opening_moves,
        flight_time: flight,
        paths,
        explorer: ex,
        events,
    })
}

/// A random connected ROI of `cells` grid cells, as in Fig. 7a: grown from cell (0, 0) by
/// adding, `cells − 1` times, a uniformly random 4-neighbour of the region that is not yet in
/// it (Eden growth). Returns the cells (always 4-connected) and a uniformly random start cell
/// among them.
pub fn random_roi<R: rand::RngExt + ?Sized>(rng: &mut R, cells: usize) -> (HashSet<Cell>, Cell) {
    let mut roi: HashSet<Cell> = HashSet::with_capacity(cells);
    if cells == 0 {
        return (roi, Cell::new(0, 0));
    }
    let mut order: Vec<Cell> = Vec::with_capacity(cells);
    let mut frontier: Vec<Cell> = Vec::new();
    let mut in_frontier: HashSet<Cell> = HashSet::new();
    let mut next = Cell::new(0, 0);
    loop {
        roi.insert(next);
        order.push(next);
        for n in next.neighbours4() {
            if !roi.contains(&n) && in_frontier.insert(n) {
                frontier.push(n);
            }
        }
        if roi.len() >= cells {
            break;
        }
        let k = rng.random_range(0..frontier.len());
        next = frontier.swap_remove(k);
        in_frontier.remove(&next);
    }
    let start = order[rng.random_range(0..order.len())];
    (roi, start)
}
