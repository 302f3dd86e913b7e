use super::*;
use proptest::prelude::*;
use std::collections::VecDeque;

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

fn t(ms: u64) -> Time {
    Time::from_secs_f64(ms as f64 / 1000.0)
}

fn rtt() -> RoundTrip {
    RoundTrip::new(ms(500), ms(200), ms(2000))
}

/// What crosses the link, either way.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Msg {
    Send(CaptureSend),
    Ack,
    Announced(i32),
    Result(i32),
}

/// One direction of a lossy FIFO link: each message is lost with probability `loss` (a
/// seeded xorshift), the rest arrive `latency` after they were sent, in order.
struct Way {
    queue: VecDeque<(Time, Msg)>,
    latency: Duration,
    loss: f64,
    rng: u64,
}

impl Way {
    fn send(&mut self, now: Time, m: Msg) {
        self.rng ^= self.rng << 13;
        self.rng ^= self.rng >> 7;
        self.rng ^= self.rng << 17;
        if (self.rng % 10_000) as f64 / 10_000.0 < self.loss {
            return;
        }
        self.queue.push_back((now + self.latency, m));
    }

    fn due(&mut self, now: Time) -> Vec<Msg> {
        let mut out = Vec::new();
        while self.queue.front().is_some_and(|(at, _)| *at <= now) {
            if let Some((_, m)) = self.queue.pop_front() {
                out.push(m);
            }
        }
        out
    }
}

/// A camera as the protocol describes it: the last sequence number remembered, one picture
/// per new command (ACK, announcement, result), the kept pictures sent again on request.
#[derive(Default)]
struct Camera {
    last_seq: Option<u32>,
    next_index: i32,
    taken: u32,
}

impl Camera {
    fn hear(&mut self, m: CaptureSend) -> Vec<Msg> {
        match m {
            CaptureSend::Capture { seq } => {
                if self.last_seq == Some(seq) {
                    return vec![Msg::Ack];
                }
                self.last_seq = Some(seq);
                let i = self.next_index;
                self.next_index += 1;
                self.taken += 1;
                vec![Msg::Ack, Msg::Announced(i), Msg::Result(i)]
            }
            CaptureSend::Again { first, last } => (first..self.next_index)
                .filter(|i| last.is_none_or(|l| *i <= l))
                .flat_map(|i| [Msg::Announced(i), Msg::Result(i)])
                .collect(),
        }
    }
}

/// One visit wanting `wanted` pictures over a link losing `loss` each way with `latency`:
/// the pictures complete, the pictures the camera took, the simulated end.
fn visit(wanted: u32, loss: f64, latency_ms: u64, seed: u64) -> (u32, u32, Time, Vec<u32>) {
    visit_with(wanted, loss, latency_ms, seed, Duration::from_secs(10))
}

/// [`visit`] with a ledger that gives up after `give_up_after` without progress.
fn visit_with(
    wanted: u32,
    loss: f64,
    latency_ms: u64,
    seed: u64,
    give_up_after: Duration,
) -> (u32, u32, Time, Vec<u32>) {
    let mut cam = Camera {
        next_index: 10,
        ..Camera::default()
    };
    let mut up = Way {
        queue: VecDeque::new(),
        latency: ms(latency_ms),
        loss,
        rng: seed | 1,
    };
    let mut down = Way {
        queue: VecDeque::new(),
        latency: ms(latency_ms),
        loss,
        rng: (seed ^ 0x9e37_79b9_7f4a_7c15) | 1,
    };
    let mut now = t(0);
    let mut ledger = CaptureLedger::new(now, wanted, 9, 1, rtt(), give_up_after);
    let mut halves: BTreeMap<i32, (bool, bool)> = BTreeMap::new();
    let mut seqs = Vec::new();
    while !ledger.is_over(now) && now < t(120_000) {
        for s in ledger.poll_transmit(now) {
            if let CaptureSend::Capture { seq } = s {
                seqs.push(seq);
            }
            up.send(now, Msg::Send(s));
        }
        for m in up.due(now) {
            if let Msg::Send(s) = m {
                for answer in cam.hear(s) {
                    down.send(now, answer);
                }
            }
        }
        for m in down.due(now) {
            match m {
                Msg::Ack => ledger.handle_ack(now, true),
                Msg::Announced(i) | Msg::Result(i) => {
                    ledger.handle_named(now, i);
                    let h = halves.entry(i).or_default();
                    if matches!(m, Msg::Announced(_)) {
                        h.0 = true;
                    } else {
                        h.1 = true;
                    }
                    if h.0 && h.1 {
                        ledger.handle_complete(now, i);
                    }
                }
                Msg::Send(_) => {}
            }
        }
        if ledger.is_over(now) {
            break;
        }
        // the next thing to happen: the ledger's timer or a message's arrival
        let mut next = ledger.poll_timeout().max(now + ms(1));
        for w in [&up, &down] {
            if let Some((at, _)) = w.queue.front() {
                next = next.min((*at).max(now + ms(1)));
            }
        }
        now = next;
    }
    (ledger.complete(), cam.taken, now, seqs)
}

