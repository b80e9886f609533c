"""Benchmarks: commands that print figures (timing goals live here, never in tests).

Each is a module run from the project root: ``.venv/bin/python -m bench.NAME [--help]``.
"""
