"""The Rerun sink of ``attitude-view`` (``attitude-view --rerun``): the same view as the Foxglove sink (the messages of
:class:`attitude_client.view.model.View`, computed there once) as Rerun entities, shown by Rerun's web viewer in a
browser.

    attitude-view --rerun --connect tcp/127.0.0.1:7447      # then open http://127.0.0.1:9090/?url=... (printed)

Needs the ``view-rerun`` extra (``pip install 'attitude-client[view-rerun]'``: rerun-sdk, Python 3.11 or later).
``docs/view.md`` is the user's page.

The server. The view starts the ``rerun`` command-line tool of the rerun-sdk wheel as a child process
(``rerun --serve-web --bind HOST``): a gRPC server that keeps the log for viewers that connect later (up to
``--memory-limit``), and an HTTP server of the web viewer (HTML + WebAssembly from the wheel). The SDK's own
``rr.serve_grpc``/``rr.serve_web_viewer`` listen on every interface with no way to choose; the command-line tool binds
where ``--host`` says (127.0.0.1 by default), as the Foxglove sink does. The view then logs to the gRPC server
(``RecordingStream.connect_grpc``) with its blueprint, so the layout opens ready.

Entities. Per vehicle ``V``, each message of the Foxglove topic ``/V/<leaf>`` is a row of the entity ``/V/<leaf>``
(``AnyValues``: every field but ``vehicle``, ``t`` and ``seq``, objects flattened: ``q.w``, ``by_code.bad_request``);
what the layout plots is also a ``Scalars`` entity ``/V/<leaf>/<field>`` (a vector one entity of three series:
``error_deg``, ``plus_3sigma_deg``, ``minus_3sigma_deg``, ``euler_deg``, ``three_sigma_deg``, ``ess``, the rejections'
``total``), and the last rejection a ``TextLog`` line (``/V/rejections/last``) with each publication of the counts.
Few entities: a viewer's cost grows with the rows it ingests. The 3D scene is
``/world`` (z up): ``/world/V/estimate`` (``Transform3D``: the estimate, the vehicle at its place on the grid) with a
box and the body axes, ``/world/V/truth`` (the truth at the estimate's ``t``) with longer thin axes, and
``/world/V/label``. ``/summary`` is a Markdown table. Timelines: ``wall`` (the view's clock, as Foxglove's log time),
and for a vehicle's messages ``t`` (the estimate's time, s, on the vehicle's clock) and ``seq``.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from typing import Any, Iterable, Sequence
from urllib.parse import quote

import numpy as np

from .model import AXIS_RGB, DEMO_VEHICLES, GRID_COLUMNS, GRID_SPACING, Pose

__all__ = ["APPLICATION_ID", "PLOTTED", "RerunServer", "RerunSink", "blueprint", "flatten", "series", "viewer_url"]

#: The recording's application id (a blueprint applies to the recordings of its application id).
APPLICATION_ID = "attitude-view"

#: The series plotted (the Foxglove layout's plots): ``Scalars`` entities ``/V/<leaf>/<field>``.
PLOTTED = {
    "attitude": ("euler_deg", "three_sigma_deg"),
    "error": ("error_deg", "plus_3sigma_deg", "minus_3sigma_deg"),
    "diagnostics": ("ess",),
    "rejections": ("total",),
}
#: Display names of the vectors' series (``<name> <axis>``), as the Foxglove layout's legends.
_SERIES_PREFIX = {"error_deg": "δα", "plus_3sigma_deg": "+3σ", "minus_3sigma_deg": "−3σ", "three_sigma_deg": "3σ"}
#: Line widths (UI points) of the error plots: the error bold, its bounds thin.
_WIDTHS = {"error_deg": 2.0, "plus_3sigma_deg": 1.0, "minus_3sigma_deg": 1.0}
#: Single series plotted across vehicles, named and coloured by vehicle.
_ACROSS = {("diagnostics", "ess"), ("rejections", "total")}
_SERIES_COLOURS = ((78, 121, 167), (242, 142, 44), (225, 87, 89), (118, 183, 178), (89, 161, 79), (237, 201, 73),
                   (175, 122, 161), (255, 157, 167))
_AXIS_RGB8 = [tuple(int(round(255 * c)) for c in rgb) for rgb in AXIS_RGB]


def flatten(message: dict, prefix: str = "") -> dict[str, Any]:
    """A view message with its objects flattened: ``{"q": {"w": 1}}`` → ``{"q.w": 1}`` (None left out)."""
    out: dict[str, Any] = {}
    for key, value in message.items():
        if isinstance(value, dict):
            out.update(flatten(value, f"{prefix}{key}."))
        elif value is not None:
            out[f"{prefix}{key}"] = value
    return out


def series(message: dict, field: str) -> tuple[list[float], list[str]] | None:
    """A plotted field of a message as ``(values, series names)``: a vector's components (``x y z``,
    ``roll pitch yaw``) or a number; None when the message has none (the ESS of a Kalman filter)."""
    value = message.get(field)
    if value is None:
        return None
    if isinstance(value, dict):
        prefix = _SERIES_PREFIX.get(field)
        return [float(x) for x in value.values()], [f"{prefix} {k}" if prefix else k for k in value]
    return [float(value)], [field]


def viewer_url(web_port: int, grpc_port: int, host: str = "127.0.0.1") -> str:
    """The web viewer's address with the gRPC server it reads (``?url=rerun+http://HOST:PORT/proxy``)."""
    shown = "127.0.0.1" if host in ("0.0.0.0", "::", "") else host
    grpc = f"rerun+http://{shown}:{grpc_port}/proxy"
    return f"http://{shown}:{web_port}/?url={quote(grpc, safe='')}"


