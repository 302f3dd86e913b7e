//! Unit tests of the tree rules and the sans-IO interface of [`Explorer`].

use super::*;
use crate::explore::simulate::{SimConfig, simulate};
use std::collections::HashSet;

pub(super) fn c(row: i32, col: i32) -> Cell {
    Cell::new(row, col)
}

pub(super) fn roi(cells: &[(i32, i32)]) -> HashSet<Cell> {
    cells.iter().map(|&(r, q)| c(r, q)).collect()
}

pub(super) fn labels(roi: &HashSet<Cell>, at: Cell) -> [bool; 4] {
    Dir4::ALL.map(|d| roi.contains(&at.step(d)))
}

pub(super) fn ids(n: u8) -> Vec<RobotId> {
    (1..=n).map(RobotId).collect()
}

/// Bring every robot to the start and let the first one image it.
pub(super) fn gather(ex: &mut Explorer, roi: &HashSet<Cell>) {
    let start = ex.start();
    for r in ex.robots().iter().map(|r| r.id).collect::<Vec<_>>() {
        assert_eq!(ex.next_action(r).unwrap(), Action::Rejoin(start));
        ex.arrived(r, start).unwrap();
    }
    let first = ex.robots()[0].id;
    assert_eq!(ex.next_action(first).unwrap(), Action::Observe);
    ex.observe(first, start, labels(roi, start)).unwrap();
}

#[test]
fn single_robot_is_a_plain_dfs_and_comes_home() {
    // An L: (0,0) (1,0) (2,0) (2,1).
    let roi = roi(&[(0, 0), (1, 0), (2, 0), (2, 1)]);
    let mut ex = Explorer::new(ExplorerConfig::default(), c(0, 0), &ids(1)).unwrap();
    let r = RobotId(1);
    gather(&mut ex, &roi);
    let mut trace = vec![];
    for _ in 0..100 {
        match ex.next_action(r).unwrap() {
            Action::MoveTo(to) => {
                trace.push(to);
                ex.arrived(r, to).unwrap();
            }
            Action::Observe => {
                let at = ex.robot_cell(r).unwrap();
                ex.observe(r, at, labels(&roi, at)).unwrap();
            }
            Action::Done => break,
            other => panic!("unexpected {other:?}"),
        }
    }
    assert_eq!(
        trace,
        vec![c(1, 0), c(2, 0), c(2, 1), c(2, 0), c(1, 0), c(0, 0)]
    );
    assert!(ex.is_finished());
    assert_eq!(ex.tree().real_count(), 4);
    assert_eq!(ex.d_max(), 3);
    assert_eq!(ex.robots()[0].moves, 6);
    assert!(
        ex.vertex_states()
            .iter()
            .all(|(_, s)| *s == VertexState::Explored)
    );
}

#[test]
fn grid_cycles_do_not_enter_the_tree() {
    // A 3 × 3 block has many cycles; the tree must have C − 1 edges and each cell once.
    let cells: Vec<(i32, i32)> = (0..3).flat_map(|r| (0..3).map(move |q| (r, q))).collect();
    let roi = roi(&cells);
    for sharing in [Sharing::Meet, Sharing::Gcs] {
        for robots in [1, 2, 3, 5] {
            let out = simulate(
                &roi,
                c(1, 1),
                &SimConfig {
                    robots,
                    sharing,
                    ..SimConfig::default()
                },
            )
            .unwrap();
            let t = out.explorer.tree();
            assert_eq!(t.real_count(), 9);
            let cells: HashSet<Cell> = t.cells().collect();
            assert_eq!(cells, roi);
            // Parent links: every real vertex but the root has a parent at Manhattan
            // distance 1 (through dummies at the same cell); following them ends at the root.
            for (i, n) in t.nodes().iter().enumerate() {
                let mut id = NodeId(i as u32);
                let mut steps = 0;
                while let Some(p) = t.node(id).parent {
                    id = p;
                    steps += 1;
                    assert!(steps <= t.len(), "cycle through {}", n.cell);
                }
                assert_eq!(id, Tree::ROOT);
                if n.kind == NodeKind::Real && i != 0 {
                    let p = t.real_of(n.parent.unwrap());
                    assert_eq!(t.node(p).cell.manhattan(n.cell), 1);
                }
            }
        }
    }
}

