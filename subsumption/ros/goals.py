"""``subsumption goals FILE``: save the poses given with rviz's "2D Nav Goal" into a patrol goals file.

rviz publishes each "2D Nav Goal" click as geometry_msgs/PoseStamped on ``/move_base_simple/goal`` (in its fixed
frame: set it to ``map``). Each one is appended to FILE as ``[x, y, yaw]`` under ``goals:`` (the format of
``robots/patrol/goals/*.yaml``), and the file is rewritten whole after every goal, so Ctrl-C loses nothing.
"""
from __future__ import annotations

import sys
from pathlib import Path

from subsumption.planar import yaw_of


def goals_text(goals: list[tuple[float, float, float]], frame: str) -> str:
    """A patrol goals file's text: the goals as [x, y, yaw] under ``goals:``, with a comment naming the frame."""
    lines = [f"# Patrol goals saved from rviz's 2D Nav Goal (frame {frame}): [x (m), y (m), yaw (rad)]", "goals:"]
    lines += [f"  - [{x:.3f}, {y:.3f}, {yaw:.3f}]" for x, y, yaw in goals]
    return "\n".join(lines) + "\n"


def record(path: Path, topic: str = "/move_base_simple/goal") -> int:
    """Append every pose published on `topic` to the goals file at `path`, rewriting it whole after each, until Ctrl-C;
    the exit status."""
    import rosgraph
    import rospy
    from geometry_msgs.msg import PoseStamped

    try:
        rosgraph.Master("/subsumption_goals").getPid()
    except Exception as error:
        print(f"subsumption goals: no ROS master at {rosgraph.get_master_uri()} ({error})", file=sys.stderr)
        return 2
    goals: list[tuple[float, float, float]] = []
    frames: set[str] = set()

    def on_goal(msg: PoseStamped) -> None:
        yaw = yaw_of(msg.pose.orientation)
        goals.append((msg.pose.position.x, msg.pose.position.y, yaw))
        frames.add(msg.header.frame_id or "map")
        path.write_text(goals_text(goals, ", ".join(sorted(frames))))
        print(f"goal {len(goals)}: [{goals[-1][0]:.3f}, {goals[-1][1]:.3f}, {yaw:.3f}] in {msg.header.frame_id!r} "
              f"-> {path}", flush=True)
        if msg.header.frame_id.lstrip("/") not in ("map", ""):
            print(f"warning: goal in frame {msg.header.frame_id!r}, not 'map': set rviz's fixed frame to map",
                  file=sys.stderr)

    rospy.init_node("subsumption_goals", anonymous=True)
    rospy.Subscriber(topic, PoseStamped, on_goal)
    print(f"saving every {topic} (rviz: 2D Nav Goal) into {path}; Ctrl-C ends", flush=True)
    rospy.spin()
    return 0


__all__ = ["record", "goals_text"]
