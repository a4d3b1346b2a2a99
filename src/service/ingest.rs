//! The subscriptions of the vehicles' input keys and what their callbacks do (proto/README.md, "Loss,
//! recovery and back-pressure").
//!
//! Each input key (`P/*/gyro`, `P/*/vectors`, `P/*/imu`) has two subscriptions when
//! `service.ingest.recovery` is on:
//!
//! * a zenoh-ext **AdvancedSubscriber** for the samples of publishers that number them (zenoh-ext
//!   AdvancedPublishers with sample-miss detection: the Python client, `loadgen`, `simulate`, the
//!   replay tools). A gap in a publisher's numbers is recovered from its cache (zenoh-ext holds the
//!   publisher's later samples until the answer comes, at most `query_timeout_s`); what cannot be
//!   recovered is reported (`Miss`) and told on the vehicle's `P/V/rejected` (`samples_missed`). When
//!   the service starts, or a publisher appears (a reconnection), the last `history_samples` of its
//!   cache are asked for: what a publisher put while the service was down or unreachable arrives
//!   (zenoh-ext drops that answer when a live put beats it: the first put of a publisher the service
//!   did not know, numbered above 0, has the puts before it fetched here too, [`Intake::numbered`]).
//! * a **plain subscriber** for every other sample (plain publishers: no recovery, no detection; the
//!   vehicles see the gaps in the sample times). They are kept apart because zenoh-ext orders the
//!   samples it cannot number by their timestamps, per clock, and drops any older than one it
//!   delivered: a router stamps every sample it forwards, from several threads, and two plain senders'
//!   samples stamped in one order and sent in the other would be lost without a word.
//!
//! A callback never decodes: it hands the raw sample to the engine's ingest channel through
//! `Admission::offer`, within its vehicle's share. Only the plain subscribers' callbacks may wait for
//! room (holding zenoh's receiving thread for that link: back-pressure on the sender, whose `Block`
//! puts then wait, and one callback at a time so that another thread receives the rest): zenoh-ext
//! calls an AdvancedSubscriber's callback under a lock that every vehicle of the key shares, so a wait
//! there would hold them all. What finds no room is refused and told (`queue_full`).
//!
//! The routed inputs of a fleet (`fleet::membership::Routing`) and the ROS 2 edge's subscriptions
//! (`ros2::net`) stay plain subscriptions with the same callback ([`Intake::plain`]): route
//! subscriptions come and go with the fleet's membership, and a new AdvancedSubscriber would ask every
//! publisher of the route for its cache again, inputs the previous owner already used; rmw_zenoh's
//! sensor publishers (best effort, volatile) number nothing and cache nothing.

use super::config::IngestConfig;
use super::{zerr, ServiceError};
use crate::engine::{Engine, Inbound, Ingest};
use crate::wire::keys::{Leaf, Received};
use std::collections::{BTreeMap, HashMap};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use zenoh::query::{ConsolidationMode, QueryTarget, Reply, ReplyKeyExpr};
use zenoh::sample::{Sample, SampleKind};
use zenoh::session::EntityGlobalId;
use zenoh::Wait;
use zenoh_ext::{AdvancedSubscriberBuilderExt, HistoryConfig, Miss, RecoveryConfig};

/// Most publishers remembered per generation of [`Sources`].
const SOURCES: usize = 1 << 16;

/// A publisher that numbers its samples: the key it puts on (a `Miss` names the publisher only), and
/// while its first puts are fetched from its cache, what it puts meanwhile.
struct Source {
    key: Arc<str>,
    catch_up: Option<CatchUp>,
}

/// The puts before a publisher's first one this service got ([`Intake::numbered`]): asked of its cache,
/// delivered before `held`, the puts that came meanwhile.
struct CatchUp {
    first: u32,
    held: Vec<Sample>,
    replies: BTreeMap<u32, Sample>,
}

