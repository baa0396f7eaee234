"""Codes: the one registry of diagnostic codes - severity, topic, title, acknowledgeable.

Every diagnostic rcsgen reports has a code registered here (`CODES`); a `Diagnostic` takes
its severity from it, so a reporting site cannot give a warning's code as an error or a
code nobody documents. What reads the registry: the reporting sites (`Diagnostics.error`,
`.warning`), the acknowledgements (`ACKNOWLEDGEABLE`: what a spec may `allow:`), the user's
selection (`--select`/`--ignore`, `[tool.rcsgen]`: `WARNING_CODES`) and its shell completion
(the titles), the SARIF log's rules (title and level) and the index of
`docs/diagnostics.md` (`index_markdown`; `python -m rcsgen.compiler.codes` prints it).
`tests/test_corpus.py` proves every code is reported somewhere, documented under its title
and tested by a case. The runtime's deployment check (E430-E443) is stdlib-only and cannot
import this; its codes are registered here all the same.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum, StrEnum


class Severity(StrEnum):
    """How bad a finding is: an error fails the command; a warning only with `--strict`."""

    ERROR = "error"
    WARNING = "warning"


class Topic(Enum):
    """What a code is about, as the index of docs/diagnostics.md groups them: (what, where
    it is found)."""

    FILES = (
        "reading files and the YAML",
        "`rcsgen/compiler/front_end/loader.py`, `compiler/frontend.py`",
    )
    SCHEMA = ("the shape of a file (JSON Schema)", "`rcsgen/compiler/front_end/schema.py`")
    EXPRESSIONS = ("expressions and numbers", "`rcsgen/compiler/expressions/`, `checks/check.py`")
    TABLES = (
        "names, hierarchy, hooks, state tables, time, results and reasons, let and "
        "functions, acknowledgements, operators",
        "`rcsgen/compiler/checks/`: `check.py`, `hook_checks.py`, `acknowledge.py`, `operators.py`",
    )
    FRAGMENTS = (
        "fragments (parameterised sub-tables), and fragments used within fragments",
        "`rcsgen/compiler/front_end/fragments.py`, `compiler/frontend.py`",
    )
    REASONS = (
        "a subordinate's reason passed up (`reason: <sub>.reason`)",
        "`rcsgen/compiler/checks/check.py`",
    )
    TYPES = ("enumerations and strings", "`rcsgen/compiler/expressions/`, `checks/check.py`")
    WORLD = ("ground truth and actuators (world fields)", "`rcsgen/compiler/checks/check.py`")
    OPERATORS = (
        "operator modules, their clients, roles on them and the scripted person",
        "`rcsgen/compiler/checks/operators.py`, `check.py`, `rcsgen/tools/scenario/check.py`",
    )
    PLANS = (
        "plans (planner and executor)",
        "`rcsgen/compiler/expressions/`, `checks/check.py`, `analysis/tables.py`",
    )
    CYCLE_PERIOD = (
        "`CYCLE_PERIOD`, the cycle period expressions read",
        "`rcsgen/compiler/checks/naming.py`, `check.py`",
    )
    OUTPUT = ("writing the output", "`rcsgen/compiler/back_end/write.py`")
    SCENARIOS = (
        "scenario files and runs",
        "`rcsgen/tools/scenario/check.py`, `runs.py`",
    )
    DEPLOYMENT = ("deployment files (`--deploy`)", "`rcsgen/runtime/operate/deploy.py`")
    ANALYSIS = ("static analysis of the tables", "`rcsgen/compiler/analysis/tables.py`")
    NAMES = ("names and text that reach generated code", "`rcsgen/compiler/checks/naming.py`")
    PROVE = ("properties of the running hierarchy (`rcsgen prove`)", "`rcsgen/compiler/prove/`")
    SAFETY = (
        "fail safe: actuators' safe values and `on_lost` policies",
        "`rcsgen/compiler/checks/check.py`, `analysis/tables.py`",
    )
    ACCESS = (
        "access: who holds each operator role, who shares the segment",
        "`rcsgen/compiler/checks/operators.py`",
    )
    INSTANCES = (
        "instances of templates (a controller and its subtree written once)",
        "`rcsgen/compiler/front_end/instances.py`",
    )
    IO = (
        "fieldbus I/O: devices and the world fields bound to their points (`io:`)",
        "`rcsgen/compiler/checks/io.py`, `rcsgen/tools/io_connect.py` (`validate --connect`)",
    )

    @property
    def what(self) -> str:
        return self.value[0]

    @property
    def where(self) -> str:
        return self.value[1]


@dataclass(frozen=True)
class Code:
    """One diagnostic code: `E204`, an error about the tables, titled `undeclared command`
    (its heading in docs/diagnostics.md); `about` says what a warning that a spec can
    acknowledge is about (`a rule`, `a state`), '' when it cannot be acknowledged."""

    code: str
    severity: Severity
    topic: Topic
    title: str
    about: str = ""

    @property
    def acknowledgeable(self) -> bool:
        return bool(self.about)


def error(code: str, topic: Topic, title: str) -> Code:
    return Code(code, Severity.ERROR, topic, title)


def warning(code: str, topic: Topic, title: str, about: str = "") -> Code:
    return Code(code, Severity.WARNING, topic, title, about)


_ALL = (
    error("E001", Topic.FILES, "invalid YAML"),
    error("E002", Topic.FILES, "duplicate key"),
    error("E003", Topic.FILES, "mapping key is not a string"),
    error("E004", Topic.FILES, "NaN or infinity"),
    error("E005", Topic.FILES, "tag, anchor, alias or merge key"),
    error("E006", Topic.FILES, "file too large"),
    error("E007", Topic.FILES, "nesting too deep"),
    error("E008", Topic.FILES, "not UTF-8"),
    error("E009", Topic.FILES, "more than one document"),
    error("E010", Topic.FILES, "cannot read a file or path"),
    error("E011", Topic.FILES, "not a regular file"),
    error("E012", Topic.FILES, "broken symbolic link"),
    error("E013", Topic.FILES, "empty file"),
    error("E014", Topic.FILES, "directories nested too deep"),
    error("S001", Topic.SCHEMA, "missing required key"),
    error("S002", Topic.SCHEMA, "unknown key"),
    error("S003", Topic.SCHEMA, "wrong type"),
    error("S004", Topic.SCHEMA, "invalid name"),
    error("S005", Topic.SCHEMA, "invalid value"),
    error("S006", Topic.SCHEMA, "malformed rule or action"),
    error("E101", Topic.EXPRESSIONS, "invalid expression"),
    error("E102", Topic.EXPRESSIONS, "construct not allowed"),
    error("E103", Topic.EXPRESSIONS, "unknown name"),
    error("E104", Topic.EXPRESSIONS, "undeclared world field"),
    error("E105", Topic.EXPRESSIONS, "world field not accessed by this controller"),
    error("E106", Topic.EXPRESSIONS, "unknown predicate"),
    error("E107", Topic.EXPRESSIONS, "type error"),
    error("E108", Topic.EXPRESSIONS, "bad attribute or bare namespace"),
    error("E109", Topic.EXPRESSIONS, "unknown command of a subordinate"),
    error("E110", Topic.EXPRESSIONS, "integer out of range"),
    error("E111", Topic.EXPRESSIONS, "division or modulo by a constant zero"),
    error("E201", Topic.TABLES, "unknown subordinate"),
    error("E202", Topic.TABLES, "two supervisors"),
    error("E203", Topic.TABLES, "cycle in the hierarchy"),
    error("E204", Topic.TABLES, "undeclared command"),
    error("E205", Topic.TABLES, "send to a controller that is not a subordinate"),
    error("E206", Topic.TABLES, "transition to an undefined state"),
    error("E207", Topic.TABLES, "unreachable state"),
    error("E208", Topic.TABLES, "undeclared hook"),
    error("E209", Topic.TABLES, "controller in no process"),
    error("E210", Topic.TABLES, "controller in two processes"),
    error("E211", Topic.TABLES, "process runs an unknown controller"),
    error("E212", Topic.TABLES, "hooks module not found or unreadable"),
    error("E213", Topic.TABLES, "hook function not defined"),
    error("E214", Topic.TABLES, "hook has the wrong number of parameters"),
    error("E215", Topic.TABLES, "hooks without a hooks module"),
    error("E216", Topic.TABLES, "command without S0"),
    error("E217", Topic.TABLES, "missing parameter in a send"),
    error("E218", Topic.TABLES, "unknown parameter in a send"),
    error("E219", Topic.TABLES, "write to an undeclared world field"),
    error("E220", Topic.TABLES, "assignment to something that is not a local"),
    error("E221", Topic.TABLES, "controller declared twice"),
    error("E222", Topic.TABLES, "file name differs from the controller"),
    error("E223", Topic.TABLES, "unknown simulator"),
    error("E224", Topic.TABLES, "no system directory"),
    error("E225", Topic.TABLES, "not a controller spec"),
    error("E226", Topic.TABLES, "report with next, or a second report"),
    error("E227", Topic.TABLES, "NOP state"),
    error("E228", Topic.TABLES, "name collides in the generated code"),
    error("E229", Topic.TABLES, "predicate calls itself"),
    error("E230", Topic.TABLES, "parameter with two types"),
    error("E231", Topic.TABLES, "two systems with one name"),
    error("E232", Topic.TABLES, "every_cycle rule with next or report"),
    error("E233", Topic.TABLES, "stand-in listed in a process or as a subordinate"),
    error("E234", Topic.TABLES, "stand-in without a spec"),
    error("E235", Topic.TABLES, "stand-in with subordinates"),
    error("E236", Topic.TABLES, "stand-in with other commands"),
    error("E237", Topic.TABLES, "code that cannot be acknowledged"),
    error("E238", Topic.TABLES, "acknowledgement names an unknown state"),
    error("E239", Topic.TABLES, "acknowledgement without a reason"),
    error("E240", Topic.TABLES, "hook is not a plain function"),
    error("E241", Topic.TABLES, "hook results contradict `returns:`"),
    error("E242", Topic.TABLES, "hook argument of the wrong type"),
    error("E243", Topic.TABLES, "world field written in two processes"),
    error("E244", Topic.TABLES, "echo timeout of a controller that is not a subordinate"),
    error("E245", Topic.TABLES, "operator role or request names an unknown module"),
    error("E246", Topic.TABLES, "a role commands a module that has a supervisor"),
    error("E247", Topic.TABLES, "a request is not open while a bool world field"),
    error("E248", Topic.TABLES, "a request's answer is not a command"),
    error("E249", Topic.TABLES, "a request's answer cannot be sent by one key"),
    error("E250", Topic.TABLES, "`for:` without `when:`"),
    error("E251", Topic.TABLES, "`after:` on an every_cycle rule"),
    error("E252", Topic.TABLES, "duration shorter than one cycle"),
    error("E253", Topic.TABLES, "result with two types"),
    error("E254", Topic.TABLES, "built-in reason declared"),
    error("E255", Topic.TABLES, "reason given with DONE"),
    error("E256", Topic.TABLES, "reason the command does not declare"),
    error("E257", Topic.TABLES, "result the command does not declare"),
    error("E258", Topic.TABLES, "unknown result of a subordinate"),
    error("E259", Topic.TABLES, "reason of a subordinate that declares none"),
    error("E260", Topic.TABLES, "unknown reason of a subordinate"),
    error("E261", Topic.TABLES, "conditional expression with values of two types"),
    error("E262", Topic.TABLES, "`let` value or function named like something else"),
    error("E263", Topic.TABLES, "function called with the wrong arguments"),
    error("E264", Topic.TABLES, "function calls a function declared after it"),
    error("E265", Topic.FRAGMENTS, "unknown fragment"),
    error("E266", Topic.FRAGMENTS, "fragment used with the wrong arguments"),
    error("E267", Topic.FRAGMENTS, "`$name` that is not a parameter of its fragment"),
    error("E268", Topic.FRAGMENTS, "a fragment's state takes a name the command already has"),
    error("E269", Topic.FRAGMENTS, "malformed fragment or use"),
    error("E270", Topic.FRAGMENTS, "fragment declared twice"),
    warning("W305", Topic.FRAGMENTS, "fragment declared but never used"),
    error("E271", Topic.REASONS, "reason passed up from a module that is not a subordinate"),
    error("E272", Topic.REASONS, "passed-up reason the command does not declare"),
    error("E273", Topic.REASONS, "reason passed up from a subordinate the command never commands"),
    warning(
        "W306",
        Topic.REASONS,
        "reason passed up by a rule that does not require the subordinate's ERROR",
        about="a rule",
    ),
    error("E274", Topic.TYPES, "unknown value of an enumeration"),
    error("E275", Topic.TYPES, "arithmetic, ordering or logic on an enumeration or a string"),
    error("E276", Topic.TYPES, "invalid string"),
    error("E277", Topic.TYPES, "value of another enumeration or a string that may not fit"),
    error("E278", Topic.TYPES, "enumeration value named like a status"),
    warning("W307", Topic.TYPES, "enumeration of one value"),
    error("E279", Topic.TABLES, "two commands to one subordinate in one rule"),
    error("E280", Topic.WORLD, "controller uses a ground-truth world field"),
    error("E299", Topic.TABLES, "stand-in of itself, or of a stand-in"),
    error("E290", Topic.PLANS, "unknown name of a plan"),
    error("E291", Topic.PLANS, "plan named like something else"),
    error("E292", Topic.PLANS, "action on an undeclared plan"),
    error("E293", Topic.PLANS, "planner argument of a type its annotation excludes"),
    error("E294", Topic.PLANS, "planner missing or not callable as declared"),
    error("E295", Topic.PLANS, "plan action in an every_cycle rule"),
    warning("W309", Topic.PLANS, "replan that can run with no replans left", about="a rule"),
    error("E296", Topic.OPERATORS, "role granted `command` on an operator module"),
    error("E297", Topic.CYCLE_PERIOD, "`CYCLE_PERIOD` declared"),
    error("E298", Topic.FRAGMENTS, "fragment used within itself"),
    error("E912", Topic.FRAGMENTS, "a list of actions given or used where it does not go"),
    error("E281", Topic.OPERATORS, "instruction text shows an unknown parameter"),
    error("E282", Topic.OPERATORS, "malformed instruction text"),
    error("E283", Topic.OPERATORS, "operator module as a simulator or stand-in"),
    error("E284", Topic.OPERATORS, "INIT or HALT with parameters, or on an operator module"),
    error("E285", Topic.OPERATORS, "not an operator module"),
    error("E286", Topic.OPERATORS, "unknown task in a scenario's operator script"),
    error("E287", Topic.OPERATORS, "unknown client in a scenario's operator script"),
    error("E288", Topic.OPERATORS, "reason the answer cannot give"),
    error("E289", Topic.OPERATORS, "unknown channel in a console answer or a scripted reply"),
    warning("W308", Topic.OPERATORS, "operator module that serves no client"),
    error("E910", Topic.OPERATORS, "a task result's range that no value or no answer fits"),
    error("E911", Topic.OPERATORS, "scripted answer whose results do not fit the task"),
    warning("W301", Topic.TABLES, "rule that never fires", about="a rule"),
    warning("W302", Topic.TABLES, "rule whose guard is always false", about="a rule"),
    warning("W303", Topic.TABLES, "acknowledgement that matches nothing"),
    warning("W304", Topic.TABLES, "duration that is not a whole number of cycles", about="a rule"),
    error("E301", Topic.OUTPUT, "symlink in the output"),
    error("E302", Topic.OUTPUT, "output path leaves the output directory"),
    error("E303", Topic.OUTPUT, "output path is not a file"),
    error("E304", Topic.OUTPUT, "file not generated by rcsgen"),
    error("E305", Topic.OUTPUT, "output directory is not a directory"),
    error("E306", Topic.OUTPUT, "cannot write the output"),
    error("E401", Topic.SCENARIOS, "not a scenario file"),
    error("E403", Topic.SCENARIOS, "no system above the scenario"),
    error("E405", Topic.SCENARIOS, "unknown module"),
    error("E406", Topic.SCENARIOS, "unknown command"),
    error("E407", Topic.SCENARIOS, "unknown or missing parameter"),
    error("E408", Topic.SCENARIOS, "value of the wrong type"),
    error("E409", Topic.SCENARIOS, "unknown world field"),
    error("E410", Topic.SCENARIOS, "unknown process"),
    error("E411", Topic.SCENARIOS, "controller that cannot be simulated"),
    error("E412", Topic.SCENARIOS, "cycle out of range or out of order"),
    error("E413", Topic.SCENARIOS, "command to a module that has a supervisor"),
    error("E414", Topic.SCENARIOS, "module that does not run in this scenario"),
    error("E415", Topic.SCENARIOS, "expectation that cannot be checked"),
    error("E416", Topic.SCENARIOS, "expectation not met"),
    error("E417", Topic.SCENARIOS, "differs from the golden trace"),
    error("E418", Topic.SCENARIOS, "generated package is stale"),
    error("E419", Topic.SCENARIOS, "trace file cannot be read or written"),
    error("E420", Topic.SCENARIOS, "hook raised an exception"),
    error("E421", Topic.SCENARIOS, "hook returned values that do not fit `returns:`"),
    error("E422", Topic.SCENARIOS, "a module failed at run time"),
    error("E423", Topic.SCENARIOS, "hook overran its deadline"),
    error("E424", Topic.SCENARIOS, "unknown setting"),
    error("E425", Topic.SCENARIOS, "force that cannot be made"),
    error("E426", Topic.SCENARIOS, "unknown device, or a device fault that cannot be made"),
    error("E427", Topic.SCENARIOS, "a device fault not met with the safe state in time"),
    error("E428", Topic.SCENARIOS, "a soft PLC that did not start"),
    error("E430", Topic.DEPLOYMENT, "not a deployment file"),
    error("E431", Topic.DEPLOYMENT, "unknown or missing key"),
    error("E432", Topic.DEPLOYMENT, "value of the wrong type"),
    error("E433", Topic.DEPLOYMENT, "unknown process"),
    error("E434", Topic.DEPLOYMENT, "process on two hosts, or on none"),
    error("E435", Topic.DEPLOYMENT, "bad endpoint"),
    error("E436", Topic.DEPLOYMENT, "deployment for another system"),
    error("E437", Topic.DEPLOYMENT, "unknown host"),
    error("E438", Topic.DEPLOYMENT, "host that no other can reach"),
    error("E439", Topic.DEPLOYMENT, "endpoint listened on twice"),
    error("E440", Topic.DEPLOYMENT, "certificate, key or password file that cannot be read"),
    error("E441", Topic.DEPLOYMENT, "key or password file others may read"),
    error("E442", Topic.DEPLOYMENT, "TLS and endpoints that disagree"),
    error("E443", Topic.DEPLOYMENT, "authentication on some hosts only"),
    error("E501", Topic.ANALYSIS, "nondeterministic state"),
    warning("W501", Topic.ANALYSIS, "overlap in a first_match state"),
    warning("W502", Topic.ANALYSIS, "exclusivity not provable", about="a rule"),
    warning("W503", Topic.ANALYSIS, "state that can wait", about="a state"),
    error("E504", Topic.ANALYSIS, "command that never finishes"),
    warning("W505", Topic.ANALYSIS, "command sent but never waited for", about="a rule"),
    warning("W506", Topic.ANALYSIS, "ERROR of a subordinate not handled", about="a state"),
    error("E507", Topic.ANALYSIS, "status of a subordinate never commanded"),
    warning("W508", Topic.ANALYSIS, "dead state", about="a state"),
    warning("W509", Topic.ANALYSIS, "state with no way out", about="a state"),
    error("E510", Topic.ANALYSIS, "first_match names an unknown state"),
    warning("W511", Topic.ANALYSIS, "unneeded first_match", about="a state"),
    warning("W512", Topic.ANALYSIS, "rule that can never fire", about="a rule"),
    warning("W520", Topic.WORLD, "actuator without a HALT that stops it"),
    warning("W701", Topic.PROVE, "no motion after ERROR", about="a rule"),
    warning("W702", Topic.PROVE, "every command finishes", about="a state"),
    warning("W703", Topic.PROVE, "no handshake deadlock", about="a state"),
    warning("W704", Topic.PROVE, "HALT reach", about="a command"),
    warning("W705", Topic.PROVE, "ERROR reaches the root", about="a state"),
    warning("W706", Topic.PROVE, "latched stop", about="a rule"),
    warning("W707", Topic.PROVE, "a stale DONE believed", about="a rule"),
    warning("W708", Topic.PROVE, "the handshake: wait for the echo", about="a rule"),
    warning("W709", Topic.PROVE, "a property of the spec's own", about="a rule"),
    error("E710", Topic.PROVE, "unknown name in a property"),
    error("E711", Topic.PROVE, "property outside one supervisor's view (global)"),
    error("E712", Topic.PROVE, "bad `within` of a property"),
    error("E713", Topic.PROVE, "property expression of a form prove cannot check"),
    error("E714", Topic.PROVE, "two properties with one name"),
    error("E601", Topic.NAMES, "invalid identifier"),
    error("E602", Topic.NAMES, "line break in a one-line text"),
    error("E801", Topic.SAFETY, "bad safe value of a world field"),
    error("E802", Topic.SAFETY, "bad `on_lost` policy"),
    warning("W803", Topic.SAFETY, "actuator that starts away from its safe value"),
    error("E810", Topic.ACCESS, "role anyone may claim beside roles with holders"),
    warning("W811", Topic.ACCESS, "role holders who cannot open the segment"),
    error("E901", Topic.INSTANCES, "unknown template"),
    error("E902", Topic.INSTANCES, "unknown template parameter"),
    error("E903", Topic.INSTANCES, "missing binding"),
    error("E904", Topic.INSTANCES, "binding to an unknown world field"),
    error("E905", Topic.INSTANCES, "binding or value of the wrong type"),
    error("E906", Topic.INSTANCES, "name made twice by instances"),
    error("E907", Topic.INSTANCES, "malformed template"),
    error("E908", Topic.INSTANCES, "template controller uses an undeclared world field"),
    error("E450", Topic.IO, "binding to an unknown world field"),
    error("E451", Topic.IO, "point the field cannot be carried by"),
    error("E452", Topic.IO, "value out of the point's range"),
    error("E453", Topic.IO, "two writers of one field"),
    error("E454", Topic.IO, "ground-truth field bound to I/O"),
    error("E455", Topic.IO, "address conflict"),
    error("E456", Topic.IO, "bad device address"),
    error("E457", Topic.IO, "bad device process or timing"),
    error("E458", Topic.IO, "device or point not there (`validate --connect`)"),
)
CODES: dict[str, Code] = {c.code: c for c in _ALL}
# Every warning rcsgen reports (what --select and --ignore can name).
WARNING_CODES = frozenset(c.code for c in _ALL if c.severity is Severity.WARNING)
# The warnings a spec can acknowledge, each with what it is about (for W303's hint).
ACKNOWLEDGEABLE = {c.code: c.about for c in _ALL if c.acknowledgeable}
# The findings of `rcsgen prove` (rcsgen/compiler/prove/): acknowledged like the others, but
# only `prove` reports them, so only `prove` says when an acknowledgement of one is unused.
PROVE_CODES = {
    c.code: c.about for c in _ALL if c.topic is Topic.PROVE and c.severity is Severity.WARNING
}


def severity_of(code: str) -> Severity:
    """The severity of a registered code; ValueError (an internal error) for any other."""
    found = CODES.get(code)
    if found is None:
        raise ValueError(f"internal error: diagnostic code {code!r} is not registered")
    return found.severity


def _runs(codes: list[str]) -> list[str]:
    """Codes as runs of consecutive numbers, whatever their letter: E201-E264, W301-W304,
    E501-W512 (E501, W501, W502, ..., W512)."""
    ordered = sorted(codes, key=lambda c: (int(c[1:]), c[0]))
    runs: list[list[str]] = []
    for code in ordered:
        if runs and int(code[1:]) - int(runs[-1][-1][1:]) <= 1:
            runs[-1].append(code)
        else:
            runs.append([code])
    return [run[0] if len(run) == 1 else f"{run[0]}-{run[-1]}" for run in runs]


def index_markdown() -> str:
    """The index of docs/diagnostics.md: a row per topic, its codes as ranges."""
    rows = ["| range | stage | module |", "|---|---|---|"]
    for topic in Topic:
        codes = _runs([c.code for c in _ALL if c.topic is topic])
        rows.append(f"| {', '.join(codes)} | {topic.what} | {topic.where} |")
    return "\n".join(rows) + "\n"


if __name__ == "__main__":
    print(index_markdown(), end="")
