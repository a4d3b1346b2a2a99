//! The vendored zenoh (vendor/README.md) finds the subscribers of a message on an undeclared key by
//! looking its verbatim chunks up among their siblings instead of visiting every sibling. What it
//! delivers must not change: every subscriber whose key expression intersects the message's key gets
//! it, once, and no other does — for keys under hundreds of declared siblings, wild subscriptions
//! beside them (`*`, `**`, `$*`, verbatim `@` chunks), and after the wild ones are undeclared.
//! The vendored zenoh also keeps the route of an undeclared key, by its text, until a declaration,
//! a face or the topology changes: the routes must follow every such change — subscriptions declared
//! and undeclared (above), and peers that arrive, subscribe and leave after the keys' routes were
//! kept (`routes_follow_peers_that_come_and_go`).
//! Through a real link: the sender's session routes each put on its tables of the receiver's
//! subscriptions, and the receiver's routes what arrives on its own; once more with the sender holding
//! a declared publisher on every sibling key (as the service does for its fast vehicles).
//! The vendored zenoh's session also keeps, per key, the callbacks of its subscribers that a sample
//! on it reaches (for samples from a link and for its own puts), emptied by every subscription
//! declared or undeclared: each phase delivers twice (the second time from what was kept), a fourth
//! phase keeps one wild subscription (`zr/**`, so that its keys still reach the receiver) and undeclares
//! the others, and the same phases run within one session too (its own puts reach its own subscribers without the
//! routing tables, by that cache alone).

use crate::common::{free_port, open_zenoh};
use std::collections::{BTreeMap, BTreeSet};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use zenoh::key_expr::KeyExpr;

const SIBLINGS: usize = 300;

fn wild() -> Vec<&'static str> {
    vec![
        "zr/*/gyro",
        "zr/**",
        "zr/v1$*/x",
        "zr/$*3/est",
        "zr/v5/*",
        "zr/v7/**/deep",
        "**/est",
        "zr/*/est/more",
    ]
}

fn messages() -> Vec<&'static str> {
    vec![
        "zr/v7/gyro",
        "zr/v77/est",
        "zr/v13/x",
        "zr/zzz/est",
        "zr/v3/est",
        "zr/v5/imu",
        "zr/v7/a/b/deep",
        "zr/v2/est/more",
        "zr/@hidden/est",
        "zr/v299/est",
        "zr/v300/est",
        "zr",
        "zr/v9",
        "other/v9/est",
        "zr/v1/x",
    ]
}

type Seen = Arc<Mutex<BTreeMap<String, Vec<String>>>>;

async fn subscribe(
    session: &zenoh::Session,
    key: &str,
    seen: &Seen,
) -> zenoh::pubsub::Subscriber<()> {
    let seen = seen.clone();
    let name = key.to_string();
    session
        .declare_subscriber(key.to_string())
        .callback(move |s| {
            seen.lock()
                .unwrap()
                .entry(name.clone())
                .or_default()
                .push(s.key_expr().to_string())
        })
        .await
        .unwrap()
}

/// The subscription that catches the sentinels, each delivery's own (`zr-sentinel/N`): a sentinel
/// of an earlier delivery still in flight must not end a later one before its messages arrived.
const SENTINELS: &str = "zr-sentinel/*";

/// Puts every message (undeclared keys), then its own sentinel, and waits for that sentinel;
/// returns, per subscription, the keys it received.
async fn deliver(sender: &zenoh::Session, seen: &Seen) -> BTreeMap<String, Vec<String>> {
    static DELIVERY: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
    let n = DELIVERY.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let sentinel = format!("zr-sentinel/{n}");
    seen.lock().unwrap().clear();
    for m in messages() {
        sender.put(m, "x").await.unwrap();
    }
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        sender.put(sentinel.as_str(), "x").await.unwrap();
        let arrived = seen
            .lock()
            .unwrap()
            .get(SENTINELS)
            .is_some_and(|keys| keys.contains(&sentinel));
        if arrived {
            break;
        }
        assert!(Instant::now() < deadline, "the sentinel never arrived");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let mut got = seen.lock().unwrap().clone();
    got.remove(SENTINELS);
    got
}

