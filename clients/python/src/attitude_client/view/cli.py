"""``attitude-view``, the command: its arguments, the zenoh session (one :class:`~attitude_client.MessageStream` of
``P/<vehicles>/estimate``, ``truth`` and ``rejected``, subscribed before the service is reached), ``--demo`` (starts
``attitude-service demo`` as a child process), the sink's server (Foxglove's WebSocket server, or Rerun's through
:mod:`attitude_client.view.rerun_sink`), then :meth:`View.run <attitude_client.view.model.View.run>` until Ctrl-C;
``--write-layout`` and ``--write-blueprint`` write a file and exit. foxglove-sdk and rerun-sdk are imported in
:func:`main` only, for the sink asked for (the Rerun sink's module with them)."""

from __future__ import annotations

import argparse
import os
import shlex
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any, Sequence

from ..client import AttitudeClient
from .foxglove_sink import FoxgloveSink, layout_json
from .model import DEMO_VEHICLES, View

__all__ = ["main"]


# ----------------------------------------------------------------------------------------------------------------
# The command


def _service_binary(given: str | None) -> str:
    for candidate in (given, os.environ.get("ATTITUDE_SERVICE_BIN")):
        if candidate:
            if not (Path(candidate).is_file() and os.access(candidate, os.X_OK)):
                raise SystemExit(f"attitude-view: {candidate} is not an executable attitude-service")
            return candidate
    found = shutil.which("attitude-service")
    if found is None:
        raise SystemExit(
            "attitude-view: --demo runs `attitude-service demo`, and no attitude-service is on PATH: pass --bin "
            "(e.g. --bin target/release/attitude-service) or set ATTITUDE_SERVICE_BIN"
        )
    return found


