//! Algorithm 1's decision at a vertex (see [`super`]): which children are candidates, how
//! the robots there are split over them (the paper's split or the nearest frontier, per
//! [`Allocation`]), and how groups are dispatched and merged.

use super::*;

impl Explorer {
    /// Algorithm 1 at the robot's vertex, for its group.
    pub(super) fn decide(&mut self, i: usize) -> Action {
        loop {
            let v = self.robots[i].node;
            let vcell = self.cell(v);
            // Line 2: observe N(v) (once per cell, by the first robot there).
            let real = self.tree.real_of(v);
            if !self.tree.node(real).observed {
                let busy = self
                    .robots
                    .iter()
                    .any(|r| r.phase == Phase::Observing && self.tree.node(r.node).cell == vcell);
                if busy {
                    return Action::Wait;
                }
                self.robots[i].phase = Phase::Observing;
                return Action::Observe;
            }
            // Line 19 splits "the robots at v": every robot standing at v decides together,
            // whichever group it came with (robots of different groups that meet at a vertex
            // are pooled and re-split). Robots travelling together arrive together, so wait
            // until every companion of the robots here has arrived too.
            let group: Vec<usize> = (0..self.robots.len())
                .filter(|&j| self.robots[j].phase == Phase::AtVertex && self.robots[j].node == v)
                .collect();
            let all_here = group.iter().all(|&j| {
                self.robots[j].companions.iter().all(|c| {
                    self.robots
                        .iter()
                        .find(|r| r.id == *c)
                        .is_none_or(|r| r.phase == Phase::AtVertex && r.node == v)
                })
            });
            if !all_here {
                return Action::Wait;
            }
            // Line 7: the robots at v tell each other what they know.
            self.merge(&group);
            let k = self.kidx(i);
            let mut cands = self.candidates(&self.knowledge[k], v);
            // Nearest-frontier allocation: `up` sends the robots back to the parent although
            // a child is not explored (nothing is left to open in it, something is elsewhere).
            let mut up = false;
            if self.config.effective_allocation() == Allocation::NearestFrontier {
                let kn = &self.knowledge[k];
                let mut open: Vec<(u32, NodeId)> = cands
                    .iter()
                    .filter_map(|&c| self.frontier_depth(kn, c).map(|d| (d, c)))
                    .collect();
                if !open.is_empty() {
                    // Stable: ties keep Algorithm 1's order.
                    open.sort_by_key(|&(d, _)| d);
                    cands = open.into_iter().map(|(_, c)| c).collect();
                } else if self.tree.node(v).parent.is_some() && self.any_frontier(kn) {
                    up = true;
                }
            }
            if self.config.sharing == Sharing::Meet {
                let informed = self.candidates(&self.team, v);
                let n = if group.len() == 1 { 1 } else { 2 };
                if cands.iter().take(n).ne(informed.iter().take(n)) {
                    self.uninformed += 1;
                }
            }
            if cands.is_empty() || up {
                // Lines 3–5, 23–24: v is explored (or, nearest-frontier, has nothing left to
                // open); go back to the parent.
                match self.tree.node(v).parent {
                    None => {
                        let ids: Vec<RobotId> = group.iter().map(|&j| self.robots[j].id).collect();
                        for &j in &group {
                            self.robots[j].phase = Phase::Done;
                            self.robots[j].companions = ids.clone();
                        }
                        return Action::Done;
                    }
                    Some(p) => self.dispatch(&group, v, p),
                }
            } else if cands.len() == 1 || group.len() == 1 {
                // Line 22 (or a lone robot at a branch: "move to one of two children").
                self.dispatch(&group, v, cands[0]);
            } else {
                // Lines 19–20: split as evenly as possible. Both halves saw the split, so
                // both know where the other went.
                let h = group.len().div_ceil(2);
                for &j in &group {
                    let k = self.kidx(j);
                    self.knowledge[k].claim(cands[0]);
                    self.knowledge[k].claim(cands[1]);
                }
                self.team.claim(cands[0]);
                self.team.claim(cands[1]);
                self.dispatch(&group[..h], v, cands[0]);
                self.dispatch(&group[h..], v, cands[1]);
            }
            match self.robots[i].phase {
                Phase::Moving { to } => return Action::MoveTo(self.cell(to)),
                // A zero-length (dummy) edge: decide again at the new vertex.
                Phase::AtVertex => continue,
                Phase::Done => return Action::Done,
                _ => return Action::Wait,
            }
        }
    }

