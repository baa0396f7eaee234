"""Front end: spec files -> the input model, every value with the span it was written at.

In: the bytes of `system.yaml`, each controller or operator file and `fragments.yaml`.
Out: `model.SystemSpec` and one `model.ControllerSpec` per module, or located diagnostics.
`loader` reads YAML strictly (E001-E014), `fragments` expands each `use:` (E265-E270,
E298, W305), `schema` checks each document's shape against `rcsgen/compiler/schemas/`
(S001-S006), `model` builds the dataclasses (the one place a type is read from the spec's
text) and adds QQ1's default INIT/HALT tables.
"""
