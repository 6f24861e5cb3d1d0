"""USD import: a stage (through pxr) to the flat host ``Scene``, with diagnostics that
name the file and prim at fault."""