#[test]
fn a_cell_seen_from_two_vertices_is_added_once() {
    // 2 × 2 block: (1,1) neighbours both (1,0) and (0,1).
    let roi = roi(&[(0, 0), (0, 1), (1, 0), (1, 1)]);
    let mut ex = Explorer::new(ExplorerConfig::default(), c(0, 0), &ids(1)).unwrap();
    let r = RobotId(1);
    gather(&mut ex, &roi);
    // Root children: north (1,0) and east (0,1).
    let root_children: Vec<Cell> = ex
        .tree()
        .node(Tree::ROOT)
        .children
        .iter()
        .map(|&n| ex.tree().node(n).cell)
        .collect();
    assert_eq!(root_children, vec![c(1, 0), c(0, 1)]);
    let mut first_obs_added = None;
    for _ in 0..50 {
        match ex.next_action(r).unwrap() {
            Action::MoveTo(to) => ex.arrived(r, to).unwrap(),
            Action::Observe => {
                let at = ex.robot_cell(r).unwrap();
                let added = ex.observe(r, at, labels(&roi, at)).unwrap();
                if at == c(1, 0) {
                    first_obs_added = Some(added);
                } else if at == c(0, 1) {
                    // (1,1) is positive here too but already in the tree: not added again.
                    assert!(added.is_empty(), "{added:?}");
                }
            }
            Action::Done => break,
            other => panic!("{other:?}"),
        }
    }
    assert_eq!(first_obs_added, Some(vec![c(1, 1)]));
    let t = ex.tree();
    assert_eq!(t.real_count(), 4);
    assert_eq!(t.node(t.real(c(1, 1)).unwrap()).parent, t.real(c(1, 0)));
    assert!(ex.is_finished());
}

#[test]
fn three_children_get_a_dummy_and_robots_split_evenly() {
    // A plus shape around (1,0), the root below it: (1,0) has three new neighbours.
    let roi = roi(&[(0, 0), (1, 0), (2, 0), (1, -1), (1, 1)]);
    let mut ex = Explorer::new(ExplorerConfig::default(), c(0, 0), &ids(5)).unwrap();
    gather(&mut ex, &roi);
    // Single child: the whole group of 5 moves north.
    for r in ids(5) {
        assert_eq!(ex.next_action(r).unwrap(), Action::MoveTo(c(1, 0)));
    }
    for r in ids(5) {
        ex.arrived(r, c(1, 0)).unwrap();
    }
    assert_eq!(ex.next_action(RobotId(1)).unwrap(), Action::Observe);
    // The others wait while robot 1 images the cell.
    assert_eq!(ex.next_action(RobotId(2)).unwrap(), Action::Wait);
    ex.observe(RobotId(1), c(1, 0), labels(&roi, c(1, 0)))
        .unwrap();
    let targets: Vec<Action> = ids(5)
        .into_iter()
        .map(|r| ex.next_action(r).unwrap())
        .collect();
    // Children in N, W, E order: [(2,0), (1,-1), (1,1)] → [dummy{(1,-1), (1,1)}, (2,0)]:
    // 3 robots to the dummy (split again 2 / 1), 2 robots to (2,0).
    assert_eq!(
        targets,
        vec![
            Action::MoveTo(c(1, -1)),
            Action::MoveTo(c(1, -1)),
            Action::MoveTo(c(1, 1)),
            Action::MoveTo(c(2, 0)),
            Action::MoveTo(c(2, 0)),
        ]
    );
    let t = ex.tree();
    let v = t.real(c(1, 0)).unwrap();
    assert_eq!(t.node(v).children.len(), 2, "binary after the dummy");
    let dummy = t
        .node(v)
        .children
        .iter()
        .copied()
        .find(|&n| t.node(n).kind == NodeKind::Dummy)
        .expect("a dummy vertex");
    assert_eq!(t.node(dummy).cell, c(1, 0));
    assert_eq!(
        t.node(dummy).depth,
        t.node(v).depth,
        "dummy edges have length 0"
    );
    let dc: Vec<Cell> = t
        .node(dummy)
        .children
        .iter()
        .map(|&n| t.node(n).cell)
        .collect();
    assert_eq!(dc, vec![c(1, -1), c(1, 1)]);
    // Companions reflect the split.
    assert_eq!(
        ex.robot(RobotId(1)).unwrap().companions,
        vec![RobotId(1), RobotId(2)]
    );
    assert_eq!(ex.robot(RobotId(3)).unwrap().companions, vec![RobotId(3)]);
    assert_eq!(
        ex.robot(RobotId(4)).unwrap().companions,
        vec![RobotId(4), RobotId(5)]
    );
}

