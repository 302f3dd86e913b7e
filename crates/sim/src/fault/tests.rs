//! The fault spec's parser and the plan's timeline.

use super::*;
use proptest::prelude::*;

fn one(s: &str) -> ScheduledFault {
    s.parse().unwrap()
}

#[test]
fn the_documented_examples_parse() {
    assert_eq!(
        one("2:battery=20@300s"),
        ScheduledFault {
            target: FaultTarget::Vehicle(2),
            fault: Fault::Battery { percent: 20.0 },
            from: Duration::from_secs(300),
            until: None,
        }
    );
    assert_eq!(
        one("1:camera=off@200s..400s"),
        ScheduledFault {
            target: FaultTarget::Vehicle(1),
            fault: Fault::CameraOff,
            from: Duration::from_secs(200),
            until: Some(Duration::from_secs(400)),
        }
    );
    let r = one("3:camera-rate=20000");
    assert_eq!(
        r.fault,
        Fault::CameraRate {
            bytes_per_s: 20000.0
        }
    );
    assert_eq!((r.from, r.until), (Duration::ZERO, None));
    assert_eq!(one("5:stuck@100s").fault, Fault::Stuck);
    let o = one("all:outage@120s..420s");
    assert_eq!(o.target, FaultTarget::All);
    assert_eq!(o.until, Some(Duration::from_secs(420)));
    assert_eq!(
        one("4:camera-interval=2.5s@1m30s").fault,
        Fault::CameraInterval { seconds: 2.5 }
    );
    assert_eq!(one("4:stuck@1m30s").from, Duration::from_secs(90));
    assert_eq!(one("4:stuck@1.5m").from, Duration::from_secs(90));
    assert_eq!(
        one(" ALL : Outage @ 30 .. 60s ").from,
        Duration::from_secs(30)
    );
    assert_eq!(one("1:battery=15%").fault, Fault::Battery { percent: 15.0 });
    let all = parse_faults("1:outage@30s..60s, 2:stuck@10s,").unwrap();
    assert_eq!(all.len(), 2);
}

#[test]
fn bad_specs_say_what_is_wrong() {
    let reason = |s: &str| s.parse::<ScheduledFault>().unwrap_err().reason;
    assert!(reason("battery=20").contains("TARGET:FAULT"));
    assert!(reason("0:stuck").contains("vehicle number"));
    assert!(reason("x:stuck").contains("vehicle number"));
    assert!(reason("1:battery=120").contains("percentage"));
    assert!(reason("1:battery=-1").contains("percentage"));
    assert!(reason("1:battery").contains("needs a value"));
    assert!(reason("1:battery=20@10s..20s").contains("no end"));
    assert!(reason("1:camera=on").contains("camera=off"));
    assert!(reason("1:camera-rate=0").contains("positive"));
    assert!(reason("1:camera-rate=fast").contains("positive"));
    assert!(reason("1:camera-interval=nan").contains("positive"));
    assert!(reason("1:outage=5").contains("no value"));
    assert!(reason("1:explode").contains("unknown fault"));
    assert!(reason("1:stuck@soon").contains("time"));
    assert!(reason("1:stuck@-5s").contains("time"));
    assert!(reason("1:stuck@5x").contains("time"));
    assert!(reason("1:stuck@2m30").contains("time"));
    assert!(reason("1:stuck@100s..50s").contains("before it starts"));
    assert!(reason("1:stuck@100s..100s").contains("before it starts"));
    assert!(reason("1:stuck@1e12").contains("year"));
    let e = parse_faults(" , ").unwrap_err();
    assert!(e.reason.contains("no fault"), "{e}");
    // the message names the entry at fault
    let e = parse_faults("1:stuck,2:bogus").unwrap_err();
    assert_eq!(e.spec, "2:bogus");
    assert!(
        e.to_string().starts_with("invalid fault \"2:bogus\""),
        "{e}"
    );
}

#[test]
fn a_plan_checks_vehicles_and_cameras() {
    let s = |x: &str| parse_faults(x).unwrap();
    let cams = [true, true, false];
    assert!(FaultPlan::new(&s("3:stuck"), &cams, Time::ZERO).is_ok());
    let e = FaultPlan::new(&s("4:stuck"), &cams, Time::ZERO).unwrap_err();
    assert!(e.reason.contains("no vehicle 4"), "{e}");
    let e = FaultPlan::new(&s("3:camera=off"), &cams, Time::ZERO).unwrap_err();
    assert!(e.reason.contains("no camera"), "{e}");
    // `all` camera faults hit the vehicles that have one
    let p = FaultPlan::new(&s("all:camera=off@1s"), &cams, Time::ZERO).unwrap();
    assert_eq!(p.entries.len(), 2);
    let e = FaultPlan::new(&s("all:camera=off"), &[false], Time::ZERO).unwrap_err();
    assert!(e.reason.contains("no vehicle has a camera"), "{e}");
}