/// The publishers, in two generations so that they stay bounded: one not heard from while [`SOURCES`]
/// others were is forgotten.
#[derive(Default)]
struct Sources {
    current: HashMap<EntityGlobalId, Source>,
    previous: HashMap<EntityGlobalId, Source>,
}

impl Sources {
    /// The publisher's entry (its key updated), and whether it was unknown.
    fn entry(&mut self, id: &EntityGlobalId, key: &str) -> (&mut Source, bool) {
        let mut new = false;
        if !self.current.contains_key(id) {
            let known = self.previous.remove(id);
            new = known.is_none();
            if self.current.len() >= SOURCES {
                self.previous = std::mem::take(&mut self.current);
            }
            self.current.insert(
                *id,
                known.unwrap_or_else(|| Source {
                    key: Arc::from(key),
                    catch_up: None,
                }),
            );
        }
        let source = self.current.get_mut(id).expect("just inserted");
        if &*source.key != key {
            source.key = Arc::from(key);
        }
        (source, new)
    }

    fn get_mut(&mut self, id: &EntityGlobalId) -> Option<&mut Source> {
        match self.current.get_mut(id) {
            Some(s) => Some(s),
            None => self.previous.get_mut(id),
        }
    }

    fn key_of(&self, id: &EntityGlobalId) -> Option<Arc<str>> {
        self.current
            .get(id)
            .or_else(|| self.previous.get(id))
            .map(|s| s.key.clone())
    }
}

/// What the subscription callbacks share: the engine and its ingest channel, the publishers.
pub struct Intake {
    engine: Arc<Engine>,
    tx: crossbeam_channel::Sender<Option<Ingest>>,
    session: zenoh::Session,
    sources: Mutex<Sources>,
}

/// Finishes a catch-up when its query is done (the reply callback, holding it, is dropped).
struct CatchUpDone {
    intake: Arc<Intake>,
    id: EntityGlobalId,
}

impl Drop for CatchUpDone {
    fn drop(&mut self) {
        self.intake.catch_up_done(&self.id);
    }
}

impl Intake {
    pub fn new(
        engine: Arc<Engine>,
        tx: crossbeam_channel::Sender<Option<Ingest>>,
        session: &zenoh::Session,
    ) -> Arc<Intake> {
        Arc::new(Intake {
            engine,
            tx,
            session: session.clone(),
            sources: Mutex::new(Sources::default()),
        })
    }

    fn offer(&self, sample: Sample, sequenced: bool, may_wait: bool) {
        if sample.kind() == SampleKind::Delete {
            // (zenoh's delete of a key: no input. An advanced publisher numbers its deletes too, so
            // they still count in its sequence, above.)
            tracing::debug!(key = %sample.key_expr(), "a delete on an input key: ignored");
            return;
        }
        // (The vehicle, for its share of the limits, is read from the sample's own key: not copied.)
        let key = sample.key_expr().as_str();
        let vehicle = match self.engine.keys.classify(key) {
            Some(Received::Vehicle {
                vehicle,
                leaf: Leaf::Gyro | Leaf::Vectors | Leaf::Imu,
                ..
            }) => Some(vehicle),
            _ => None,
        };
        let inbound = Inbound {
            key: key.to_string(),
            payload: sample.payload().to_bytes().into_owned(),
        };
        let ingest = Ingest::Input {
            inbound,
            sequenced,
            held: Default::default(),
        };
        self.engine
            .admission
            .offer(&self.engine, &self.tx, vehicle, ingest, may_wait);
    }

    /// A plain subscription's sample (routed inputs, standby batches, the ROS 2 edge's). May wait for
    /// room.
    pub fn plain(&self, sample: Sample) {
        self.offer(sample, false, true);
    }

    /// The plain subscription beside an AdvancedSubscriber: the samples that carry no publisher
    /// sequence number (the AdvancedSubscriber takes the others).
    pub fn unnumbered(&self, sample: Sample) {
        if sample.source_info().is_none() {
            self.offer(sample, false, true);
        }
    }