#[test]
fn four_children_at_the_root_get_two_dummies() {
    let roi = roi(&[(0, 0), (1, 0), (0, -1), (-1, 0), (0, 1)]);
    let out = simulate(
        &roi,
        c(0, 0),
        &SimConfig {
            robots: 4,
            sharing: Sharing::Gcs,
            record_paths: true,
            ..SimConfig::default()
        },
    )
    .unwrap();
    let t = out.explorer.tree();
    let root = t.node(Tree::ROOT);
    assert_eq!(root.children.len(), 2);
    for &d in &root.children {
        assert_eq!(t.node(d).kind, NodeKind::Dummy);
        assert_eq!(t.node(d).children.len(), 2);
    }
    // One robot per arm: each robot's path is start → arm → start.
    let arms: HashSet<Cell> = out.paths.iter().map(|p| p[1]).collect();
    assert_eq!(arms.len(), 4);
    assert_eq!(out.cost, 2.0);
    assert!(out.paths.iter().all(|p| p.len() == 3));
}

#[test]
fn every_vertex_ends_with_at_most_two_children() {
    let cells: Vec<(i32, i32)> = (-2..=2)
        .flat_map(|r| (-2..=2).map(move |q| (r, q)))
        .collect();
    let out = simulate(
        &roi(&cells),
        c(0, 0),
        &SimConfig {
            robots: 7,
            ..SimConfig::default()
        },
    )
    .unwrap();
    // A vertex can keep three children only if it was never decided at with three open
    // candidates; with a perfect sensor every vertex is decided at right after it is imaged.
    for n in out.explorer.tree().nodes() {
        assert!(n.children.len() <= 2, "{} has {:?}", n.cell, n.children);
    }
}

#[test]
fn explored_state_propagates_up_like_fig_3() {
    // Root (0,0) with a long arm north and a short arm east.
    let roi = roi(&[(0, 0), (1, 0), (2, 0), (3, 0), (0, 1)]);
    let mut ex = Explorer::new(
        ExplorerConfig {
            sharing: Sharing::Gcs,
            ..ExplorerConfig::default()
        },
        c(0, 0),
        &ids(2),
    )
    .unwrap();
    gather(&mut ex, &roi);
    assert_eq!(
        ex.vertex_state(c(0, 0)),
        Some(VertexState::UnderExploration)
    );
    assert_eq!(ex.vertex_state(c(3, 0)), None, "not yet discovered");
    // Split: robot 1 north, robot 2 east.
    assert_eq!(ex.next_action(RobotId(1)).unwrap(), Action::MoveTo(c(1, 0)));
    assert_eq!(ex.next_action(RobotId(2)).unwrap(), Action::MoveTo(c(0, 1)));
    // Claimed by a group, nobody there yet: under exploration.
    assert_eq!(
        ex.vertex_state(c(1, 0)),
        Some(VertexState::UnderExploration)
    );
    ex.arrived(RobotId(2), c(0, 1)).unwrap();
    assert_eq!(ex.next_action(RobotId(2)).unwrap(), Action::Observe);
    ex.observe(RobotId(2), c(0, 1), labels(&roi, c(0, 1)))
        .unwrap();
    // A leaf: explored as soon as it is imaged; the root is not (north arm open).
    assert_eq!(ex.vertex_state(c(0, 1)), Some(VertexState::Explored));
    assert_eq!(
        ex.vertex_state(c(0, 0)),
        Some(VertexState::UnderExploration)
    );
    // Robot 2 goes back to the root, then helps in the north arm (under exploration).
    assert_eq!(ex.next_action(RobotId(2)).unwrap(), Action::MoveTo(c(0, 0)));
    ex.arrived(RobotId(2), c(0, 0)).unwrap();
    assert_eq!(ex.next_action(RobotId(2)).unwrap(), Action::MoveTo(c(1, 0)));
    // Robot 1 walks to the end of the arm.
    let mut at = c(0, 0);
    for row in 1..=3 {
        ex.arrived(RobotId(1), c(row, 0)).unwrap();
        at = c(row, 0);
        assert_eq!(ex.next_action(RobotId(1)).unwrap(), Action::Observe);
        ex.observe(RobotId(1), at, labels(&roi, at)).unwrap();
        if row < 3 {
            assert_eq!(
                ex.next_action(RobotId(1)).unwrap(),
                Action::MoveTo(c(row + 1, 0))
            );
            assert_eq!(
                ex.vertex_state(c(row, 0)),
                Some(VertexState::UnderExploration)
            );
        }
    }
    // The last leaf is visited: the whole branch and the root become explored at once.
    assert_eq!(at, c(3, 0));
    for cell in [c(3, 0), c(2, 0), c(1, 0), c(0, 0)] {
        assert_eq!(ex.vertex_state(cell), Some(VertexState::Explored), "{cell}");
    }
    // Robot 2, arriving at (1,0), finds everything explored and turns home.
    ex.arrived(RobotId(2), c(1, 0)).unwrap();
    assert_eq!(ex.next_action(RobotId(2)).unwrap(), Action::MoveTo(c(0, 0)));
}