def _say(text: str) -> None:
    print(f"attitude-view: {text}", file=sys.stderr, flush=True)


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    demo_args: list[str] = []
    if "--" in argv:
        cut = argv.index("--")
        argv, demo_args = argv[:cut], argv[cut + 1 :]
    ap = argparse.ArgumentParser(
        prog="attitude-view",
        description="A live view of a running attitude service: in Foxglove (a Foxglove WebSocket server, the default) "
                    "or in Rerun's web viewer (--rerun).",
        epilog="Options after `--` go to `attitude-service demo` (with --demo). docs/view.md has the details.",
    )
    ap.add_argument("--connect", default="tcp/127.0.0.1:7447",
                    help="zenoh endpoint of the service (default tcp/127.0.0.1:7447; with --demo, where the demo listens)")
    ap.add_argument("--prefix", default="attitude", help="the service's key prefix (default attitude)")
    ap.add_argument("--vehicles", default="*",
                    help="the vehicles to follow, one key chunk with zenoh wildcards, e.g. 'sc*' (default: all)")
    ap.add_argument("--sink", choices=("foxglove", "rerun"), default="foxglove",
                    help="foxglove: a Foxglove WebSocket server (default); rerun: Rerun's gRPC server and web viewer")
    ap.add_argument("--rerun", dest="sink", action="store_const", const="rerun", help="the same as --sink rerun")
    ap.add_argument("--host", default="127.0.0.1",
                    help="address the view's servers listen on (default 127.0.0.1; 0.0.0.0 for other machines)")
    ap.add_argument("--port", type=int, default=8765, help="the Foxglove WebSocket server's port (default 8765, Foxglove's)")
    ap.add_argument("--web-port", type=int, default=9090, help="--rerun: the web viewer's HTTP port (default 9090, Rerun's)")
    ap.add_argument("--grpc-port", type=int, default=9876, help="--rerun: the gRPC server's port (default 9876, Rerun's)")
    ap.add_argument("--memory-limit", default="1GiB",
                    help="--rerun: the log the gRPC server keeps for viewers that connect later, beyond which it drops "
                         "the oldest (default 1GiB; e.g. 4GB, 25%%)")
    ap.add_argument("--max-rate", type=float, default=30.0,
                    help="publications per vehicle per second at most (default 30; 0: every estimate). The latest "
                         "estimate is always published")
    ap.add_argument("--republish", type=float, default=1.0,
                    help="seconds between repetitions of the 3D scene and the summary (default 1)")
    ap.add_argument("--buffer", type=int, default=65536,
                    help="messages buffered between zenoh and the view; beyond, the oldest are dropped (default 65536)")
    ap.add_argument("--wait", type=float, default=10.0,
                    help="seconds to wait for the service at start (default 10; the view then runs anyway)")
    ap.add_argument("--demo", action="store_true",
                    help="start `attitude-service demo --listen <--connect>` and view it; the view keeps serving "
                         "after the demo ends, until Ctrl-C")
    ap.add_argument("--bin", help="the attitude-service binary for --demo (default: $ATTITUDE_SERVICE_BIN, then PATH)")
    ap.add_argument("--write-layout", metavar="FILE", type=Path,
                    help="write the Foxglove layout for --layout-vehicles to FILE ('-': standard output) and exit")
    ap.add_argument("--write-blueprint", metavar="FILE", type=Path,
                    help="write the Rerun blueprint for --layout-vehicles to FILE (.rbl) and exit")
    ap.add_argument("--layout-vehicles",
                    help="comma-separated vehicle ids of the layout (default sc1,sc2,sc3,sc4: the demo's; with "
                         "--rerun, the vehicles as they appear)")
    ap.add_argument("--no-truth", action="store_true",
                    help="a layout for vehicles without a truth: roll/pitch/yaw and 3σ instead of the error")
    args = ap.parse_args(argv)

    layout_vehicles = None
    if args.layout_vehicles is not None:
        layout_vehicles = [n.strip() for n in args.layout_vehicles.split(",") if n.strip()]
    if args.write_layout is not None:
        names = layout_vehicles or list(DEMO_VEHICLES)
        text = layout_json(names, truth=not args.no_truth)
        if str(args.write_layout) == "-":
            sys.stdout.write(text)
        else:
            args.write_layout.write_text(text, encoding="utf-8")
            _say(f"wrote {args.write_layout} ({len(names)} vehicles)")
        return 0
    if demo_args and not args.demo:
        ap.error("options after `--` are for --demo")
    if args.max_rate < 0 or args.republish <= 0 or args.buffer < 1:
        ap.error("--max-rate must be ≥ 0, --republish > 0 and --buffer ≥ 1")
    if args.sink == "rerun" or args.write_blueprint is not None:
        try:
            import rerun  # noqa: F401  (rerun-sdk refuses Python before 3.11 with a RuntimeError)

            from . import rerun_sink
        except (ImportError, RuntimeError):
            _say("the Rerun view needs rerun-sdk: pip install 'attitude-client[view-rerun]' (Python 3.11 or later)")
            return 2
        if args.write_blueprint is not None:
            names = layout_vehicles or list(DEMO_VEHICLES)
            rerun_sink.write_blueprint(args.write_blueprint, names, truth=not args.no_truth)
            _say(f"wrote {args.write_blueprint} ({len(names)} vehicles)")
            return 0
    else:
        try:
            import foxglove
        except ImportError:
            _say("the view needs foxglove-sdk: pip install 'attitude-client[view]' (Python 3.10 or later)")
            return 2

    # The first Ctrl-C (or SIGTERM) stops following and shows what was already received; a second skips that.
    stop, hurry = threading.Event(), threading.Event()

    def on_signal(signum, frame):  # noqa: ARG001
        (hurry if stop.is_set() else stop).set()

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)

    demo: subprocess.Popen | None = None
    if args.demo:
        binary = _service_binary(args.bin)
        cmd = [binary, "demo", "--listen", args.connect, "--prefix", args.prefix, *demo_args]
        _say("starting " + " ".join(shlex.quote(c) for c in cmd))
        demo = subprocess.Popen(cmd)

    try:
        client = AttitudeClient(args.connect, prefix=args.prefix)
    except Exception as e:  # a malformed endpoint or prefix
        _say(f"cannot open a zenoh session to {args.connect}: {e}")
        if demo is not None:
            demo.send_signal(signal.SIGINT)
            demo.wait()
        return 2
    server = None
    stream = None
    sink: Any = None
    try:
        # Subscribe first, then reach the service: once it answers, it knows the subscriptions.
        stream = client.messages(("estimate", "truth", "rejected"), vehicles=args.vehicles, maxsize=args.buffer)
        deadline = time.monotonic() + args.wait
        while not stop.is_set():
            if demo is not None and demo.poll() is not None:
                _say(f"the demo exited with {demo.returncode} before its service answered")
                return 1
            try:
                client.health(timeout=0.5)
                break
            except TimeoutError:
                if time.monotonic() > deadline:
                    _say(f"no service answered on {args.connect} (prefix {args.prefix}) within {args.wait:g} s; "
                         "waiting for estimates anyway")
                    break
        following = f"following {args.prefix}/{args.vehicles} on {args.connect}"
        if args.sink == "rerun":
            try:
                server = rerun_sink.RerunServer(args.host, args.grpc_port, args.web_port, args.memory_limit)
            except (OSError, RuntimeError) as e:
                _say(f"cannot start Rerun's server on {args.host} (ports {args.grpc_port}, {args.web_port}): {e}")
                return 1
            _, sink = rerun_sink.open_recording(server, layout_vehicles, truth=not args.no_truth)
            _say(f"Rerun's web viewer on {server.url} (gRPC {server.grpc_url}); {following}. Open the first address "
                 f"in a browser (or a Rerun viewer: rerun {server.grpc_url}).")
        else:
            context = foxglove.Context()
            try:
                server = foxglove.start_server(name="attitude-view", host=args.host, port=args.port, context=context)
            except Exception as e:  # the port is taken, the address is wrong
                _say(f"cannot start the Foxglove WebSocket server on {args.host}:{args.port}: {e}")
                return 1
            sink = FoxgloveSink(context)
            _say(f"Foxglove WebSocket server on ws://{args.host}:{server.port}; {following}. In Foxglove: Open "
                 f"connection → Foxglove WebSocket → ws://localhost:{server.port}, then import the layout "
                 "(attitude-view --write-layout FILE).")
        view = View(sink, prefix=args.prefix, max_rate=args.max_rate, republish_s=args.republish)

        def watch_demo() -> None:
            while not stop.is_set() and demo is not None:
                if demo.poll() is not None:
                    _say(f"the demo ended (exit code {demo.returncode}); still serving what it showed until Ctrl-C")
                    return
                stop.wait(0.2)

        if demo is not None:
            threading.Thread(target=watch_demo, name="demo-watch", daemon=True).start()
        view.run(stream, stop, hurry, _say)
        if view.malformed:
            _say(f"{view.malformed} messages were not understood")
    finally:
        if stream is not None:
            stream.close()
        if sink is not None and hasattr(sink, "close"):
            sink.close()  # Rerun: the last messages reach the server before it stops
        if server is not None:
            server.stop()
        client.close()
        if demo is not None and demo.poll() is None:
            demo.send_signal(signal.SIGINT)
            try:
                demo.wait(timeout=10)
            except subprocess.TimeoutExpired:
                demo.kill()
                demo.wait()
    return 0