#[test]
fn the_plan_changes_state_at_starts_and_ends_and_overlaps_combine() {
    let sched = parse_faults(
        "1:camera=off@10s..30s,1:camera=off@20s..40s,2:camera-rate=1000@5s..50s,\
         2:camera-rate=500@10s..20s,1:battery=20@15s,all:outage@0s..5s",
    )
    .unwrap();
    let mut p = FaultPlan::new(&sched, &[true, true], Time::from_secs(100)).unwrap();
    assert_eq!(
        p.outages(0),
        vec![(Time::from_secs(100), Time::from_secs(105))]
    );
    let at = |p: &mut FaultPlan, s: u64| {
        let t = Time::from_secs(100 + s);
        if p.due(t) { p.step(t).0 } else { Vec::new() }
    };
    assert!(at(&mut p, 4).is_empty());
    assert_eq!(at(&mut p, 5), vec![(1, Action::CameraRate(Some(1000.0)))]);
    assert_eq!(
        at(&mut p, 10),
        vec![
            (0, Action::CameraFailed(true)),
            (1, Action::CameraRate(Some(500.0)))
        ]
    );
    assert_eq!(at(&mut p, 15), vec![(0, Action::Battery(20.0))]);
    // the second window keeps the camera off when the first ends; the inner rate
    // window ends and the outer one holds again
    assert_eq!(at(&mut p, 30), vec![(1, Action::CameraRate(Some(1000.0)))]);
    assert_eq!(at(&mut p, 40), vec![(0, Action::CameraFailed(false))]);
    assert_eq!(at(&mut p, 60), vec![(1, Action::CameraRate(None))]);
    assert!(!p.due(Time::from_secs(10_000)));
}

#[test]
fn a_late_step_applies_everything_passed_once() {
    let sched = parse_faults("1:stuck@10s..20s,1:battery=30@12s").unwrap();
    let mut p = FaultPlan::new(&sched, &[false], Time::ZERO).unwrap();
    let (actions, events) = p.step(Time::from_secs(25));
    // stuck and free again within the step: no net change; the battery drop happens
    assert_eq!(actions, vec![(0, Action::Battery(30.0))]);
    assert_eq!(events.len(), 3, "{events:?}");
}

fn fault() -> impl Strategy<Value = Fault> {
    prop_oneof![
        Just(Fault::Outage),
        Just(Fault::CameraOff),
        Just(Fault::Stuck),
        (0u32..10_000).prop_map(|p| Fault::Battery {
            percent: f64::from(p) / 100.0
        }),
        (1u32..1_000_000).prop_map(|b| Fault::CameraRate {
            bytes_per_s: f64::from(b)
        }),
        (1u32..100_000).prop_map(|s| Fault::CameraInterval {
            seconds: f64::from(s) / 1000.0
        }),
    ]
}

proptest! {
    /// What an entry prints parses back to the same entry.
    #[test]
    fn display_parses_back(
        k in prop_oneof![Just(None), (1usize..=250).prop_map(Some)],
        f in fault(),
        from_ms in 0u64..10_000_000,
        len_ms in prop_oneof![Just(None), (1u64..10_000_000).prop_map(Some)],
    ) {
        let until = if matches!(f, Fault::Battery { .. }) { None } else { len_ms };
        let e = ScheduledFault {
            target: k.map_or(FaultTarget::All, FaultTarget::Vehicle),
            fault: f,
            from: Duration::from_millis(from_ms),
            until: until.map(|l| Duration::from_millis(from_ms + l)),
        };
        let text = e.to_string();
        prop_assert_eq!(text.parse::<ScheduledFault>(), Ok(e), "{}", text);
    }

    /// Any text gives an entry or an error, never a panic.
    #[test]
    fn any_text_parses_or_errs(s in ".{0,40}") {
        let _ = parse_faults(&s);
    }

    /// However the clock is stepped, a vehicle ends in the state the windows say.
    #[test]
    fn stepping_in_any_increments_ends_in_the_same_state(
        windows in proptest::collection::vec((0u64..100, 1u64..50), 1..6),
        steps in proptest::collection::vec(1u64..40, 1..20),
    ) {
        let sched: Vec<ScheduledFault> = windows
            .iter()
            .map(|&(a, l)| ScheduledFault {
                target: FaultTarget::Vehicle(1),
                fault: Fault::Stuck,
                from: Duration::from_secs(a),
                until: Some(Duration::from_secs(a + l)),
            })
            .collect();
        let mut p = FaultPlan::new(&sched, &[false], Time::ZERO).unwrap();
        let mut stuck = false;
        let mut t = 0;
        for s in steps {
            t += s;
            for (_, a) in p.step(Time::from_secs(t)).0 {
                if let Action::Stuck(x) = a {
                    prop_assert_ne!(x, stuck, "a change that changes nothing");
                    stuck = x;
                }
            }
            let want = windows.iter().any(|&(a, l)| a <= t && t < a + l);
            prop_assert_eq!(stuck, want, "at {}s", t);
        }
    }
}