#[test]
fn meeting_sharing_only_learns_on_meeting() {
    let roi = roi(&[(0, 0), (1, 0), (0, 1)]);
    let mut ex = Explorer::new(
        ExplorerConfig {
            sharing: Sharing::Meet,
            ..ExplorerConfig::default()
        },
        c(0, 0),
        &ids(2),
    )
    .unwrap();
    gather(&mut ex, &roi);
    assert_eq!(ex.next_action(RobotId(1)).unwrap(), Action::MoveTo(c(1, 0)));
    assert_eq!(ex.next_action(RobotId(2)).unwrap(), Action::MoveTo(c(0, 1)));
    ex.arrived(RobotId(2), c(0, 1)).unwrap();
    assert_eq!(ex.next_action(RobotId(2)).unwrap(), Action::Observe);
    ex.observe(RobotId(2), c(0, 1), [false; 4]).unwrap();
    // Robot 2 knows its leaf is explored; robot 1 does not.
    assert_eq!(
        ex.vertex_state_known_by(RobotId(2), c(0, 1)).unwrap(),
        Some(VertexState::Explored)
    );
    assert_eq!(
        ex.vertex_state_known_by(RobotId(1), c(0, 1)).unwrap(),
        Some(VertexState::UnderExploration)
    );
    ex.arrived(RobotId(1), c(1, 0)).unwrap();
    assert_eq!(ex.next_action(RobotId(1)).unwrap(), Action::Observe);
    ex.observe(RobotId(1), c(1, 0), [false, false, true, false])
        .unwrap();
    // Both go home; robot 2 gets there first and is done as far as it knows — it does not
    // know robot 1's leaf is explored, so it heads for (1,0) to help.
    assert_eq!(ex.next_action(RobotId(2)).unwrap(), Action::MoveTo(c(0, 0)));
    ex.arrived(RobotId(2), c(0, 0)).unwrap();
    assert_eq!(ex.next_action(RobotId(1)).unwrap(), Action::MoveTo(c(0, 0)));
    // Robot 2 now leaves (0,0) for (1,0) while robot 1 flies (1,0) → (0,0): they pass each
    // other on the edge and share what they know.
    assert_eq!(ex.next_action(RobotId(2)).unwrap(), Action::MoveTo(c(1, 0)));
    assert_eq!(
        ex.vertex_state_known_by(RobotId(2), c(1, 0)).unwrap(),
        Some(VertexState::Explored)
    );
    ex.arrived(RobotId(2), c(1, 0)).unwrap();
    assert_eq!(ex.next_action(RobotId(2)).unwrap(), Action::MoveTo(c(0, 0)));
    ex.arrived(RobotId(1), c(0, 0)).unwrap();
    assert_eq!(ex.next_action(RobotId(1)).unwrap(), Action::Done);
    ex.arrived(RobotId(2), c(0, 0)).unwrap();
    assert_eq!(ex.next_action(RobotId(2)).unwrap(), Action::Done);
    assert!(ex.is_finished());
}

