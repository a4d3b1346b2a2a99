"""A fault-injection study: recorded IMU trials through a real attitude-service over a real zenoh link, with
what a network and its ends do to a stream (lost batches, bursts, duplicates, reordering, a cut link, a restart),
each case beside VQF fed the same samples (docs/faults.md).

    attitude-faults TRIAL.hdf5|TRIAL.csv [...] [--cases none,loss-1%,...] [--json] [--bin PATH]

(installed with the package; needs the ``replay`` extra: h5py, vqf). It starts the service itself
(``--bin``, default ``$ATTITUDE_SERVICE_BIN`` or ``attitude-service`` on the PATH) with the IMU preset
(``--config``, default the repository's ``config/imu.json5``) on a free port, and for each trial runs every case
on a vehicle of its own (the preset's MEKF), one after the other:

* ``none``: every batch once, in order (the baseline);
* ``loss-0.1%``, ``loss-1%``, ``loss-5%``: that share of the batches never sent (at least one; seeded, none of
  the first second nor the last batch): what a lossy link leaves of a sender that nothing numbers;
* ``burst-0.2s``, ``burst-1s``, ``burst-5s``: every sample of that span lost, from a seeded point in the movement;
* ``duplicates``: 5% of the batches sent twice in a row (the service refuses the copy: ``duplicate``);
* ``reorder-within``: 5% of the batches sent 1 s (of sample time) late, within ``time.max_lag_s``: fused by a
  replay (``late_fused``), the estimates those of the in-order stream;
* ``reorder-beyond``: 1% of the batches sent ``max_lag_s`` + 1 s late: refused (``out_of_order``), a gap;
* ``cut-cache``, ``cut-small-cache``, ``cut-plain``: the sender's link cut for ``--cut-s`` (a TCP proxy closes it and
  refuses to reconnect) at a seeded point in the movement while it keeps putting: through advanced publishers with
  a cache of ``--cache`` puts (the service fetches what it missed), with a cache of 4 puts (what the cache no longer
  holds is reported, ``samples_missed``) and with plain puts (lost, and nobody can tell);
* ``restart``: the service stopped (SIGTERM; it checkpoints every vehicle) at a seeded point in the movement and
  started again ``--down-s`` later on the same state directory, while the sender keeps putting through an advanced
  publisher: the puts made meanwhile come from its cache.

The sender paces its puts at ``--speed`` times the recording's rate (a cut or a restart lasts that many seconds
of wall time), in batches of ``--batch`` samples. Each case's estimates (the last received per sample: a replayed
one replaces the first) are scored as ``attitude-replay`` scores them (``broad_scores``): total, heading and
inclination RMSE over ``movement``, the honesty figures (``tilt_in99``, 3-axis ``att_in99``, median tilt NEES),
the ratio to the case ``none``. VQF (9D, PyPI ``vqf``) is fed exactly the samples the service used (those with an
estimate, and the alignment's before them), in time order: ``vqf`` as they come (a fixed-rate filter does not see
a gap), ``vqf_hold`` with each missing sample replaced by the last one used (the last rate held over a gap). The
service's own counts are read back per case (rejections by code from ``P/V/rejected``, the last estimate's
``missed``, ``late_fused``, ``imu.gaps``, ``imu.blind_s``, and ``P/@/vehicles``) and checked against what was
injected (``accounted``; a case that does not add up is named on stderr and the command exits 1).

Data: BROAD (Laidig, Caruso, Cereatti, Seel, Data 6(7), 2021, doi:10.3390/data6070072), CC-BY-4.0.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import zlib
from pathlib import Path

import numpy as np
import zenoh

from .client import AttitudeClient
from .replay import ATTRIBUTION, broad_scores, load_trial, quatmult, invquat
from .tcp_proxy import TcpProxy

#: Every case, in the order they run.
CASES = {
    "none": {"kind": "none"},
    "loss-0.1%": {"kind": "loss", "p": 0.001},
    "loss-1%": {"kind": "loss", "p": 0.01},
    "loss-5%": {"kind": "loss", "p": 0.05},
    "burst-0.2s": {"kind": "burst", "s": 0.2},
    "burst-1s": {"kind": "burst", "s": 1.0},
    "burst-5s": {"kind": "burst", "s": 5.0},
    "duplicates": {"kind": "dup", "p": 0.05},
    "reorder-within": {"kind": "reorder", "p": 0.05, "beyond": False},
    "reorder-beyond": {"kind": "reorder", "p": 0.01, "beyond": True},
    "cut-cache": {"kind": "cut", "publisher": "cache"},
    "cut-small-cache": {"kind": "cut", "publisher": "small"},
    "cut-plain": {"kind": "cut", "publisher": "plain"},
    "restart": {"kind": "restart"},
}
#: The cases whose every sample reaches the service (or is refused as a copy): their estimates must be the
#: baseline's.
RECOVERED = ("duplicates", "reorder-within", "cut-cache", "restart")
#: Messages on ``P/V/rejected`` that refuse nothing: a gap in the stream (bridged), puts zenoh lost for good.
NOTICES = ("gap", "samples_missed")
#: The reorder-within delay (s of sample time), the small cache (puts), what a lossy case keeps clear at the start
#: (s: the alignment and the first estimates).
WITHIN_DELAY_S = 1.0
SMALL_CACHE = 4
CLEAR_START_S = 1.0


def _root() -> Path:
    return Path(__file__).resolve().parents[4]


def default_config() -> Path | None:
    p = _root() / "config" / "imu.json5"
    return p if p.exists() else None


def max_lag_of(config: Path) -> float:
    """The configuration's ``service.time.max_lag_s`` (the service's default 2 s when it sets none)."""
    try:
        import json5
    except ImportError:
        return 2.0
    doc = json5.loads(Path(config).read_text())
    return float(((doc.get("service") or {}).get("time") or {}).get("max_lag_s", 2.0))


# ---------------------------------------------------------------------------------------------------
# What each case sends


def plan(case: str, t: np.ndarray, movement: np.ndarray | None, batch: int, max_lag_s: float, seed: int,
         after_s: float = 0.0) -> dict:
    """The puts of ``case`` in the order they are made: ``puts`` (a list of sample-index arrays), ``event`` (the put
    before which the link is cut or the service restarted, or None) and what is injected (``lost``: the samples
    never sent, ``copies``: the samples sent twice, ``late``: the samples sent late, ``late_s``: by how much).
    A cut or a restart comes at a point in the movement with ``after_s`` of samples after it (as many as the trial
    has). Seeded by ``seed`` and the case's name: the same call gives the same plan."""
    spec = CASES[case]
    n = len(t)
    rate = (n - 1) / (t[-1] - t[0])
    nb = (n + batch - 1) // batch
    batches = [np.arange(k * batch, min(n, (k + 1) * batch)) for k in range(nb)]
    rng = np.random.default_rng([seed, zlib.crc32(case.encode())])
    first_movement = int(np.argmax(movement)) if movement is not None and movement.any() else 0
    clear = max(1, int(np.ceil(CLEAR_START_S * rate / batch)))
    eligible = np.arange(clear, nb - 1)
    out = {"case": case, "kind": spec["kind"], "event": None, "lost": np.zeros(0, int), "copies": np.zeros(0, int),
           "late": np.zeros(0, int), "late_s": 0.0}
    order = list(range(nb))
    kind = spec["kind"]

    def movement_point(span_s: float) -> float:
        """The time of a seeded ``movement`` sample (not in the movement's first second) with ``span_s`` after it
        before the trial's end, or the movement's first second when the trial is not that long."""
        lo = t[first_movement] + 1.0
        moving = movement if movement is not None else np.ones(n, bool)
        cand = np.flatnonzero(moving & (t >= lo) & (t <= t[-1] - span_s))
        return float(t[rng.choice(cand)]) if len(cand) else float(lo)

    if kind == "loss":
        k = max(1, int(round(spec["p"] * nb)))
        gone = np.sort(rng.choice(eligible, size=min(k, len(eligible)), replace=False))
        order = [b for b in order if b not in set(gone.tolist())]
        out["lost"] = np.concatenate([batches[b] for b in gone]) if len(gone) else np.zeros(0, int)
        puts = [batches[b] for b in order]
    elif kind == "burst":
        t0 = movement_point(spec["s"] + 1.0)
        lost = np.flatnonzero((t >= t0) & (t < t0 + spec["s"]))
        out["lost"], out["burst_t"] = lost, t0
        keep = np.ones(n, bool)
        keep[lost] = False
        puts = [b[keep[b]] for b in batches if keep[b].any()]
    elif kind == "dup":
        k = max(1, int(round(spec["p"] * nb)))
        twice = set(rng.choice(eligible, size=min(k, len(eligible)), replace=False).tolist())
        puts = []
        for b in order:
            puts.append(batches[b])
            if b in twice:
                puts.append(batches[b])
        out["copies"] = np.concatenate([batches[b] for b in sorted(twice)])
    elif kind == "reorder":
        delay = max_lag_s + 1.0 if spec["beyond"] else WITHIN_DELAY_S
        d = int(np.ceil(delay * rate / batch))
        if not spec["beyond"] and ((d + 1) * batch - 1) / rate >= max_lag_s:
            raise SystemExit(f"--batch {batch}: a batch {WITHIN_DELAY_S} s late would be beyond max_lag_s {max_lag_s}")
        cand = eligible[eligible + d < nb - 1]
        k = max(1, int(round(spec["p"] * nb)))
        late = np.sort(rng.choice(cand, size=min(k, len(cand)), replace=False))
        key = {b: float(b) for b in order}
        for b in late:
            key[int(b)] = b + d + 0.5  # sent right after batch b + d
        order = sorted(order, key=lambda b: key[b])
        puts = [batches[b] for b in order]
        out["late"] = np.concatenate([batches[b] for b in late])
        out["late_s"] = d * batch / rate
        out["late_batches"] = len(late)
    elif kind in ("cut", "restart"):
        t0 = movement_point(after_s)
        puts = [batches[b] for b in order]
        out["event_t"] = t0
        out["event"] = int(np.searchsorted([float(t[b[0]]) for b in puts], t0))
    else:
        puts = [batches[b] for b in order]
    out["puts"] = puts
    return out


