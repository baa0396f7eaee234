"""Operate: what starts, stops and operates a system; nothing here runs every cycle.

`launcher` starts the processes (`python -m <system>`) and stops them, `startup` is what a
process checks before it starts, `deploy` reads a deployment file, `ctl` is the operator's
console (`python -m <system> ctl`) and `command` the one contract a command meets before it
reaches a running machine, and its one writer. They import the cycle's modules (`..loop`,
`..block`, `..contract`, `..override`, `..transport`); those never import them. Copied
verbatim into every generated package as `<system>/rcs/operate/`.
"""
