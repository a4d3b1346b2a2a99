//! The dispatcher thread, the wire edge: inputs in arrival order, classified by key (a vehicle's input,
//! plain or routed, or another key the hooks take: a standby batch, the ROS 2 edge's), checked for
//! ownership, decoded straight into measurements and queued on their vehicle's inbox; the vehicles go
//! to the worker pool once the inputs already waiting are queued too. Between inputs it runs the
//! tasks it is given (a fleet's change of members) and tells what the subscribers could not hand
//! over or zenoh reported lost.

use super::admission::NoRoom;
use super::{Engine, Inbound, Ingest, Input, Task, Vehicle};
use crate::sensors::Measurement;
use crate::wire::keys::{parse_route, route_of, Leaf, Received};
use crate::wire::{
    decode_batch_into, validate_vehicle_id, GyroMsg, ImuMsg, RejectCode, Rejection, VectorsMsg,
};
use std::sync::atomic::Ordering;
use std::sync::Arc;

/// Inputs already waiting that the dispatcher queues before handing their vehicles to the workers.
const DISPATCH_BATCH: usize = 64;
/// The longest the dispatcher waits for inputs, tasks or a nudge before it looks again, s. What the
/// subscribers could not hand over nudges it awake (`Engine::nudge_dispatcher`), so this is only a
/// backstop: an idle dispatcher wakes once a second instead of a hundred times (it used to look
/// every 10 ms, most of an idle fleet member's CPU).
const DOZE_S: f64 = 1.0;

impl Engine {
    /// The dispatcher thread: the inputs in arrival order, and the tasks it is given between them,
    /// until the ingest channel says stop. Between them it tells what the subscribers could not hand
    /// over (`Engine::tell_untold`), as soon as a nudge says there is some.
    pub(super) fn dispatcher(
        &self,
        ingest: crossbeam_channel::Receiver<Option<Ingest>>,
        tasks: crossbeam_channel::Receiver<Task>,
        nudge: crossbeam_channel::Receiver<()>,
    ) {
        let (mut decoded, mut touched) = (Vec::new(), Vec::new());
        let doze = std::time::Duration::from_secs_f64(DOZE_S);
        loop {
            self.tell_untold();
            crossbeam_channel::select! {
                recv(ingest) -> m => {
                    let Ok(Some(first)) = m else { return };
                    // What else is already waiting is queued too before the vehicles go to the
                    // workers: in a burst a vehicle's inputs then take one worker turn, not one each.
                    self.dispatch_ingest(first, &mut decoded, &mut touched);
                    let mut stop = false;
                    for _ in 1..DISPATCH_BATCH {
                        match ingest.try_recv() {
                            Ok(Some(next)) => self.dispatch_ingest(next, &mut decoded, &mut touched),
                            Ok(None) => {
                                stop = true;
                                break;
                            }
                            Err(_) => break,
                        }
                    }
                    for v in touched.drain(..) {
                        self.schedule(&v);
                    }
                    if stop {
                        self.tell_untold();
                        return;
                    }
                }
                recv(tasks) -> t => {
                    if let Ok(task) = t {
                        task(self);
                    }
                }
                recv(nudge) -> _ => {}
                default(doze) => {}
            }
        }
    }

    /// One item of the ingest channel: an input (its share released), or a report of samples missed.
    fn dispatch_ingest(
        &self,
        ingest: Ingest,
        decoded: &mut Vec<Measurement>,
        touched: &mut Vec<Arc<Vehicle>>,
    ) {
        match ingest {
            Ingest::Input {
                inbound,
                sequenced,
                held,
            } => {
                self.admission.release(held);
                self.dispatch_with(inbound, sequenced, decoded, touched);
            }
            Ingest::Missed { key, count, source } => self.missed(&key, count, &source),
        }
    }

    /// Decodes one raw input and queues its measurements on the vehicle (dispatcher thread).
    pub fn dispatch(&self, inbound: Inbound) {
        let mut touched = Vec::new();
        self.dispatch_with(inbound, false, &mut Vec::new(), &mut touched);
        for v in touched {
            self.schedule(&v);
        }
    }

    /// [`Engine::dispatch`] for any item of the ingest channel (tests hand it what zenoh reports).
    pub fn dispatch_item(&self, ingest: Ingest) {
        let mut touched = Vec::new();
        self.dispatch_ingest(ingest, &mut Vec::new(), &mut touched);
        for v in touched {
            self.schedule(&v);
        }
    }

