"""The README's first robot: one module and a one-level network file, to copy from."""