fn expected(subscriptions: &[String]) -> BTreeMap<String, Vec<String>> {
    let mut want = BTreeMap::new();
    for sub in subscriptions {
        let k = KeyExpr::try_from(sub.as_str()).unwrap();
        let hits: Vec<String> = messages()
            .into_iter()
            .filter(|m| k.intersects(&KeyExpr::try_from(*m).unwrap()))
            .map(String::from)
            .collect();
        if !hits.is_empty() {
            want.insert(sub.clone(), hits);
        }
    }
    want
}

fn sorted(mut m: BTreeMap<String, Vec<String>>) -> BTreeMap<String, BTreeSet<String>> {
    let mut out = BTreeMap::new();
    for (k, v) in m.iter_mut() {
        let set: BTreeSet<String> = v.iter().cloned().collect();
        assert_eq!(set.len(), v.len(), "{k} received a message twice: {v:?}");
        out.insert(k.clone(), set);
    }
    out
}

/// The three phases, each delivered twice. `one_session`: the sender is the receiver.
async fn check(sender_publishers: bool, one_session: bool) {
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let receiver = open_zenoh(std::slice::from_ref(&endpoint), &[]).await;
    let sender = if one_session {
        receiver.clone()
    } else {
        open_zenoh(&[], std::slice::from_ref(&endpoint)).await
    };
    let seen: Seen = Arc::default();
    let mut plain: Vec<String> = (0..SIBLINGS).map(|i| format!("zr/v{i}/est")).collect();
    plain.push("zr/@hidden/est".into());
    let mut publishers = Vec::new();
    if sender_publishers {
        for key in plain.iter() {
            publishers.push(sender.declare_publisher(key.clone()).await.unwrap());
        }
    }
    let mut subs = Vec::new();
    for key in plain.iter() {
        subs.push(subscribe(&receiver, key, &seen).await);
    }
    let mut wild_subs = Vec::new();
    for key in wild() {
        wild_subs.push(subscribe(&receiver, key, &seen).await);
    }
    let _sentinel = subscribe(&receiver, SENTINELS, &seen).await;
    // The sender's puts reach the receiver's subscriptions once their declarations have arrived.
    tokio::time::sleep(Duration::from_millis(500)).await;

    let mut all: Vec<String> = plain.clone();
    all.extend(wild().into_iter().map(String::from));
    let how = format!("sender's publishers: {sender_publishers}, one session: {one_session}");
    for round in 1..=2 {
        assert_eq!(
            sorted(deliver(&sender, &seen).await),
            sorted(expected(&all)),
            "with the wild subscriptions, delivery {round} ({how})"
        );
    }
    for s in wild_subs {
        s.undeclare().await.unwrap();
    }
    tokio::time::sleep(Duration::from_millis(500)).await;
    for round in 1..=2 {
        assert_eq!(
            sorted(deliver(&sender, &seen).await),
            sorted(expected(&plain)),
            "after the wild subscriptions were undeclared, delivery {round} ({how})"
        );
    }
    // And declared again: found again, once each.
    let mut wild_again = Vec::new();
    for key in wild() {
        wild_again.push((key, subscribe(&receiver, key, &seen).await));
    }
    tokio::time::sleep(Duration::from_millis(500)).await;
    for round in 1..=2 {
        assert_eq!(
            sorted(deliver(&sender, &seen).await),
            sorted(expected(&all)),
            "with the wild subscriptions declared again, delivery {round} ({how})"
        );
    }
    // All undeclared but `zr/**`: the keys it matches still come to the receiver, and no other
    // wild subscription, though each matched them a moment ago, receives them.
    let kept = "zr/**";
    for (key, sub) in wild_again {
        if key == kept {
            subs.push(sub);
        } else {
            sub.undeclare().await.unwrap();
        }
    }
    tokio::time::sleep(Duration::from_millis(500)).await;
    let mut plain_and_kept = plain.clone();
    plain_and_kept.push(kept.into());
    for round in 1..=2 {
        assert_eq!(
            sorted(deliver(&sender, &seen).await),
            sorted(expected(&plain_and_kept)),
            "with every wild subscription but {kept} undeclared, delivery {round} ({how})"
        );
    }
    drop(subs);
    drop(publishers);
    if !one_session {
        sender.close().await.unwrap();
    }
    receiver.close().await.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn undeclared_keys_reach_exactly_the_intersecting_subscribers() {
    check(false, false).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn undeclared_keys_reach_exactly_the_intersecting_subscribers_beside_declared_publishers() {
    check(true, false).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_sessions_own_puts_reach_exactly_its_intersecting_subscribers() {
    check(false, true).await;
}

/// Puts `keys` from `sender` (undeclared keys), five times at least (so that their routes are kept),
/// until what the subscriptions received is `want` or the deadline passes; then, after a pause,
/// returns what each one received.
async fn put_until(
    sender: &zenoh::Session,
    keys: &[&str],
    want: &BTreeMap<String, BTreeSet<String>>,
    seen: &Seen,
) -> BTreeMap<String, BTreeSet<String>> {
    seen.lock().unwrap().clear();
    let deadline = Instant::now() + Duration::from_secs(10);
    let have = |seen: &Seen| -> BTreeMap<String, BTreeSet<String>> {
        seen.lock()
            .unwrap()
            .iter()
            .map(|(k, v)| (k.clone(), v.iter().cloned().collect()))
            .collect()
    };
    for round in 0.. {
        for k in keys {
            sender.put(*k, "x").await.unwrap();
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
        if (round >= 4 && have(seen) == *want) || Instant::now() > deadline {
            break;
        }
    }
    tokio::time::sleep(Duration::from_millis(200)).await;
    have(seen)
}

fn want(pairs: &[(&str, &[&str])]) -> BTreeMap<String, BTreeSet<String>> {
    pairs
        .iter()
        .map(|(sub, keys)| {
            (
                sub.to_string(),
                keys.iter().map(|k| k.to_string()).collect(),
            )
        })
        .collect()
}

/// A sender puts on two undeclared keys, often enough that their routes are kept, while peers
/// connect to it, subscribe, unsubscribe and leave. Each change must reach the next puts: a kept
/// route that missed a change would starve a new subscriber.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn routes_follow_peers_that_come_and_go() {
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let sender = open_zenoh(std::slice::from_ref(&endpoint), &[]).await;
    // Siblings enough for the look-up path, declared by the sender itself.
    let mut own = Vec::new();
    for i in 0..SIBLINGS {
        own.push(
            sender
                .declare_subscriber(format!("zr/v{i}/own"))
                .callback(|_| {})
                .await
                .unwrap(),
        );
    }
    let keys = ["zr/v1/est", "zr/v2/est"];
    let seen: Seen = Arc::default();

    // No subscriber anywhere yet: the routes kept are empty ones.
    let nobody = put_until(&sender, &keys, &BTreeMap::new(), &seen).await;
    assert_eq!(nobody, BTreeMap::new(), "nobody subscribed yet");

    // A peer arrives and subscribes to one key, then a wild expression too.
    let first = open_zenoh(&[], std::slice::from_ref(&endpoint)).await;
    let one = subscribe(&first, "zr/v1/est", &seen).await;
    let expect = want(&[("zr/v1/est", &["zr/v1/est"])]);
    assert_eq!(
        put_until(&sender, &keys, &expect, &seen).await,
        expect,
        "a peer arrived"
    );
    let wild = subscribe(&first, "zr/*/est", &seen).await;
    let expect = want(&[
        ("zr/v1/est", &["zr/v1/est"]),
        ("zr/*/est", &["zr/v1/est", "zr/v2/est"]),
    ]);
    assert_eq!(
        put_until(&sender, &keys, &expect, &seen).await,
        expect,
        "it subscribed again"
    );

    // It drops the plain one, then leaves.
    one.undeclare().await.unwrap();
    let expect = want(&[("zr/*/est", &["zr/v1/est", "zr/v2/est"])]);
    assert_eq!(
        put_until(&sender, &keys, &expect, &seen).await,
        expect,
        "it unsubscribed"
    );
    drop(wild);
    first.close().await.unwrap();

    // Another peer, on the same endpoint: it must get what it asks for, no more.
    let second = open_zenoh(&[], std::slice::from_ref(&endpoint)).await;
    let _two = subscribe(&second, "zr/v2/est", &seen).await;
    let expect = want(&[("zr/v2/est", &["zr/v2/est"])]);
    assert_eq!(
        put_until(&sender, &keys, &expect, &seen).await,
        expect,
        "a second peer arrived"
    );
    second.close().await.unwrap();
    drop(own);
    sender.close().await.unwrap();
}