# ---------------------------------------------------------------------------------------------------
# The service


_GIVEN_PORTS: set[int] = set()


def free_port() -> int:
    """A TCP port on 127.0.0.1 that was free a moment ago and that this process has not handed out before. Taken
    below the kernel's ephemeral range (32768 and up on Linux), where ``bind(0)`` and every outgoing connection get
    theirs: a zenoh client connecting elsewhere cannot take it before the service binds it, as it can take a port
    ``bind(0)`` has just handed out (the service then exits with "Address already in use")."""
    low, span = 20000, 12000
    start = (os.getpid() * 7919) % span
    for k in range(span):
        port = low + (start + k * 4001) % span
        if port in _GIVEN_PORTS:
            continue
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
            try:
                s.bind(("127.0.0.1", port))
            except OSError:
                continue
        _GIVEN_PORTS.add(port)
        return port
    raise RuntimeError(f"no free port on 127.0.0.1 in {low}..{low + span}")


class Service:
    """``BIN serve --config CONFIG --listen tcp/127.0.0.1:PORT [--connect EP ...] [--state-dir DIR]``, its log in
    ``workdir``."""

    def __init__(self, binary: str, config: Path, workdir: Path, connect: tuple = (), state_dir: Path | None = None,
                 port: int | None = None):
        self.port = port or free_port()
        self.endpoint = f"tcp/127.0.0.1:{self.port}"
        args = [binary, "serve", "--config", str(config), "--listen", self.endpoint]
        for ep in connect:
            args += ["--connect", ep]
        if state_dir is not None:
            args += ["--state-dir", str(state_dir)]
        self.log_path = workdir / f"service-{self.port}-{int(time.time() * 1000) % 100000}.log"
        self._log = open(self.log_path, "wb")
        env = dict(os.environ)
        env.setdefault("RUST_LOG", "warn")
        self.proc = subprocess.Popen(args, stdout=self._log, stderr=subprocess.STDOUT, env=env)

    def log(self) -> str:
        try:
            return self.log_path.read_text(errors="replace")
        except OSError:
            return ""

    def wait_ready(self, client: AttitudeClient, timeout: float = 30.0) -> None:
        deadline = time.monotonic() + timeout
        while True:
            if self.proc.poll() is not None:
                raise SystemExit(f"the service exited with {self.proc.returncode} at start:\n{self.log()[-3000:]}")
            try:
                client.health(timeout=0.5)
                return
            except Exception:  # noqa: BLE001 - not up yet
                if time.monotonic() > deadline:
                    raise SystemExit(f"the service did not answer within {timeout} s:\n{self.log()[-3000:]}")

    def stop(self, timeout: float = 15.0) -> int | None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
        try:
            code = self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(timeout=10)
            code = None
        self._log.close()
        return code


