//! Unit tests of fleetmap's team rules beside Algorithm 1: handover on a pause, direct
//! transit, the spread allocation.

use super::tests::{c, gather, ids, labels, roi};
use super::*;
use std::collections::HashSet;

/// Drive `ex` on `roi` to its end, robots polled in turn; returns every robot's cells in the
/// order it was sent to them.
fn drive(ex: &mut Explorer, roi: &HashSet<Cell>) -> Vec<Vec<Cell>> {
    let ids: Vec<RobotId> = ex.robots().iter().map(|r| r.id).collect();
    let mut paths = vec![Vec::new(); ids.len()];
    for _ in 0..10_000 {
        if ex.is_finished() {
            return paths;
        }
        for (k, &r) in ids.iter().enumerate() {
            match ex.next_action(r).unwrap() {
                Action::MoveTo(to) | Action::Rejoin(to) => {
                    paths[k].push(to);
                    ex.arrived(r, to).unwrap();
                }
                Action::Observe => {
                    let at = ex.robot_cell(r).unwrap();
                    ex.observe(r, at, labels(roi, at)).unwrap();
                }
                Action::Wait | Action::Done | Action::ReturnHome => {}
            }
        }
    }
    panic!("no end");
}

/// Handover: a robot paused on its way to a vertex not yet imaged releases it (unexplored
/// again, for the others); with another robot headed there too it stays under exploration.
#[test]
fn a_paused_robot_hands_its_vertex_over() {
    // The start with two children, north and south.
    let roi = roi(&[(0, 0), (1, 0), (-1, 0)]);
    let mut ex = Explorer::new(ExplorerConfig::default(), c(0, 0), &ids(2)).unwrap();
    gather(&mut ex, &roi);
    let a = ex.next_action(RobotId(1)).unwrap();
    let b = ex.next_action(RobotId(2)).unwrap();
    let (Action::MoveTo(ca), Action::MoveTo(cb)) = (a, b) else {
        panic!("{a:?} {b:?}");
    };
    assert_ne!(ca, cb);
    assert_eq!(ex.vertex_state(cb), Some(VertexState::UnderExploration));
    ex.pause(RobotId(2)).unwrap();
    assert_eq!(ex.vertex_state(cb), Some(VertexState::Unexplored));
    // Robot 1 images its leaf, walks back and takes the released vertex.
    ex.arrived(RobotId(1), ca).unwrap();
    assert_eq!(ex.next_action(RobotId(1)).unwrap(), Action::Observe);
    ex.observe(RobotId(1), ca, labels(&roi, ca)).unwrap();
    assert_eq!(ex.next_action(RobotId(1)).unwrap(), Action::MoveTo(c(0, 0)));
    ex.arrived(RobotId(1), c(0, 0)).unwrap();
    assert_eq!(ex.next_action(RobotId(1)).unwrap(), Action::MoveTo(cb));

    // Two robots headed to the same vertex: one leaving releases nothing.
    let roi1 = roi_line();
    let mut ex = Explorer::new(ExplorerConfig::default(), c(0, 0), &ids(2)).unwrap();
    gather(&mut ex, &roi1);
    assert_eq!(ex.next_action(RobotId(1)).unwrap(), Action::MoveTo(c(1, 0)));
    assert_eq!(ex.next_action(RobotId(2)).unwrap(), Action::MoveTo(c(1, 0)));
    ex.pause(RobotId(2)).unwrap();
    assert_eq!(
        ex.vertex_state(c(1, 0)),
        Some(VertexState::UnderExploration)
    );
}

fn roi_line() -> HashSet<Cell> {
    roi(&[(0, 0), (1, 0), (2, 0), (3, 0)])
}

/// Direct transit: a lone robot crosses cells already imaged without stopping. An L of five
/// cells: after its end the walk back to the start is passed through at once (the tour
/// ends there), the tree edges counted as walked, and the states end as with the walk.
#[test]
fn direct_transit_skips_the_stops_over_imaged_cells() {
    let cells = roi(&[(0, 0), (0, 1), (1, 1), (2, 1), (3, 1)]);
    let config = |direct_transit| ExplorerConfig {
        direct_transit,
        ..ExplorerConfig::default()
    };
    let mut walk = Explorer::new(config(false), c(0, 0), &ids(1)).unwrap();
    let mut fly = Explorer::new(config(true), c(0, 0), &ids(1)).unwrap();
    let pw = drive(&mut walk, &cells);
    let pf = drive(&mut fly, &cells);
    // The walk goes out along the line and back, one edge at a time.
    assert_eq!(
        pw[0],
        vec![
            c(0, 0),
            c(0, 1),
            c(1, 1),
            c(2, 1),
            c(3, 1),
            c(2, 1),
            c(1, 1),
            c(0, 1),
            c(0, 0)
        ]
    );
    // Direct: at the line's end nothing is left; the walk back passes imaged cells only,
    // so its tour ends there (the runner flies it home from where it is).
    assert_eq!(pf[0], vec![c(0, 0), c(0, 1), c(1, 1), c(2, 1), c(3, 1)]);
    assert_eq!(fly.next_action(RobotId(1)).unwrap(), Action::Done);
    let r = |e: &Explorer| e.robot(RobotId(1)).unwrap().moves;
    assert_eq!(r(&walk), r(&fly), "the same tree edges counted");
    assert_eq!(walk.vertex_states(), fly.vertex_states());
    assert!(walk.is_finished() && fly.is_finished());
}

/// Spread: three robots at a start with two children whose subtrees hold one frontier
/// vertex each send one robot to each and the third (nothing elsewhere) to the first; and
/// nobody waits at the start for a robot still on its way.
#[test]
fn spread_sends_one_robot_per_frontier_vertex_first() {
    let cells = roi(&[(0, 0), (1, 0), (-1, 0)]);
    let config = ExplorerConfig {
        allocation: Allocation::Spread,
        ..ExplorerConfig::default()
    };
    let mut ex = Explorer::new(config, c(0, 0), &ids(3)).unwrap();
    for r in [1, 2] {
        assert_eq!(ex.next_action(RobotId(r)).unwrap(), Action::Rejoin(c(0, 0)));
        ex.arrived(RobotId(r), c(0, 0)).unwrap();
    }
    // Robot 3 still on its way: robot 1 images the start, both decide without it.
    assert_eq!(ex.next_action(RobotId(1)).unwrap(), Action::Observe);
    ex.observe(RobotId(1), c(0, 0), labels(&cells, c(0, 0)))
        .unwrap();
    let a = ex.next_action(RobotId(1)).unwrap();
    let b = ex.next_action(RobotId(2)).unwrap();
    assert!(matches!(a, Action::MoveTo(_)) && matches!(b, Action::MoveTo(_)));
    assert_ne!(a, b, "one robot to each child");
    // Robot 3 arrives: nothing is frontier any more; it follows the first child.
    ex.arrived(RobotId(3), c(0, 0)).unwrap();
    assert!(matches!(
        ex.next_action(RobotId(3)).unwrap(),
        Action::MoveTo(_)
    ));
    let mut ex2 = ex.clone();
    drive(&mut ex2, &cells);
    assert!(ex2.is_finished());
}
