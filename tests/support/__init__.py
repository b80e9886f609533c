"""Test support: data and fixtures the tests and the benches share, which no capability imports.

:mod:`support.photoscene` composites camera frames from real photographs (from before the simulator rendered);
:mod:`support.make_pictures` is how the simulator's face cards and posters (``subsim/pictures/``) were made
from them. Tests import ``support.*`` (pytest puts tests/ on the path); benches, run from the project root,
import ``tests.support.*``.
"""