# ---------------------------------------------------------------------------------------------------
# One case


class Observer:
    """A vehicle's estimates (the last received per sample), its rejections and its newest estimated sample."""

    def __init__(self, client: AttitudeClient, vehicle: str, t: np.ndarray):
        self.vehicle, self.t, n = vehicle, t, len(t)
        self.q = np.full((n, 4), np.nan)
        self.cov = np.full((n, 3, 3), np.nan)
        self.cond = threading.Condition()
        self.newest = -1
        self.estimates = 0
        self.replayed = 0
        self.last: dict = {}
        self.rejected: dict[str, int] = {}
        self.rejected_messages: list[dict] = []
        self.sub = client.session.declare_subscriber(client.key(vehicle, "estimate"), zenoh.handlers.FifoChannel(1 << 18))
        self.rej = client.subscribe_rejections(self._on_rejected, vehicle, events=True)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._drain, daemon=True)
        self._thread.start()
        client.health()  # the service has the subscriptions before the first input
        client.wait_listened()  # and puts estimates: it knows of the subscriber

    def _index(self, tt: float) -> int | None:
        i = int(np.searchsorted(self.t, tt - 1e-7))
        return i if i < len(self.t) and abs(self.t[i] - tt) <= 1e-6 else None

    def _drain(self) -> None:
        while not self._stop.is_set():
            try:
                sample = self.sub.try_recv()
            except zenoh.ZError:
                return
            if sample is None:
                time.sleep(0.001)
                continue
            try:
                msg = json.loads(sample.payload.to_bytes())
                i = self._index(float(msg["t"]))
            except (ValueError, KeyError, TypeError):
                continue
            if i is None:
                continue
            q = msg["q"]
            with self.cond:
                self.q[i] = [q["w"], q["x"], q["y"], q["z"]]
                self.cov[i] = np.asarray(msg["cov"], dtype=float)[:3, :3]
                self.estimates += 1
                self.replayed += bool(msg.get("diagnostics", {}).get("replayed"))
                if i >= self.newest:
                    self.newest = i
                    self.last = msg
                self.cond.notify_all()

    def _on_rejected(self, msg: dict) -> None:
        with self.cond:
            code = msg.get("code", "?")
            self.rejected[code] = self.rejected.get(code, 0) + 1
            self.rejected_messages.append(msg)

    def wait_newest(self, index: int, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        with self.cond:
            while self.newest < index:
                left = deadline - time.monotonic()
                if left <= 0:
                    return False
                self.cond.wait(timeout=min(left, 0.5))
        return True

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        for s in (self.sub, self.rej):
            try:
                s.undeclare()
            except Exception:  # noqa: BLE001 - the session went away
                pass


def encode(trial: dict, idx: np.ndarray) -> str:
    t, g, a, m = (trial[k][idx].tolist() for k in ("t", "gyr", "acc", "mag"))
    return json.dumps([{"t": t[i], "gyr": g[i], "acc": a[i], "mag": m[i]} for i in range(len(idx))])


def send(sender: AttitudeClient, vehicle: str, trial: dict, p: dict, speed: float, window: int, observer: Observer,
         on_event=None, during=None) -> dict:
    """Makes the plan's puts, paced at ``speed`` times the recording's rate, at most ``window`` samples ahead of the
    newest estimate (waiting at most 2 s for it: a fault may hold the estimates back); ``on_event()`` runs before the
    plan's event put. Returns the puts made and those made while ``during()`` was true."""
    rate = trial["rate_hz"]
    payloads = [encode(trial, idx) for idx in p["puts"]]
    t0 = time.monotonic()
    sent = made_during = 0
    for k, (idx, payload) in enumerate(zip(p["puts"], payloads)):
        due = t0 + sent / (rate * speed)
        delay = due - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        with observer.cond:
            stall = time.monotonic() + 2.0
            while idx[0] - observer.newest > window and time.monotonic() < stall:
                observer.cond.wait(timeout=0.1)
        if k == p["event"] and on_event is not None:
            on_event()
        sender.put_raw(vehicle, "imu", payload)
        sent += len(idx)
        if during is not None and during():
            made_during += 1
    return {"puts": len(p["puts"]), "puts_during_fault": made_during, "send_s": time.monotonic() - t0}


def settle(client: AttitudeClient, observer: Observer, last: int, timeout: float) -> dict | None:
    """Waits for the estimate of sample ``last``, then until the vehicle has processed or refused everything it
    received, twice in a row 0.3 s apart; returns its ``P/@/vehicles`` row."""
    observer.wait_newest(last, timeout)
    deadline = time.monotonic() + timeout
    before = None
    while time.monotonic() < deadline:
        try:
            row = next((r for r in client.vehicles(timeout=5.0) if r["vehicle"] == observer.vehicle), None)
        except Exception:  # noqa: BLE001 - a restarting service
            row = None
        if row is not None and row["processed"] + row["rejected"] >= row["received"]:
            key = (row["received"], row["processed"], row["rejected"], observer.estimates)
            if key == before:
                return row
            before = key
        time.sleep(0.3)
    return row


def run_case(case: str, trial: dict, p: dict, args, service: Service, workdir: Path, tag: str) -> dict:
    """Runs one case against ``service`` (the restart case starts its own), returns the raw result."""
    vehicle = f"fault-{case.replace('%', 'pc').replace('.', '_')}-{tag}"
    kind = CASES[case]["kind"]
    n = len(trial["t"])
    info: dict = {}
    if kind == "restart":
        return run_restart(case, trial, p, args, workdir, vehicle)
    with AttitudeClient(service.endpoint, timeout=10.0) as observer_client:
        obs = Observer(observer_client, vehicle, trial["t"])
        proxy = None
        try:
            publisher = CASES[case].get("publisher", "cache")
            endpoint = service.endpoint
            if kind == "cut":
                proxy = TcpProxy(("127.0.0.1", service.port))
                endpoint = proxy.endpoint
            cache = SMALL_CACHE if publisher == "small" else args.cache
            with AttitudeClient(endpoint, timeout=10.0, recovery=publisher != "plain", cache=cache) as sender:
                sender.wait_for_service(timeout=20.0)
                window = [float("inf"), float("inf")]

                def cut() -> None:
                    window[0] = time.monotonic()
                    window[1] = window[0] + args.cut_s
                    proxy.cut(args.cut_s)

                info = send(sender, vehicle, trial, p, args.speed, args.window, obs,
                            on_event=cut if kind == "cut" else None,
                            during=lambda: window[0] <= time.monotonic() <= window[1])
                if proxy is not None:
                    info["reconnections"] = proxy.connections - 1
                row = settle(observer_client, obs, n - 1, args.timeout)
        finally:
            obs.close()
            if proxy is not None:
                proxy.close()
    return {"vehicle": vehicle, "q": obs.q, "cov": obs.cov, "row": row, "rejected": dict(obs.rejected),
            "rejected_messages": obs.rejected_messages, "last": obs.last, "estimates": obs.estimates,
            "replayed": obs.replayed, "sender": info}


def run_restart(case: str, trial: dict, p: dict, args, workdir: Path, vehicle: str) -> dict:
    """The sender and the observer listen, the service connects to both (so both are there before it takes an
    input, after the restart too) with a state directory; SIGTERM at the plan's event, a new process on the same
    state directory ``--down-s`` after it exited."""
    n = len(trial["t"])
    sender_ep, observer_ep = (f"tcp/127.0.0.1:{free_port()}" for _ in range(2))
    state_dir = Path(tempfile.mkdtemp(prefix="state-", dir=workdir))

    def start() -> Service:
        return Service(args.bin, args.config, workdir, connect=(sender_ep, observer_ep), state_dir=state_dir)

    services = [start()]
    down: dict = {}
    observer_client = AttitudeClient(observer_ep, connect=False, timeout=10.0)
    sender = AttitudeClient(sender_ep, connect=False, timeout=10.0, cache=args.cache)
    obs = None
    try:
        services[0].wait_ready(observer_client)
        obs = Observer(observer_client, vehicle, trial["t"])
        sender.wait_for_service(timeout=20.0)

        def restart() -> None:
            down["t0"] = time.monotonic()
            down["code"] = services[0].stop()
            time.sleep(args.down_s)
            services.append(start())
            while time.monotonic() < down["t0"] + 60:
                try:
                    observer_client.health(timeout=0.2)
                    down["t1"] = time.monotonic()
                    return
                except Exception:  # noqa: BLE001 - not up yet
                    pass

        restarter = []

        def on_event() -> None:
            th = threading.Thread(target=restart, daemon=True)
            th.start()
            restarter.append(th)

        info = send(sender, vehicle, trial, p, args.speed, args.window, obs, on_event=on_event,
                    during=lambda: "t0" in down and "t1" not in down)
        for th in restarter:
            th.join(timeout=90)
        info["down_s"] = down.get("t1", float("nan")) - down.get("t0", float("nan"))
        info["exit_code"] = down.get("code")
        row = settle(observer_client, obs, n - 1, args.timeout)
        health = observer_client.health()
        info["restored"] = (health.get("checkpoints") or {}).get("restored")
        info["redelivered"] = (health.get("ingest") or {}).get("redelivered")
    finally:
        if obs is not None:
            obs.close()
        observer_client.close()
        sender.close()
        for s in services:
            s.stop()
        shutil.rmtree(state_dir, ignore_errors=True)
    return {"vehicle": vehicle, "q": obs.q, "cov": obs.cov, "row": row, "rejected": dict(obs.rejected),
            "rejected_messages": obs.rejected_messages, "last": obs.last, "estimates": obs.estimates,
            "replayed": obs.replayed, "sender": info}


# ---------------------------------------------------------------------------------------------------
# Scores and accounts


def runs_of(idx: np.ndarray) -> int:
    """How many runs of consecutive indices ``idx`` (sorted) holds."""
    idx = np.unique(idx)
    return int(len(idx) and 1 + np.count_nonzero(np.diff(idx) > 1))


def vqf_on(trial: dict, used: np.ndarray, hold: bool) -> np.ndarray:
    """VQF (9D) on the samples ``used`` (sorted), at the recording's rate: as they come, or (``hold``) with each
    missing sample replaced by the last used one. NaN where a sample was not used."""
    from vqf import VQF

    n = len(trial["t"])
    out = np.full((n, 4), np.nan)
    if len(used) == 0:
        return out
    if hold:
        span = np.arange(used[0], used[-1] + 1)
        src = used[np.searchsorted(used, span, side="right") - 1]
        q = VQF(1.0 / trial["rate_hz"]).updateBatch(*(np.ascontiguousarray(trial[k][src]) for k in ("gyr", "acc", "mag")))["quat9D"]
        out[span] = q
        mask = np.ones(n, bool)
        mask[used] = False
        out[mask] = np.nan
    else:
        q = VQF(1.0 / trial["rate_hz"]).updateBatch(*(np.ascontiguousarray(trial[k][used]) for k in ("gyr", "acc", "mag")))["quat9D"]
        out[used] = q
    return out


def angle_deg(qa: np.ndarray, qb: np.ndarray) -> np.ndarray:
    e = quatmult(qa, invquat(qb))
    return np.rad2deg(2.0 * np.arctan2(np.linalg.norm(e[:, 1:], axis=1), np.abs(e[:, 0])))


def evaluate(case: str, trial: dict, p: dict, run: dict, base: dict | None) -> dict:
    """The case's scores, the service's counts and whether they account for what was injected."""
    n = len(trial["t"])
    q, cov = run["q"], run["cov"]
    has = np.isfinite(q[:, 0])
    sent = np.zeros(n, bool)
    for idx in p["puts"]:
        sent[idx] = True
    first = int(np.argmax(has)) if has.any() else n
    used = np.flatnonzero(has | (sent & (np.arange(n) < first)))
    ours = broad_scores(q, cov, trial["opt_quat"], trial["movement"], trial["truth"], trial["gyr"])
    peers = {name: broad_scores(vqf_on(trial, used, hold), None, trial["opt_quat"], trial["movement"], trial["truth"])
             for name, hold in (("vqf", False), ("vqf_hold", True))}
    diag = run["last"].get("diagnostics", {}) if run["last"] else {}
    imu = diag.get("imu") or {}
    row = run["row"] or {}
    counts = {
        "sent_samples": int(sent.sum()),
        "estimated": int(has.sum()),
        "aligning": first,
        "sent_without_estimate": int((sent & ~has & (np.arange(n) >= first)).sum()),
        "received": row.get("received"),
        "processed": row.get("processed"),
        "rejected_total": row.get("rejected"),
        "rejected": run["rejected"],
        "missed": diag.get("missed", 0),
        "late_fused": diag.get("late_fused", 0),
        "gaps": imu.get("gaps"),
        "blind_s": imu.get("blind_s"),
        "replayed_estimates": run["replayed"],
    }
    injected = {
        "lost_samples": int(len(p["lost"])),
        "lost_s": float(len(p["lost"]) / trial["rate_hz"]),
        "lost_runs": runs_of(p["lost"]),
        "copies": int(len(p["copies"])),
        "late_samples": int(len(p["late"])),
        "late_s": p["late_s"],
    }
    out = {"case": case, "injected": injected, "counts": counts, "sender": run["sender"],
           "ours": {k: v for k, v in ours.items()}, "vqf": peers["vqf"], "vqf_hold": peers["vqf_hold"]}
    if base is not None:
        bq, bc = base["q"], base["cov"]
        both = has & np.isfinite(bq[:, 0])
        out["identical_to_none"] = bool(np.array_equal(q, bq, equal_nan=True) and np.array_equal(cov, bc, equal_nan=True))
        out["max_diff_to_none_deg"] = float(angle_deg(q[both], bq[both]).max()) if both.any() else float("nan")
    out["problems"] = account(case, p, trial, out)
    return out


def account(case: str, p: dict, trial: dict, r: dict) -> list[str]:
    """What does not add up between what was injected and what the service counted (empty: accounted for)."""
    kind = CASES[case]["kind"]
    c, inj = r["counts"], r["injected"]
    rej = c["rejected"]
    problems = []

    def want(ok: bool, what: str) -> None:
        if not ok:
            problems.append(what)

    refused = sum(v for k, v in rej.items() if k not in NOTICES)
    told = rej.get("gap", 0)
    rate = trial["rate_hz"]
    complete = case in RECOVERED + ("none",)
    if complete:
        want(c["sent_without_estimate"] == 0, f"{c['sent_without_estimate']} samples sent got no estimate")
        want(c["missed"] == 0, f"missed {c['missed']}")
        want(c["gaps"] in (0, None), f"gaps {c['gaps']} without a loss")
        if case != "reorder-within":  # (a late batch's gap is told, then filled by the replay)
            want(told == 0, f"{told} gaps told without a loss")
    if kind == "none":
        want(refused == 0, f"refusals {rej}")
    if kind in ("loss", "burst"):
        want(refused == 0, f"refusals {rej}")
        want(c["sent_without_estimate"] == 0, f"{c['sent_without_estimate']} samples sent got no estimate")
        if c["gaps"] is not None:
            want(c["gaps"] == inj["lost_runs"] == told,
                 f"gaps {c['gaps']}, told {told} ≠ {inj['lost_runs']} runs of lost samples")
            want(abs(c["blind_s"] - inj["lost_s"]) <= (inj["lost_runs"] + 1) * 1.5 / rate,
                 f"blind_s {c['blind_s']:.3f} ≠ {inj['lost_s']:.3f} s lost")
    if kind == "dup":
        want(rej.get("duplicate", 0) == inj["copies"] and refused == inj["copies"],
             f"refusals {rej} ≠ {inj['copies']} copies")
    if kind == "reorder" and not CASES[case]["beyond"]:
        want(refused == 0, f"refusals {rej}")
        want(c["late_fused"] == inj["late_samples"], f"late_fused {c['late_fused']} ≠ {inj['late_samples']} sent late")
    if kind == "reorder" and CASES[case]["beyond"]:
        want(rej.get("out_of_order", 0) == inj["late_samples"] and refused == inj["late_samples"],
             f"refusals {rej} ≠ {inj['late_samples']} out_of_order")
        want(c["sent_without_estimate"] == inj["late_samples"],
             f"{c['sent_without_estimate']} without an estimate ≠ {inj['late_samples']} refused")
        if c["gaps"] is not None:
            want(c["gaps"] == runs_of(p["late"]) == told, f"gaps {c['gaps']}, told {told} ≠ {runs_of(p['late'])} "
                 "refused runs")
    if kind in ("cut", "restart"):
        want(refused == 0, f"refusals {rej}")
        puts = r["sender"].get("puts_during_fault", 0)
        want(puts >= 5, f"only {puts} puts during the fault")
    if case in RECOVERED:
        want(r.get("identical_to_none", False), f"estimates differ from none's by up to {r.get('max_diff_to_none_deg')}°")
    if kind == "cut" and CASES[case]["publisher"] == "plain":
        want(c["sent_without_estimate"] > 0, "nothing lost by the plain sender")
        want(c["missed"] == 0, f"missed {c['missed']}: nothing numbers plain puts")
        if c["gaps"] is not None:
            want(c["gaps"] >= 1 and told == c["gaps"], f"gaps {c['gaps']}, told {told}")
    if kind == "cut" and CASES[case]["publisher"] == "small":
        want(c["missed"] >= 1 and rej.get("samples_missed", 0) >= 1,
             f"missed {c['missed']}, samples_missed messages {rej.get('samples_missed', 0)}")
        want(c["sent_without_estimate"] == c["missed"] * len(p["puts"][0]),
             f"{c['sent_without_estimate']} samples without an estimate ≠ {c['missed']} puts missed")
        if c["gaps"] is not None:
            want(c["gaps"] >= 1 and told == c["gaps"], f"gaps {c['gaps']}, told {told}")
    if kind == "restart":
        want(r["sender"].get("exit_code") == 0, f"exit code {r['sender'].get('exit_code')}")
        want(r["sender"].get("restored") == 1, f"restored {r['sender'].get('restored')}")
    return problems


# ---------------------------------------------------------------------------------------------------


def study(trial: dict, cases: list[str], args, workdir: Path) -> dict:
    """Every case of ``cases`` on ``trial``: {"trial", "samples", ..., "cases": {case: evaluate(...)}}."""
    max_lag = max_lag_of(args.config)
    tag = f"{os.getpid()}-{int(time.time() * 1000) % 1_000_000}"
    results: dict = {}
    runs: dict = {}
    service = None
    try:
        order = ["none"] + [c for c in cases if c != "none"]
        for case in order:
            # (A cut or a restart needs samples after it for the fault, the reconnection and more.)
            after_s = ((args.cut_s if CASES[case]["kind"] == "cut" else args.down_s) + 3.0) * args.speed
            p = plan(case, trial["t"], trial["movement"], args.batch, max_lag, args.seed, after_s)
            if CASES[case]["kind"] != "restart" and service is None:
                service = Service(args.bin, args.config, workdir)
                with AttitudeClient(service.endpoint, timeout=10.0) as c:
                    service.wait_ready(c)
            t0 = time.monotonic()
            run = run_case(case, trial, p, args, service, workdir, tag)
            runs[case] = run
            r = evaluate(case, trial, p, run, runs.get("none") if case != "none" else None)
            r["seconds"] = time.monotonic() - t0
            results[case] = r
            if not args.json:
                print(f"  {case}: {r['ours']['total_rmse_deg']:.2f}° ({r['seconds']:.0f} s)"
                      + (f"  NOT ACCOUNTED: {'; '.join(r['problems'])}" if r["problems"] else ""), file=sys.stderr)
    finally:
        if service is not None:
            code = service.stop()
            if code != 0:
                print(f"warning: the service exited with {code}:\n{service.log()[-2000:]}", file=sys.stderr)
    base = results["none"]["ours"]
    for case, r in results.items():
        r["ratio_to_none"] = r["ours"]["total_rmse_deg"] / base["total_rmse_deg"]
        r["ratio_to_vqf"] = r["ours"]["total_rmse_deg"] / r["vqf"]["total_rmse_deg"]
        r["ratio_to_vqf_hold"] = r["ours"]["total_rmse_deg"] / r["vqf_hold"]["total_rmse_deg"]
    if "none" not in cases:
        results.pop("none")
    return {"trial": trial["name"], "samples": len(trial["t"]), "rate_hz": trial["rate_hz"],
            "seconds": float(trial["t"][-1] - trial["t"][0]), "batch": args.batch, "speed": args.speed,
            "max_lag_s": max_lag, "seed": args.seed, "cases": results}


def injected_text(r: dict) -> str:
    inj, case = r["injected"], r["case"]
    kind = CASES[case]["kind"]
    if kind in ("loss", "burst"):
        return f"{inj['lost_samples']} lost ({inj['lost_s']:.2f} s, {inj['lost_runs']} runs)"
    if kind == "dup":
        return f"{inj['copies']} sent twice"
    if kind == "reorder":
        return f"{inj['late_samples']} sent {inj['late_s']:.2f} s late"
    if kind == "cut":
        return f"{r['sender'].get('puts_during_fault', 0)} puts in the cut"
    if kind == "restart":
        return f"{r['sender'].get('puts_during_fault', 0)} puts while down"
    return "–"


def counts_text(r: dict) -> str:
    c = r["counts"]
    parts = []
    for code, k in sorted(c["rejected"].items()):
        parts.append(f"gaps told {k}" if code == "gap" else f"{code} {k}")
    if c["missed"]:
        parts.append(f"missed {c['missed']}")
    if c["late_fused"]:
        parts.append(f"late_fused {c['late_fused']}")
    if c["gaps"]:
        parts.append(f"gaps {c['gaps']} ({c['blind_s']:.2f} s)")
    if c["sent_without_estimate"]:
        parts.append(f"{c['sent_without_estimate']} sent, no estimate")
    if "identical_to_none" in r and r["case"] in RECOVERED + ("none",):
        parts.append("= none" if r["identical_to_none"] else f"≠ none ({r['max_diff_to_none_deg']:.2g}°)")
    if r["problems"]:
        parts.append("NOT ACCOUNTED: " + "; ".join(r["problems"]))
    return ", ".join(parts) or "–"


def markdown(result: dict) -> str:
    lines = [f"**{result['trial']}** ({result['samples']} samples, {result['seconds']:.0f} s; batches of "
             f"{result['batch']}, sent at {result['speed']:g}× the recording's rate; time.max_lag_s "
             f"{result['max_lag_s']:g} s; seed {result['seed']})", "",
             "| case | injected | total° | heading° | incl.° | ×none | tilt in99 | 3-axis in99 | tilt NEES med. "
             "| VQF° as fed | VQF° held | ×VQF | the service's counts |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    def f(x, p=2):
        return "–" if x is None or not np.isfinite(x) else f"{x:.{p}f}"

    for case, r in result["cases"].items():
        o = r["ours"]
        lines.append(
            f"| {case} | {injected_text(r)} | {f(o['total_rmse_deg'])} | {f(o['heading_rmse_deg'])} | "
            f"{f(o['inclination_rmse_deg'])} | {f(r['ratio_to_none'])} | {f(o['tilt_in99'], 3)} | "
            f"{f(o['att_in99'], 3)} | {f(o['tilt_nees_median'])} | {f(r['vqf']['total_rmse_deg'])} | "
            f"{f(r['vqf_hold']['total_rmse_deg'])} | {f(r['ratio_to_vqf'])} | {counts_text(r)} |")
    return "\n".join(lines)


def _jsonable(x):
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.floating,)):
        return float(x)
    if isinstance(x, float) and not np.isfinite(x):
        return None
    return x


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("trials", type=Path, nargs="*", help="BROAD trials (.hdf5) or CSV trials (docs/recordings.md)")
    ap.add_argument("--table", type=Path, help="print the tables of results saved by --json, and run nothing")
    ap.add_argument("--cases", default=",".join(CASES), help=f"comma-separated, of: {', '.join(CASES)} (default all)".replace("%", "%%"))
    ap.add_argument("--bin", default=os.environ.get("ATTITUDE_SERVICE_BIN") or shutil.which("attitude-service"),
                    help="the service binary (default $ATTITUDE_SERVICE_BIN, else attitude-service on the PATH)")
    ap.add_argument("--config", type=Path, default=default_config(),
                    help="the service's configuration (default the repository's config/imu.json5)")
    ap.add_argument("--excerpt-seconds", type=float,
                    help="only the opening rest and this many seconds from the first movement sample")
    ap.add_argument("--batch", type=int, default=40, help="samples per put (default 40: 0.14 s at 286 Hz)")
    ap.add_argument("--speed", type=float, default=8.0,
                    help="puts paced at this many times the recording's rate (default 8)")
    ap.add_argument("--window", type=int, default=6000,
                    help="most samples sent ahead of the newest estimate (default 6000; waits at most 2 s)")
    ap.add_argument("--cache", type=int, default=1000, help="puts an advanced publisher keeps (default 1000)")
    ap.add_argument("--cut-s", type=float, default=1.0,
                    help="how long the link is cut, wall s (default 1: --speed s of samples)")
    ap.add_argument("--down-s", type=float, default=1.0,
                    help="wall s between the service's exit and its restart (default 1)")
    ap.add_argument("--timeout", type=float, default=60.0, help="longest wait for a case's last estimate, s")
    ap.add_argument("--seed", type=int, default=1, help="what is dropped, delayed and when (default 1)")
    ap.add_argument("--json", action="store_true", help="print the results as JSON (a list, one object per trial)")
    ap.add_argument("--keep-logs", type=Path, help="keep the service's logs in this directory")
    args = ap.parse_args(argv)
    if args.table:
        for r in json.loads(args.table.read_text()):
            print(markdown(r))
            print()
        return 0
    if not args.trials:
        ap.error("give one or more trials")
    cases = [c.strip() for c in args.cases.split(",") if c.strip()]
    unknown = [c for c in cases if c not in CASES]
    if unknown:
        ap.error(f"unknown case {unknown[0]!r}: one of {', '.join(CASES)}")
    if not args.bin or not Path(args.bin).exists():
        ap.error("no service binary: give --bin or set ATTITUDE_SERVICE_BIN (or put attitude-service on the PATH)")
    if args.config is None or not args.config.exists():
        ap.error("no configuration: give --config (the repository's config/imu.json5)")
    if args.batch < 1 or args.speed <= 0 or args.window < args.batch:
        ap.error("--batch must be ≥ 1, --speed > 0, --window ≥ --batch")
    workdir = Path(tempfile.mkdtemp(prefix="attitude-faults-"))
    results = []
    try:
        for path in args.trials:
            trial = load_trial(path, args.excerpt_seconds)
            if trial["opt_quat"] is None or trial["movement"] is None or not trial["movement"].any():
                raise SystemExit(f"{path}: needs opt_quat and movement samples to score")
            if not args.json:
                print(f"{trial['name']}: {len(trial['t'])} samples", file=sys.stderr)
            results.append(study(trial, cases, args, workdir))
    finally:
        if args.keep_logs:
            args.keep_logs.mkdir(parents=True, exist_ok=True)
            for f in workdir.glob("*.log"):
                shutil.copy(f, args.keep_logs / f.name)
        shutil.rmtree(workdir, ignore_errors=True)
    bad = [(r["trial"], case, c["problems"]) for r in results for case, c in r["cases"].items() if c["problems"]]
    for trial_name, case, problems in bad:
        print(f"{trial_name}: {case} not accounted for: {'; '.join(problems)}", file=sys.stderr)
    if args.json:
        print(json.dumps(_jsonable(results)))
    else:
        for r in results:
            print(markdown(r))
            print()
        print("RMSE over `movement` as attitude-replay scores it; ×none: total RMSE over the case none's; ×VQF: over "
              "VQF's fed the same samples as they come. " + ATTRIBUTION)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
