"""What scripts/fleet-cpu.py and scripts/fleet-scale.py both need: a free port, a process's CPU time,
and the zenohd router of scripts/ensure-zenohd.sh."""

from __future__ import annotations

import os
import pathlib
import re
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


def thread_cpu_s(pid: int) -> dict[str, float]:
    """utime + stime of each of a process's threads, summed by thread name (threads of one pool share a
    name stem: a trailing number is dropped), s. A thread that ended before the read is not counted."""
    out: dict[str, float] = {}
    for task in pathlib.Path(f"/proc/{pid}/task").iterdir():
        try:
            stat = (task / "stat").read_text()
        except OSError:
            continue
        name = re.sub(r"[-_ ]?[0-9]+$", "", stat[stat.index("(") + 1 : stat.rindex(")")]) or "?"
        fields = stat[stat.rindex(")") + 2 :].split()
        out[name] = out.get(name, 0.0) + (int(fields[11]) + int(fields[12])) / TICK
    return out


def zenohd() -> str:
    """The zenohd router of scripts/ensure-zenohd.sh (installed once into a cache)."""
    out = subprocess.run(["bash", str(ROOT / "scripts" / "ensure-zenohd.sh")], check=True, capture_output=True, text=True)
    return out.stdout.strip().splitlines()[-1]
