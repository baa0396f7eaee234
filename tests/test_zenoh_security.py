"""Zenoh with its own TLS and user/password authentication (a deployment's `tls`, `auth`).

The miner on two "hosts" on 127.0.0.1, each from one deployment file: pc1 (every actuator)
listens on tls/, pc2 (the path planner) connects; both show a certificate the test's own
authority signed (mutual TLS) and the connecting one logs in with a user and password
(Zenoh checks the password of the peer that connects, against the listener's users file).
Certificates are made here with the `openssl` command (.ci/run installs it where missing);
nothing is left behind: no process, no listening port, nothing in /dev/shm.

What a refused peer means for the machine: pc2 killed, pc1 latches every actuator safe and
its root reports ERROR(LOST); a pc2 that comes back with a wrong password, or with a
certificate of another authority, is refused by pc1's Zenoh, so pc1 keeps it lost and its
actuators latched; the real pc2, with the right credentials, joins again (the control that
shows the refused ones had the time to join).
"""

from __future__ import annotations

import importlib
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest
from conftest import read_whole, wait_for
from support.running import listening

from rcsgen.runtime.operate.deploy import DeployError, load
from rcsgen.tools.harness import import_package

zenoh = pytest.importorskip("zenoh")
if shutil.which("openssl") is None:  # pragma: no cover - .ci/run installs it
    pytest.skip("the openssl command makes the test's certificates", allow_module_level=True)

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "generated" / "miner"
HOOKS = ROOT / "specs" / "miner"
PASSWORDS = {"vehicle": "vehicle-secret", "planner": "planner-secret"}


def openssl(*args: str, cwd: Path) -> None:
    subprocess.run(["openssl", *args], cwd=cwd, check=True, capture_output=True, timeout=60)


def authority(where: Path, name: str) -> None:
    """A self-signed authority `name`.pem with its key."""
    openssl(
        "req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1",
        "-nodes", "-keyout", f"{name}.key", "-out", f"{name}.pem", "-days", "2",
        "-subj", f"/CN=rcsgen test {name}", cwd=where,
    )  # fmt: skip


def certificate(where: Path, name: str, signer: str) -> None:
    """`name`.pem, signed by `signer`, for 127.0.0.1, with its key `name`.key (mode 0600)."""
    (where / "san.cnf").write_text("subjectAltName=IP:127.0.0.1,DNS:localhost\n")
    openssl(
        "req", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes",
        "-keyout", f"{name}.key", "-out", f"{name}.csr", "-subj", f"/CN={name}", cwd=where,
    )  # fmt: skip
    openssl(
        "x509", "-req", "-in", f"{name}.csr", "-CA", f"{signer}.pem", "-CAkey",
        f"{signer}.key", "-CAcreateserial", "-out", f"{name}.pem", "-days", "2",
        "-extfile", "san.cnf", cwd=where,
    )  # fmt: skip
    os.chmod(where / f"{name}.key", 0o600)


def secret(path: Path, text: str) -> None:
    path.write_text(text)
    os.chmod(path, 0o600)


