//! The multi-robot recursive DFS of the runway paper (§4.1, Algorithm 1) as a sans-IO state
//! machine.
//!
//! # Model
//! The ROI is a set of grid cells; the robots start at the root cell (the first positive
//! detection) and, at each vertex, an image tells which of the four neighbours are ROI cells
//! (line 2). Positive neighbours that are not yet in the tree become children of the vertex
//! ("unless those cells have been previously added to the tree. This condition prevents
//! cycles"), so the tree is built online and never has a cycle: lines 9–12 (dropping an
//! under-exploration neighbour whose move would close a cycle) are implied by construction.
//! Each vertex is *unexplored*, *under exploration* or *explored* ([`VertexState`], Fig. 3).
//! The tree is kept binary as it grows (line 15, footnote 3): a third child of a vertex is
//! paired with an existing child slot under a dummy vertex joined by a zero-length edge
//! (`[a, b] + c → [a, dummy{b, c}]`, a fourth at the root gives `[dummy{a, d}, dummy{b, c}]`),
//! over all children, explored or not — so every vertex has at most two children whatever
//! the sensing did (`Tree::attach`). At a vertex, *all* the robots standing there decide
//! together (line 19 splits "the robots at v"): robots of different groups that meet at a
//! vertex are pooled and re-split. They drop the explored children (line 8); with two
//! candidates the robots are split as evenly as possible, ⌈k/2⌉ to the first and ⌊k/2⌋ to
//! the second (line 19); with one the whole pool moves there (line 22); with none the vertex
//! is explored and the pool moves back to the parent (lines 3–5, 24). Candidates nobody has
//! been sent to come before those under exploration (so a lone robot opens new branches
//! first and a robot that finished its branch helps in a sibling branch still under
//! exploration), and a dummy slot (two grid branches) before a single cell. A pool at the
//! root with nothing left to explore is done: every robot ends at the start, and the
//! exploration ends when all robots are back and the root is explored.
//!
//! # Sharing
//! The tree itself (which cells are ROI cells and who is whose child) is built by the GCS,
//! which classifies every image; what robots share is the *vertex states* (line 7):
//! - [`Sharing::Meet`] (the paper's model, after Higashikawa et al. \[12\]): each robot keeps its
//!   own states and two robots exchange everything they know when they are at the same cell
//!   at the same time, or pass each other on the same edge;
//! - [`Sharing::Gcs`]: every robot decides on the global states (the GCS hears every robot).
//!
//! Lemma 1 needs more than meetings. Its proof (eq. 1, the reward argument of Higashikawa
//! et al.) needs the robots to collect reward at rate 1 + ⌊log₂ R⌋ until the last leaf is
//! reached, i.e. never to walk forward again over a rib edge another group already took.
//! With meeting-only sharing a robot that finished its branch and goes to help a sibling
//! branch cannot know which child the robots there took, and line 20 ("move to one of two
//! children") lets it take the same one. Smallest case (`tests::meeting_sharing_can_exceed_lemma_1`,
//! worked by hand in docs/results/dfs.md): 7 cells, 2 robots, the start with three children;
//! the robot back from the one-cell branch follows the other into the branch it is doing,
//! and the team is home at t = 10 where eq. (2) allows 9 (GCS sharing: 6). Every meeting-only
//! run above the bound that we have seen made at least one *uninformed* decision
//! ([`Explorer::uninformed_decisions`]: a decision a fully informed team would have made
//! differently); with [`Sharing::Gcs`] there are none. So the GCS's global view is the
//! default, and the meeting model is kept for the study.
//!
//! # Allocation
//! [`ExplorerConfig::allocation`] chooses how the robots at a vertex are sent on:
//! - [`Allocation::Paper`]: Algorithm 1 as above.
//! - [`Allocation::NearestFrontier`] (GCS sharing only): a *frontier* vertex is a real vertex
//!   nobody has reached or been sent to (a known ROI cell, left behind at a branch). The
//!   non-explored children whose subtree holds a frontier vertex are the candidates, the one
//!   with the shallowest such vertex first (ties in Algorithm 1's order), split as in
//!   line 19 or taken whole as in line 22. If no child's subtree holds one but the tree does
//!   elsewhere, the robots go back to the parent (line 24's move, made before v is explored)
//!   rather than follow another group into a subtree with nothing left to open. With no
//!   frontier anywhere, Algorithm 1's rule applies (the groups still out may find more).
//!
//! - [`Allocation::Spread`] (GCS sharing only): nearest frontier, the robots at v spread
//!   over the frontier rather than halved: one to each child whose subtree holds a frontier
//!   vertex, then more up to one per frontier vertex there, the rest back up when a frontier
//!   vertex lies elsewhere; each robot decides on reaching the start.
//!
//! The tree, the dummies and the vertex states are built exactly as before, so the tree is
//! binary and every robot's move is a tree edge. Every robot either moves towards a frontier
//! vertex along the tree path (which stays finite: vertices only become non-frontier) or
//! acts as Algorithm 1, so every ROI cell is reached, and the exploration ends with every
//! robot at the start. With one robot the two allocations make the same moves (a lone robot
//! only leaves a child when it is explored, so every non-explored child is itself a frontier
//! vertex at the same depth): eq. (8) and the single-robot bounds carry over unchanged. For
//! R > 1 we have no proof that Lemma 1 still holds (the reward argument of Higashikawa et al.
//! is written for the paper's split); it is checked, not proved — by the property test
//! `nearest_frontier_covers_terminates_and_meets_lemma_1` and on the Fig. 7 trials (see
//! docs/results/dfs.md, "Allocation").
//!
//! # Driving it (per robot)
//! ```text
//! loop {
//!     match explorer.next_action(robot)? {
//!         Action::Rejoin(cell) | Action::MoveTo(cell) => { fly to cell; explorer.arrived(robot, cell)? }
//!         Action::Observe => { image the cell; explorer.observe(robot, cell, labels)? }
//!         Action::Wait => { wait until another robot's call changed something }
//!         Action::ReturnHome => { the robot is paused: fly it home; later explorer.resume(robot)? }
//!         Action::Done => { at the start, nothing left: land }
//!     }
//!     persist(serde_json::to_vec(&explorer)); // all state is serialisable
//! }
//! ```
//! `MoveTo` names a 4-neighbour of the robot's cell along a tree edge (every path runs over
//! known ROI cells) — or, with direct transit, the first vertex past a run of imaged ones
//! that a lone robot passes through without stopping; `Rejoin` is the transit from wherever
//! the robot is (its sweep, or home after a battery swap) to the start or to its saved
//! vertex.
//!
//! # Where fleetmap departs from Algorithm 1 (the field's rules)
//! - [`Allocation::Spread`] (above, and docs/results/dfs.md).
//! - Direct transit ([`ExplorerConfig::direct_transit`]): a lone robot passes imaged
//!   vertices without stopping and flies straight on.
//! - Handover ([`Explorer::pause`]): a robot leaving for a battery swap releases the vertex
//!   it was headed to.
//! - Home when the map is done (`Explorer::finish_where_it_is`): no walk back to the start.
//!
//! None changes how the tree is built or the vertex states; the property test
//! `direct_transit_covers_and_terminates` (tests/suite/explore.rs) checks §4's invariants with
//! the first two. Direct transit is outside Lemma 1 (`direct_transit_can_exceed_lemma_1`: a
//! robot's destination done by another before it arrives).

