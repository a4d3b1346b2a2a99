"""What scripts/fleet-cpu.py and scripts/fleet-scale.py both need: a free port, a process's CPU time,
and the zenohd router of scripts/ensure-zenohd.sh."""

from __future__ import annotations

import os
import pathlib
import socket
import subprocess

ROOT = pathlib.Path(__file__).resolve().parent.parent
TICK = os.sysconf("SC_CLK_TCK")


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def cpu_s(pid: int) -> float:
    """utime + stime of a process, s."""
    stat = pathlib.Path(f"/proc/{pid}/stat").read_text()
    fields = stat[stat.rindex(")") + 2 :].split()
    return (int(fields[11]) + int(fields[12])) / TICK


def zenohd() -> str:
    """The zenohd router of scripts/ensure-zenohd.sh (installed once into a cache)."""
    out = subprocess.run(["bash", str(ROOT / "scripts" / "ensure-zenohd.sh")], check=True, capture_output=True, text=True)
    return out.stdout.strip().splitlines()[-1]