    /// Lines 8–17 of Algorithm 1 at `v` with knowledge `kn`: the children of `v` that are
    /// not explored, new branches first, then the slot standing for more grid branches.
    /// Line 8: N(v) ← N(v) \ explored. Lines 9–12 (dropping a neighbour whose move would
    /// close a cycle) hold by construction of the tree; lines 15–17 (dummies) are applied as
    /// the tree grows ([`Tree::attach`]), so there are at most two candidates.
    pub(super) fn candidates(&self, kn: &Knowledge, v: NodeId) -> Vec<NodeId> {
        let mut cands: Vec<NodeId> = self
            .tree
            .node(v)
            .children
            .iter()
            .copied()
            .filter(|&c| !kn.explored(c))
            .collect();
        debug_assert!(cands.len() <= 2, "the tree is binary");
        let state = |c: NodeId| {
            if kn.visited(c) || kn.claimed(c) {
                VertexState::UnderExploration
            } else {
                VertexState::Unexplored
            }
        };
        cands.sort_by_key(|&c| {
            (
                state(c) != VertexState::Unexplored,
                std::cmp::Reverse(self.tree.branches(c)),
            )
        });
        cands
    }

    /// The smallest depth (tree distance from the root, §4.2: real edges 1, dummy edges 0)
    /// of an unexplored real vertex — a known ROI cell nobody has reached or been sent to —
    /// in the subtree of `c`, by knowledge `kn`; `None` if there is none.
    pub(super) fn frontier_depth(&self, kn: &Knowledge, c: NodeId) -> Option<u32> {
        let mut best: Option<u32> = None;
        let mut stack = vec![c];
        while let Some(n) = stack.pop() {
            if kn.explored(n) {
                continue;
            }
            let node = self.tree.node(n);
            if best.is_some_and(|b| node.depth >= b) {
                continue;
            }
            if node.kind == NodeKind::Real && !kn.visited(n) && !kn.claimed(n) {
                best = Some(node.depth);
                continue;
            }
            stack.extend(node.children.iter().copied());
        }
        best
    }

    /// Whether any real vertex of the tree is unexplored by knowledge `kn`.
    pub(super) fn any_frontier(&self, kn: &Knowledge) -> bool {
        self.tree.nodes().iter().enumerate().any(|(i, n)| {
            let id = NodeId(i as u32);
            n.kind == NodeKind::Real && !kn.visited(id) && !kn.claimed(id) && !kn.explored(id)
        })
    }

    /// Send `group` (robot indices) from `from` to the adjacent vertex `to`.
    pub(super) fn dispatch(&mut self, group: &[usize], from: NodeId, to: NodeId) {
        let ids: Vec<RobotId> = group.iter().map(|&j| self.robots[j].id).collect();
        for &j in group {
            let k = self.kidx(j);
            self.knowledge[k].claim(to);
            self.robots[j].companions = ids.clone();
        }
        if self.config.sharing == Sharing::Meet {
            self.team.claim(to);
        }
        if self.cell(to) == self.cell(from) {
            for &j in group {
                self.robots[j].node = to;
                self.robots[j].phase = Phase::AtVertex;
            }
            return;
        }
        for &j in group {
            self.robots[j].phase = Phase::Moving { to };
        }
        if self.config.sharing == Sharing::Meet {
            // Robots flying the same edge the other way pass this group: they meet.
            let (a, b) = (self.cell(from), self.cell(to));
            let mut meeting: Vec<usize> = group.to_vec();
            for (j, r) in self.robots.iter().enumerate() {
                if let Phase::Moving { to: x } = r.phase
                    && self.cell(x) == a
                    && self.cell(r.node) == b
                {
                    meeting.push(j);
                }
            }
            if meeting.len() > group.len() {
                self.merge(&meeting);
            }
        }
    }

    /// Robots `who` (indices) tell each other everything they know (meeting sharing).
    pub(super) fn merge(&mut self, who: &[usize]) {
        if self.config.sharing != Sharing::Meet || who.len() < 2 {
            return;
        }
        let mut all = self.knowledge[who[0]].clone();
        let mut changed = false;
        for &j in &who[1..] {
            changed |= all.merge(&self.tree, &self.knowledge[j]);
        }
        if !changed && who.iter().all(|&j| self.knowledge[j] == all) {
            return;
        }
        for &j in who {
            self.knowledge[j] = all.clone();
        }
    }
}