# ----------------------------------------------------------------------------------------------------------------
# The blueprint


def blueprint(vehicles: Sequence[str] = DEMO_VEHICLES, truth: bool = True) -> Any:
    """The Rerun blueprint of the view, the Foxglove layout's twin (:func:`attitude_client.view.foxglove_sink.layout`):
    the 3D scene and the table of the vehicles on the left; on the right a plot per vehicle (``truth``: its error per
    body axis with ±3σ; otherwise its roll/pitch/yaw and, below, its 3σ per body axis), the ESS of every vehicle and
    the rejections."""
    import rerun.blueprint as rrb

    vehicles = list(vehicles)
    per_vehicle: list[Any] = []
    for v in vehicles:
        if truth:
            per_vehicle.append(
                rrb.TimeSeriesView(
                    name=f"{v}: attitude error per body axis (deg) and ±3σ", origin=f"/{v}/error",
                    contents=[f"$origin/{f}" for f in ("error_deg", "plus_3sigma_deg", "minus_3sigma_deg")],
                )
            )
        else:
            per_vehicle.append(
                rrb.Vertical(
                    rrb.TimeSeriesView(name=f"{v}: roll, pitch, yaw (deg)", origin=f"/{v}/attitude",
                                       contents="$origin/euler_deg"),
                    rrb.TimeSeriesView(name=f"{v}: 3σ per body axis (deg)", origin=f"/{v}/attitude",
                                       contents="$origin/three_sigma_deg"),
                    row_shares=[3, 2],
                )
            )
    across = rrb.Horizontal(
        rrb.TimeSeriesView(name="effective sample size (particle filters)", origin="/",
                           contents=[f"/{v}/diagnostics/ess" for v in vehicles]),
        rrb.TimeSeriesView(name="rejected inputs since the view started", origin="/",
                           contents=[f"/{v}/rejections/total" for v in vehicles]),
    )
    if per_vehicle:
        n_cols = max(1, (len(per_vehicle) + 3) // 4)  # about four down at most per column, as the layout
        grid = rrb.Grid(*per_vehicle, grid_columns=n_cols) if n_cols > 1 else rrb.Vertical(*per_vehicle)
        right = rrb.Vertical(grid, across, row_shares=[72, 28])
    else:
        right = across
    # The camera: the vehicles' grid from the front and above, its labels side by side.
    n = max(1, len(vehicles))
    rows = (n + GRID_COLUMNS - 1) // GRID_COLUMNS
    cx, cy = GRID_SPACING * (min(n, GRID_COLUMNS) - 1) / 2.0, -GRID_SPACING * (rows - 1) / 2.0
    d = 6.0 + 2.0 * min(n, GRID_COLUMNS)
    eye = rrb.EyeControls3D(kind="Orbital", position=[cx, cy - 0.9 * d, 0.35 * d], look_target=[cx, cy, 0.5],
                            eye_up=[0.0, 0.0, 1.0])
    left = rrb.Vertical(
        rrb.Spatial3DView(name="attitude", origin="/world", eye_controls=eye),
        rrb.TextDocumentView(name="vehicles", origin="/summary"),
        row_shares=[68, 32],
    )
    return rrb.Blueprint(
        rrb.Horizontal(left, right, column_shares=[42, 58]),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed", timeline="wall"),
    )


# ----------------------------------------------------------------------------------------------------------------
# The sink


class RerunSink:
    """The view's messages as Rerun entities of ``recording`` (a ``rerun.RecordingStream``; the module's docstring
    lists them). The blueprint covers ``vehicles`` when given, else every vehicle seen so far (sent again, and made
    active, when a new one appears: at most once per :meth:`summary`)."""

    def __init__(self, recording: Any, vehicles: Sequence[str] | None = None, truth: bool = True):
        import rerun as rr

        self.rr = rr
        self.rec = recording
        self.truth = truth
        self.fixed = list(vehicles) if vehicles else None
        self.seen: list[str] = []
        self._styled: set[str] = set()
        self._placed: set[str] = set()  # static geometry logged: "V" (body) and "V/truth"
        self._blueprint_of: list[str] | None = None
        self.rec.log("/world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self.send_blueprint()

    def blueprint_vehicles(self) -> list[str]:
        return list(self.fixed if self.fixed is not None else self.seen)

    def send_blueprint(self) -> None:
        vehicles = self.blueprint_vehicles()
        if vehicles != self._blueprint_of:
            self._blueprint_of = vehicles
            self.rec.send_blueprint(blueprint(vehicles, self.truth), make_active=True, make_default=True)

    # -- time ------------------------------------------------------------------------------------------
    def _at(self, log_ns: int, message: dict | None = None) -> None:
        self.rec.set_time("wall", timestamp=np.datetime64(int(log_ns), "ns"))
        if message is not None and "t" in message:
            self.rec.set_time("t", duration=float(message["t"]))
            self.rec.set_time("seq", sequence=int(message["seq"]))
        else:
            self.rec.disable_timeline("t")
            self.rec.disable_timeline("seq")

    # -- the sink's calls ------------------------------------------------------------------------------
    def add_vehicle(self, vehicle: str, log_ns: int) -> None:
        self.seen.append(vehicle)
        # No rejection yet: a zero from the start, so that the rejections plot has every vehicle's line.
        self._at(log_ns)
        self._style(vehicle, "rejections", "total", ["total"])
        self.rec.log(f"/{vehicle}/rejections/total", self.rr.Scalars([0.0]))

    def _style(self, vehicle: str, leaf: str, field: str, names: list[str]) -> None:
        entity = f"/{vehicle}/{leaf}/{field}"
        if entity in self._styled:
            return
        self._styled.add(entity)
        rr = self.rr
        if (leaf, field) in _ACROSS:
            colour = _SERIES_COLOURS[self.seen.index(vehicle) % len(_SERIES_COLOURS)]
            style = rr.SeriesLines(names=[vehicle], colors=[colour], widths=[1.5])
        else:
            style = rr.SeriesLines(names=names, colors=_AXIS_RGB8[: len(names)],
                                   widths=[_WIDTHS.get(field, 1.5)] * len(names))
        self.rec.log(entity, style, static=True)

    def publish(self, vehicle: str, leaf: str, message: dict, log_ns: int) -> None:
        rr = self.rr
        self._at(log_ns, message)
        # The whole message, one row (the selection panel and a dataframe view show its fields)...
        # (`vehicle` is in the path, `t` and `seq` are timelines.)
        fields = {k: v for k, v in flatten(message).items() if k not in ("vehicle", "t", "seq")}
        self.rec.log(f"/{vehicle}/{leaf}", rr.AnyValues(**fields))
        # ...and what is plotted as series of its own.
        for field in PLOTTED.get(leaf, ()):
            got = series(message, field)
            if got is not None:
                self._style(vehicle, leaf, field, got[1])
                self.rec.log(f"/{vehicle}/{leaf}/{field}", rr.Scalars(got[0]))
        if leaf == "rejections" and message.get("last"):
            last = message["last"]
            self.rec.log(f"/{vehicle}/rejections/last",
                         rr.TextLog(f"{last['code']}: {last['message']} ({last['key']})", level=rr.TextLogLevel.WARN))

    def scene(self, poses: list[Pose], log_ns: int, republish: bool) -> None:  # noqa: ARG002 (both alike)
        rr = self.rr
        self._at(log_ns)
        for p in poses:
            base = f"/world/{p.vehicle}"
            if p.vehicle not in self._placed:
                # The body in its own frame, once: the transforms below move it.
                self._placed.add(p.vehicle)
                self.rec.log(f"{base}/estimate/body", rr.Boxes3D(half_sizes=[[0.45, 0.3, 0.225]],
                                                                  colors=[(191, 191, 204, 150)], fill_mode="solid"),
                             static=True)
                self.rec.log(f"{base}/estimate/axes", _axes(rr, 1.3, 0.035), static=True)
            self.rec.log(f"{base}/estimate", _transform(rr, p.position, p.q))
            if p.truth is not None:
                if f"{p.vehicle}/truth" not in self._placed:
                    self._placed.add(f"{p.vehicle}/truth")
                    self.rec.log(f"{base}/truth/axes", _axes(rr, 1.6, 0.012), static=True)
                self.rec.log(f"{base}/truth", _transform(rr, p.position, p.truth))
            x, y, z = p.position
            # Every other column's label higher: Rerun draws labels at a fixed size, wider than the grid's spacing.
            lift = 1.7 + 1.0 * (round(x / GRID_SPACING) % 2)
            self.rec.log(f"{base}/label", rr.Points3D([[x, y, z + lift]], radii=[0.02], labels=[p.label],
                                                      show_labels=True))

    def summary(self, message: dict, log_ns: int) -> None:
        self._at(log_ns)
        self.rec.log("/summary", self.rr.TextDocument(summary_markdown(message), media_type="text/markdown"))
        # The rejection totals again (the summary's `rejected`, the same count): a plot draws a line through the
        # points of a series, and a vehicle without rejections would otherwise have one point, at its start.
        for row in message["vehicles"]:
            self.rec.log(f"/{row['vehicle']}/rejections/total", self.rr.Scalars([float(row["rejected"])]))
        self.send_blueprint()

    def close(self) -> None:
        self.rec.flush(timeout_sec=10.0)  # bounded: a server killed from outside must not hold the view up
        self.rec.disconnect()


def _transform(rr: Any, position: Iterable[float], q: np.ndarray) -> Any:
    w, x, y, z = (float(c) for c in q)
    return rr.Transform3D(translation=list(position), quaternion=rr.Quaternion(xyzw=[x, y, z, w]))


def _axes(rr: Any, length: float, radius: float) -> Any:
    return rr.Arrows3D(vectors=(length * np.eye(3)).tolist(), radii=[radius] * 3, colors=_AXIS_RGB8)


def _num(x: Any, fmt: str) -> str:
    return "–" if x is None else format(x, fmt)


def summary_markdown(message: dict) -> str:
    """The ``/summary`` message as a Markdown table (Rerun's text document view renders it)."""
    lines = [
        "| vehicle | filter | t (s) | seq | error (°) | 3σ (°) | inside 3σ | ESS | rejected | Hz |",
        "|---|---|---:|---:|---:|---:|---|---:|---:|---:|",
    ]
    for r in message["vehicles"]:
        inside = "–" if r["within_3sigma"] is None else ("yes" if r["within_3sigma"] else "**no**")
        lines.append(
            f"| {r['vehicle']} | {r['filter']} | {r['t']:.6g} | {r['seq']} | {_num(r['error_deg'], '.3g')} | "
            f"{r['three_sigma_deg']:.3g} | {inside} | {_num(r['ess'], '.0f')} | {r['rejected']} | {r['rate_hz']:.1f} |"
        )
    lines.append("")
    lines.append(f"{len(message['vehicles'])} vehicles; {message['dropped']} messages dropped by the view.")
    return "\n".join(lines) + "\n"


# ----------------------------------------------------------------------------------------------------------------
# The server: the wheel's `rerun` command, bound where asked


def rerun_cli() -> Path:
    """The ``rerun`` binary of the rerun-sdk wheel (the ``rerun_cli`` package)."""
    import rerun_cli

    here = Path(rerun_cli.__file__).parent
    for candidate in (here / "rerun", here / "rerun.exe", here / "Rerun.app" / "Contents" / "MacOS" / "Rerun"):
        if candidate.is_file():
            return candidate
    raise FileNotFoundError(f"no rerun binary in {here} (rerun-sdk's rerun_cli)")


def _taken(host: str, port: int) -> bool:
    """Whether a socket listens on ``host:port`` already (a bind with SO_REUSEADDR fails only then, on Linux)."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((host, port))
        except OSError:
            return True
    return False


def _listening(host: str, port: int) -> bool:
    try:
        with socket.create_connection((host, port), timeout=0.2):
            return True
    except OSError:
        return False


def _die_with_parent():
    """What the child runs before exec on Linux: SIGTERM when the process that started it dies (PR_SET_PDEATHSIG,
    1). The function is looked up here, in the parent: the forked child only calls it (no loading after a fork)."""
    import ctypes

    prctl = ctypes.CDLL(None, use_errno=True).prctl
    return lambda: prctl(1, signal.SIGTERM)


class RerunServer:
    """``rerun --serve-web`` as a child process: the gRPC server the view logs to and viewers read (it keeps up to
    ``memory_limit`` of the log for viewers that connect later), and the web viewer over HTTP, both on ``host``."""

    def __init__(self, host: str, grpc_port: int, web_port: int, memory_limit: str = "1GiB", timeout: float = 20.0):
        self.host, self.grpc_port, self.web_port = host, grpc_port, web_port
        local = "127.0.0.1" if host in ("0.0.0.0", "::", "") else host
        self.grpc_url = f"rerun+http://{local}:{grpc_port}/proxy"
        self.url = viewer_url(web_port, grpc_port, host)
        cmd = [str(rerun_cli()), "--serve-web", "--bind", host, "--port", str(grpc_port),
               "--web-viewer-port", str(web_port), "--server-memory-limit", memory_limit]
        # Readiness is "both ports listen": so neither may be taken before (or the view would log to another server).
        for port in (grpc_port, web_port):
            if _taken(host, port):
                raise RuntimeError(f"port {port} on {host} is taken")
        env = dict(os.environ)
        env.setdefault("RUST_LOG", "warn")  # its own banner would repeat the view's
        # Its own session: a Ctrl-C in the terminal reaches the view only, which sends its last messages to the
        # server and then stops it (stop()); in the view's process group the server would die first. A view killed
        # outright takes it along on Linux (the parent-death signal), rather than leaving a server on its ports.
        self.proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, env=env, start_new_session=True,
                                     preexec_fn=_die_with_parent() if sys.platform == "linux" else None)
        deadline = time.monotonic() + timeout
        while not (_listening(local, grpc_port) and _listening(local, web_port)):
            if self.proc.poll() is not None:
                raise RuntimeError(f"`{' '.join(cmd)}` exited with {self.proc.returncode} (is a port taken?)")
            if time.monotonic() > deadline:
                self.stop()
                raise RuntimeError(f"`{' '.join(cmd)}` did not listen on ports {grpc_port} and {web_port} "
                                   f"within {timeout:g} s")
            time.sleep(0.05)

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


def open_recording(server: RerunServer, vehicles: Sequence[str] | None, truth: bool) -> tuple[Any, RerunSink]:
    """A recording stream connected to ``server``, and the sink logging to it."""
    import rerun as rr

    rec = rr.RecordingStream(APPLICATION_ID)
    # `wall` is the view's own clock; Rerun's automatic log_time and log_tick would only repeat it.
    rec.set_log_time_enabled(False)
    rec.set_log_tick_enabled(False)
    rec.connect_grpc(server.grpc_url)
    return rec, RerunSink(rec, vehicles=vehicles, truth=truth)


def write_blueprint(path: Path, vehicles: Sequence[str], truth: bool) -> None:
    """The blueprint as an ``.rbl`` file, for a saved recording opened in a Rerun viewer."""
    blueprint(vehicles, truth).save(APPLICATION_ID, str(path))


if __name__ == "__main__":  # pragma: no cover
    sys.exit("run `attitude-view --rerun` instead")