#[test]
fn gcs_sharing_knows_at_once() {
    let roi = roi(&[(0, 0), (1, 0), (0, 1)]);
    let mut ex = Explorer::new(
        ExplorerConfig {
            sharing: Sharing::Gcs,
            ..ExplorerConfig::default()
        },
        c(0, 0),
        &ids(2),
    )
    .unwrap();
    gather(&mut ex, &roi);
    ex.next_action(RobotId(1)).unwrap();
    ex.next_action(RobotId(2)).unwrap();
    ex.arrived(RobotId(2), c(0, 1)).unwrap();
    ex.next_action(RobotId(2)).unwrap();
    ex.observe(RobotId(2), c(0, 1), [false; 4]).unwrap();
    assert_eq!(
        ex.vertex_state_known_by(RobotId(1), c(0, 1)).unwrap(),
        Some(VertexState::Explored)
    );
}

#[test]
fn a_false_negative_is_corrected_by_a_later_positive() {
    // True ROI: (0,0) (1,0) (1,1) (0,1). The image at the root misses (0,1).
    let mut ex = Explorer::new(ExplorerConfig::default(), c(0, 0), &ids(1)).unwrap();
    let r = RobotId(1);
    assert_eq!(ex.next_action(r).unwrap(), Action::Rejoin(c(0, 0)));
    ex.arrived(r, c(0, 0)).unwrap();
    assert_eq!(ex.next_action(r).unwrap(), Action::Observe);
    // N positive, E falsely negative.
    ex.observe(r, c(0, 0), [true, false, false, false]).unwrap();
    assert!(ex.negatives().contains(&c(0, 1)));
    assert!(!ex.tree().contains(c(0, 1)));
    assert_eq!(ex.next_action(r).unwrap(), Action::MoveTo(c(1, 0)));
    ex.arrived(r, c(1, 0)).unwrap();
    ex.next_action(r).unwrap();
    ex.observe(r, c(1, 0), [false, false, true, true]).unwrap();
    assert_eq!(ex.next_action(r).unwrap(), Action::MoveTo(c(1, 1)));
    ex.arrived(r, c(1, 1)).unwrap();
    ex.next_action(r).unwrap();
    // From (1,1) the south neighbour (0,1) shows as positive: it joins the tree under (1,1).
    let added = ex.observe(r, c(1, 1), [false, true, true, false]).unwrap();
    assert_eq!(added, vec![c(0, 1)]);
    assert!(!ex.negatives().contains(&c(0, 1)));
    let t = ex.tree();
    assert_eq!(t.node(t.real(c(0, 1)).unwrap()).parent, t.real(c(1, 1)));
    assert_eq!(ex.next_action(r).unwrap(), Action::MoveTo(c(0, 1)));
    ex.arrived(r, c(0, 1)).unwrap();
    ex.next_action(r).unwrap();
    // Its own image says the west neighbour (the root) is not ROI: a positive stays.
    ex.observe(r, c(0, 1), [true, false, false, false]).unwrap();
    assert!(ex.tree().contains(c(0, 0)));
    assert!(!ex.negatives().contains(&c(0, 0)));
    let mut guard = 0;
    while ex.next_action(r).unwrap() != Action::Done {
        let Action::MoveTo(to) = ex.next_action(r).unwrap() else {
            panic!("expected a move");
        };
        ex.arrived(r, to).unwrap();
        guard += 1;
        assert!(guard < 10);
    }
    assert!(ex.is_finished());
    assert_eq!(ex.tree().real_count(), 4);
}

#[test]
fn a_late_positive_reopens_an_explored_branch() {
    let mut ex = Explorer::new(ExplorerConfig::default(), c(0, 0), &ids(1)).unwrap();
    let r = RobotId(1);
    ex.next_action(r).unwrap();
    ex.arrived(r, c(0, 0)).unwrap();
    ex.next_action(r).unwrap();
    ex.observe(r, c(0, 0), [false; 4]).unwrap();
    assert_eq!(ex.next_action(r).unwrap(), Action::Done);
    assert!(ex.is_finished());
    // Another image taken here (e.g. while landing) shows a neighbour after all.
    ex.observe(r, c(0, 0), [false, false, false, true]).unwrap();
    assert!(!ex.is_finished());
    assert_eq!(ex.next_action(r).unwrap(), Action::MoveTo(c(0, 1)));
}

