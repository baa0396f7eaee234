"""Back end: the checked system -> the IR -> every file of the generated package.

In: `checks.tables.CheckedSystem`. Out: `ir.IRSystem` (`lower`: names printed, codes fixed,
the block laid out; `module_io`: what each module reads and writes of the block), then the
rendered, formatted files (`emit`: templates and filters only) and the output directory
written all-or-nothing (`write`, E301-E306).
"""
