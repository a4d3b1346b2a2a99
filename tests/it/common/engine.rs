//! The service's engine in process, without zenoh (with its fleet member and ROS 2 edge, a
//! `service::Node`): configured from a configuration file's text, it publishes into a list.

use attitude_service::engine::{EngineThreads, Sink};
use attitude_service::service::config::{parse, ServiceConfig};
use attitude_service::service::Node;
use std::sync::{Arc, Mutex};

/// Everything an engine published, `(key, payload)` in order.
pub type Outputs = Arc<Mutex<Vec<(String, Vec<u8>)>>>;

/// The `service` section of a configuration file's text, as the service reads it.
pub fn service_config(text: &str) -> ServiceConfig {
    parse(text, "test")
        .unwrap_or_else(|e| panic!("{text}: {e}"))
        .service
}

/// An engine whose publications are collected in [`Outputs`].
pub fn collecting_engine(config: ServiceConfig) -> (Node, EngineThreads, Outputs) {
    let out: Outputs = Arc::default();
    let sink: Sink = {
        let out = out.clone();
        Arc::new(move |key: &str, payload: Vec<u8>| {
            out.lock().unwrap().push((key.to_string(), payload))
        })
    };
    let (node, threads) = Node::start(config, sink).expect("the engine starts");
    (node, threads, out)
}
