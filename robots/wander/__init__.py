"""Brooks' three-layer wander robot (1986), as in the paper's Fig. 1, with a laser instead of stereo at level 2.

- level 0 (avoid contact):   :mod:`.level0`  sonar, collide, feelforce, runaway, turn, forward
- level 1 (wander):          :mod:`.level1`  wander (+ the paper's avoid AFSM from subsumption.examples.avoid)
- level 2 (explore):         :mod:`.level2`  whenlook, look, pathplan, integrate

The wiring, arbiters and time constants are in ``wander.yaml`` beside this file.
"""
