"""Deployment files (`python -m <system> --deploy FILE [HOST]`): good files place the
processes and give each host its endpoints; each bad one is one located line with its code
(E430-E439), exit 2, no traceback; the miner runs on two "hosts" from one file."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import read_whole

from rcsgen.runtime.operate.deploy import DeployError, load

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "generated" / "miner"
HOOKS = ROOT / "specs" / "miner"
PROCESSES = ["pc1", "pc2"]

GOOD = """\
{"system": "miner",
 "hosts": {
   "vehicle": {"processes": ["pc1"], "listen": ["tcp/192.0.2.10:7447"],
               "connect": ["tcp/192.0.2.20:7447"]},
   "planner": {"processes": ["pc2"], "listen": ["tcp/192.0.2.20:7447", "tcp/[::1]:7447"]}
 }}
"""


def write(tmp_path: Path, text: str) -> str:
    path = tmp_path / "deploy.json"
    path.write_text(text, encoding="utf-8")
    return str(path)


def test_a_good_file_places_every_process_with_its_hosts_endpoints(tmp_path: Path) -> None:
    deployment = load(write(tmp_path, GOOD), "miner", PROCESSES)
    vehicle, planner = deployment.hosts["vehicle"], deployment.hosts["planner"]
    assert (vehicle.processes, vehicle.listen, vehicle.connect) == (
        ("pc1",),
        ("tcp/192.0.2.10:7447",),
        ("tcp/192.0.2.20:7447",),
    )
    assert planner.listen == ("tcp/192.0.2.20:7447", "tcp/[::1]:7447")
    assert planner.connect == ()
    assert deployment.host("planner", "elsewhere") is planner
    assert deployment.host(None, "vehicle") is vehicle  # the machine's own name by default


def test_one_host_may_run_every_process(tmp_path: Path) -> None:
    text = '{"system": "miner", "hosts": {"solo": {"processes": ["pc2", "pc1"]}}}'
    deployment = load(write(tmp_path, text), "miner", PROCESSES)
    assert deployment.hosts["solo"].processes == ("pc2", "pc1")


def _host(**fields: object) -> str:
    other = {"processes": ["pc2"], "listen": ["tcp/127.0.0.1:7447"]}
    return json.dumps({"system": "miner", "hosts": {"a": fields, "b": other}})


BAD = [
    (
        '{"system": "miner",\n "hosts": {,}}',
        "2:12: error[E430]: not JSON: Expecting property name enclosed in double quotes",
    ),
    ("[1, 2]", "1:1: error[E432]: the deployment must be an object, not a list"),
    (
        '{"system": "miner", "host": {}}',
        "1:21: error[E431]: unknown key `host` in the deployment (did you mean `hosts`?)",
    ),
    ('{"system": "miner"}', "1:1: error[E431]: the deployment has no `hosts`"),
    ('{"system": "miner", "hosts": {}}', "1:30: error[E431]: `hosts` names no host"),
    ('{"system": 3, "hosts": {}}', "1:12: error[E432]: `system` must be a string, not a number"),
    (
        '{"system": "submarine", "hosts": {}}',
        "1:12: error[E436]: the deployment is for system `submarine`, not `miner`",
    ),
    (
        _host(processes="pc1", connect=["tcp/127.0.0.1:7447"]),
        "1:50: error[E432]: `processes` of host `a` must be a list of strings, not a string",
    ),
    (
        _host(processes=[True], connect=["tcp/127.0.0.1:7447"]),
        "1:51: error[E432]: an item of `processes` of host `a` must be a string, not true/false",
    ),
    (
        _host(processes=["pc1"], conect=[]),
        "1:59: error[E431]: unknown key `conect` in host `a` (did you mean `connect`?)",
    ),
    (_host(listen=[]), "1:36: error[E431]: host `a` has no `processes`"),
    (
        _host(processes=["pc3"], connect=["tcp/127.0.0.1:7447"]),
        "1:51: error[E433]: `miner` has no process `pc3` (did you mean `pc2`?)",
    ),
    (
        _host(processes=["pc1", "pc1"]),
        "1:58: error[E434]: process `pc1` is on host `a` already",
    ),
    (
        _host(processes=["pc1"], connect=["127.0.0.1:7447"]),
        "1:71: error[E435]: endpoint '127.0.0.1:7447' is not PROTO/HOST:PORT "
        "(e.g. tcp/127.0.0.1:7447)",
    ),
    (
        _host(processes=["pc1"]),
        "1:31: error[E438]: host `a` neither listens nor connects: no other host can reach it",
    ),
    (
        _host(processes=["pc1"], listen=["tcp/127.0.0.1:7447"]),
        "1:133: error[E439]: host `a` listens on tcp/127.0.0.1:7447 already",
    ),
    (
        _host(processes=[], connect=["tcp/127.0.0.1:7447"]),
        "1:36: error[E431]: host `a` runs no process",
    ),
    (
        '{"system": "miner", "hosts": {"a": {"processes": ["pc2"]}}}',
        "1:30: error[E434]: process(es) pc1 of `miner` are on no host",
    ),
]


@pytest.mark.parametrize(("text", "message"), BAD, ids=[m.split("]")[0][-4:] for _, m in BAD])
def test_a_bad_file_is_one_located_line_with_its_code(
    tmp_path: Path, text: str, message: str
) -> None:
    path = write(tmp_path, text)
    with pytest.raises(DeployError) as raised:
        load(path, "miner", PROCESSES)
    assert str(raised.value) == f"{path}:{message}"


def test_an_unknown_host_or_an_unreadable_file_is_named(tmp_path: Path) -> None:
    path = write(tmp_path, GOOD)
    deployment = load(path, "miner", PROCESSES)
    with pytest.raises(DeployError) as raised:
        deployment.host("planer", "x")
    assert str(raised.value) == (
        f"{path}:1:1: error[E437]: no host `planer` in the deployment (did you mean "
        "`planner`?); its hosts: vehicle, planner"
    )
    with pytest.raises(DeployError) as raised:
        deployment.host(None, "workstation")
    assert "no HOST given, and no host named after this machine, `workstation`" in str(raised.value)
    with pytest.raises(DeployError) as raised:
        load(str(tmp_path / "missing.json"), "miner", PROCESSES)
    assert str(raised.value) == (
        f"{tmp_path / 'missing.json'}: error[E430]: cannot read the deployment file: "
        "No such file or directory"
    )


def miner(*args: str, timeout: float = 60) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "miner", *args],
        cwd=PACKAGE.parent,
        env={**os.environ, "PYTHONPATH": str(HOOKS)},
        capture_output=True,
        text=True,
        timeout=timeout,
    )


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["planer"], "error[E437]: no host `planer` in the deployment"),
        (["planner", "--listen", "tcp/127.0.0.1:1"], "no --transport, --listen, --connect"),
        (["planner", "--lockstep"], "not the hosts of --deploy"),
    ],
)
def test_the_command_line_refuses_a_bad_deployment_in_one_line(
    tmp_path: Path, args: list[str], message: str
) -> None:
    done = miner("--deploy", write(tmp_path, GOOD), *args)
    assert done.returncode == 2
    assert message in done.stderr.splitlines()[-1]
    assert "Traceback" not in done.stderr


def test_without_deploy_an_unknown_process_is_refused_as_before() -> None:
    done = miner("pc3")
    assert done.returncode == 2
    assert done.stderr.splitlines()[-1].endswith(
        "argument process: invalid choice: 'pc3' (choose from 'pc1', 'pc2')"
    )


zenoh_needed = pytest.mark.skipif(
    __import__("importlib").util.find_spec("zenoh") is None, reason="needs eclipse-zenoh"
)


def free_port() -> int:
    import socket

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@zenoh_needed
def test_two_hosts_of_one_file_exchange_buffers(tmp_path: Path) -> None:
    """`--deploy FILE planner` and `--deploy FILE vehicle`: pc2 listens where the file says,
    pc1 connects there; vg (pc1) commands pp (pc2), whose INIT DONE comes back to pc1;
    then pc1 stops after its cycles, pc2 on SIGTERM, each removing its own segment."""
    import importlib
    import signal

    from rcsgen.tools.harness import import_package

    package = import_package(PACKAGE, HOOKS)
    layout = importlib.import_module(f"{package.__name__}.layout")
    rcs = importlib.import_module(f"{package.__name__}.rcs.block")
    port = free_port()
    text = {
        "system": "miner",
        "hosts": {
            "vehicle": {"processes": ["pc1"], "connect": [f"tcp/127.0.0.1:{port}"]},
            "planner": {"processes": ["pc2"], "listen": [f"tcp/127.0.0.1:{port}"]},
        },
    }
    path = write(tmp_path, json.dumps(text))
    segments = {n: f"rcsgen_deploy_{os.getpid()}_{n}" for n in ("pc1", "pc2")}
    env = {**os.environ, "PYTHONPATH": str(HOOKS)}
    planner = subprocess.Popen(
        [sys.executable, "-m", "miner", "--deploy", path, "planner", "--shm", segments["pc2"]],
        cwd=PACKAGE.parent,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        vehicle = miner("--deploy", path, "vehicle", "--shm", segments["pc1"], "--cycles", "40")
        assert vehicle.returncode == 0, vehicle.stderr
        # vg (on pc1) commanded pp (on pc2) over the link: pc2's block holds the command
        block = rcs.Block(layout, segments["pc2"], create=False)
        try:
            assert read_whole(layout.COMMAND_IN["pp"], block.buf)["command_num"] >= 1
        finally:
            block.close()
    finally:
        planner.send_signal(signal.SIGTERM)
        out, err = planner.communicate(timeout=20)
    assert planner.returncode == 0, err
    assert vehicle.stdout.splitlines()[0] == "pc1: 40 cycles"
    assert out.splitlines()[1].startswith("pc2: stopped, ")
    assert not [n for n in os.listdir("/dev/shm") if n in segments.values()]


@zenoh_needed
def test_a_host_of_several_processes_launches_them_all(tmp_path: Path) -> None:
    port = free_port()
    text = {
        "system": "miner",
        "hosts": {"solo": {"processes": ["pc1", "pc2"], "listen": [f"tcp/127.0.0.1:{port}"]}},
    }
    segment = f"rcsgen_deploy_{os.getpid()}_solo"
    done = miner(
        "--deploy",
        write(tmp_path, json.dumps(text)),
        "solo",
        "--shm",
        segment,
        "--fast",
        "--set",
        "map=maps/box_cut.map",
        "--set",
        "seed=7",
        "--send",
        "sec.BOX_CUT:depth=1.5",
        "--until-done",
        "--report",
        "depth_cut",
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[:2] == ["sec DONE #2", "depth_cut = 1.5"], done.stdout
    assert any(line.startswith("pc2: stopped, ") for line in lines), done.stdout
    assert not [n for n in os.listdir("/dev/shm") if n.startswith(segment)]
