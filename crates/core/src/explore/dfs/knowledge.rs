//! What one robot (or, with GCS sharing, the whole team) knows about the vertex states of the
//! tree: which vertices were visited, which ones a group was sent to, and which ones are
//! explored.
//!
//! The three states of §4.1 follow from these facts:
//! *unexplored* — nobody visited the vertex (nor was sent to it);
//! *under exploration* — visited (or being flown to) but some vertex of its subtree is not;
//! *explored* — the vertex and every vertex below it were visited ("the vertex as well as the
//! leaf vertex in the same branch are visited", Fig. 3). A dummy vertex is explored when both
//! its children are. Explored states propagate upward as soon as the last leaf of a subtree
//! is visited.

use super::tree::{NodeId, NodeKind, Tree};
use serde::{Deserialize, Serialize};

/// A growable set of small integers.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(transparent)]
pub(crate) struct BitSet(Vec<u64>);

impl BitSet {
    pub(crate) fn get(&self, i: usize) -> bool {
        self.0.get(i / 64).is_some_and(|w| w >> (i % 64) & 1 == 1)
    }

    pub(crate) fn set(&mut self, i: usize, v: bool) {
        let w = i / 64;
        if w >= self.0.len() {
            if !v {
                return;
            }
            self.0.resize(w + 1, 0);
        }
        if v {
            self.0[w] |= 1 << (i % 64);
        } else {
            self.0[w] &= !(1 << (i % 64));
        }
    }

    /// `self |= other`; whether anything changed.
    pub(crate) fn union_with(&mut self, other: &BitSet) -> bool {
        if other.0.len() > self.0.len() {
            self.0.resize(other.0.len(), 0);
        }
        let mut changed = false;
        for (a, b) in self.0.iter_mut().zip(&other.0) {
            let n = *a | *b;
            changed |= n != *a;
            *a = n;
        }
        changed
    }
}

/// Vertex-state knowledge (one per robot with meeting-based sharing, one for the team with
/// GCS sharing).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) struct Knowledge {
    /// Vertices some robot stood on.
    visited: BitSet,
    /// Vertices some group was sent to (under exploration before anyone gets there).
    claimed: BitSet,
    /// Vertices whose whole subtree was visited (derived, kept up to date).
    explored: BitSet,
}

impl Knowledge {
    pub(crate) fn visited(&self, n: NodeId) -> bool {
        self.visited.get(n.index())
    }

    pub(crate) fn claimed(&self, n: NodeId) -> bool {
        self.claimed.get(n.index())
    }

    pub(crate) fn explored(&self, n: NodeId) -> bool {
        self.explored.get(n.index())
    }

    pub(crate) fn claim(&mut self, n: NodeId) {
        self.claimed.set(n.index(), true);
    }

    /// Forget that `n` was visited or claimed: a vertex not yet imaged whose robot left the
    /// tree is unexplored again (explored states cannot change: `n` was not explored).
    pub(crate) fn release(&mut self, tree: &Tree, n: NodeId) {
        if tree.node(n).kind == NodeKind::Real && !tree.node(n).observed {
            self.visited.set(n.index(), false);
            self.claimed.set(n.index(), false);
        }
    }

    /// Record a visit and propagate the explored state upward.
    pub(crate) fn visit(&mut self, tree: &Tree, n: NodeId) {
        self.visited.set(n.index(), true);
        self.refresh(tree, n);
    }

    /// The explored state `n` should have given its children's states.
    fn derived(&self, tree: &Tree, n: NodeId) -> bool {
        let node = tree.node(n);
        let here = match node.kind {
            NodeKind::Real => node.observed && self.visited(n),
            NodeKind::Dummy => !node.children.is_empty(),
        };
        here && node.children.iter().all(|&c| self.explored(c))
    }