    /// [`Engine::dispatch`] with the dispatcher thread's buffer of decoded measurements (its
    /// capacity is kept from one input to the next), pushing the vehicles to schedule on `touched`
    /// instead of scheduling them. `sequenced`: the input carries its publisher's sequence number
    /// (what a restarted service may be given again, `Engine::skip_redelivered`).
    fn dispatch_with(
        &self,
        inbound: Inbound,
        sequenced: bool,
        decoded: &mut Vec<Measurement>,
        touched: &mut Vec<Arc<Vehicle>>,
    ) {
        decoded.clear();
        let (vehicle, leaf, route) = match self.keys.classify(&inbound.key) {
            Some(Received::Vehicle {
                vehicle,
                leaf,
                route,
            }) => (vehicle, leaf, route),
            // (A standby batch, a ROS 2 topic: the hooks decode and queue it.)
            _ => {
                self.hooks.other_input(self, inbound, decoded, touched);
                return;
            }
        };
        if !matches!(leaf, Leaf::Gyro | Leaf::Vectors | Leaf::Imu) {
            return;
        }
        if let Some(chunk) = route {
            // A routed key whose route is not its vehicle's would reach the wrong member of a fleet:
            // refused by the one that receives it.
            if validate_vehicle_id(vehicle).is_ok() && parse_route(chunk) != Some(route_of(vehicle))
            {
                let r = Rejection::new(
                    RejectCode::WrongRoute,
                    format!(
                        "{}: the route of vehicle {vehicle} is {:x}, not {chunk} (proto/README.md, Routed inputs)",
                        inbound.key,
                        route_of(vehicle)
                    ),
                );
                self.counters.received.fetch_add(1, Ordering::Relaxed);
                self.reject(vehicle, &inbound.key, &r);
                return;
            }
        }
        if !self.hooks.owns(vehicle) {
            let vehicle = vehicle.to_string();
            self.hooks.not_owned(self, &vehicle, inbound);
            return;
        }
        if self
            .hooks
            .used_before(self, vehicle, leaf, &inbound.payload)
        {
            return;
        }
        let accepted = if sequenced {
            self.accept_sequenced(vehicle, leaf, &inbound.key, &inbound.payload, decoded)
        } else {
            self.accept(vehicle, leaf, &inbound.key, &inbound.payload, decoded)
        };
        if let Some(v) = accepted {
            touched.push(v);
        }
    }

    /// [`Engine::accept`] for a sequenced input: what a restored vehicle's checkpoint already held
    /// is skipped first.
    fn accept_sequenced(
        &self,
        vehicle: &str,
        leaf: Leaf,
        key: &str,
        payload: &[u8],
        decoded: &mut Vec<Measurement>,
    ) -> Option<Arc<Vehicle>> {
        decoded.clear();
        let result = match self.decode(leaf, payload, decoded)? {
            Ok(n) if n > 0 => match self.skip_redelivered(vehicle, decoded) {
                0 => return None,
                kept => Ok(kept),
            },
            other => other,
        };
        self.queue(vehicle, key, result, decoded)
    }

    /// Decodes an input of an owned vehicle and queues its measurements on its inbox, or refuses it
    /// (published on `P/V/rejected`, with `key`); the vehicle to schedule.
    pub fn accept(
        &self,
        vehicle: &str,
        leaf: Leaf,
        key: &str,
        payload: &[u8],
        decoded: &mut Vec<Measurement>,
    ) -> Option<Arc<Vehicle>> {
        decoded.clear();
        let result = self.decode(leaf, payload, decoded)?;
        self.queue(vehicle, key, result, decoded)
    }

    /// Queues the measurements decoded from one input on its vehicle's inbox (creating the vehicle),
    /// or refuses the input: the rejection of its decoding, an invalid vehicle id, too many vehicles,
    /// a full inbox. Returns the vehicle to schedule.
    pub fn queue(
        &self,
        vehicle: &str,
        key: &str,
        result: Result<usize, Rejection>,
        decoded: &mut Vec<Measurement>,
    ) -> Option<Arc<Vehicle>> {
        let n = *result.as_ref().unwrap_or(&1) as u64;
        self.counters.received.fetch_add(n, Ordering::Relaxed);
        let refused = |r: &Rejection| {
            self.reject(vehicle, key, r);
            None
        };
        if let Err(r) = validate_vehicle_id(vehicle) {
            decoded.clear();
            return refused(&r);
        }
        if let Err(r) = result {
            return refused(&r);
        }
        let v = match self.get_or_create(vehicle) {
            Ok(v) => v,
            Err(r) => {
                decoded.clear();
                return refused(&r);
            }
        };
        {
            let mut inbox = v.inbox.lock().unwrap_or_else(|e| e.into_inner());
            if inbox.len() + decoded.len() > self.config.limits.queue_per_vehicle {
                let waiting = inbox.len();
                drop(inbox);
                decoded.clear();
                let r = Rejection::new(
                    RejectCode::QueueFull,
                    format!(
                        "vehicle {vehicle} has {} samples waiting (limit {}); these {n} are dropped",
                        waiting, self.config.limits.queue_per_vehicle,
                    ),
                );
                return refused(&r);
            }
            let at = self.now_s();
            inbox.extend(decoded.drain(..).map(|m| Input::Measurement(m, at)));
            // (A refused payload is counted as one rejection, not as received samples.)
            v.received.fetch_add(n, Ordering::Relaxed);
        }
        Some(v)
    }

