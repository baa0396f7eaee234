"""Runtime: the standard-library Python every generated package carries as its `rcs` package.

At the top, what runs every cycle: `contract` (status and mode codes, buffer fields,
records), `block` (private or shared memory), `loop` (processes, pacing, the watchdog),
`transport` and `zenoh_transport` (records between processes and hosts), `override`,
`operator` and `deadline`. In `operate/`, what starts, stops and operates a system: the
launcher, the console, the command contract, deployment files and start-up checks. Each
file is copied verbatim into `<system>/rcs/`, so generated code imports only its own
vendored runtime; nothing here imports the compiler or the tools.
"""
