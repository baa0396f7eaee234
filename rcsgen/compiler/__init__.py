"""Compiler: spec files -> generated packages (load, schema, model, check, analysis, lower, emit,
write). Each stage is its own module; `frontend` runs the stages up to the IR."""