mod decide;
mod knowledge;
mod tree;

pub use tree::{Node, NodeId, NodeKind, Tree};

use super::ExploreError;
use crate::geo::{Cell, Dir4};
use knowledge::Knowledge;
use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;
use std::fmt;

/// A robot of the exploration team (the runner maps it to a MAVLink system id).
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize, Default,
)]
#[serde(transparent)]
pub struct RobotId(pub u8);

impl fmt::Display for RobotId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// How robots learn the vertex states (see the module documentation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Sharing {
    /// Robots exchange states when they meet at a vertex or on an edge (the paper's model).
    Meet,
    /// Every robot uses the global states held by the GCS (the default: it is what a GCS
    /// that hears every robot has, and the only one of the two under which Lemma 1 holds
    /// in our measurements — see the module documentation).
    #[default]
    Gcs,
}

impl fmt::Display for Sharing {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Sharing::Meet => "meet",
            Sharing::Gcs => "gcs",
        })
    }
}

pub use crate::mission::strategy::Allocation;

/// Options of the explorer. Fields missing from a saved state take their defaults.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ExplorerConfig {
    /// How vertex states are shared.
    #[serde(default)]
    pub sharing: Sharing,
    /// How the robots at a vertex are allocated (only [`Sharing::Gcs`] tells them apart). An
    /// explorer saved before this field existed ran the paper's split and keeps it on resume.
    #[serde(default = "Allocation::paper")]
    pub allocation: Allocation,
    /// Direct transit (fleetmap's rule, [`Sharing::Gcs`] only): a robot travelling alone
    /// through vertices already imaged does not stop at each of them. The decisions
    /// Algorithm 1 would make there (with what the team knows now) are made at once, and
    /// the robot flies straight to the first vertex where something is left to do — one not
    /// imaged yet, or one where other robots stand or are headed (so groups still pool as
    /// in line 19). The straight flight is never longer than the tree path (triangle
    /// inequality), so no robot reaches a vertex later than by the walk it replaces; the
    /// tree, the vertex states and the moves counted (one per tree edge passed) are as in
    /// the walk. [`Action::MoveTo`] may then name a vertex several edges away. Off in the
    /// paper's model (the Fig. 7 study) and in explorers saved before it existed.
    #[serde(default)]
    pub direct_transit: bool,
}

