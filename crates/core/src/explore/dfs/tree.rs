//! The exploration tree of Algorithm 1: real vertices (ROI cells), dummy vertices joined by
//! zero-length edges (footnote 3, line 15), parent/child links, and the `observed` flag of
//! each real vertex.
//!
//! The tree is only ever grown: a positive neighbour that is not yet in the tree becomes a
//! child of the observing vertex ("unless those cells have been previously added to the tree.
//! This condition prevents cycles", §4.1), so every cell appears at most once and the
//! structure stays a tree. Dummy vertices are inserted as children are added, over all the
//! children of a vertex (explored or not), so the tree is binary at every moment.

use crate::geo::Cell;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// Index of a vertex in the tree (stable: vertices are never removed).
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize, Default,
)]
#[serde(transparent)]
pub struct NodeId(pub u32);

impl NodeId {
    /// The index as `usize`.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// What a vertex stands for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum NodeKind {
    /// An ROI cell.
    Real,
    /// A dummy vertex at its parent's cell, joined by an edge of length 0 (footnote 3).
    Dummy,
}

/// One vertex of the tree.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Node {
    /// The cell (for a dummy: the cell of the real vertex it hangs from).
    pub cell: Cell,
    /// Real or dummy.
    pub kind: NodeKind,
    /// The parent vertex (`None` for the root).
    pub parent: Option<NodeId>,
    /// The children, in the order they were added (dummies take the place of the first
    /// child they group).
    pub children: Vec<NodeId>,
    /// Whether the cell has been imaged (real vertices; dummies are always `true`).
    pub observed: bool,
    /// Distance from the root counting real edges as 1 and dummy edges as 0 (§4.2, l(e)).
    pub(crate) depth: u32,
}

/// The exploration tree.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(from = "TreeRepr", into = "TreeRepr")]
pub struct Tree {
    nodes: Vec<Node>,
    index: HashMap<Cell, NodeId>,
}

/// Serialised form: the vertices only; the cell index is rebuilt on load.
#[derive(Serialize, Deserialize)]
struct TreeRepr {
    nodes: Vec<Node>,
}

impl From<TreeRepr> for Tree {
    fn from(r: TreeRepr) -> Tree {
        let index = r
            .nodes
            .iter()
            .enumerate()
            .filter(|(_, n)| n.kind == NodeKind::Real)
            .map(|(i, n)| (n.cell, NodeId(i as u32)))
            .collect();
        Tree {
            nodes: r.nodes,
            index,
        }
    }
}

impl From<Tree> for TreeRepr {
    fn from(t: Tree) -> TreeRepr {
        TreeRepr { nodes: t.nodes }
    }
}

impl Tree {
    /// The root vertex id.
    pub(crate) const ROOT: NodeId = NodeId(0);

    /// A tree with only the root, at `start`, not yet observed.
    pub fn new(start: Cell) -> Tree {
        let mut index = HashMap::new();
        index.insert(start, Tree::ROOT);
        Tree {
            nodes: vec![Node {
                cell: start,
                kind: NodeKind::Real,
                parent: None,
                children: Vec::new(),
                observed: false,
                depth: 0,
            }],
            index,
        }
    }

    /// Number of vertices, dummies included.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Whether the tree has no vertex (never: the root always exists).
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The vertex `id` (panics on an id not from this tree — ids are never user input).
    pub fn node(&self, id: NodeId) -> &Node {
        &self.nodes[id.index()]
    }

    /// All vertices, in creation order (index = `NodeId`).
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// The real vertex of `cell`, if the cell is in the tree.
    pub fn real(&self, cell: Cell) -> Option<NodeId> {
        self.index.get(&cell).copied()
    }

    /// Whether `cell` is in the tree (i.e. known to be an ROI cell).
    pub fn contains(&self, cell: Cell) -> bool {
        self.index.contains_key(&cell)
    }

