#!/usr/bin/env python3
"""docs/figures/view-rerun.png: Rerun's web viewer showing `attitude-view --rerun --demo`, taken by headless Chromium.

    apt-get install -y chromium                          # Debian's; any Chromium or Chrome will do (--chromium)
    .venv/bin/pip install playwright==1.65.2             # drives it (its own browser download is not needed)
    .venv/bin/python scripts/view-screenshot.py [--out docs/figures/view-rerun.png] [--bin target/release/attitude-service]

(`.venv` is scripts/python-tests.sh's: attitude-client editable, rerun-sdk pinned.) The script starts
`attitude-view --rerun --demo` on free ports (the demo's four spacecraft, their service, Rerun's server), opens the
web viewer's address in headless Chromium (WebGL by SwiftShader: no GPU needed), waits `--after` seconds from the
start (the viewer, drawing on the CPU, lags the demo), takes the screenshot and stops everything. A docs artefact, not a test:
tests/python/test_view_rerun.py checks what the view serves.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

#: Headless, software-rendered, no network but the loopback: no first-run tasks, updates, sync or QUIC.
CHROMIUM_ARGS = [
    "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
    "--disable-component-update", "--disable-sync", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "figures" / "view-rerun.png")
    ap.add_argument("--bin", type=Path, default=ROOT / "target" / "release" / "attitude-service")
    ap.add_argument("--chromium", default=shutil.which("chromium") or shutil.which("chromium-browser")
                    or shutil.which("google-chrome"), help="the browser (default: chromium on PATH)")
    ap.add_argument("--width", type=int, default=1440)
    ap.add_argument("--height", type=int, default=900)
    ap.add_argument("--after", type=float, default=120.0,
                    help="seconds from the start to the screenshot (default 120: the demo runs 30 s at its speed, and a "
                         "viewer drawing in software needs the rest to catch up with it)")
    ap.add_argument("--speed", default="480", help="the demo's --speed (default 480, the demo's own)")
    # A browser that draws in software (SwiftShader) ingests a few hundred rows a second while it draws: at the
    # view's default 30 a second per vehicle it falls minutes behind the demo. 5 keeps it live; a GPU needs no such cut.
    ap.add_argument("--max-rate", type=float, default=5.0, help="the view's --max-rate (default 5)")
    args = ap.parse_args()

    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        sys.exit("view-screenshot: needs Playwright's Python package: .venv/bin/pip install playwright==1.65.2")
    if not args.chromium:
        sys.exit("view-screenshot: no chromium on PATH (apt-get install -y chromium), or pass --chromium")
    if not args.bin.is_file():
        sys.exit(f"view-screenshot: {args.bin} is missing (cargo build --release)")
    view = Path(sys.executable).parent / "attitude-view"
    if not view.is_file():
        sys.exit(f"view-screenshot: {view} is missing: run with the venv that has attitude-client (.venv/bin/python)")

    web, grpc, zenoh = free_port(), free_port(), free_port()
    cmd = [str(view), "--rerun", "--demo", "--bin", str(args.bin), "--connect", f"tcp/127.0.0.1:{zenoh}",
           "--web-port", str(web), "--grpc-port", str(grpc), "--max-rate", str(args.max_rate), "--", "--speed",
           args.speed]
    print("view-screenshot: " + " ".join(cmd), file=sys.stderr)
    log = tempfile.NamedTemporaryFile("w+", prefix="view-screenshot-", suffix=".log", delete=False)
    proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT)
    started = time.monotonic()
    try:
        url = None
        while url is None:
            if proc.poll() is not None or time.monotonic() - started > 60:
                log.seek(0)
                sys.exit(f"view-screenshot: the view did not start:\n{log.read()}")
            log.seek(0)
            m = re.search(r"web viewer on (http://\S+) ", log.read())
            url = m.group(1) if m else None
            time.sleep(0.2)
        print(f"view-screenshot: {url}", file=sys.stderr)
        with tempfile.TemporaryDirectory(prefix="view-screenshot-chromium-") as profile, sync_playwright() as p:
            browser = p.chromium.launch_persistent_context(
                profile, executable_path=args.chromium, headless=True, args=CHROMIUM_ARGS,
                viewport={"width": args.width, "height": args.height},
            )
            page = browser.pages[0] if browser.pages else browser.new_page()
            page.goto(url)
            # Its canvas turns visible once the WebAssembly has started (slow in software: generous timeouts).
            page.wait_for_selector("canvas.visible", timeout=180_000)
            # The WebAssembly viewer compiles, connects and draws in software: give it the demo's time.
            remaining = args.after - (time.monotonic() - started)
            time.sleep(max(remaining, 10.0))
            args.out.parent.mkdir(parents=True, exist_ok=True)
            page.screenshot(path=str(args.out), timeout=180_000)
            browser.close()
        try:  # a palette of 256 colours: a third of the size, no visible loss for a UI (Pillow comes with rerun-sdk)
            from PIL import Image

            Image.open(args.out).convert("RGB").quantize(256).save(args.out, optimize=True)
        except ImportError:
            pass
        print(f"view-screenshot: wrote {args.out} ({os.path.getsize(args.out)} bytes)", file=sys.stderr)
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        log.close()
        os.unlink(log.name)
    return 0


if __name__ == "__main__":
    sys.exit(main())
