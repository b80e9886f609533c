"""terminal: a remote operator terminal in the browser, served by a ROS node on the robot.

A web page (live camera, map, alarms, the subsumption network with each arbiter's holder) and a WebSocket
speaking the rosbridge v2 JSON protocol, limited to the topics the terminal exposes. Depends on the core
(:mod:`subsumption`) only, never on the simulator.
"""
