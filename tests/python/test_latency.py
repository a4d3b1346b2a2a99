"""A coarse latency check (the figures come from `python tests/python/latency.py`)."""

from __future__ import annotations

from latency import fmt, put_to_estimate, get_latency


def test_put_to_estimate_latency_is_small(client):
    vehicle = "lat-1"  # configured mekf
    est = put_to_estimate(client, vehicle, samples=50)
    get = get_latency(client, client.health, samples=50)
    print("\n" + fmt("put vectors → estimate (mekf)", est) + "\n" + fmt("get P/@/health", get))
    # Loose bounds: a loaded 2-core machine still answers in milliseconds.
    assert est["median_us"] < 50_000, est
    assert get["median_us"] < 50_000, get
