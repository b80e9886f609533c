"""vision: perception from camera pixels (RGB-D): depth to scan, face detection and recognition, tracking.

Modules that run on both runtimes and read only sensor messages (``sensor_msgs/Image``, ``CameraInfo``);
they never look at a simulator's ground truth. Depends on the core (:mod:`subsumption`) only.
"""

# The level-4 modules (imported lazily by class path, e.g. "vision.modules:Detect", so that importing the
# package stays cheap): Detect, Track and Follow in vision.modules; the pieces they are made of in
# vision.faces, vision.recognition, vision.appearance, vision.tracking and vision.follow.