impl ExplorerConfig {
    /// The allocation that actually runs: `allocation` with [`Sharing::Gcs`], always
    /// [`Allocation::Paper`] with [`Sharing::Meet`] (nearest-frontier needs the global view).
    /// What a field report should name.
    pub fn effective_allocation(&self) -> Allocation {
        match self.sharing {
            Sharing::Gcs => self.allocation,
            Sharing::Meet => Allocation::Paper,
        }
    }
}

/// What a robot should do next.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Action {
    /// Fly to the centre of this cell — a 4-neighbour of the robot's cell, along a tree
    /// edge — then call [`Explorer::arrived`].
    MoveTo(Cell),
    /// Fly from wherever the robot is (its sweep, or home after a battery swap) to the centre
    /// of this cell (the start, or the robot's saved vertex), then call [`Explorer::arrived`].
    Rejoin(Cell),
    /// Image the current cell and call [`Explorer::observe`] with the neighbour labels.
    Observe,
    /// Nothing to do until another robot's call changes the state (group members still on
    /// their way, or another robot imaging this cell): ask again after the next call.
    Wait,
    /// The robot is paused (battery swap, operator): fly it home; its vertex is saved and
    /// [`Explorer::resume`] brings it back.
    ReturnHome,
    /// The robot is at the start and, as far as it knows, everything is explored: land.
    Done,
}

/// The state of a vertex (§4.1, Fig. 3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VertexState {
    /// No robot has visited it (or been sent to it).
    Unexplored,
    /// Visited (or being flown to), but part of its subtree is not yet visited.
    UnderExploration,
    /// It and its whole subtree were visited.
    Explored,
}

/// What a robot is doing, as the explorer sees it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Phase {
    /// Flying to `node` from outside the tree (start of the exploration, or after `resume`).
    Rejoining,
    /// Standing at `node`, ready for a decision.
    AtVertex,
    /// Standing at `node`, imaging it.
    Observing,
    /// Flying along a tree edge from `node` to `to`.
    Moving {
        /// Destination vertex.
        to: NodeId,
    },
    /// Out of the exploration (battery swap); `node` is where it resumes.
    Paused,
    /// Back at the start with nothing left to explore.
    Done,
}

