"""The shop's and the workcell's two protocols (the paper's section 5.3.2: "A workcell node
resides above the workstation node. This node converts and decomposes a highest level
incoming job, implemented via a CORBA protocol, to the IWS native communication protocol,
implemented via the EMC NML").

Between the shop and the workcell a job is a CORBA request: one operation of the
workcell's interface, invoked with its arguments and marshalled as text,

    Workcell::initForInspect()
    Workcell::inspectPart("bracket")

The shop marshals it (`inspect_request`); the workcell unmarshals it (`native_job`) into
the IWS native job, an RCS command to the workstation (INIT_FOR_INSPECT, or INSPECT_PART
with its program) sent with a command number, as every level below speaks. A request the
workcell cannot read is no job (NO_JOB): the workcell refuses it with ERROR BAD_REQUEST,
never a stopped run, since a request comes from outside the station (`why_not` says what
is wrong with it, for a person reading a refusal).
"""

from __future__ import annotations

import re

INTERFACE = "Workcell"
INIT_REQUEST = f"{INTERFACE}::initForInspect()"

# The workcell's native jobs, in the order of its `job` local's enumeration (wc.yaml).
NO_JOB, INIT_JOB, INSPECT_JOB = 0, 1, 2

REQUEST = re.compile(r"(?P<interface>\w+)::(?P<operation>\w+)\((?P<args>.*)\)")
PROGRAM = re.compile(r'"(?P<program>[a-z0-9_]{1,32})"')


def inspect_request(program: str) -> str:
    """The shop's CORBA request for one part's inspection by `program`."""
    return f'{INTERFACE}::inspectPart("{program}")'


def read_request(request: str) -> tuple[int, str, str]:
    """(job, program, why not): the native job a CORBA request asks for and its program
    ("" but for inspectPart), or NO_JOB and what is wrong with the request."""
    match = REQUEST.fullmatch(request.strip())
    if match is None:
        return NO_JOB, "", f"{request!r} is not a request `Interface::operation(arguments)`"
    if match["interface"] != INTERFACE:
        return NO_JOB, "", f"interface {match['interface']!r} is not {INTERFACE!r}"
    operation, args = match["operation"], match["args"].strip()
    if operation == "initForInspect" and not args:
        return INIT_JOB, "", ""
    if operation == "initForInspect":
        return NO_JOB, "", f"initForInspect takes no argument, got {args!r}"
    if operation == "inspectPart":
        program = PROGRAM.fullmatch(args)
        if program is None:
            return NO_JOB, "", f"inspectPart takes one program name in quotes, got {args!r}"
        return INSPECT_JOB, program["program"], ""
    return NO_JOB, "", f"{INTERFACE} has no operation {operation!r}"


def native_job(request: str) -> tuple[int, str]:
    """The workcell's conversion: the native job (an index of its `job` enumeration) and
    program a CORBA request asks for; (NO_JOB, "") for one it cannot read."""
    job, program, _ = read_request(request)
    return job, program


def why_not(request: str) -> str:
    """What is wrong with a CORBA request the workcell refuses ("" for a good one)."""
    return read_request(request)[2]