#[test]
fn pause_and_resume_at_the_saved_vertex() {
    let cells: Vec<(i32, i32)> = (0..6).map(|r| (r, 0)).chain([(0, 1), (0, 2)]).collect();
    let roi = roi(&cells);
    let mut ex = Explorer::new(ExplorerConfig::default(), c(0, 0), &ids(2)).unwrap();
    gather(&mut ex, &roi);
    // Robot 1 goes north, robot 2 east.
    assert_eq!(ex.next_action(RobotId(1)).unwrap(), Action::MoveTo(c(1, 0)));
    assert_eq!(ex.next_action(RobotId(2)).unwrap(), Action::MoveTo(c(0, 1)));
    let step = |ex: &mut Explorer, r: RobotId| match ex.next_action(r).unwrap() {
        Action::MoveTo(to) => ex.arrived(r, to).unwrap(),
        Action::Observe => {
            let at = ex.robot_cell(r).unwrap();
            ex.observe(r, at, labels(&roi, at)).unwrap();
        }
        other => panic!("{other:?}"),
    };
    for _ in 0..6 {
        step(&mut ex, RobotId(1));
    }
    let saved = ex.robot_cell(RobotId(1)).unwrap();
    assert_eq!(saved, c(3, 0));
    // Battery low while flying on: pause; its vertex stays (3,0).
    assert!(matches!(
        ex.next_action(RobotId(1)).unwrap(),
        Action::MoveTo(_)
    ));
    ex.pause(RobotId(1)).unwrap();
    assert_eq!(ex.next_action(RobotId(1)).unwrap(), Action::ReturnHome);
    assert_eq!(ex.robot_cell(RobotId(1)).unwrap(), saved);
    // Persist and restore mid-run: the restored explorer behaves the same.
    let json = serde_json::to_string(&ex).unwrap();
    let mut ex: Explorer = serde_json::from_str(&json).unwrap();
    assert!(ex.resume(RobotId(2)).is_err(), "robot 2 is not paused");
    ex.resume(RobotId(1)).unwrap();
    assert_eq!(ex.next_action(RobotId(1)).unwrap(), Action::Rejoin(saved));
    ex.arrived(RobotId(1), saved).unwrap();
    // Finish: drive both robots until done.
    let mut done = HashSet::new();
    for _ in 0..200 {
        for r in ids(2) {
            if done.contains(&r) {
                continue;
            }
            match ex.next_action(r).unwrap() {
                Action::MoveTo(to) => ex.arrived(r, to).unwrap(),
                Action::Observe => {
                    let at = ex.robot_cell(r).unwrap();
                    ex.observe(r, at, labels(&roi, at)).unwrap();
                }
                Action::Done => {
                    done.insert(r);
                }
                Action::Wait => {}
                other => panic!("{other:?}"),
            }
        }
    }
    assert_eq!(done.len(), 2);
    assert!(ex.is_finished());
    let mapped: HashSet<Cell> = ex.tree().cells().collect();
    assert_eq!(mapped, roi);
}

#[test]
fn pausing_a_group_member_lets_the_rest_go_on() {
    let roi = roi(&[(0, 0), (1, 0), (2, 0)]);
    let mut ex = Explorer::new(ExplorerConfig::default(), c(0, 0), &ids(3)).unwrap();
    for r in ids(3) {
        ex.next_action(r).unwrap();
    }
    ex.arrived(RobotId(1), c(0, 0)).unwrap();
    ex.arrived(RobotId(2), c(0, 0)).unwrap();
    // Robot 3 never makes it to the start: the others wait for it ...
    assert_eq!(ex.next_action(RobotId(1)).unwrap(), Action::Observe);
    ex.observe(RobotId(1), c(0, 0), labels(&roi, c(0, 0)))
        .unwrap();
    assert_eq!(ex.next_action(RobotId(1)).unwrap(), Action::Wait);
    // ... until it is paused.
    ex.pause(RobotId(3)).unwrap();
    assert_eq!(ex.next_action(RobotId(1)).unwrap(), Action::MoveTo(c(1, 0)));
    assert_eq!(ex.next_action(RobotId(2)).unwrap(), Action::MoveTo(c(1, 0)));
    // A robot paused while imaging hands the job to a companion.
    ex.arrived(RobotId(1), c(1, 0)).unwrap();
    ex.arrived(RobotId(2), c(1, 0)).unwrap();
    assert_eq!(ex.next_action(RobotId(1)).unwrap(), Action::Observe);
    assert_eq!(ex.next_action(RobotId(2)).unwrap(), Action::Wait);
    ex.pause(RobotId(1)).unwrap();
    assert_eq!(ex.next_action(RobotId(2)).unwrap(), Action::Observe);
}