    /// The cells of the tree (the mapped region), in the order they were added.
    pub fn cells(&self) -> impl Iterator<Item = Cell> + '_ {
        self.nodes
            .iter()
            .filter(|n| n.kind == NodeKind::Real)
            .map(|n| n.cell)
    }

    /// Number of real vertices (C when the sensing is perfect).
    pub fn real_count(&self) -> usize {
        self.index.len()
    }

    /// d_max: the largest distance from the root (real edges count 1, dummy edges 0).
    pub fn d_max(&self) -> u32 {
        self.nodes.iter().map(|n| n.depth).max().unwrap_or(0)
    }

    /// The real vertex a vertex stands at (itself, or for a dummy its nearest real ancestor).
    pub(crate) fn real_of(&self, mut id: NodeId) -> NodeId {
        while self.node(id).kind == NodeKind::Dummy {
            match self.node(id).parent {
                Some(p) => id = p,
                None => break,
            }
        }
        id
    }

    /// Mark a real vertex as imaged.
    pub(crate) fn set_observed(&mut self, id: NodeId) {
        self.nodes[id.index()].observed = true;
    }

    /// Add `cell` as a new real child of the real vertex `parent`, keeping the tree binary
    /// (Algorithm 1, line 15 and footnote 3). The caller checks that the cell is not yet in
    /// the tree. Returns the new vertex and the dummy vertex created for it, if any.
    ///
    /// The first two children hang from `parent` itself. A further child `c` is paired with
    /// the child slot `s` of `parent` that leads to the fewest real branches (the later slot
    /// on a tie): `s` is replaced by a dummy vertex at `parent`'s cell, joined by an edge of
    /// length 0, whose children are `s` and `c`. So children added in the order `a, b, c, d`
    /// (four only at the root) give `[a, b]`, then `[a, dummy{b, c}]`, then
    /// `[dummy{a, d}, dummy{b, c}]`. Dummies are built over *all* children, explored or not,
    /// so the tree is binary whatever the sensing did (a late positive label included).
    #[cfg(test)]
    pub(crate) fn add_child(&mut self, parent: NodeId, cell: Cell) -> NodeId {
        self.attach(parent, cell).0
    }

    /// [`Tree::add_child`], also returning the dummy vertex it created.
    pub(crate) fn attach(&mut self, parent: NodeId, cell: Cell) -> (NodeId, Option<NodeId>) {
        debug_assert!(!self.contains(cell));
        debug_assert_eq!(self.node(parent).kind, NodeKind::Real);
        let id = NodeId(self.nodes.len() as u32);
        let depth = self.node(parent).depth + 1;
        self.nodes.push(Node {
            cell,
            kind: NodeKind::Real,
            parent: Some(parent),
            children: Vec::new(),
            observed: false,
            depth,
        });
        self.index.insert(cell, id);
        let slots = self.node(parent).children.clone();
        if slots.len() < 2 {
            self.nodes[parent.index()].children.push(id);
            return (id, None);
        }
        let (pos, &slot) = slots
            .iter()
            .enumerate()
            .rev()
            .min_by_key(|&(_, &s)| self.branches(s))
            .unwrap_or((slots.len() - 1, &slots[slots.len() - 1]));
        let dummy = NodeId(self.nodes.len() as u32);
        self.nodes.push(Node {
            cell: self.node(parent).cell,
            kind: NodeKind::Dummy,
            parent: Some(parent),
            children: vec![slot, id],
            observed: true,
            depth: self.node(parent).depth,
        });
        self.nodes[parent.index()].children[pos] = dummy;
        self.nodes[slot.index()].parent = Some(dummy);
        self.nodes[id.index()].parent = Some(dummy);
        (id, Some(dummy))
    }

    /// Number of real vertices reached from `n` through dummy edges only (1 for a real
    /// vertex): how many grid branches the slot `n` stands for.
    pub(crate) fn branches(&self, n: NodeId) -> usize {
        let node = self.node(n);
        match node.kind {
            NodeKind::Real => 1,
            NodeKind::Dummy => node.children.iter().map(|&c| self.branches(c)).sum(),
        }
    }

    /// The vertices in post-order (children before parents), from the root.
    pub(crate) fn post_order(&self) -> Vec<NodeId> {
        let mut out = Vec::with_capacity(self.nodes.len());
        let mut stack = vec![(Tree::ROOT, false)];
        while let Some((id, expanded)) = stack.pop() {
            if expanded {
                out.push(id);
            } else {
                stack.push((id, true));
                for &c in self.node(id).children.iter().rev() {
                    stack.push((c, false));
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn children_are_binarised_as_they_are_added() {
        let mut t = Tree::new(Cell::new(0, 0));
        let a = t.add_child(Tree::ROOT, Cell::new(1, 0));
        let b = t.add_child(Tree::ROOT, Cell::new(0, -1));
        assert_eq!(t.node(Tree::ROOT).children, vec![a, b]);
        let (c, d1) = t.attach(Tree::ROOT, Cell::new(-1, 0));
        let d1 = d1.expect("a third child needs a dummy");
        assert_eq!(t.node(Tree::ROOT).children, vec![a, d1]);
        assert_eq!(t.node(d1).children, vec![b, c]);
        let (d, d2) = t.attach(Tree::ROOT, Cell::new(0, 1));
        let d2 = d2.expect("a fourth child needs a dummy");
        assert_eq!(t.node(Tree::ROOT).children, vec![d2, d1]);
        assert_eq!(t.node(d2).children, vec![a, d]);
        assert_eq!(t.node(d2).kind, NodeKind::Dummy);
        assert_eq!(t.node(a).parent, Some(d2));
        assert_eq!(t.node(a).depth, 1);
        assert_eq!(t.node(d2).depth, 0);
        assert_eq!(t.real_of(d2), Tree::ROOT);
        assert_eq!(t.branches(d1), 2);
        assert_eq!(t.branches(Tree::ROOT), 1);

        let e = t.add_child(a, Cell::new(2, 0));
        let f = t.add_child(a, Cell::new(1, -1));
        let (g, y) = t.attach(a, Cell::new(1, 1));
        let y = y.unwrap();
        assert_eq!(t.node(y).children, vec![f, g]);
        assert_eq!(t.node(a).children, vec![e, y]);
        assert_eq!(t.d_max(), 2);
        assert_eq!(t.real_count(), 8);
        for n in t.nodes() {
            assert!(n.children.len() <= 2);
        }
        // Post-order lists every vertex once, children first.
        let po = t.post_order();
        assert_eq!(po.len(), t.len());
        assert_eq!(*po.last().unwrap(), Tree::ROOT);
        let pos = |id: NodeId| po.iter().position(|&p| p == id).unwrap();
        for (i, n) in t.nodes().iter().enumerate() {
            for &c in &n.children {
                assert!(pos(c) < pos(NodeId(i as u32)));
            }
        }
    }

    #[test]
    fn serde_rebuilds_the_index() {
        let mut t = Tree::new(Cell::new(3, 4));
        t.add_child(Tree::ROOT, Cell::new(4, 4));
        let json = serde_json::to_string(&t).unwrap();
        let back: Tree = serde_json::from_str(&json).unwrap();
        assert_eq!(back.real(Cell::new(4, 4)), Some(NodeId(1)));
        assert_eq!(back.nodes(), t.nodes());
    }
}