@pytest.fixture(scope="module")
def pki(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The system's authority and a certificate per host; a rogue authority and a planner
    certificate it signed; the users each host accepts; each host's password file."""
    where = tmp_path_factory.mktemp("pki")
    authority(where, "ca")
    authority(where, "rogue")
    for host in ("vehicle", "planner"):
        certificate(where, host, "ca")
        secret(where / f"{host}.pw", PASSWORDS[host] + "\n")
    certificate(where, "impostor", "rogue")
    secret(where / "wrong.pw", "not-the-password\n")
    secret(where / "users.txt", "".join(f"{u}:{p}\n" for u, p in PASSWORDS.items()))
    return where


def free_port() -> int:
    import socket

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def deployment(
    pki: Path, port: int, planner: str = "planner", password: str = "planner.pw"
) -> dict[str, Any]:
    """Both hosts on TLS with authentication; the planner's certificate and password file
    may be swapped for an impostor's."""

    def host(name: str, cert: str, pw: str) -> dict[str, Any]:
        return {
            "tls": {"root_ca": "ca.pem", "certificate": f"{cert}.pem", "key": f"{cert}.key"},
            "auth": {"user": name, "password_file": pw, "users_file": "users.txt"},
        }

    return {
        "system": "miner",
        "hosts": {
            "vehicle": {
                "processes": ["pc1"],
                "listen": [f"tls/127.0.0.1:{port}"],
                **host("vehicle", "vehicle", "vehicle.pw"),
            },
            "planner": {
                "processes": ["pc2"],
                "connect": [f"tls/127.0.0.1:{port}"],
                **host("planner", planner, password),
            },
        },
    }


def test_a_deployment_with_tls_and_auth_is_checked_and_carried_to_the_node(pki: Path) -> None:
    """The host's files, made absolute, reach Zenoh's configuration: TLS only, mutual, the
    one authority, the password read from its file (never in the deployment)."""
    from rcsgen.runtime.zenoh_transport import Options, config_json

    path = pki / "good.json"
    path.write_text(json.dumps(deployment(pki, 7447)))
    host = load(str(path), "miner", ["pc1", "pc2"]).hosts["planner"]
    assert host.security.root_ca == str(pki / "ca.pem")
    config = config_json(Options(connect=host.connect, security=host.security))
    assert config["transport/link/protocols"] == ["tls"]
    assert config["transport/link/tls/enable_mtls"] is True
    assert config["transport/link/tls/listen_private_key"] == str(pki / "planner.key")
    assert config["transport/link/tls/connect_certificate"] == str(pki / "planner.pem")
    assert config["transport/auth/usrpwd/user"] == "planner"
    assert config["transport/auth/usrpwd/password"] == PASSWORDS["planner"]
    assert config["transport/auth/usrpwd/dictionary_file"] == str(pki / "users.txt")
    plain = config_json(Options(("tcp/127.0.0.1:7447",)))
    assert not [k for k in plain if "tls" in k or "auth" in k], "no deployment: plaintext"


@pytest.mark.parametrize(
    ("edit", "code", "message"),
    [
        (lambda d: d["hosts"]["planner"]["tls"].update(key="nowhere.key"), "E440",
         "cannot read nowhere.key: No such file or directory"),
        (lambda d: d["hosts"]["planner"]["auth"].update(password_file="loose.pw"), "E441",
         "loose.pw holds a secret but others may read it (mode 0644): chmod 600 loose.pw"),
        (lambda d: d["hosts"]["planner"].update(connect=["tcp/127.0.0.1:7447"]), "E442",
         "host `planner` declares `tls`, so its endpoints are tls/HOST:PORT, not "
         "tcp/127.0.0.1:7447"),
        (lambda d: d["hosts"]["vehicle"].pop("tls"), "E442",
         "tls/127.0.0.1:7447 is a TLS endpoint, but host `vehicle` declares no `tls`"),
        (lambda d: d["hosts"]["vehicle"].pop("auth"), "E443",
         "host `vehicle` declares no `auth`, while `planner` does: a host without "
         "authentication cannot join the others"),
        (lambda d: d["hosts"]["vehicle"]["auth"].pop("users_file"), "E431",
         "`auth` of host `vehicle` has no `users_file`"),
    ],
    ids=["unreadable", "loose", "plaintext", "tls-endpoint", "auth-some", "missing"],
)  # fmt: skip
def test_a_bad_security_entry_is_one_located_line(
    pki: Path, edit: Any, code: str, message: str
) -> None:
    (pki / "loose.pw").write_text("x\n")
    os.chmod(pki / "loose.pw", 0o644)
    text = deployment(pki, 7447)
    edit(text)
    path = pki / f"bad_{code}.json"
    path.write_text(json.dumps(text, indent=1))
    with pytest.raises(DeployError) as raised:
        load(str(path), "miner", ["pc1", "pc2"])
    found = str(raised.value)
    assert found.startswith(f"{path}:") and f": error[{code}]: {message}" in found, found
    assert len(found.splitlines()) == 1


@pytest.fixture
def hosts(pki: Path) -> Iterator[dict[str, Any]]:
    """Start and stop `--deploy` hosts; at the end nothing runs, listens or stays in /dev/shm."""
    started: list[subprocess.Popen[str]] = []
    segments: list[str] = []
    port = free_port()

    def start(name: str, file: str, process: str) -> subprocess.Popen[str]:
        segment = f"rcsgen_tls_{os.getpid()}_{process}_{len(segments)}"
        segments.append(segment)
        child = subprocess.Popen(
            [sys.executable, "-m", "miner", "--deploy", str(pki / file), name, "--shm", segment],
            cwd=PACKAGE.parent,
            env={**os.environ, "PYTHONPATH": str(HOOKS)},
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        started.append(child)
        return child

    try:
        yield {"start": start, "started": started, "segments": segments, "port": port}
    finally:
        for child in started:
            if child.poll() is None:
                child.terminate()
        for child in started:
            try:
                child.communicate(timeout=15)
            except subprocess.TimeoutExpired:
                child.kill()
                child.communicate()
        package = import_package(PACKAGE, HOOKS)
        unlink = importlib.import_module(f"{package.__name__}.rcs.block").unlink
        for segment in segments:  # a killed host could not remove its own
            unlink(segment)
    assert listening({port}) == set()
    assert not [n for n in os.listdir("/dev/shm") if n.startswith(f"rcsgen_tls_{os.getpid()}_")]


def test_a_refused_peer_is_never_heard_and_the_outputs_stay_safe(
    pki: Path, hosts: dict[str, Any]
) -> None:
    """pc2 killed: pc1 latches every actuator and its root reports ERROR(LOST); a pc2 with
    a wrong password, then one whose certificate another authority signed, runs for longer
    than the real one took to join and is never heard (pc2 stays lost, its heartbeat
    unchanged, every actuator latched); the real pc2 then joins again, which un-safes
    nothing."""
    package = import_package(PACKAGE, HOOKS)

    def rcs(name: str) -> ModuleType:
        return importlib.import_module(f"{package.__name__}.{name}")

    layout, contract, override = rcs("layout"), rcs("rcs.contract"), rcs("rcs.override")
    Block, BlockError = rcs("rcs.block").Block, rcs("rcs.block").BlockError
    port = hosts["port"]
    for name, planner, password in (
        ("good", "planner", "planner.pw"),
        ("wrong_password", "planner", "wrong.pw"),
        ("untrusted", "impostor", "planner.pw"),
    ):
        text = deployment(pki, port, planner, password)
        (pki / f"{name}.json").write_text(json.dumps(text))
    vehicle = hosts["start"]("vehicle", "good.json", "pc1")
    hosts["start"]("planner", "good.json", "pc2")

    def attach() -> Any:
        try:
            return Block(layout, hosts["segments"][0], create=False)
        except BlockError:
            return None

    pc1 = wait_for(attach, "pc1's segment")
    buf = pc1.buf
    try:
        lost_bit = 1 << list(layout.PROCESSES).index("pc2")

        def pc2_lost() -> bool:
            return bool(read_whole(layout.PROCESSES["pc1"], buf)["lost"] & lost_bit)

        def pc2_beats() -> int:
            return int(read_whole(layout.PROCESSES["pc2"], buf)["heartbeat"])

        def safe() -> bool:
            latched = override.overrides(layout, buf)
            return all(latched.get(f, ("",))[0] == "SAFE" for f in layout.SAFE_VALUES)

        def pp_done() -> bool:
            status = layout.STATUS_OUT["pp"].read(buf)
            return bool(status["status"] == contract.DONE and status["status_num"] >= 1)

        # over TLS, logged in: pp's INIT DONE (on pc2) reached pc1's block
        wait_for(pp_done, "pp's INIT done, mirrored into pc1 over TLS", 60)
        assert not pc2_lost() and not safe()
        began = time.monotonic()
        wait_for(lambda: pc2_beats() > 0, "pc2's heartbeat on pc1")
        joined_in = time.monotonic() - began
        first = next(c for c in hosts["started"] if "planner" in c.args)
        first.send_signal(signal.SIGKILL)
        first.wait(10)
        wait_for(pc2_lost, "pc1 reports the killed pc2 lost")
        wait_for(safe, "every actuator latched safe in pc1's block")
        wait_for(
            lambda: layout.STATUS_OUT["sec"].read(buf)["status"] == contract.ERROR,
            "the root reports ERROR",
        )
        for name in ("wrong_password", "untrusted"):
            impostor = hosts["start"]("planner", f"{name}.json", "pc2")
            seen = pc2_beats()
            # a real pc2 joins within a few seconds (the last step shows it): watch for
            # longer than that, and it must never be heard
            deadline = time.monotonic() + max(6.0, 5 * joined_in)
            while time.monotonic() < deadline:
                assert impostor.poll() is None, impostor.communicate()[1]
                assert pc2_lost() and pc2_beats() == seen, f"{name}: a refused peer was heard"
                assert safe(), f"{name}: the actuators were un-safed"
                time.sleep(0.1)
            impostor.terminate()
            impostor.communicate(timeout=15)
        hosts["start"]("planner", "good.json", "pc2")
        wait_for(lambda: not pc2_lost(), "the real pc2, with its credentials, joins again", 60)
        assert safe(), "joining again un-safes nothing: a reset does"
        vehicle.terminate()
        assert vehicle.wait(15) == 0
    finally:
        pc1.close()


def test_a_secured_host_of_several_processes_hands_its_children_the_credentials(
    pki: Path,
) -> None:
    """One host running pc1 and pc2 behind its launcher, on TLS with authentication: its
    children connect to its node with the host's certificate and password (passed as
    paths, `--security`), and the box cut ends DONE at its depth."""
    port = free_port()
    text = deployment(pki, port)
    solo = {**text["hosts"]["vehicle"], "processes": ["pc1", "pc2"]}
    solo["auth"] = {**solo["auth"], "user": "vehicle"}
    path = pki / "solo.json"
    path.write_text(json.dumps({"system": "miner", "hosts": {"solo": solo}}))
    segment = f"rcsgen_tls_{os.getpid()}_solo"
    done = subprocess.run(
        [sys.executable, "-m", "miner", "--deploy", str(path), "solo", "--shm", segment]
        + ["--fast", "--set", "map=maps/box_cut.map", "--set", "seed=7"]
        + ["--send", "sec.BOX_CUT:depth=1.5", "--until-done", "--report", "depth_cut"],
        cwd=PACKAGE.parent,
        env={**os.environ, "PYTHONPATH": str(HOOKS)},
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[:2] == ["sec DONE #2", "depth_cut = 1.5"], done.stdout
    assert not [n for n in os.listdir("/dev/shm") if n.startswith(segment)]
    assert listening({port}) == set()