#[test]
fn bad_calls_are_errors() {
    assert_eq!(
        Explorer::new(ExplorerConfig::default(), c(0, 0), &[]).unwrap_err(),
        ExploreError::NoRobots
    );
    assert_eq!(
        Explorer::new(
            ExplorerConfig::default(),
            c(0, 0),
            &[RobotId(1), RobotId(1)]
        )
        .unwrap_err(),
        ExploreError::DuplicateRobot(RobotId(1))
    );
    let mut ex = Explorer::new(ExplorerConfig::default(), c(0, 0), &ids(1)).unwrap();
    assert!(matches!(
        ex.next_action(RobotId(9)),
        Err(ExploreError::UnknownRobot(_))
    ));
    assert!(matches!(
        ex.arrived(RobotId(1), c(5, 5)),
        Err(ExploreError::WrongCell { .. })
    ));
    assert!(matches!(
        ex.observe(RobotId(1), c(0, 0), [true; 4]),
        Err(ExploreError::CannotObserve { .. })
    ));
    ex.arrived(RobotId(1), c(0, 0)).unwrap();
    assert!(matches!(
        ex.arrived(RobotId(1), c(0, 0)),
        Err(ExploreError::NotMoving { .. })
    ));
    assert!(matches!(
        ex.observe(RobotId(1), c(1, 0), [true; 4]),
        Err(ExploreError::ObservedElsewhere { .. })
    ));
    assert!(matches!(
        ex.resume(RobotId(1)),
        Err(ExploreError::NotPaused(_))
    ));
}

#[test]
fn moves_only_over_tree_cells_between_neighbours() {
    let cells: Vec<(i32, i32)> = (-3..=3)
        .flat_map(|r| (-3..=3).map(move |q| (r, q)))
        .filter(|&(r, q)| (r + q) % 3 != 0 || r == 0)
        .collect();
    let roi = roi(&cells);
    for sharing in [Sharing::Meet, Sharing::Gcs] {
        let out = simulate(
            &roi,
            c(0, 0),
            &SimConfig {
                robots: 6,
                sharing,
                record_paths: true,
                ..SimConfig::default()
            },
        )
        .unwrap();
        for p in &out.paths {
            assert_eq!(p.first(), Some(&c(0, 0)));
            assert_eq!(p.last(), Some(&c(0, 0)));
            for w in p.windows(2) {
                assert_eq!(w[0].manhattan(w[1]), 1);
                assert!(roi.contains(&w[1]));
            }
        }
    }
}

