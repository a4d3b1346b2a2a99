//
// Copyright (c) 2026 ZettaScale Technology
//
// This program and the accompanying materials are made available under the
// terms of the Eclipse Public License 2.0 which is available at
// http://www.eclipse.org/legal/epl-2.0, or the Apache License, Version 2.0
// which is available at https://www.apache.org/licenses/LICENSE-2.0.
//
// SPDX-License-Identifier: EPL-2.0 OR Apache-2.0
//
// Contributors:
//   ZettaScale Zenoh Team, <zenoh@zettascale.tech>
//

// Scenario 4
//   R      R      R
// C C C  C C C  C C C

use std::time::Duration;

use predicates::Predicate;
use zenoh::{
    query::{ConsolidationMode, QueryTarget},
    sample::SampleKind,
    Wait,
};
use zenoh_config::WhatAmI::{Client, Router};
use zenoh_core::{lazy_static, ztimeout};

use crate::{loc, predicates_ext, skip_fmt, unbounded_sink, Node};

const TIMEOUT: Duration = Duration::from_secs(10);

lazy_static! {
    static ref STORAGE: tracing_capture::SharedStorage = tracing_capture::SharedStorage::default();
}

fn init_tracing_subscriber() {
    use tracing_subscriber::layer::SubscriberExt;
    let subscriber = tracing_subscriber::fmt()
        .with_env_filter("debug,zenoh::net::routing::dispatcher=trace")
        .finish();
    let subscriber = subscriber.with(tracing_capture::CaptureLayer::new(&STORAGE));
    tracing::subscriber::set_global_default(subscriber).ok();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 1)]
