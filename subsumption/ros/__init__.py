"""The ROS binding: the only part of the core that imports rospy.

- :mod:`.runtime`       a NodeHandle on rospy, so a module runs as its own ROS node;
- :mod:`.arbiter_node`  the generic inhibitor/suppressor/defaulter nodes (any message type, no code generation);
- :mod:`.module_node`   `rosrun subsumption module _class:=pkg.mod:Class` runs any module class as a node;
- :mod:`.master`        find or start a ROS master;
- :mod:`.launch`        run a network file on ROS and write the equivalent roslaunch XML.
"""