/// The smallest instance (found by search over random ROIs) where meeting-only sharing
/// exceeds Lemma 1's bound while GCS sharing stays well within it: the counterexample worked
/// step by step in docs/results/dfs.md (see also the module docs). The cost is pinned.
#[test]
fn meeting_sharing_can_exceed_lemma_1() {
    use crate::explore::bounds::lemma1_upper_bound;
    let roi = roi(&[(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (1, 3), (2, 1)]);
    let run = |sharing| {
        simulate(
            &roi,
            c(1, 1),
            &SimConfig {
                robots: 2,
                sharing,
                record_paths: true,
                ..SimConfig::default()
            },
        )
        .unwrap()
    };
    let meet = run(Sharing::Meet);
    // The trace of docs/results/dfs.md: robot 2 follows robot 1 into (0,1) at t = 3, they
    // pool there and go on together.
    let cells = |v: &[(i32, i32)]| v.iter().map(|&(r, q)| c(r, q)).collect::<Vec<_>>();
    assert_eq!(
        meet.paths[0],
        cells(&[
            (1, 1),
            (0, 1),
            (0, 0),
            (0, 1),
            (0, 2),
            (0, 1),
            (1, 1),
            (1, 2),
            (1, 3),
            (1, 2),
            (1, 1)
        ])
    );
    assert_eq!(
        meet.paths[1],
        cells(&[
            (1, 1),
            (2, 1),
            (1, 1),
            (0, 1),
            (0, 2),
            (0, 1),
            (1, 1),
            (1, 2),
            (1, 3),
            (1, 2),
            (1, 1)
        ])
    );
    let gcs = run(Sharing::Gcs);
    assert_eq!(meet.d_max, 2);
    let bound = lemma1_upper_bound(7, meet.d_max, 2, 1.0, 0.0);
    assert_eq!(bound, 9.0);
    assert_eq!(meet.cost, 10.0);
    assert_eq!(gcs.cost, 6.0);
    // The excess comes from the one uninformed choice worked out in docs/results/dfs.md:
    // robot 2, back at t = 2, takes the dummy's first child, which robot 1 already took.
    assert_eq!(meet.explorer.uninformed_decisions(), 1);
    assert_eq!(gcs.explorer.uninformed_decisions(), 0);
    let t = meet.explorer.tree();
    let root = t.node(Tree::ROOT);
    assert_eq!(root.children.len(), 2);
    let dummy = root.children[1];
    assert_eq!(t.node(dummy).kind, NodeKind::Dummy);
    let cells: Vec<Cell> = t
        .node(dummy)
        .children
        .iter()
        .map(|&n| t.node(n).cell)
        .collect();
    assert_eq!(cells, vec![c(0, 1), c(1, 2)]);
    assert!(gcs.cost <= lemma1_upper_bound(7, gcs.d_max, 2, 1.0, 0.0));
}

/// A saved configuration or explorer from before the allocation existed (no `allocation`
/// key) loads with the default allocation; the names are the serde names.
#[test]
fn allocation_is_optional_in_saved_states_and_named_stably() {
    let old: ExplorerConfig = serde_json::from_str(r#"{"sharing":"meet"}"#).unwrap();
    assert_eq!(old.sharing, Sharing::Meet);
    assert_eq!(old.allocation, Allocation::default());
    let empty: ExplorerConfig = serde_json::from_str("{}").unwrap();
    assert_eq!(empty, ExplorerConfig::default());
    for a in Allocation::ALL {
        assert_eq!(
            serde_json::to_string(&a).unwrap(),
            format!("\"{}\"", a.name())
        );
        assert_eq!(a.to_string(), a.name());
    }
    let meet = ExplorerConfig {
        sharing: Sharing::Meet,
        allocation: Allocation::NearestFrontier,
        direct_transit: false,
    };
    assert_eq!(meet.effective_allocation(), Allocation::Paper);
    assert_eq!(
        ExplorerConfig::default().effective_allocation(),
        Allocation::default()
    );
    let ex = Explorer::new(ExplorerConfig::default(), c(0, 0), &ids(2)).unwrap();
    let mut v = serde_json::to_value(&ex).unwrap();
    v["config"]
        .as_object_mut()
        .unwrap()
        .remove("allocation")
        .unwrap();
    let back: Explorer = serde_json::from_value(v).unwrap();
    assert_eq!(back, ex);
}

/// With meeting-only sharing the nearest-frontier allocation is Algorithm 1's split: the
/// same moves on the same ROIs.
#[test]
fn nearest_frontier_is_the_paper_split_with_meeting_sharing() {
    use crate::explore::simulate::random_roi;
    use rand::SeedableRng;
    for seed in 0..20u64 {
        let (roi, start) = random_roi(&mut rand_chacha::ChaCha8Rng::seed_from_u64(seed), 60);
        let run = |allocation| {
            simulate(
                &roi,
                start,
                &SimConfig {
                    robots: 1 + (seed as usize % 8),
                    sharing: Sharing::Meet,
                    allocation,
                    record_paths: true,
                    ..SimConfig::default()
                },
            )
            .unwrap()
        };
        let (a, b) = (run(Allocation::Paper), run(Allocation::NearestFrontier));
        assert_eq!(a.paths, b.paths, "seed {seed}");
        assert_eq!(a.cost, b.cost, "seed {seed}");
    }
}
