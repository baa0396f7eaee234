"""Analysis: the checked system -> findings about its state tables, with counter-examples.

In: `checks.tables.CheckedSystem`. Out: diagnostics E501-W512 (nondeterminism, waits,
dead and inescapable states, commands never waited for). `tables` turns each guard into a
solver `Guard` and asks the questions; `solver` decides them over finite domains and
knows nothing of RCS.
"""