impl Phase {
    fn name(&self) -> &'static str {
        match self {
            Phase::Rejoining => "rejoining",
            Phase::AtVertex => "at a vertex",
            Phase::Observing => "observing",
            Phase::Moving { .. } => "moving",
            Phase::Paused => "paused",
            Phase::Done => "done",
        }
    }
}

/// One robot's place in the exploration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RobotState {
    /// The robot.
    pub id: RobotId,
    /// The vertex it last reached (its saved position in the tree).
    pub node: NodeId,
    /// What it is doing.
    pub phase: Phase,
    /// The group it travels with (itself included, sorted): it decides with them at the
    /// next vertex (Algorithm 1, line 19 splits the robots *at* a vertex).
    pub(crate) companions: Vec<RobotId>,
    /// Tree edges of length 1 it has flown.
    pub moves: u64,
}

/// The multi-robot recursive DFS (see the module documentation). All state is
/// serialisable: persist it after every call and deserialise it to resume.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Explorer {
    config: ExplorerConfig,
    tree: Tree,
    robots: Vec<RobotState>,
    /// One per robot with [`Sharing::Meet`], a single shared one with [`Sharing::Gcs`].
    knowledge: Vec<Knowledge>,
    /// Cells labelled negative and (so far) never positive: the known non-ROI cells.
    negatives: BTreeSet<Cell>,
    /// Number of `observe` calls.
    observations: u64,
    /// With [`Sharing::Meet`]: what all robots know together (every visit and every claim),
    /// kept only to tell when a robot decides differently from a robot that knew it all.
    #[serde(default)]
    team: Knowledge,
    /// With [`Sharing::Meet`]: decisions whose targets differ from those the same robots
    /// would have chosen with the whole team's knowledge ([`Explorer::uninformed_decisions`]).
    #[serde(default)]
    uninformed: u64,
}