    /// An AdvancedSubscriber's sample, in its publisher's order, recovered gaps included: never
    /// waits (zenoh-ext calls under a lock all its key's vehicles share).
    ///
    /// The first sample of a publisher this service has not heard from, numbered above 0, means puts
    /// before it (the publisher put while the service was down or unreachable). zenoh-ext asks the
    /// publisher's cache for them when it detects the publisher, but drops the answer if a live put
    /// arrives first: so they are asked for here too (`_sn=..first-1`, at most
    /// `ingest.history_samples`), and the publisher's puts meanwhile are held (as many at most), then
    /// delivered after them, in order.
    pub fn numbered(self: &Arc<Self>, sample: Sample) {
        let Some((id, sn)) = sample
            .source_info()
            .map(|s| (*s.source_id(), s.source_sn()))
        else {
            // (Its plain twin takes those.)
            return;
        };
        let config = &self.engine.config.ingest;
        let mut sources = self.sources.lock().unwrap_or_else(|e| e.into_inner());
        let (source, new) = sources.entry(&id, sample.key_expr().as_str());
        if let Some(c) = &mut source.catch_up {
            if c.held.len() < config.history_samples {
                c.held.push(sample);
                return;
            }
            // (The cache is slow to answer and the publisher fast: what it answers later is
            // dropped, older than what follows.)
            let c = source.catch_up.take().expect("checked");
            for s in c.replies.into_values().chain(c.held) {
                self.offer(s, true, false);
            }
        } else if new && sn > 0 && config.recovery && config.history_samples > 0 {
            let key = source.key.clone();
            source.catch_up = Some(CatchUp {
                first: sn,
                held: vec![sample],
                replies: BTreeMap::new(),
            });
            drop(sources);
            self.ask_cache(id, &key, sn);
            return;
        }
        drop(sources);
        self.offer(sample, true, false);
    }

    /// Asks the cache of publisher `id` on `key` for its puts before `first` (see [`Intake::numbered`]).
    fn ask_cache(self: &Arc<Self>, id: EntityGlobalId, key: &str, first: u32) {
        let config = &self.engine.config.ingest;
        let selector = format!(
            "{key}/@adv/*/{}/{}/**?_sn=..{};_max={}",
            id.zid(),
            id.eid(),
            first - 1,
            config.history_samples
        );
        let done = CatchUpDone {
            intake: self.clone(),
            id,
        };
        let intake = Arc::downgrade(self);
        let asked = self
            .session
            .get(selector.as_str())
            .callback(move |reply: Reply| {
                let _keep = &done;
                let (Some(intake), Ok(s)) = (intake.upgrade(), reply.into_result()) else {
                    return;
                };
                let Some(sn) = s.source_info().map(|i| i.source_sn()) else {
                    return;
                };
                let mut sources = intake.sources.lock().unwrap_or_else(|e| e.into_inner());
                if let Some(c) = sources
                    .get_mut(&id)
                    .and_then(|src| src.catch_up.as_mut())
                    .filter(|c| sn < c.first)
                {
                    c.replies.insert(sn, s);
                }
            })
            .consolidation(ConsolidationMode::None)
            .accept_replies(ReplyKeyExpr::Any)
            .target(QueryTarget::All)
            .timeout(Duration::from_secs_f64(config.query_timeout_s))
            .wait();
        if let Err(e) = asked {
            // (The callback, and with it `done`, is dropped: what was held goes on.)
            tracing::warn!(%selector, error = %e, "cannot ask a publisher's cache");
        }
    }

    /// The cache answered (or could not): its puts, then those held, in order.
    fn catch_up_done(&self, id: &EntityGlobalId) {
        let mut sources = self.sources.lock().unwrap_or_else(|e| e.into_inner());
        let Some(c) = sources.get_mut(id).and_then(|s| s.catch_up.take()) else {
            return;
        };
        if !c.replies.is_empty() {
            tracing::info!(
                publisher = %format!("{}/{}", id.zid(), id.eid()),
                puts = c.replies.len(),
                "puts made before this service heard of the publisher fetched from its cache"
            );
        }
        for s in c.replies.into_values().chain(c.held) {
            self.offer(s, true, false);
        }
    }

