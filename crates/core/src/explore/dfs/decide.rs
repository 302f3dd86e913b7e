//! Algorithm 1's decision at a vertex (see [`super`]): which children are candidates, how
//! the robots there are split over them (the paper's split or the nearest frontier, per
//! [`Allocation`]), and how groups are dispatched and merged.

use super::*;

impl Explorer {
    /// Algorithm 1 at the robot's vertex, for its group.
    pub(super) fn decide(&mut self, i: usize) -> Action {
        // Direct transit: vertices passed through without stopping, at most one per tree
        // vertex (a guard; a lone robot's walk towards work does not revisit a vertex).
        let mut passes = 0usize;
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
            if matches!(
                self.config.effective_allocation(),
                Allocation::NearestFrontier | Allocation::Spread
            ) {
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
            if self.config.effective_allocation() == Allocation::Spread
                && let Some(plan) = self.spread(k, v, &group)
            {
                // Robots in group order: the first `plan[0].1` to the first target, …
                let mut from = 0;
                for (to, n) in plan {
                    let chunk: Vec<usize> = group[from..from + n].to_vec();
                    from += n;
                    self.dispatch(&chunk, v, to);
                }
                match self.after_dispatch(i, &mut passes) {
                    Some(action) => return action,
                    None => continue,
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
            match self.after_dispatch(i, &mut passes) {
                Some(action) => return action,
                None => continue,
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

    /// [`Allocation::Spread`] at `v` for the robots `group` (indices) with knowledge index
    /// `ki`: where each share of them goes, as (vertex, how many) in the order of the robots.
    /// A child's *need* is the frontier vertices (nobody reached or was sent to them) of its
    /// subtree less the robots already working in it. One robot to each child in need
    /// (nearest frontier first), then more in turn up to its need; the rest back to the
    /// parent when the frontier outside `v`'s subtree is not covered by the robots out
    /// there, else in turn to the children with a frontier vertex. `None` when no child's
    /// subtree holds a frontier vertex: nearest frontier's rule then applies (back up if the
    /// tree holds one elsewhere, else Algorithm 1's).
    pub(super) fn spread(
        &self,
        ki: usize,
        v: NodeId,
        group: &[usize],
    ) -> Option<Vec<(NodeId, usize)>> {
        let kn = &self.knowledge[ki];
        let k = group.len();
        let mut open: Vec<(u32, usize, NodeId)> = self
            .candidates(kn, v)
            .into_iter()
            .filter_map(|c| {
                let d = self.frontier_depth(kn, c)?;
                let need = self
                    .count_frontier(kn, c)
                    .saturating_sub(self.robots_working_in(c, group));
                Some((d, need, c))
            })
            .collect();
        if open.is_empty() || k == 0 {
            return None;
        }
        // Stable: ties keep Algorithm 1's order.
        open.sort_by_key(|&(d, _, _)| d);
        let outside_need = (self.count_frontier(kn, Tree::ROOT) - self.count_frontier(kn, v))
            .saturating_sub(
                self.robots_working(group)
                    .saturating_sub(self.robots_working_in(v, group)),
            );
        let up = self.tree.node(v).parent.filter(|_| outside_need > 0);
        let mut share = vec![0usize; open.len()];
        let mut left = k;
        loop {
            let mut gave = false;
            for (j, &(_, need, _)) in open.iter().enumerate() {
                if left > 0 && share[j] < need {
                    share[j] += 1;
                    left -= 1;
                    gave = true;
                }
            }
            if !gave || left == 0 {
                break;
            }
        }
        let mut plan: Vec<(NodeId, usize)> = open
            .iter()
            .zip(&share)
            .filter(|&(_, &n)| n > 0)
            .map(|(&(_, _, c), &n)| (c, n))
            .collect();
        if left > 0 {
            match up {
                Some(p) => plan.push((p, left)),
                None => {
                    // Nothing uncovered elsewhere: the rest help where the frontier is.
                    let mut j = 0;
                    while left > 0 {
                        let c = open[j % open.len()].2;
                        match plan.iter_mut().find(|(x, _)| *x == c) {
                            Some(e) => e.1 += 1,
                            None => plan.push((c, 1)),
                        }
                        left -= 1;
                        j += 1;
                    }
                }
            }
        }
        Some(plan)
    }

    /// Robots in the tree (not paused, not done, not in `group`).
    fn robots_working(&self, group: &[usize]) -> usize {
        (0..self.robots.len())
            .filter(|j| !group.contains(j))
            .filter(|&j| !matches!(self.robots[j].phase, Phase::Paused | Phase::Done))
            .count()
    }

    /// Robots (not paused, not done, not in `group`) standing in the subtree of `c` or
    /// headed into it.
    fn robots_working_in(&self, c: NodeId, group: &[usize]) -> usize {
        let inside = |mut n: NodeId| loop {
            if n == c {
                return true;
            }
            match self.tree.node(n).parent {
                Some(p) => n = p,
                None => return false,
            }
        };
        (0..self.robots.len())
            .filter(|j| !group.contains(j))
            .filter(|&j| match self.robots[j].phase {
                Phase::Paused | Phase::Done => false,
                Phase::Moving { to } => inside(to),
                _ => inside(self.robots[j].node),
            })
            .count()
    }

    /// Frontier vertices (real vertices nobody reached or was sent to) in the subtree of
    /// `c`, by knowledge `kn`.
    fn count_frontier(&self, kn: &Knowledge, c: NodeId) -> usize {
        let mut n = 0;
        let mut stack = vec![c];
        while let Some(x) = stack.pop() {
            if kn.explored(x) {
                continue;
            }
            let node = self.tree.node(x);
            if node.kind == NodeKind::Real && !kn.visited(x) && !kn.claimed(x) {
                n += 1;
            }
            stack.extend(node.children.iter().copied());
        }
        n
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
