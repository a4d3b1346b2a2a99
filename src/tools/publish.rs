//! How the tools put a vehicle's inputs (proto/README.md, "Loss, recovery and back-pressure"): through
//! a zenoh-ext AdvancedPublisher per key, made at the key's first put, with a cache of its last puts,
//! a sequence number on each and a heartbeat, so that the service detects a lost put and fetches it
//! again (and after a reconnection or a restart of the service, what it missed meanwhile); or plain
//! puts. Either way congestion control `Block`: never a silent drop in the sender's queue.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::Duration;
use zenoh::bytes::Encoding;
use zenoh::key_expr::KeyExpr;
use zenoh::qos::CongestionControl;
use zenoh_ext::{AdvancedPublisher, AdvancedPublisherBuilderExt, CacheConfig, MissDetectionConfig};

/// The tools' default cache, puts per key (the Python client's `CACHE`).
pub const CACHE: usize = 256;
/// The tools' default heartbeat period, s (the Python client's `HEARTBEAT_S`).
pub const HEARTBEAT_S: f64 = 0.25;

/// How inputs are put.
#[derive(Clone, Debug, PartialEq)]
pub struct Publishing {
    /// Through advanced publishers (`false`: plain puts).
    pub advanced: bool,
    /// Puts kept per key.
    pub cache: usize,
    /// Between heartbeats (sent only when something was put since), s.
    pub heartbeat_s: f64,
}

impl Default for Publishing {
    fn default() -> Self {
        Publishing {
            advanced: true,
            cache: CACHE,
            heartbeat_s: HEARTBEAT_S,
        }
    }
}

impl Publishing {
    /// Plain puts.
    pub fn plain() -> Self {
        Publishing {
            advanced: false,
            ..Publishing::default()
        }
    }
}

/// Puts inputs on their keys, through one advanced publisher per key (see the module's text).
pub struct Inputs {
    session: zenoh::Session,
    how: Publishing,
    publishers: Mutex<HashMap<String, Arc<AdvancedPublisher<'static>>>>,
}

impl Inputs {
    pub fn new(session: &zenoh::Session, how: Publishing) -> Self {
        Inputs {
            session: session.clone(),
            how,
            publishers: Mutex::new(HashMap::new()),
        }
    }

    async fn publisher(
        &self,
        key: &KeyExpr<'static>,
    ) -> Result<Arc<AdvancedPublisher<'static>>, zenoh::Error> {
        if let Some(p) = self
            .publishers
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get(key.as_str())
        {
            return Ok(p.clone());
        }
        let p = Arc::new(
            self.session
                .declare_publisher(key.clone())
                .encoding(Encoding::APPLICATION_JSON)
                .congestion_control(CongestionControl::Block)
                .cache(CacheConfig::default().max_samples(self.how.cache.max(1)))
                .sample_miss_detection(
                    MissDetectionConfig::default()
                        .sporadic_heartbeat(Duration::from_secs_f64(self.how.heartbeat_s)),
                )
                .publisher_detection()
                .await?,
        );
        Ok(self
            .publishers
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .entry(key.as_str().to_string())
            .or_insert(p)
            .clone())
    }

    /// Puts `payload` on `key`.
    pub async fn put(&self, key: &KeyExpr<'static>, payload: Vec<u8>) -> Result<(), zenoh::Error> {
        if !self.how.advanced {
            return self
                .session
                .put(key.clone(), payload)
                .encoding(Encoding::APPLICATION_JSON)
                .congestion_control(CongestionControl::Block)
                .await;
        }
        self.publisher(key).await?.put(payload).await
    }

    /// Undeclares the publishers (their caches go with them).
    pub async fn close(self) {
        let publishers: Vec<_> = self
            .publishers
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .drain()
            .map(|(_, p)| p)
            .collect();
        for p in publishers {
            if let Ok(p) = Arc::try_unwrap(p) {
                let _ = p.undeclare().await;
            }
        }
    }
}
