"""What several tests share that is not a fixture (fixtures are in tests/conftest.py).

`browser` loads a page in headless Chromium; `tcp_relay` is a TCP relay a test can cut
and mend (run as a script); `workarounds` counts the `# workaround(KIND)` lines of a
system's specs (run as a script too); `reference_interpreter` is the independent
interpreter of docs/semantics.md that generated code is compared with; `running` names
segments and reads a running system from outside.
"""
