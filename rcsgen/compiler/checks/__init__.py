"""Checks: the input model -> semantic diagnostics and the checked system.

In: the system and controller specs. Out: `tables.CheckedSystem` (every name resolved,
every expression typed, each controller's scopes; the rule semantics every later stage
shares) or located diagnostics (E2xx, W30x, E6xx). `check` runs the checks of the hierarchy,
processes, stand-ins and tables; `naming` owns every name-collision check (E228, E6xx);
`operators` the roles, requests and operator modules; `acknowledge` the `allow:` entries;
`hook_checks` the hooks module against its declarations, read by `hooks` with `ast`.
"""
