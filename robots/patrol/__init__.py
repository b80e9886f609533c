"""The security patrol robot of the paper's Fig. 3: a TurtleBot's six levels, built from the core's public pieces,
the wander robot's modules, and the navigation, vision and terminal packages. See ``patrol.yaml``."""
