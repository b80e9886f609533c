"""Experiments: a robot's network run in the simulator, per level, with pictures and numbers.

This package is where the core, the simulator and the robots meet; neither of them imports it.
"""