#[test]
fn a_clean_link_takes_the_pictures_back_to_back() {
    let (complete, taken, end, seqs) = visit(5, 0.0, 50, 1);
    assert_eq!((complete, taken), (5, 5));
    assert_eq!(seqs, vec![1, 2, 3, 4, 5]);
    // one round trip per picture, the results of one crossing while the next is asked for
    assert!(end <= t(5 * 100 + 60), "{end}");
}

#[test]
fn the_timeout_follows_the_round_trips() {
    let mut r = rtt();
    assert_eq!(r.rto(), ms(500));
    for _ in 0..20 {
        r.sample(ms(100));
    }
    // converged on 100 ms with no variation: the floor
    assert_eq!(r.rto(), ms(200));
    for _ in 0..20 {
        r.sample(ms(900));
    }
    assert!(r.rto() >= ms(900) && r.rto() <= ms(2000), "{:?}", r.rto());
}

#[test]
fn a_lost_last_announcement_is_found_by_probing() {
    // the ACK arrives, both halves of the one picture are lost: the ledger asks for the
    // captures after the newest it knows and gets it
    let mut l = CaptureLedger::new(t(0), 1, 9, 1, rtt(), Duration::from_secs(10));
    assert_eq!(l.poll_transmit(t(0)), vec![CaptureSend::Capture { seq: 1 }]);
    l.handle_ack(t(100), true);
    assert!(l.poll_transmit(t(100)).is_empty());
    let wake = l.poll_timeout();
    assert!(wake > t(100) && wake <= t(700), "{wake}");
    assert_eq!(
        l.poll_transmit(wake),
        vec![CaptureSend::Again {
            first: 10,
            last: None
        }]
    );
    assert!(l.handle_complete(wake + ms(100), 10));
    assert!(l.is_over(wake + ms(100)));
}

#[test]
fn an_earlier_pictures_announcement_does_not_confirm_the_next_command() {
    let mut l = CaptureLedger::new(t(0), 3, 9, 1, rtt(), Duration::from_secs(10));
    assert_eq!(l.poll_transmit(t(0)), vec![CaptureSend::Capture { seq: 1 }]);
    l.handle_ack(t(50), true);
    assert_eq!(
        l.poll_transmit(t(50)),
        vec![CaptureSend::Capture { seq: 2 }]
    );
    // picture 10 is command 1's
    l.handle_named(t(60), 10);
    assert!(l.poll_transmit(t(60)).is_empty());
    // command 2's ACK lost: sent again with the same number after the timeout
    let sends = l.poll_transmit(t(50) + rtt().rto());
    assert!(
        sends.contains(&CaptureSend::Capture { seq: 2 }),
        "{sends:?}"
    );
    assert!(
        sends.contains(&CaptureSend::Again {
            first: 11,
            last: None
        }),
        "{sends:?}"
    );
}