impl Explorer {
    /// A new exploration rooted at `start` (an ROI cell: the first positive detection) with
    /// `robots`, which all begin by flying to the start ([`Action::Rejoin`]) and leave it
    /// together as one group.
    pub fn new(
        config: ExplorerConfig,
        start: Cell,
        robots: &[RobotId],
    ) -> Result<Explorer, ExploreError> {
        if robots.is_empty() {
            return Err(ExploreError::NoRobots);
        }
        let mut ids = robots.to_vec();
        ids.sort();
        if let Some(w) = ids.windows(2).find(|w| w[0] == w[1]) {
            return Err(ExploreError::DuplicateRobot(w[0]));
        }
        // Spread: each robot decides on reaching the start, not waiting for the others.
        let alone = config.effective_allocation() == Allocation::Spread;
        let states = robots
            .iter()
            .map(|&id| RobotState {
                id,
                node: Tree::ROOT,
                phase: Phase::Rejoining,
                companions: if alone { vec![id] } else { ids.clone() },
                moves: 0,
            })
            .collect();
        let nk = match config.sharing {
            Sharing::Meet => robots.len(),
            Sharing::Gcs => 1,
        };
        Ok(Explorer {
            config,
            tree: Tree::new(start),
            robots: states,
            knowledge: vec![Knowledge::default(); nk],
            negatives: BTreeSet::new(),
            observations: 0,
            team: Knowledge::default(),
            uninformed: 0,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &ExplorerConfig {
        &self.config
    }

    /// The tree built so far.
    pub fn tree(&self) -> &Tree {
        &self.tree
    }

    /// The start (root) cell.
    pub fn start(&self) -> Cell {
        self.tree.node(Tree::ROOT).cell
    }

    /// Every robot's state, in the order given to [`Explorer::new`].
    pub fn robots(&self) -> &[RobotState] {
        &self.robots
    }

    /// One robot's state.
    pub fn robot(&self, robot: RobotId) -> Result<&RobotState, ExploreError> {
        Ok(&self.robots[self.idx(robot)?])
    }

    /// The cell a robot last reached (where it resumes after a pause).
    pub fn robot_cell(&self, robot: RobotId) -> Result<Cell, ExploreError> {
        let r = self.robot(robot)?;
        Ok(self.tree.node(r.node).cell)
    }

    #[cfg(test)]
    /// Cells labelled negative and never positive (known non-ROI cells).
    pub(crate) fn negatives(&self) -> &BTreeSet<Cell> {
        &self.negatives
    }

    /// With [`Sharing::Meet`], how many decisions (Algorithm 1 at a vertex, for the robots
    /// there) sent robots elsewhere than the same rule would have with everything the team
    /// knew at that moment — a robot following into a branch another group already took,
    /// or walking into a subtree already explored. Always 0 with [`Sharing::Gcs`]. A run
    /// with no such decision made exactly the decisions of a fully informed team.
    pub fn uninformed_decisions(&self) -> u64 {
        self.uninformed
    }

    /// d_max of the tree built so far (§4.2).
    pub fn d_max(&self) -> u32 {
        self.tree.d_max()
    }

    fn idx(&self, robot: RobotId) -> Result<usize, ExploreError> {
        self.robots
            .iter()
            .position(|r| r.id == robot)
            .ok_or(ExploreError::UnknownRobot(robot))
    }

    fn kidx(&self, i: usize) -> usize {
        match self.config.sharing {
            Sharing::Meet => i,
            Sharing::Gcs => 0,
        }
    }

    fn cell(&self, n: NodeId) -> Cell {
        self.tree.node(n).cell
    }

    #[cfg(test)]
    fn state_in(&self, k: usize, n: NodeId) -> VertexState {
        let kn = &self.knowledge[k];
        if kn.explored(n) {
            VertexState::Explored
        } else if kn.visited(n) || kn.claimed(n) {
            VertexState::UnderExploration
        } else {
            VertexState::Unexplored
        }
    }

    /// What everyone knows together (the GCS's view, for reports and the UI).
    fn global(&self) -> Knowledge {
        let mut g = self.knowledge[0].clone();
        for k in &self.knowledge[1..] {
            g.merge(&self.tree, k);
        }
        g
    }

    /// The global state of every tree cell (what all robots know together), in tree order.
    pub fn vertex_states(&self) -> Vec<(Cell, VertexState)> {
        let g = self.global();
        let mut out = Vec::with_capacity(self.tree.real_count());
        for (i, n) in self.tree.nodes().iter().enumerate() {
            if n.kind == NodeKind::Real {
                let id = NodeId(i as u32);
                let s = if g.explored(id) {
                    VertexState::Explored
                } else if g.visited(id) || g.claimed(id) {
                    VertexState::UnderExploration
                } else {
                    VertexState::Unexplored
                };
                out.push((n.cell, s));
            }
        }
        out
    }

    /// The global state of `cell`, or `None` if it is not in the tree.
    pub fn vertex_state(&self, cell: Cell) -> Option<VertexState> {
        self.tree.real(cell)?;
        self.vertex_states()
            .into_iter()
            .find(|(c, _)| *c == cell)
            .map(|(_, s)| s)
    }

    #[cfg(test)]
    /// The state of `cell` as `robot` knows it (differs from the global one with
    /// [`Sharing::Meet`]).
    pub(crate) fn vertex_state_known_by(
        &self,
        robot: RobotId,
        cell: Cell,
    ) -> Result<Option<VertexState>, ExploreError> {
        let i = self.idx(robot)?;
        Ok(self.tree.real(cell).map(|n| self.state_in(self.kidx(i), n)))
    }

    /// Whether the exploration is over: every vertex explored and every robot back at the
    /// start (or paused, i.e. at home).
    pub fn is_finished(&self) -> bool {
        self.robots
            .iter()
            .all(|r| matches!(r.phase, Phase::Done | Phase::Paused))
            && self.global().explored(Tree::ROOT)
    }

    /// The next action of `robot`. May make the decision of Algorithm 1 for the robot's
    /// whole group (when all of it is at the vertex), so call it again for every robot after
    /// any change.
    pub fn next_action(&mut self, robot: RobotId) -> Result<Action, ExploreError> {
        let i = self.idx(robot)?;
        let r = &self.robots[i];
        Ok(match r.phase {
            Phase::Rejoining => Action::Rejoin(self.cell(r.node)),
            Phase::Moving { to } => {
                if self.pass_through(i, to) {
                    self.decide(i)
                } else {
                    Action::MoveTo(self.cell(to))
                }
            }
            Phase::Paused => Action::ReturnHome,
            Phase::Observing => Action::Observe,
            Phase::Done => {
                if r.node == Tree::ROOT && self.knowledge[self.kidx(i)].explored(Tree::ROOT) {
                    Action::Done
                } else {
                    // A later positive label re-opened part of the tree: go back to work,
                    // alone (the rest of the old group decides for itself).
                    let me = r.id;
                    self.robots[i].phase = Phase::AtVertex;
                    self.robots[i].companions = vec![me];
                    self.decide(i)
                }
            }
            Phase::AtVertex => self.decide(i),
        })
    }

    /// What robot `i` does once a decision has set its phase: move (or, by direct transit
    /// through `to`, decide again there: `None`, counted in `passes`, at most one pass per
    /// vertex of the tree), decide again at a vertex reached by a zero-length (dummy) edge
    /// (`None`), be done, or wait.
    pub(super) fn after_dispatch(&mut self, i: usize, passes: &mut usize) -> Option<Action> {
        match self.robots[i].phase {
            Phase::Moving { to } => {
                if *passes < self.tree.len() && self.pass_through(i, to) {
                    *passes += 1;
                    return None;
                }
                Some(Action::MoveTo(self.cell(to)))
            }
            Phase::AtVertex => None,
            Phase::Done => Some(Action::Done),
            _ => Some(Action::Wait),
        }
    }

    /// Whether a robot other than `i` stands at `cell`, images it, rejoins to it or is headed
    /// there (paused and finished robots are nowhere).
    fn others_at(&self, i: usize, cell: Cell) -> bool {
        self.robots.iter().enumerate().any(|(j, o)| {
            j != i
                && match o.phase {
                    Phase::Moving { to } => self.cell(to) == cell,
                    Phase::AtVertex | Phase::Observing | Phase::Rejoining => {
                        self.cell(o.node) == cell
                    }
                    Phase::Paused | Phase::Done => false,
                }
        })
    }

    /// Direct transit ([`ExplorerConfig::direct_transit`]): robot `i`, sent along the edge to
    /// `to`, passes through it without stopping when it travels alone, `to` is already
    /// imaged, and no other robot stands there or is headed there. Then it counts as having
    /// arrived (one move) and decides there at once. Returns whether it did.
    pub(super) fn pass_through(&mut self, i: usize, to: NodeId) -> bool {
        if !self.config.direct_transit || self.config.sharing != Sharing::Gcs {
            return false;
        }
        let r = &self.robots[i];
        if r.phase != (Phase::Moving { to }) || r.companions != [r.id] {
            return false;
        }
        let node = self.tree.node(to);
        if node.kind != NodeKind::Real || !node.observed {
            return false;
        }
        if self.others_at(i, node.cell) {
            return false;
        }
        self.robots[i].moves += 1;
        self.robots[i].node = to;
        self.robots[i].phase = Phase::AtVertex;
        let k = self.kidx(i);
        self.knowledge[k].visit(&self.tree, to);
        true
    }

    /// The runner reports that `robot` reached the centre of `cell` (after `MoveTo` or
    /// `Rejoin`).
    pub fn arrived(&mut self, robot: RobotId, cell: Cell) -> Result<(), ExploreError> {
        let i = self.idx(robot)?;
        let r = &self.robots[i];
        let node = match r.phase {
            Phase::Moving { to } => to,
            Phase::Rejoining => r.node,
            other => {
                return Err(ExploreError::NotMoving {
                    robot,
                    cell,
                    phase: other.name(),
                });
            }
        };
        let expected = self.cell(node);
        if cell != expected {
            return Err(ExploreError::WrongCell {
                robot,
                cell,
                expected,
            });
        }
        if matches!(r.phase, Phase::Moving { .. }) {
            self.robots[i].moves += 1;
        }
        self.robots[i].node = node;
        self.robots[i].phase = Phase::AtVertex;
        let k = self.kidx(i);
        self.knowledge[k].visit(&self.tree, node);
        if self.config.sharing == Sharing::Meet {
            self.team.visit(&self.tree, node);
        }
        if self.config.sharing == Sharing::Meet {
            let here: Vec<usize> = self
                .robots
                .iter()
                .enumerate()
                .filter(|(_, r)| {
                    matches!(r.phase, Phase::AtVertex | Phase::Observing | Phase::Done)
                        && self.tree.node(r.node).cell == cell
                })
                .map(|(j, _)| j)
                .collect();
            self.merge(&here);
        }
        Ok(())
    }

    /// The runner reports what an image taken by `robot` at `cell` showed: `labels[i]` says
    /// whether the neighbour in direction `Dir4::ALL[i]` (north, west, south, east) is an ROI
    /// cell. Positive neighbours not yet in the tree become children of `cell`; a positive is
    /// never removed, and a negative is overridden by any later positive (§7). Returns the
    /// cells added to the tree.
    pub fn observe(
        &mut self,
        robot: RobotId,
        cell: Cell,
        labels: [bool; 4],
    ) -> Result<Vec<Cell>, ExploreError> {
        let i = self.idx(robot)?;
        let r = &self.robots[i];
        if !matches!(
            r.phase,
            Phase::AtVertex | Phase::Observing | Phase::Done | Phase::Paused
        ) {
            return Err(ExploreError::CannotObserve {
                robot,
                phase: r.phase.name(),
            });
        }
        let at = self.cell(r.node);
        if at != cell {
            return Err(ExploreError::ObservedElsewhere { robot, cell, at });
        }
        let v = self.tree.real_of(r.node);
        let mut added = Vec::new();
        for (d, positive) in Dir4::ALL.into_iter().zip(labels) {
            let n = cell.step(d);
            if positive {
                self.negatives.remove(&n);
                if !self.tree.contains(n) {
                    let (_, dummy) = self.tree.attach(v, n);
                    if let Some(d) = dummy {
                        // The dummy takes the place of an existing child slot: it is under
                        // exploration for whoever knew that slot was.
                        let slot = self.tree.node(d).children[0];
                        for k in self.knowledge.iter_mut().chain([&mut self.team]) {
                            if k.visited(slot) || k.claimed(slot) || k.explored(slot) {
                                k.claim(d);
                            }
                            k.refresh(&self.tree, d);
                        }
                    }
                    added.push(n);
                }
            } else if !self.tree.contains(n) {
                self.negatives.insert(n);
            }
        }
        self.tree.set_observed(v);
        for k in self.knowledge.iter_mut().chain([&mut self.team]) {
            k.refresh(&self.tree, v);
        }
        if self.robots[i].phase == Phase::Observing {
            self.robots[i].phase = Phase::AtVertex;
        }
        self.observations += 1;
        Ok(added)
    }

    /// Take `robot` out of the exploration (battery swap, operator): it leaves its group,
    /// which carries on without it, and keeps its vertex to resume from. Idempotent.
    ///
    /// Handover (fleetmap's rule, [`Sharing::Gcs`]): the vertex it was flying to or was
    /// about to image, not yet imaged and with no other robot there or headed there, is
    /// released — unexplored again, as if it had never been sent there — so the robots
    /// still in the tree take it (Algorithm 1 opens unexplored children first; nearest
    /// frontier and spread count it as frontier). Without it the vertex would stay "under
    /// exploration" with nobody working on it until the robot is back from its swap.
    pub fn pause(&mut self, robot: RobotId) -> Result<(), ExploreError> {
        let i = self.idx(robot)?;
        if self.robots[i].phase == Phase::Paused {
            return Ok(());
        }
        if self.config.sharing == Sharing::Gcs {
            let r = &self.robots[i];
            let pending = match r.phase {
                Phase::Moving { to } => Some(to),
                Phase::AtVertex | Phase::Observing | Phase::Rejoining => Some(r.node),
                Phase::Paused | Phase::Done => None,
            };
            if let Some(n) = pending
                && !self.others_at(i, self.cell(n))
            {
                self.knowledge[0].release(&self.tree, n);
            }
        }
        for r in &mut self.robots {
            r.companions.retain(|&c| c != robot);
        }
        self.robots[i].companions = vec![robot];
        self.robots[i].phase = Phase::Paused;
        Ok(())
    }

    /// A paused robot that knows every vertex is explored has nothing to come back for: it
    /// is done where it is (at home, which ends its tour as the start does for the others).
    /// Returns whether it was retired.
    pub(crate) fn retire(&mut self, robot: RobotId) -> Result<bool, ExploreError> {
        let i = self.idx(robot)?;
        if self.robots[i].phase != Phase::Paused
            || !self.knowledge[self.kidx(i)].explored(Tree::ROOT)
        {
            return Ok(false);
        }
        self.robots[i].node = Tree::ROOT;
        self.robots[i].phase = Phase::Done;
        Ok(true)
    }

    /// Home when the map is done (fleetmap's rule; Algorithm 1 walks every robot back to the
    /// start, lines 3–5 and 24): once every vertex of the tree is explored by what the whole
    /// team knows, a robot still in the tree has nothing left to reach — walking back only
    /// re-walks edges whose reward was collected — so its tour ends where it is and the
    /// runner flies it straight home. It leaves its group (the others decide without
    /// waiting for it), and counts as back at the start ([`Explorer::is_finished`]). Changes
    /// no vertex state, so the map and every cell's decision are those of the full walk; and
    /// since it only shortens tours after the last vertex is reached, every bound of the
    /// paper on the time to the last vertex (Lemma 1, eq. 8) is untouched. Returns whether
    /// the robot was finished (false while part of the tree is not explored, or when it is
    /// paused or already done).
    pub(crate) fn finish_where_it_is(&mut self, robot: RobotId) -> Result<bool, ExploreError> {
        let i = self.idx(robot)?;
        if matches!(self.robots[i].phase, Phase::Paused | Phase::Done) {
            return Ok(false);
        }
        let global = self.global();
        if !global.explored(Tree::ROOT) {
            return Ok(false);
        }
        for r in &mut self.robots {
            r.companions.retain(|&c| c != robot);
        }
        let k = self.kidx(i);
        // With meeting sharing the GCS tells it what the team knows (it could not learn
        // it otherwise before it is back at the start).
        self.knowledge[k] = global;
        self.robots[i].companions = vec![robot];
        self.robots[i].node = Tree::ROOT;
        self.robots[i].phase = Phase::Done;
        Ok(true)
    }

    /// Bring a paused robot back: it flies to its saved vertex ([`Action::Rejoin`]) and
    /// carries on from there alone — or straight to the start if it knows everything is
    /// already explored.
    pub fn resume(&mut self, robot: RobotId) -> Result<(), ExploreError> {
        let i = self.idx(robot)?;
        if self.robots[i].phase != Phase::Paused {
            return Err(ExploreError::NotPaused(robot));
        }
        if self.knowledge[self.kidx(i)].explored(Tree::ROOT) {
            self.robots[i].node = Tree::ROOT;
        }
        self.robots[i].phase = Phase::Rejoining;
        Ok(())
    }
}

#[cfg(test)]
mod team_tests;
#[cfg(test)]
mod tests;