    /// Recompute `n` and, while it changes, its ancestors (Fig. 3: a vertex becomes explored
    /// when its last unexplored child does; a new child makes it, and its ancestors,
    /// unexplored again).
    pub(crate) fn refresh(&mut self, tree: &Tree, mut n: NodeId) {
        loop {
            let e = self.derived(tree, n);
            if e == self.explored(n) {
                return;
            }
            self.explored.set(n.index(), e);
            match tree.node(n).parent {
                Some(p) => n = p,
                None => return,
            }
        }
    }

    /// Recompute every explored state from the visits (after a merge).
    pub(crate) fn recompute(&mut self, tree: &Tree) {
        for n in tree.post_order() {
            let e = self.derived(tree, n);
            self.explored.set(n.index(), e);
        }
    }

    /// Merge `other` into `self` (robots meeting at a vertex tell each other everything they
    /// know); whether anything changed.
    pub(crate) fn merge(&mut self, tree: &Tree, other: &Knowledge) -> bool {
        let a = self.visited.union_with(&other.visited);
        let b = self.claimed.union_with(&other.claimed);
        if a || b {
            self.recompute(tree);
        }
        a || b
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geo::Cell;

    #[test]
    fn bitset_basics() {
        let mut b = BitSet::default();
        assert!(!b.get(200));
        b.set(200, false);
        assert_eq!(b, BitSet::default());
        b.set(3, true);
        b.set(130, true);
        assert!(b.get(3) && b.get(130) && !b.get(4));
        let mut c = BitSet::default();
        c.set(7, true);
        assert!(c.union_with(&b));
        assert!(!c.union_with(&b));
        assert!(c.get(130) && c.get(7));
        c.set(130, false);
        assert!(!c.get(130));
    }

    /// Fig. 3: explored propagates from the leaves to the root, and only through vertices
    /// that were themselves visited.
    #[test]
    fn explored_propagation() {
        let mut t = Tree::new(Cell::new(0, 0));
        t.set_observed(Tree::ROOT);
        let a = t.add_child(Tree::ROOT, Cell::new(1, 0));
        let b = t.add_child(Tree::ROOT, Cell::new(-1, 0));
        let mut k = Knowledge::default();
        k.visit(&t, Tree::ROOT);
        assert!(!k.explored(Tree::ROOT));
        t.set_observed(a);
        k.visit(&t, a);
        assert!(k.explored(a), "a visited, observed leaf is explored");
        assert!(!k.explored(Tree::ROOT), "b is still unexplored");
        // b visited but not yet observed: not explored.
        k.visit(&t, b);
        assert!(!k.explored(b));
        t.set_observed(b);
        k.refresh(&t, b);
        assert!(k.explored(b) && k.explored(Tree::ROOT));
        // A new child (a later positive label) re-opens the branch up to the root.
        let c = t.add_child(b, Cell::new(-2, 0));
        k.refresh(&t, b);
        assert!(!k.explored(b) && !k.explored(Tree::ROOT));
        t.set_observed(c);
        k.visit(&t, c);
        assert!(k.explored(Tree::ROOT));
        // Recompute from scratch agrees.
        let mut k2 = k.clone();
        k2.recompute(&t);
        assert_eq!(k, k2);
    }

    #[test]
    fn merge_combines_visits() {
        let mut t = Tree::new(Cell::new(0, 0));
        t.set_observed(Tree::ROOT);
        let a = t.add_child(Tree::ROOT, Cell::new(1, 0));
        let b = t.add_child(Tree::ROOT, Cell::new(-1, 0));
        t.set_observed(a);
        t.set_observed(b);
        let mut ka = Knowledge::default();
        let mut kb = Knowledge::default();
        ka.visit(&t, Tree::ROOT);
        kb.visit(&t, Tree::ROOT);
        ka.visit(&t, a);
        kb.visit(&t, b);
        assert!(!ka.explored(Tree::ROOT) && !kb.explored(Tree::ROOT));
        assert!(ka.merge(&t, &kb));
        assert!(ka.explored(Tree::ROOT));
        assert!(!ka.merge(&t, &kb));
    }
}
