//! Sending inputs to a dynamic fleet the way it scales (`loadgen --routed`, `simulate --routed`; the
//! Python client's `routed=True` does the same): every input on its routed key `P/V/<leaf>/<r>`, which
//! only the route's owner subscribes to, and the same inputs batched per route on
//! `P/@/standby/<r>/inputs` every flush interval ([`FLUSH_S`]), which only the route's standby members
//! subscribe to. The sender computes the route ([`route_of`]); nothing else about the fleet.
//!
//! A single instance takes routed inputs too (and no batch): routed senders work against either.

use super::batch::BatchWriter;
use crate::wire::keys::{route_of, Keys, Leaf, ROUTES};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use zenoh::bytes::Encoding;
use zenoh::key_expr::KeyExpr;
use zenoh::qos::CongestionControl;

/// The senders' default interval between batches, s.
pub const FLUSH_S: f64 = 0.25;

/// A batch is sent at once when it grows beyond this many bytes.
const BATCH_BYTES: usize = 256 << 10;

/// Puts inputs on their routed keys and batches them for the routes' standby members.
pub struct RoutedSender {
    session: zenoh::Session,
    keys: Keys,
    batches: Arc<Mutex<Vec<BatchWriter>>>,
    stop: tokio::sync::watch::Sender<bool>,
    flusher: tokio::task::JoinHandle<()>,
}

async fn send(session: &zenoh::Session, keys: &Keys, route: u8, batch: Vec<u8>) {
    let put = session
        .put(keys.standby_inputs(route), batch)
        .encoding(Encoding::APPLICATION_OCTET_STREAM)
        .congestion_control(CongestionControl::Block);
    if let Err(e) = put.await {
        tracing::warn!(route, error = %e, "a standby batch was not sent");
    }
}

fn take_all(batches: &Mutex<Vec<BatchWriter>>) -> Vec<(u8, Vec<u8>)> {
    let mut b = batches.lock().unwrap_or_else(|e| e.into_inner());
    b.iter_mut()
        .enumerate()
        .filter(|(_, w)| !w.is_empty())
        .map(|(r, w)| (r as u8, w.take()))
        .collect()
}

impl RoutedSender {
    /// Starts the sender (its batches go out every `flush`) on a tokio runtime.
    pub fn start(session: &zenoh::Session, keys: &Keys, flush: Duration) -> Self {
        let batches: Arc<Mutex<Vec<BatchWriter>>> = Arc::new(Mutex::new(
            (0..ROUTES).map(|_| BatchWriter::default()).collect(),
        ));
        let (stop, mut stopped) = tokio::sync::watch::channel(false);
        let flusher = {
            let (session, keys, batches) = (session.clone(), keys.clone(), batches.clone());
            tokio::spawn(async move {
                let mut tick = tokio::time::interval(flush);
                tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
                loop {
                    tokio::select! {
                        _ = tick.tick() => {}
                        _ = stopped.changed() => break,
                    }
                    for (r, b) in take_all(&batches) {
                        send(&session, &keys, r, b).await;
                    }
                }
            })
        };
        RoutedSender {
            session: session.clone(),
            keys: keys.clone(),
            batches,
            stop,
            flusher,
        }
    }

    /// The routed key of `vehicle`'s `leaf` (to check once and put on many times).
    pub fn key(&self, vehicle: &str, leaf: Leaf) -> Result<KeyExpr<'static>, zenoh::Error> {
        KeyExpr::try_from(self.keys.routed(vehicle, leaf))
    }

    /// Puts `payload` on `key` (`vehicle`'s `leaf`, from [`RoutedSender::key`]) and adds it to its
    /// route's next batch.
    pub async fn put(
        &self,
        vehicle: &str,
        leaf: Leaf,
        key: &KeyExpr<'static>,
        payload: Vec<u8>,
    ) -> Result<(), zenoh::Error> {
        let route = route_of(vehicle);
        self.session
            .put(key.clone(), payload.as_slice())
            .encoding(Encoding::APPLICATION_JSON)
            .congestion_control(CongestionControl::Block)
            .await?;
        let full = {
            let mut b = self.batches.lock().unwrap_or_else(|e| e.into_inner());
            let w = &mut b[route as usize];
            w.push(vehicle, leaf.as_str(), &payload);
            (w.len() > BATCH_BYTES).then(|| w.take())
        };
        if let Some(b) = full {
            send(&self.session, &self.keys, route, b).await;
        }
        Ok(())
    }

    /// Sends what the batches still hold and stops.
    pub async fn close(self) {
        let _ = self.stop.send(true);
        let _ = self.flusher.await;
        for (r, b) in take_all(&self.batches) {
            send(&self.session, &self.keys, r, b).await;
        }
    }
}