    /// Decodes a gyro, vectors or IMU payload straight into measurements appended to `out` (nothing
    /// on a fault; `None` for other leaves), and how many.
    pub fn decode(
        &self,
        leaf: Leaf,
        payload: &[u8],
        out: &mut Vec<Measurement>,
    ) -> Option<Result<usize, Rejection>> {
        let limits = &self.config.limits.input;
        Some(match leaf {
            Leaf::Gyro => decode_batch_into(
                payload,
                limits,
                |g: GyroMsg| g.to_domain(limits).map(Measurement::Gyro),
                out,
            ),
            Leaf::Imu => decode_batch_into(
                payload,
                limits,
                |s: ImuMsg| s.to_domain(limits).map(Measurement::Imu),
                out,
            ),
            Leaf::Vectors => decode_batch_into(
                payload,
                limits,
                |v: VectorsMsg| v.to_domain(limits).map(Measurement::Vectors),
                out,
            ),
            _ => return None,
        })
    }
}

/// What could not be handed over or was lost, told on the dispatcher thread.
impl Engine {
    /// The dispatcher's side: tells what the subscribers could not hand over (dispatcher thread,
    /// between inputs).
    pub(super) fn tell_untold(&self) {
        let Some(untold) = self.admission.take_untold() else {
            return;
        };
        for (key, u) in untold {
            if u.missed > 0 {
                self.missed(&key, u.missed, &u.source);
            }
            if u.refused > 0 {
                let why = match u.why {
                    Some(NoRoom::Share) => format!(
                        "its vehicle's inputs waiting to be decoded already held {} bytes (service.ingest.pending_bytes_per_vehicle)",
                        self.config.ingest.pending_bytes_per_vehicle
                    ),
                    _ => format!(
                        "the service's ingest was full ({} bytes or {} inputs waiting to be decoded)",
                        self.config.ingest.pending_bytes, self.admission.capacity()
                    ),
                };
                let r = Rejection::new(
                    RejectCode::QueueFull,
                    format!(
                        "{} input(s) on {key} refused on arrival: {why}; the sender is faster than this service",
                        u.refused
                    ),
                );
                self.tell(&key, &r);
            }
        }
    }

    /// The vehicle of an input key (plain, routed, or the ROS 2 edge's).
    fn vehicle_of_key<'a>(&self, key: &'a str) -> Option<&'a str> {
        match self.keys.classify(key) {
            Some(Received::Vehicle { vehicle, .. }) => Some(vehicle),
            Some(_) => None,
            None => self.hooks.vehicle_of(key),
        }
    }

    /// Publishes `r` about the input key `key` on its vehicle's `P/V/rejected` (counted as every
    /// rejection), when this instance owns the vehicle; counted only otherwise (another member of
    /// the fleet speaks for it).
    fn tell(&self, key: &str, r: &Rejection) {
        match self.vehicle_of_key(key) {
            Some(vehicle) if validate_vehicle_id(vehicle).is_ok() => {
                if self.hooks.owns(vehicle) {
                    self.reject(vehicle, key, r);
                }
            }
            _ => {
                // (Not a vehicle's key: nobody to tell but the log and the counters.)
                self.counters.reject(r.code);
                tracing::warn!(key, code = r.code.as_str(), message = %r.message, "not told");
            }
        }
    }

    /// zenoh reports `count` puts on `key` lost (dispatcher thread, in order with the inputs): counted
    /// per vehicle and in all, and told on the vehicle's `P/V/rejected` (`samples_missed`).
    pub(super) fn missed(&self, key: &str, count: u64, source: &str) {
        self.counters.missed.fetch_add(count, Ordering::Relaxed);
        if let Some(v) = self.vehicle_of_key(key).and_then(|id| self.vehicle(id)) {
            v.missed.fetch_add(count, Ordering::Relaxed);
        }
        tracing::info!(key, count, source, "samples missed");
        let r = Rejection::new(
            RejectCode::SamplesMissed,
            format!(
                "zenoh reports {count} put(s) on {key} from publisher {source} lost on the way and not recovered from its cache (too small, or no answer within service.ingest.query_timeout_s)"
            ),
        );
        self.tell(key, &r);
    }

    /// Of the measurements decoded from a sequenced input of a vehicle restored from a checkpoint,
    /// drops those at or before what the checkpoint held of their stream: zenoh delivers a
    /// publisher's cache again to a restarted service, and what the checkpoint already used is no
    /// input to refuse. Returns how many are left.
    pub(super) fn skip_redelivered(&self, vehicle: &str, decoded: &mut Vec<Measurement>) -> usize {
        let Some(newest) = self.vehicle(vehicle).and_then(|v| v.restored_newest) else {
            return decoded.len();
        };
        let before = decoded.len();
        decoded
            .retain(|m| newest[crate::vehicle::stream_of(m) as usize].is_none_or(|t| m.t_s() > t));
        let skipped = before - decoded.len();
        if skipped > 0 {
            self.admission
                .redelivered
                .fetch_add(skipped as u64, Ordering::Relaxed);
        }
        decoded.len()
    }
}
