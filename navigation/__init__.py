"""navigation: map building, localization and navigation behind the standard ROS interfaces.

What gmapping, amcl and move_base do for a ROS robot, as subsumption modules that run on both runtimes (the
in-process LocalRuntime and ROS) and as ROS nodes speaking the interfaces ROS clients already use
(``/map``, ``map -> odom`` on tf, ``initialpose``, ``amcl_pose``, the ``move_base`` action, ...).

It depends on the core (:mod:`subsumption`) only, never on the simulator: any robot that publishes a
``LaserScan``, ``Odometry`` and tf can use it.
"""
