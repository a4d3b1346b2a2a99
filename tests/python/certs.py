"""Test certificates made with `openssl` at test time: a CA, a server certificate for localhost and
127.0.0.1, and client certificates whose common names are the access-control subjects (``sensor-sc1``,
``operator``...).

``make_pki(dir, clients)`` writes ``ca.pem``/``ca.key``, ``server.pem``/``server.key`` and ``<cn>.pem``/``<cn>.key``
for every client common name, and returns ``dir``. ``make_ca(dir, name)`` alone makes another (untrusted) CA.
Keys are ECDSA P-256 (fast to generate), certificates valid for two days.
"""

from __future__ import annotations

import pathlib
import shutil
import subprocess

OPENSSL = shutil.which("openssl") or "/usr/bin/openssl"


def _run(*args: str, cwd: pathlib.Path) -> None:
    r = subprocess.run([OPENSSL, *args], cwd=cwd, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"openssl {' '.join(args)} failed:\n{r.stderr}")


def _key(path: pathlib.Path) -> None:
    # PKCS#8 PEM, which zenoh's TLS link (rustls) reads.
    _run("genpkey", "-algorithm", "EC", "-pkeyopt", "ec_paramgen_curve:P-256", "-out", str(path), cwd=path.parent)


def make_ca(d: pathlib.Path, name: str = "ca", cn: str = "attitude-test-ca") -> tuple[pathlib.Path, pathlib.Path]:
    """A self-signed CA: ``<name>.pem``, ``<name>.key``."""
    d.mkdir(parents=True, exist_ok=True)
    key, cert = d / f"{name}.key", d / f"{name}.pem"
    _key(key)
    _run(
        "req", "-x509", "-new", "-key", str(key), "-out", str(cert), "-days", "2", "-subj", f"/CN={cn}",
        "-addext", "basicConstraints=critical,CA:TRUE",
        "-addext", "keyUsage=critical,keyCertSign,cRLSign",
        cwd=d,
    )
    return cert, key


def make_cert(d: pathlib.Path, name: str, cn: str, ca: tuple[pathlib.Path, pathlib.Path], server: bool) -> None:
    """``<name>.pem``/``<name>.key`` signed by ``ca``; a server certificate names localhost and 127.0.0.1."""
    key, csr, cert, ext = d / f"{name}.key", d / f"{name}.csr", d / f"{name}.pem", d / f"{name}.ext"
    _key(key)
    _run("req", "-new", "-key", str(key), "-out", str(csr), "-subj", f"/CN={cn}", cwd=d)
    lines = ["basicConstraints=critical,CA:FALSE", "keyUsage=critical,digitalSignature"]
    if server:
        lines += ["extendedKeyUsage=serverAuth,clientAuth", "subjectAltName=DNS:localhost,IP:127.0.0.1"]
    else:
        lines += ["extendedKeyUsage=clientAuth"]
    ext.write_text("\n".join(lines) + "\n")
    _run(
        "x509", "-req", "-in", str(csr), "-CA", str(ca[0]), "-CAkey", str(ca[1]), "-CAcreateserial",
        "-out", str(cert), "-days", "2", "-sha256", "-extfile", str(ext),
        cwd=d,
    )


def make_pki(d: pathlib.Path, clients: list[str]) -> pathlib.Path:
    ca = make_ca(d)
    make_cert(d, "server", "localhost", ca, server=True)
    for cn in clients:
        make_cert(d, cn, cn, ca, server=False)
    return d