async fn test_regions_scenario4_order1_putsub() {
    init_tracing_subscriber();

    let z9100 = ztimeout!(Node::new(Router, "41aa9100")
        .endpoints("tcp/0.0.0.0:0", &[])
        .open());
    let z9200 = ztimeout!(Node::new(Router, "41aa9200")
        .endpoints("tcp/0.0.0.0:0", &[loc!(z9100)])
        .open());
    let z9300 = ztimeout!(Node::new(Router, "41aa9300")
        .endpoints("tcp/0.0.0.0:0", &[loc!(z9100), loc!(z9200)])
        .open());

    let z9110 = ztimeout!(Node::new(Client, "41aa9110").connect(&[loc!(z9100)]).open());
    let z9120 = ztimeout!(Node::new(Client, "41aa9120").connect(&[loc!(z9100)]).open());
    let z9130 = ztimeout!(Node::new(Client, "41aa9130").connect(&[loc!(z9100)]).open());

    let z9210 = ztimeout!(Node::new(Client, "41aa9210").connect(&[loc!(z9200)]).open());
    let z9220 = ztimeout!(Node::new(Client, "41aa9220").connect(&[loc!(z9200)]).open());
    let z9230 = ztimeout!(Node::new(Client, "41aa9230").connect(&[loc!(z9200)]).open());

    let z9310 = ztimeout!(Node::new(Client, "41aa9310").connect(&[loc!(z9300)]).open());
    let z9320 = ztimeout!(Node::new(Client, "41aa9320").connect(&[loc!(z9300)]).open());
    let z9330 = ztimeout!(Node::new(Client, "41aa9330").connect(&[loc!(z9300)]).open());

    skip_fmt! {
        let s9110 = z9110.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9120 = z9120.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9130 = z9130.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9210 = z9210.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9220 = z9220.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9230 = z9230.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9310 = z9310.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9320 = z9320.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9330 = z9330.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
    }

    ztimeout!(async {
        loop {
            z9110.put("test", "9110").await.unwrap();
            z9120.put("test", "9120").await.unwrap();
            z9130.put("test", "9130").await.unwrap();
            z9210.put("test", "9210").await.unwrap();
            z9220.put("test", "9220").await.unwrap();
            z9230.put("test", "9230").await.unwrap();
            z9310.put("test", "9310").await.unwrap();
            z9320.put("test", "9320").await.unwrap();
            z9330.put("test", "9330").await.unwrap();
            tokio::time::sleep(Duration::from_millis(100)).await;

            if [
                &s9110, &s9120, &s9130, &s9210, &s9220, &s9230, &s9310, &s9320, &s9330,
            ]
            .iter()
            .all(|sub| sub.count_unique_by_payload(SampleKind::Put) == 9)
            {
                break;
            }
        }
    });

    assert!(
        [&s9110, &s9120, &s9130, &s9210, &s9220, &s9230, &s9310, &s9320, &s9330]
            .iter()
            .all(|sub| sub.unique_timestamps())
    );

    let s = STORAGE.lock();

    for zid in [
        "41aa9110", "41aa9120", "41aa9130", "41aa9210", "41aa9220", "41aa9230", "41aa9310",
        "41aa9320", "41aa9330",
    ] {
        assert_eq!(
            s.all_events()
                .filter(|e| predicates_ext::register_subscriber(zid, "test").eval(e))
                .count(),
            0
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 1)]
async fn test_regions_scenario4_order1_pubsub() {
    init_tracing_subscriber();

    let z9100 = ztimeout!(Node::new(Router, "41ab9100")
        .endpoints("tcp/0.0.0.0:0", &[])
        .open());
    let z9200 = ztimeout!(Node::new(Router, "41ab9200")
        .endpoints("tcp/0.0.0.0:0", &[loc!(z9100)])
        .open());
    let z9300 = ztimeout!(Node::new(Router, "41ab9300")
        .endpoints("tcp/0.0.0.0:0", &[loc!(z9100), loc!(z9200)])
        .open());

    let z9110 = ztimeout!(Node::new(Client, "41ab9110").connect(&[loc!(z9100)]).open());
    let z9120 = ztimeout!(Node::new(Client, "41ab9120").connect(&[loc!(z9100)]).open());
    let z9130 = ztimeout!(Node::new(Client, "41ab9130").connect(&[loc!(z9100)]).open());

    let z9210 = ztimeout!(Node::new(Client, "41ab9210").connect(&[loc!(z9200)]).open());
    let z9220 = ztimeout!(Node::new(Client, "41ab9220").connect(&[loc!(z9200)]).open());
    let z9230 = ztimeout!(Node::new(Client, "41ab9230").connect(&[loc!(z9200)]).open());

    let z9310 = ztimeout!(Node::new(Client, "41ab9310").connect(&[loc!(z9300)]).open());
    let z9320 = ztimeout!(Node::new(Client, "41ab9320").connect(&[loc!(z9300)]).open());
    let z9330 = ztimeout!(Node::new(Client, "41ab9330").connect(&[loc!(z9300)]).open());

    skip_fmt! {
        let s9110 = z9110.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9120 = z9120.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9130 = z9130.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9210 = z9210.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9220 = z9220.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9230 = z9230.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9310 = z9310.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9320 = z9320.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9330 = z9330.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
    }

    let p9110 = z9110.declare_publisher("test").await.unwrap();
    let p9120 = z9120.declare_publisher("test").await.unwrap();
    let p9130 = z9130.declare_publisher("test").await.unwrap();
    let p9210 = z9210.declare_publisher("test").await.unwrap();
    let p9220 = z9220.declare_publisher("test").await.unwrap();
    let p9230 = z9230.declare_publisher("test").await.unwrap();
    let p9310 = z9310.declare_publisher("test").await.unwrap();
    let p9320 = z9320.declare_publisher("test").await.unwrap();
    let p9330 = z9330.declare_publisher("test").await.unwrap();

    ztimeout!(async {
        loop {
            p9110.put("9110").await.unwrap();
            p9120.put("9120").await.unwrap();
            p9130.put("9130").await.unwrap();
            p9210.put("9210").await.unwrap();
            p9220.put("9220").await.unwrap();
            p9230.put("9230").await.unwrap();
            p9310.put("9310").await.unwrap();
            p9320.put("9320").await.unwrap();
            p9330.put("9330").await.unwrap();
            tokio::time::sleep(Duration::from_millis(100)).await;

            if [
                &s9110, &s9120, &s9130, &s9210, &s9220, &s9230, &s9310, &s9320, &s9330,
            ]
            .iter()
            .all(|sub| sub.count_unique_by_payload(SampleKind::Put) == 9)
            {
                break;
            }
        }
    });

    assert!(
        [&s9110, &s9120, &s9130, &s9210, &s9220, &s9230, &s9310, &s9320, &s9330]
            .iter()
            .all(|sub| sub.unique_timestamps())
    );

    let s = STORAGE.lock();

    for zid in [
        "41ab9110", "41ab9120", "41ab9130", "41ab9210", "41ab9220", "41ab9230", "41ab9310",
        "41ab9320", "41ab9330",
    ] {
        assert_eq!(
            s.all_events()
                .filter(|e| predicates_ext::register_subscriber(zid, "test").eval(e))
                .count(),
            1
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 1)]
async fn test_regions_scenario4_order1_getque() {
    init_tracing_subscriber();

    let z9100 = ztimeout!(Node::new(Router, "41ac9100")
        .endpoints("tcp/0.0.0.0:0", &[])
        .open());
    let z9200 = ztimeout!(Node::new(Router, "41ac9200")
        .endpoints("tcp/0.0.0.0:0", &[loc!(z9100)])
        .open());
    let z9300 = ztimeout!(Node::new(Router, "41ac9300")
        .endpoints("tcp/0.0.0.0:0", &[loc!(z9100), loc!(z9200)])
        .open());

    let z9110 = ztimeout!(Node::new(Client, "41ac9110").connect(&[loc!(z9100)]).open());
    let z9120 = ztimeout!(Node::new(Client, "41ac9120").connect(&[loc!(z9100)]).open());
    let z9130 = ztimeout!(Node::new(Client, "41ac9130").connect(&[loc!(z9100)]).open());
    let z9210 = ztimeout!(Node::new(Client, "41ac9210").connect(&[loc!(z9200)]).open());
    let z9220 = ztimeout!(Node::new(Client, "41ac9220").connect(&[loc!(z9200)]).open());
    let z9230 = ztimeout!(Node::new(Client, "41ac9230").connect(&[loc!(z9200)]).open());
    let z9310 = ztimeout!(Node::new(Client, "41ac9310").connect(&[loc!(z9300)]).open());
    let z9320 = ztimeout!(Node::new(Client, "41ac9320").connect(&[loc!(z9300)]).open());
    let z9330 = ztimeout!(Node::new(Client, "41ac9330").connect(&[loc!(z9300)]).open());

    skip_fmt! {
        let _q9110 = z9110.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9110")).unwrap()).await.unwrap();
        let _q9120 = z9120.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9120")).unwrap()).await.unwrap();
        let _q9130 = z9130.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9130")).unwrap()).await.unwrap();
        let _q9210 = z9210.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9210")).unwrap()).await.unwrap();
        let _q9220 = z9220.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9220")).unwrap()).await.unwrap();
        let _q9230 = z9230.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9230")).unwrap()).await.unwrap();
        let _q9310 = z9310.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9310")).unwrap()).await.unwrap();
        let _q9320 = z9320.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9320")).unwrap()).await.unwrap();
        let _q9330 = z9330.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9330")).unwrap()).await.unwrap();
    }

    skip_fmt! {ztimeout!(async {
        loop {
            if z9110.get("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap().iter().count() == 9
                && z9120.get("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap().iter().count() == 9
                && z9130.get("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap().iter().count() == 9
                && z9210.get("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap().iter().count() == 9
                && z9220.get("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap().iter().count() == 9
                && z9230.get("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap().iter().count() == 9
                && z9310.get("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap().iter().count() == 9
                && z9320.get("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap().iter().count() == 9
                && z9330.get("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap().iter().count() == 9
            {
                break;
            }
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    })};

    let s = STORAGE.lock();

    for zid in [
        "41ac9110", "41ac9120", "41ac9130", "41ac9210", "41ac9220", "41ac9230", "41ac9310",
        "41ac9320", "41ac9330",
    ] {
        assert_eq!(
            s.all_events()
                .filter(|e| predicates_ext::register_queryable(zid, "test").eval(e))
                .count(),
            0
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 1)]
async fn test_regions_scenario4_order1_queque() {
    init_tracing_subscriber();

    let z9100 = ztimeout!(Node::new(Router, "41ad9100")
        .endpoints("tcp/0.0.0.0:0", &[])
        .open());
    let z9200 = ztimeout!(Node::new(Router, "41ad9200")
        .endpoints("tcp/0.0.0.0:0", &[loc!(z9100)])
        .open());
    let z9300 = ztimeout!(Node::new(Router, "41ad9300")
        .endpoints("tcp/0.0.0.0:0", &[loc!(z9100), loc!(z9200)])
        .open());

    let z9110 = ztimeout!(Node::new(Client, "41ad9110").connect(&[loc!(z9100)]).open());
    let z9120 = ztimeout!(Node::new(Client, "41ad9120").connect(&[loc!(z9100)]).open());
    let z9130 = ztimeout!(Node::new(Client, "41ad9130").connect(&[loc!(z9100)]).open());
    let z9210 = ztimeout!(Node::new(Client, "41ad9210").connect(&[loc!(z9200)]).open());
    let z9220 = ztimeout!(Node::new(Client, "41ad9220").connect(&[loc!(z9200)]).open());
    let z9230 = ztimeout!(Node::new(Client, "41ad9230").connect(&[loc!(z9200)]).open());
    let z9310 = ztimeout!(Node::new(Client, "41ad9310").connect(&[loc!(z9300)]).open());
    let z9320 = ztimeout!(Node::new(Client, "41ad9320").connect(&[loc!(z9300)]).open());
    let z9330 = ztimeout!(Node::new(Client, "41ad9330").connect(&[loc!(z9300)]).open());

    skip_fmt! {
        let _q9110 = z9110.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9110")).unwrap()).await.unwrap();
        let _q9120 = z9120.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9120")).unwrap()).await.unwrap();
        let _q9130 = z9130.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9130")).unwrap()).await.unwrap();
        let _q9210 = z9210.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9210")).unwrap()).await.unwrap();
        let _q9220 = z9220.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9220")).unwrap()).await.unwrap();
        let _q9230 = z9230.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9230")).unwrap()).await.unwrap();
        let _q9310 = z9310.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9310")).unwrap()).await.unwrap();
        let _q9320 = z9320.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9320")).unwrap()).await.unwrap();
        let _q9330 = z9330.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9330")).unwrap()).await.unwrap();

        let q9110 = z9110.declare_querier("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap();
        let q9120 = z9120.declare_querier("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap();
        let q9130 = z9130.declare_querier("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap();
        let q9210 = z9210.declare_querier("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap();
        let q9220 = z9220.declare_querier("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap();
        let q9230 = z9230.declare_querier("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap();
        let q9310 = z9310.declare_querier("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap();
        let q9320 = z9320.declare_querier("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap();
        let q9330 = z9330.declare_querier("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap();
    }

    ztimeout!(async {
        loop {
            if q9110.get().await.unwrap().iter().count() == 9
                && q9120.get().await.unwrap().iter().count() == 9
                && q9130.get().await.unwrap().iter().count() == 9
                && q9210.get().await.unwrap().iter().count() == 9
                && q9220.get().await.unwrap().iter().count() == 9
                && q9230.get().await.unwrap().iter().count() == 9
                && q9310.get().await.unwrap().iter().count() == 9
                && q9320.get().await.unwrap().iter().count() == 9
                && q9330.get().await.unwrap().iter().count() == 9
            {
                break;
            }
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    });

    let s = STORAGE.lock();

    for zid in [
        "41ad9110", "41ad9120", "41ad9130", "41ad9210", "41ad9220", "41ad9230", "41ad9310",
        "41ad9320", "41ad9330",
    ] {
        assert_eq!(
            s.all_events()
                .filter(|e| predicates_ext::register_queryable(zid, "test").eval(e))
                .count(),
            1
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 1)]
async fn test_regions_scenario4_order1_toksub() {
    init_tracing_subscriber();

    let z9100 = ztimeout!(Node::new(Router, "41ae9100")
        .endpoints("tcp/0.0.0.0:0", &[])
        .open());

    let z9200 = ztimeout!(Node::new(Router, "41ae9200")
        .endpoints("tcp/0.0.0.0:0", &[loc!(z9100)])
        .open());

    let z9300 = ztimeout!(Node::new(Router, "41ae9300")
        .endpoints("tcp/0.0.0.0:0", &[loc!(z9100), loc!(z9200)])
        .open());

    let z9110 = ztimeout!(Node::new(Client, "41ae9110").connect(&[loc!(z9100)]).open());
    let z9120 = ztimeout!(Node::new(Client, "41ae9120").connect(&[loc!(z9100)]).open());
    let z9130 = ztimeout!(Node::new(Client, "41ae9130").connect(&[loc!(z9100)]).open());
    let z9210 = ztimeout!(Node::new(Client, "41ae9210").connect(&[loc!(z9200)]).open());
    let z9220 = ztimeout!(Node::new(Client, "41ae9220").connect(&[loc!(z9200)]).open());
    let z9230 = ztimeout!(Node::new(Client, "41ae9230").connect(&[loc!(z9200)]).open());
    let z9310 = ztimeout!(Node::new(Client, "41ae9310").connect(&[loc!(z9300)]).open());
    let z9320 = ztimeout!(Node::new(Client, "41ae9320").connect(&[loc!(z9300)]).open());
    let z9330 = ztimeout!(Node::new(Client, "41ae9330").connect(&[loc!(z9300)]).open());

    skip_fmt! {
        let s9110 = z9110.liveliness().declare_subscriber("test/**").history(true).with(unbounded_sink()).await.unwrap();
        let s9120 = z9120.liveliness().declare_subscriber("test/**").history(true).with(unbounded_sink()).await.unwrap();
        let s9130 = z9130.liveliness().declare_subscriber("test/**").history(true).with(unbounded_sink()).await.unwrap();
        let s9210 = z9210.liveliness().declare_subscriber("test/**").history(true).with(unbounded_sink()).await.unwrap();
        let s9220 = z9220.liveliness().declare_subscriber("test/**").history(true).with(unbounded_sink()).await.unwrap();
        let s9230 = z9230.liveliness().declare_subscriber("test/**").history(true).with(unbounded_sink()).await.unwrap();
        let s9310 = z9310.liveliness().declare_subscriber("test/**").history(true).with(unbounded_sink()).await.unwrap();
        let s9320 = z9320.liveliness().declare_subscriber("test/**").history(true).with(unbounded_sink()).await.unwrap();
        let s9330 = z9330.liveliness().declare_subscriber("test/**").history(true).with(unbounded_sink()).await.unwrap();
    }

    let t9110 = z9110.liveliness().declare_token("test/9110").await.unwrap();
    let t9120 = z9120.liveliness().declare_token("test/9120").await.unwrap();
    let t9130 = z9130.liveliness().declare_token("test/9130").await.unwrap();
    let t9210 = z9210.liveliness().declare_token("test/9210").await.unwrap();
    let t9220 = z9220.liveliness().declare_token("test/9220").await.unwrap();
    let t9230 = z9230.liveliness().declare_token("test/9230").await.unwrap();
    let t9310 = z9310.liveliness().declare_token("test/9310").await.unwrap();
    let t9320 = z9320.liveliness().declare_token("test/9320").await.unwrap();
    let t9330 = z9330.liveliness().declare_token("test/9330").await.unwrap();

    ztimeout!(async {
        loop {
            tokio::time::sleep(Duration::from_millis(100)).await;

            if [
                &s9110, &s9120, &s9130, &s9210, &s9220, &s9230, &s9310, &s9320, &s9330,
            ]
            .iter()
            .all(|sub| sub.count_unique_by_keyexpr(SampleKind::Put) == 9)
            {
                break;
            }
        }
    });

    t9110.undeclare().await.unwrap();
    t9120.undeclare().await.unwrap();
    t9130.undeclare().await.unwrap();
    t9210.undeclare().await.unwrap();
    t9220.undeclare().await.unwrap();
    t9230.undeclare().await.unwrap();
    t9310.undeclare().await.unwrap();
    t9320.undeclare().await.unwrap();
    t9330.undeclare().await.unwrap();

    ztimeout!(async {
        loop {
            tokio::time::sleep(Duration::from_millis(100)).await;

            if [
                &s9110, &s9120, &s9130, &s9210, &s9220, &s9230, &s9310, &s9320, &s9330,
            ]
            .iter()
            .all(|sub| sub.count_unique_by_keyexpr(SampleKind::Delete) == 9)
            {
                break;
            }
        }
    });
}

#[tokio::test(flavor = "multi_thread", worker_threads = 1)]
async fn test_regions_scenario4_order2_putsub() {
    init_tracing_subscriber();

    let z9100 = ztimeout!(Node::new(Router, "42aa9100")
        .endpoints("tcp/0.0.0.0:0", &[])
        .open());
    let z9200 = ztimeout!(Node::new(Router, "42aa9200")
        .endpoints("tcp/0.0.0.0:0", &[loc!(z9100)])
        .open());

    let z9110 = ztimeout!(Node::new(Client, "42aa9110").connect(&[loc!(z9100)]).open());
    let z9120 = ztimeout!(Node::new(Client, "42aa9120").connect(&[loc!(z9100)]).open());
    let z9130 = ztimeout!(Node::new(Client, "42aa9130").connect(&[loc!(z9100)]).open());

    let z9210 = ztimeout!(Node::new(Client, "42aa9210").connect(&[loc!(z9200)]).open());
    let z9220 = ztimeout!(Node::new(Client, "42aa9220").connect(&[loc!(z9200)]).open());
    let z9230 = ztimeout!(Node::new(Client, "42aa9230").connect(&[loc!(z9200)]).open());

    skip_fmt! {
        let s9110 = z9110.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9120 = z9120.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9130 = z9130.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9210 = z9210.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9220 = z9220.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9230 = z9230.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
    }

    let z9300 = ztimeout!(Node::new(Router, "42aa9300")
        .endpoints("tcp/0.0.0.0:0", &[loc!(z9100), loc!(z9200)])
        .open());

    let z9310 = ztimeout!(Node::new(Client, "42aa9310").connect(&[loc!(z9300)]).open());
    let z9320 = ztimeout!(Node::new(Client, "42aa9320").connect(&[loc!(z9300)]).open());
    let z9330 = ztimeout!(Node::new(Client, "42aa9330").connect(&[loc!(z9300)]).open());

    skip_fmt! {
        let s9310 = z9310.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9320 = z9320.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9330 = z9330.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
    }

    ztimeout!(async {
        loop {
            z9110.put("test", "9110").await.unwrap();
            z9120.put("test", "9120").await.unwrap();
            z9130.put("test", "9130").await.unwrap();
            z9210.put("test", "9210").await.unwrap();
            z9220.put("test", "9220").await.unwrap();
            z9230.put("test", "9230").await.unwrap();
            z9310.put("test", "9310").await.unwrap();
            z9320.put("test", "9320").await.unwrap();
            z9330.put("test", "9330").await.unwrap();
            tokio::time::sleep(Duration::from_millis(100)).await;

            if [
                &s9110, &s9120, &s9130, &s9210, &s9220, &s9230, &s9310, &s9320, &s9330,
            ]
            .iter()
            .all(|sub| sub.count_unique_by_payload(SampleKind::Put) == 9)
            {
                break;
            }
        }
    });

    assert!(
        [&s9110, &s9120, &s9130, &s9210, &s9220, &s9230, &s9310, &s9320, &s9330]
            .iter()
            .all(|sub| sub.unique_timestamps())
    );

    let s = STORAGE.lock();

    for zid in [
        "42aa9110", "42aa9120", "42aa9130", "42aa9210", "42aa9220", "42aa9230", "42aa9310",
        "42aa9320", "42aa9330",
    ] {
        assert_eq!(
            s.all_events()
                .filter(|e| predicates_ext::register_subscriber(zid, "test").eval(e))
                .count(),
            0
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 1)]
async fn test_regions_scenario4_order2_pubsub() {
    init_tracing_subscriber();

    let z9100 = ztimeout!(Node::new(Router, "42ab9100")
        .endpoints("tcp/0.0.0.0:0", &[])
        .open());
    let z9200 = ztimeout!(Node::new(Router, "42ab9200")
        .endpoints("tcp/0.0.0.0:0", &[loc!(z9100)])
        .open());

    let z9110 = ztimeout!(Node::new(Client, "42ab9110").connect(&[loc!(z9100)]).open());
    let z9120 = ztimeout!(Node::new(Client, "42ab9120").connect(&[loc!(z9100)]).open());
    let z9130 = ztimeout!(Node::new(Client, "42ab9130").connect(&[loc!(z9100)]).open());

    let z9210 = ztimeout!(Node::new(Client, "42ab9210").connect(&[loc!(z9200)]).open());
    let z9220 = ztimeout!(Node::new(Client, "42ab9220").connect(&[loc!(z9200)]).open());
    let z9230 = ztimeout!(Node::new(Client, "42ab9230").connect(&[loc!(z9200)]).open());

    skip_fmt! {
        let s9110 = z9110.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9120 = z9120.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9130 = z9130.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9210 = z9210.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9220 = z9220.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9230 = z9230.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
    }

    let p9110 = z9110.declare_publisher("test").await.unwrap();
    let p9120 = z9120.declare_publisher("test").await.unwrap();
    let p9130 = z9130.declare_publisher("test").await.unwrap();
    let p9210 = z9210.declare_publisher("test").await.unwrap();
    let p9220 = z9220.declare_publisher("test").await.unwrap();
    let p9230 = z9230.declare_publisher("test").await.unwrap();

    let z9300 = ztimeout!(Node::new(Router, "42ab9300")
        .endpoints("tcp/0.0.0.0:0", &[loc!(z9100), loc!(z9200)])
        .open());

    let z9310 = ztimeout!(Node::new(Client, "42ab9310").connect(&[loc!(z9300)]).open());
    let z9320 = ztimeout!(Node::new(Client, "42ab9320").connect(&[loc!(z9300)]).open());
    let z9330 = ztimeout!(Node::new(Client, "42ab9330").connect(&[loc!(z9300)]).open());

    skip_fmt! {
        let s9310 = z9310.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9320 = z9320.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
        let s9330 = z9330.declare_subscriber("test").with(unbounded_sink()).await.unwrap();
    }

    let p9310 = z9310.declare_publisher("test").await.unwrap();
    let p9320 = z9320.declare_publisher("test").await.unwrap();
    let p9330 = z9330.declare_publisher("test").await.unwrap();

    ztimeout!(async {
        loop {
            p9110.put("9110").await.unwrap();
            p9120.put("9120").await.unwrap();
            p9130.put("9130").await.unwrap();
            p9210.put("9210").await.unwrap();
            p9220.put("9220").await.unwrap();
            p9230.put("9230").await.unwrap();
            p9310.put("9310").await.unwrap();
            p9320.put("9320").await.unwrap();
            p9330.put("9330").await.unwrap();
            tokio::time::sleep(Duration::from_millis(100)).await;

            if [
                &s9110, &s9120, &s9130, &s9210, &s9220, &s9230, &s9310, &s9320, &s9330,
            ]
            .iter()
            .all(|sub| sub.count_unique_by_payload(SampleKind::Put) == 9)
            {
                break;
            }
        }
    });

    assert!(
        [&s9110, &s9120, &s9130, &s9210, &s9220, &s9230, &s9310, &s9320, &s9330]
            .iter()
            .all(|sub| sub.unique_timestamps())
    );

    let s = STORAGE.lock();

    for zid in [
        "42ab9110", "42ab9120", "42ab9130", "42ab9210", "42ab9220", "42ab9230", "42ab9310",
        "42ab9320", "42ab9330",
    ] {
        assert_eq!(
            s.all_events()
                .filter(|e| predicates_ext::register_subscriber(zid, "test").eval(e))
                .count(),
            1
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 1)]
async fn test_regions_scenario4_order2_getque() {
    init_tracing_subscriber();

    let z9100 = ztimeout!(Node::new(Router, "42ac9100")
        .endpoints("tcp/0.0.0.0:0", &[])
        .open());
    let z9200 = ztimeout!(Node::new(Router, "42ac9200")
        .endpoints("tcp/0.0.0.0:0", &[loc!(z9100)])
        .open());

    let z9110 = ztimeout!(Node::new(Client, "42ac9110").connect(&[loc!(z9100)]).open());
    let z9120 = ztimeout!(Node::new(Client, "42ac9120").connect(&[loc!(z9100)]).open());
    let z9130 = ztimeout!(Node::new(Client, "42ac9130").connect(&[loc!(z9100)]).open());
    let z9210 = ztimeout!(Node::new(Client, "42ac9210").connect(&[loc!(z9200)]).open());
    let z9220 = ztimeout!(Node::new(Client, "42ac9220").connect(&[loc!(z9200)]).open());
    let z9230 = ztimeout!(Node::new(Client, "42ac9230").connect(&[loc!(z9200)]).open());

    skip_fmt! {
        let _q9110 = z9110.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9110")).unwrap()).await.unwrap();
        let _q9120 = z9120.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9120")).unwrap()).await.unwrap();
        let _q9130 = z9130.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9130")).unwrap()).await.unwrap();
        let _q9210 = z9210.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9210")).unwrap()).await.unwrap();
        let _q9220 = z9220.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9220")).unwrap()).await.unwrap();
        let _q9230 = z9230.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9230")).unwrap()).await.unwrap();
    }

    let z9300 = ztimeout!(Node::new(Router, "42ac9300")
        .endpoints("tcp/0.0.0.0:0", &[loc!(z9100), loc!(z9200)])
        .open());

    let z9310 = ztimeout!(Node::new(Client, "42ac9310").connect(&[loc!(z9300)]).open());
    let z9320 = ztimeout!(Node::new(Client, "42ac9320").connect(&[loc!(z9300)]).open());
    let z9330 = ztimeout!(Node::new(Client, "42ac9330").connect(&[loc!(z9300)]).open());

    skip_fmt! {
        let _q9310 = z9310.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9310")).unwrap()).await.unwrap();
        let _q9320 = z9320.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9320")).unwrap()).await.unwrap();
        let _q9330 = z9330.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9330")).unwrap()).await.unwrap();
    }

    skip_fmt! {ztimeout!(async {
        loop {
            if z9110.get("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap().iter().count() == 9
                && z9120.get("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap().iter().count() == 9
                && z9130.get("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap().iter().count() == 9
                && z9210.get("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap().iter().count() == 9
                && z9220.get("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap().iter().count() == 9
                && z9230.get("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap().iter().count() == 9
                && z9310.get("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap().iter().count() == 9
                && z9320.get("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap().iter().count() == 9
                && z9330.get("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap().iter().count() == 9
            {
                break;
            }
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    })};

    let s = STORAGE.lock();

    for zid in [
        "42ac9110", "42ac9120", "42ac9130", "42ac9210", "42ac9220", "42ac9230", "42ac9310",
        "42ac9320", "42ac9330",
    ] {
        assert_eq!(
            s.all_events()
                .filter(|e| predicates_ext::register_queryable(zid, "test").eval(e))
                .count(),
            0
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 1)]
async fn test_regions_scenario4_order2_queque() {
    init_tracing_subscriber();

    let z9100 = ztimeout!(Node::new(Router, "42ad9100")
        .endpoints("tcp/0.0.0.0:0", &[])
        .open());
    let z9200 = ztimeout!(Node::new(Router, "42ad9200")
        .endpoints("tcp/0.0.0.0:0", &[loc!(z9100)])
        .open());

    let z9110 = ztimeout!(Node::new(Client, "42ad9110").connect(&[loc!(z9100)]).open());
    let z9120 = ztimeout!(Node::new(Client, "42ad9120").connect(&[loc!(z9100)]).open());
    let z9130 = ztimeout!(Node::new(Client, "42ad9130").connect(&[loc!(z9100)]).open());
    let z9210 = ztimeout!(Node::new(Client, "42ad9210").connect(&[loc!(z9200)]).open());
    let z9220 = ztimeout!(Node::new(Client, "42ad9220").connect(&[loc!(z9200)]).open());
    let z9230 = ztimeout!(Node::new(Client, "42ad9230").connect(&[loc!(z9200)]).open());

    skip_fmt! {
        let _q9110 = z9110.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9110")).unwrap()).await.unwrap();
        let _q9120 = z9120.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9120")).unwrap()).await.unwrap();
        let _q9130 = z9130.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9130")).unwrap()).await.unwrap();
        let _q9210 = z9210.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9210")).unwrap()).await.unwrap();
        let _q9220 = z9220.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9220")).unwrap()).await.unwrap();
        let _q9230 = z9230.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9230")).unwrap()).await.unwrap();

        let q9110 = z9110.declare_querier("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap();
        let q9120 = z9120.declare_querier("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap();
        let q9130 = z9130.declare_querier("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap();
        let q9210 = z9210.declare_querier("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap();
        let q9220 = z9220.declare_querier("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap();
        let q9230 = z9230.declare_querier("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap();
    }

    let z9300 = ztimeout!(Node::new(Router, "42ad9300")
        .endpoints("tcp/0.0.0.0:0", &[loc!(z9100), loc!(z9200)])
        .open());

    let z9310 = ztimeout!(Node::new(Client, "42ad9310").connect(&[loc!(z9300)]).open());
    let z9320 = ztimeout!(Node::new(Client, "42ad9320").connect(&[loc!(z9300)]).open());
    let z9330 = ztimeout!(Node::new(Client, "42ad9330").connect(&[loc!(z9300)]).open());

    skip_fmt! {
        let _q9310 = z9310.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9310")).unwrap()).await.unwrap();
        let _q9320 = z9320.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9320")).unwrap()).await.unwrap();
        let _q9330 = z9330.declare_queryable("test").callback(|q| Wait::wait(q.reply("test", "9330")).unwrap()).await.unwrap();

        let q9310 = z9310.declare_querier("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap();
        let q9320 = z9320.declare_querier("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap();
        let q9330 = z9330.declare_querier("test").target(QueryTarget::All).consolidation(ConsolidationMode::None).await.unwrap();
    }

    ztimeout!(async {
        loop {
            if q9110.get().await.unwrap().iter().count() == 9
                && q9120.get().await.unwrap().iter().count() == 9
                && q9130.get().await.unwrap().iter().count() == 9
                && q9210.get().await.unwrap().iter().count() == 9
                && q9220.get().await.unwrap().iter().count() == 9
                && q9230.get().await.unwrap().iter().count() == 9
                && q9310.get().await.unwrap().iter().count() == 9
                && q9320.get().await.unwrap().iter().count() == 9
                && q9330.get().await.unwrap().iter().count() == 9
            {
                break;
            }
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    });

    let s = STORAGE.lock();

    for zid in [
        "42ad9110", "42ad9120", "42ad9130", "42ad9210", "42ad9220", "42ad9230", "42ad9310",
        "42ad9320", "42ad9330",
    ] {
        assert_eq!(
            s.all_events()
                .filter(|e| predicates_ext::register_queryable(zid, "test").eval(e))
                .count(),
            1
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 1)]
async fn test_regions_scenario4_order2_toksub() {
    init_tracing_subscriber();

    let z9100 = ztimeout!(Node::new(Router, "42ae9100")
        .endpoints("tcp/0.0.0.0:0", &[])
        .open());

    let z9200 = ztimeout!(Node::new(Router, "42ae9200")
        .endpoints("tcp/0.0.0.0:0", &[loc!(z9100)])
        .open());

    let z9110 = ztimeout!(Node::new(Client, "42ae9110").connect(&[loc!(z9100)]).open());
    let z9120 = ztimeout!(Node::new(Client, "42ae9120").connect(&[loc!(z9100)]).open());
    let z9130 = ztimeout!(Node::new(Client, "42ae9130").connect(&[loc!(z9100)]).open());
    let z9210 = ztimeout!(Node::new(Client, "42ae9210").connect(&[loc!(z9200)]).open());
    let z9220 = ztimeout!(Node::new(Client, "42ae9220").connect(&[loc!(z9200)]).open());
    let z9230 = ztimeout!(Node::new(Client, "42ae9230").connect(&[loc!(z9200)]).open());

    skip_fmt! {
        let s9110 = z9110.liveliness().declare_subscriber("test/**").history(true).with(unbounded_sink()).await.unwrap();
        let s9120 = z9120.liveliness().declare_subscriber("test/**").history(true).with(unbounded_sink()).await.unwrap();
        let s9130 = z9130.liveliness().declare_subscriber("test/**").history(true).with(unbounded_sink()).await.unwrap();
        let s9210 = z9210.liveliness().declare_subscriber("test/**").history(true).with(unbounded_sink()).await.unwrap();
        let s9220 = z9220.liveliness().declare_subscriber("test/**").history(true).with(unbounded_sink()).await.unwrap();
        let s9230 = z9230.liveliness().declare_subscriber("test/**").history(true).with(unbounded_sink()).await.unwrap();
    }

    let z9300 = ztimeout!(Node::new(Router, "42ae9300")
        .endpoints("tcp/0.0.0.0:0", &[loc!(z9100), loc!(z9200)])
        .open());

    let z9310 = ztimeout!(Node::new(Client, "42ae9310").connect(&[loc!(z9300)]).open());
    let z9320 = ztimeout!(Node::new(Client, "42ae9320").connect(&[loc!(z9300)]).open());
    let z9330 = ztimeout!(Node::new(Client, "42ae9330").connect(&[loc!(z9300)]).open());

    skip_fmt! {
        let s9310 = z9310.liveliness().declare_subscriber("test/**").history(true).with(unbounded_sink()).await.unwrap();
        let s9320 = z9320.liveliness().declare_subscriber("test/**").history(true).with(unbounded_sink()).await.unwrap();
        let s9330 = z9330.liveliness().declare_subscriber("test/**").history(true).with(unbounded_sink()).await.unwrap();
    }

    let t9110 = z9110.liveliness().declare_token("test/9110").await.unwrap();
    let t9120 = z9120.liveliness().declare_token("test/9120").await.unwrap();
    let t9130 = z9130.liveliness().declare_token("test/9130").await.unwrap();
    let t9210 = z9210.liveliness().declare_token("test/9210").await.unwrap();
    let t9220 = z9220.liveliness().declare_token("test/9220").await.unwrap();
    let t9230 = z9230.liveliness().declare_token("test/9230").await.unwrap();
    let t9310 = z9310.liveliness().declare_token("test/9310").await.unwrap();
    let t9320 = z9320.liveliness().declare_token("test/9320").await.unwrap();
    let t9330 = z9330.liveliness().declare_token("test/9330").await.unwrap();

    ztimeout!(async {
        loop {
            tokio::time::sleep(Duration::from_millis(100)).await;

            if [
                &s9110, &s9120, &s9130, &s9210, &s9220, &s9230, &s9310, &s9320, &s9330,
            ]
            .iter()
            .all(|sub| sub.count_unique_by_keyexpr(SampleKind::Put) == 9)
            {
                break;
            }
        }
    });

    t9110.undeclare().await.unwrap();
    t9120.undeclare().await.unwrap();
    t9130.undeclare().await.unwrap();
    t9210.undeclare().await.unwrap();
    t9220.undeclare().await.unwrap();
    t9230.undeclare().await.unwrap();
    t9310.undeclare().await.unwrap();
    t9320.undeclare().await.unwrap();
    t9330.undeclare().await.unwrap();

    ztimeout!(async {
        loop {
            tokio::time::sleep(Duration::from_millis(100)).await;

            if [
                &s9110, &s9120, &s9130, &s9210, &s9220, &s9230, &s9310, &s9320, &s9330,
            ]
            .iter()
            .all(|sub| sub.count_unique_by_keyexpr(SampleKind::Delete) == 9)
            {
                break;
            }
        }
    });
}