#[test]
fn holes_are_asked_for_as_one_range() {
    let mut l = CaptureLedger::new(t(0), 5, 9, 1, rtt(), Duration::from_secs(10));
    for (i, at) in [(10, 0), (11, 100), (12, 200)] {
        l.poll_transmit(t(at));
        l.handle_named(t(at + 50), i);
    }
    l.handle_complete(t(260), 11);
    let sends = l.poll_transmit(t(2_000));
    assert!(
        sends.contains(&CaptureSend::Again {
            first: 10,
            last: Some(12)
        }),
        "{sends:?}"
    );
}

#[test]
fn a_stale_ack_does_not_confirm_the_next_command() {
    let mut l = CaptureLedger::new(t(0), 2, 9, 1, rtt(), Duration::from_secs(10));
    l.poll_transmit(t(0));
    // sent again before its (slow) ACK: two ACKs are owed
    let again = l.poll_transmit(t(600));
    assert!(again.contains(&CaptureSend::Capture { seq: 1 }));
    l.handle_ack(t(700), true);
    assert_eq!(
        l.poll_transmit(t(700)),
        vec![CaptureSend::Capture { seq: 2 }]
    );
    // the repeat's ACK: not command 2's
    l.handle_ack(t(710), true);
    let sends = l.poll_transmit(t(710) + l.round_trip().rto());
    assert!(
        sends.contains(&CaptureSend::Capture { seq: 2 }),
        "{sends:?}"
    );
}

#[test]
fn nothing_heard_gives_up() {
    let mut l = CaptureLedger::new(t(0), 5, 9, 1, rtt(), Duration::from_secs(10));
    let mut now = t(0);
    while !l.is_over(now) {
        l.poll_transmit(now);
        now = l.poll_timeout().max(now + ms(1));
    }
    assert_eq!(l.complete(), 0);
    assert!(now >= t(10_000) && now <= t(10_100), "{now}");
}

/// A give-up long enough that a link losing 30 % each way is never silent for it (24 tries in
/// a row failing: below 1e-10).
const PATIENT: Duration = Duration::from_secs(30);

/// A case the property once failed on with a 10 s give-up: picture 15's result arrived, but
/// its announcement was lost seven times in a row, and nothing new came for 10 s. The visit
/// gives up with 5 of 6 (the caller retakes the sixth); a patient one gets all six.
#[test]
fn a_visit_whose_last_half_is_lost_for_10_s_gives_up_and_a_patient_one_completes() {
    let seed = 15_372_013_936_790_894_686;
    let (complete, taken, end, _) = visit(6, 0.2955, 141, seed);
    assert_eq!((complete, taken), (5, 6), "by {end}");
    assert!(end >= t(12_500) && end < t(12_600), "{end}");
    let (complete, taken, end, _) = visit_with(6, 0.2955, 141, seed, PATIENT);
    assert_eq!((complete, taken), (6, 6), "by {end}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    /// Over any loss up to 30 % each way and any latency, a visit gets its pictures and the
    /// camera takes at most a few more than wanted; with no loss, exactly the ones wanted.
    ///
    /// The protocol's property, so the ledger here waits 30 s without progress before it
    /// gives up (0 short in a sweep of 1,000,000 cases). With the 10 s the runway's visits
    /// use, 27 of those cases ended short (this test then failed about one run in 90): at
    /// 30 % loss each way a third of the round trips fail, and 10 s holds eight tries at a
    /// 1.3 s timeout (the case above). The caller retakes what is missing.
    #[test]
    fn visits_complete_under_loss(
        wanted in 1u32..7,
        loss in 0.0f64..0.3,
        latency in 5u64..600,
        seed in any::<u64>(),
    ) {
        let (complete, taken, end, seqs) = visit_with(wanted, loss, latency, seed, PATIENT);
        prop_assert!(complete >= wanted, "{complete} of {wanted} by {end}");
        prop_assert!(taken <= wanted + 3, "{taken} taken for {wanted}");
        // sequence numbers only go up: a repeat is always of the newest command
        prop_assert!(seqs.windows(2).all(|w| w[1] >= w[0]), "{seqs:?}");
        let (c0, t0, _, _) = visit(wanted, 0.0, latency, seed);
        prop_assert_eq!((c0, t0), (wanted, wanted));
    }
}
