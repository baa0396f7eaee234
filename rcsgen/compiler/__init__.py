"""Compiler: spec files -> generated packages, in stages, each a folder.

    front_end/    spec bytes -> the input model (load, fragments, schema, model)
    expressions/  expression text -> typed tree -> Python (resolve, fold, print)
    checks/       the model -> the checked system, or located diagnostics
    analysis/     the checked system -> findings about its tables, with counter-examples
    back_end/     the checked system -> IR -> rendered files -> the output directory

Shared by every stage: `diagnostics` (spans, located messages), `codes` (the registry of
diagnostic codes), `types` (the value types), `ir` (the IR the back end and the tools
read). `frontend` runs the stages from spec paths to IR systems.
"""
