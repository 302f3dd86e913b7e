//! The simulator served over in-process links ([`fleetmap_io::link::transport::MemoryPort`]) on the
//! runtime's clock: the tests' fully virtual runs.

use super::{SimTask, Stepper, log_event, pause};
use crate::harness::Sim;
use crate::pace::Speed;
use fleetmap_io::clock::MonotonicClock;
use tokio::sync::mpsc;

/// Serve `sim` over in-process links, one [`fleetmap_io::link::transport::MemoryPort`] per vehicle
/// in the order of [`Sim::sysids`], on the runtime's clock at real speed. With tokio's clock paused
/// (tests with `start_paused`) this is a fully virtual run: the simulator, the links and the
/// fleet share tokio's virtual time, which jumps to the next timer whenever every task
/// waits, so simulated minutes cost only the CPU time of the work done.
pub fn spawn_memory(sim: Sim, ports: Vec<fleetmap_io::link::transport::MemoryPort>) -> SimTask {
    let (stop_tx, mut stop_rx) = tokio::sync::oneshot::channel::<()>();
    let sysids = sim.sysids();
    let (tx, mut rx) = mpsc::unbounded_channel::<(usize, Vec<u8>)>();
    let mut outs = Vec::new();
    for (k, p) in ports.into_iter().enumerate() {
        let fleetmap_io::link::transport::MemoryPort {
            mut from_gcs,
            to_gcs,
        } = p;
        outs.push(to_gcs);
        let tx = tx.clone();
        tokio::spawn(async move {
            while let Some(b) = from_gcs.recv().await {
                if tx.send((k, b)).is_err() {
                    return;
                }
            }
        });
    }
    drop(tx);
    let task = tokio::spawn(async move {
        let clock = MonotonicClock::new();
        let mut stepper = Stepper::new(sim, Speed::REAL_TIME, None);
        let mut open = true;
        loop {
            let wall = clock.now();
            stepper.step(wall);
            stepper.record(wall);
            while stepper.sim.poll_image().is_some() {}
            while let Some((sysid, ev)) = stepper.sim.poll_event() {
                log_event(sysid, &ev);
            }
            for k in 0..sysids.len() {
                while let Some(d) = stepper.sim.recv_bytes_at(k) {
                    if let Some(o) = outs.get(k) {
                        let _ = o.send(d);
                    }
                }
            }
            let wait = stepper.wait(clock.now());
            // `biased`: in this order, not tokio's random one, so that a run on a paused
            // clock is the same every time (a stop first: it ends the task).
            tokio::select! {
                biased;
                _ = &mut stop_rx => return Ok(stepper.sim),
                r = rx.recv(), if open => {
                    if r.is_none() {
                        open = false;
                    }
                    let mut next = r;
                    while let Some((k, bytes)) = next {
                        if k < sysids.len() {
                            stepper.receive(k, &bytes);
                        }
                        next = rx.try_recv().ok();
                    }
                    stepper.deliver();
                }
                _ = pause(wait) => {}
            }
        }
    });
    SimTask::new(stop_tx, task)
}