    /// zenoh-ext reports samples of a publisher lost and not recovered: in order with its samples (the
    /// next one follows), to its vehicle.
    pub fn missed(&self, miss: Miss) {
        let id = miss.source();
        let key = self
            .sources
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .key_of(&id);
        let source = format!("{}/{}", id.zid(), id.eid());
        let Some(key) = key else {
            // (A miss is reported before the sample after the gap, so its publisher has delivered one
            // before: reached only if it was forgotten.)
            tracing::warn!(%source, count = miss.nb(), "samples missed from a publisher of unknown key");
            self.engine
                .counters
                .missed
                .fetch_add(u64::from(miss.nb()), std::sync::atomic::Ordering::Relaxed);
            return;
        };
        let ingest = Ingest::Missed {
            key: key.to_string(),
            count: u64::from(miss.nb()),
            source,
        };
        self.engine
            .admission
            .offer(&self.engine, &self.tx, None, ingest, false);
    }
}

/// The input subscriptions: the AdvancedSubscribers (when recovery is on) and the plain ones.
pub struct InputSubscriptions {
    advanced: Vec<zenoh_ext::AdvancedSubscriber<()>>,
    plain: Vec<zenoh::pubsub::Subscriber<()>>,
}

impl InputSubscriptions {
    /// Subscribes to `keys` (the input keys), as `config` says.
    pub async fn declare(
        session: &zenoh::Session,
        keys: &[String],
        config: &IngestConfig,
        intake: &Arc<Intake>,
    ) -> Result<InputSubscriptions, ServiceError> {
        let mut subs = InputSubscriptions {
            advanced: Vec::new(),
            plain: Vec::new(),
        };
        for key in keys {
            if !config.recovery {
                let i = intake.clone();
                let sub = session
                    .declare_subscriber(key.as_str())
                    .callback(move |s| i.plain(s))
                    .await
                    .map_err(zerr)?;
                subs.plain.push(sub);
                continue;
            }
            let i = intake.clone();
            let mut builder = session
                .declare_subscriber(key.as_str())
                .callback(move |s| i.numbered(s))
                .advanced()
                .recovery(RecoveryConfig::default().heartbeat())
                .query_timeout(Duration::from_secs_f64(config.query_timeout_s));
            if config.history_samples > 0 {
                builder = builder.history(
                    HistoryConfig::default()
                        .detect_late_publishers()
                        .max_samples(config.history_samples),
                );
            }
            let adv = builder.await.map_err(zerr)?;
            let i = intake.clone();
            adv.sample_miss_listener()
                .callback(move |m| i.missed(m))
                .background()
                .await
                .map_err(zerr)?;
            subs.advanced.push(adv);
            let i = intake.clone();
            let sub = session
                .declare_subscriber(key.as_str())
                .callback(move |s| i.unnumbered(s))
                .await
                .map_err(zerr)?;
            subs.plain.push(sub);
        }
        Ok(subs)
    }

    pub async fn undeclare(self) {
        for s in self.advanced {
            let _ = s.undeclare().await;
        }
        for s in self.plain {
            let _ = s.undeclare().await;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sources_stay_bounded_and_follow_their_key() {
        // (A default ZenohId is a random one: one for all.)
        let zid = zenoh::config::ZenohId::default();
        let id = |i: u32| EntityGlobalId::new(zid, i);
        let mut s = Sources::default();
        assert!(s.entry(&id(0), "p/a/imu").1);
        assert!(!s.entry(&id(0), "p/a/imu").1);
        assert!(s.entry(&id(1), "p/b/imu").1);
        assert_eq!(s.key_of(&id(0)).as_deref(), Some("p/a/imu"));
        assert_eq!(s.key_of(&id(2)), None);
        s.entry(&id(0), "p/c/imu");
        assert_eq!(s.key_of(&id(0)).as_deref(), Some("p/c/imu"));
    }
}
