"""Runtime: the standard-library Python every generated package carries as its `rcs` package.

`contract` (status and mode codes, buffer fields, records), `block` (private or shared
memory) and `loop` (processes, pacing). Each file is copied verbatim into
`<system>/rcs/`, so generated code imports only its own vendored runtime; nothing here
imports the compiler or the tools.
"""
