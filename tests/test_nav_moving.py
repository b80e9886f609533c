"""Moving obstacles from the scan (navigation.moving_obstacles) and the local planner's prediction of them: a
person crossing the robot's path is let by, not run into."""
from __future__ import annotations

import math

import numpy as np

from navigation.local_planner import LocalParams, compute_command
from navigation.moving_obstacles import ObstacleTracker, clusters
from subsumption.planar import inverse, transform_points

PERSON_RADIUS = 0.25
ROBOT_RADIUS = 0.18


def seen_arc(centre: np.ndarray, robot: np.ndarray) -> np.ndarray:
    """The hits a laser on `robot` (x, y, yaw) gets from a round person at `centre`: the half of the circle facing
    it, a point every 0.05 m, in the robot's frame."""
    facing = math.atan2(robot[1] - centre[1], robot[0] - centre[0])
    angles = facing + np.linspace(-1.3, 1.3, 11)
    world = centre + PERSON_RADIUS * np.column_stack((np.cos(angles), np.sin(angles)))
    return transform_points(inverse(robot), world)


def test_clusters_split_at_the_tolerance():
    a = np.array([[0.0, 0.0], [0.1, 0.0], [0.2, 0.0]])
    groups = clusters(np.concatenate([a, a + [1.0, 0.0]]), 0.15)
    assert sorted(len(g) for g in groups) == [3, 3]


def test_a_walker_is_tracked_at_its_speed_and_a_standing_person_stands_while_the_robot_drives():
    """The robot drives at 0.5 m/s (its odometry says so): a person walking across at 0.9 m/s is estimated at
    about that; one standing still, whose visible arc shifts as the robot passes, is not taken for a walker."""
    tracker = ObstacleTracker()
    walker, stander = np.array([3.0, -1.5]), np.array([2.0, 1.0])
    for k in range(12):
        t = 0.1 * k
        robot = np.array([0.5 * t, 0.0, 0.0])
        hits = np.concatenate([seen_arc(walker + [0.0, 0.9 * t], robot), seen_arc(stander, robot)])
        tracker.update(t, robot, hits)
    moving = tracker.moving(1.1, robot)
    speeds = np.hypot(*moving.velocities.T)
    near_walker = np.hypot(*(moving.points - transform_points(inverse(robot), (walker + [0, 0.99])[None])).T) < 0.4
    assert near_walker.any() and np.all(np.abs(speeds[near_walker] - 0.9) < 0.15)
    assert np.all(speeds[~near_walker] == 0.0)
    assert len(tracker.movers()) == 1


def cross(horizon: float, steps: int = 80) -> tuple[float, float | None]:
    """A person walks across the robot's straight plan from its left at 0.9 m/s, timed to meet it on the plan;
    the robot (perfect odometry) follows its local planner's commands, seeing the person only as laser hits.
    Returns the least distance between the two centres and the person's y when the robot passed her line."""
    params = LocalParams(dynamic_padding=0.1, prediction_horizon=horizon)
    path, goal = np.array([[0.0, 0.0], [5.0, 0.0]]), np.array([5.0, 0.0, 0.0])
    robot, velocity = np.array([0.0, 0.0, 0.0]), (0.5, 0.0)
    person, walk = np.array([2.2, 3.6]), np.array([0.0, -0.9])
    tracker = ObstacleTracker()
    least, passed_at = math.inf, None
    dt = 0.1
    for k in range(steps):
        t = k * dt
        hits = seen_arc(person, robot)
        hits = hits[np.hypot(*hits.T) < 8.0]
        tracker.update(t, robot, hits)
        command = compute_command(robot, velocity, path, goal, hits, params, dynamic=hits,
                                  moving=tracker.moving(t, robot) if horizon > 0 else None)
        v, w = (command.v, command.w) if command.ok else (0.0, 0.0)
        # the base follows within its acceleration limits
        v = velocity[0] + float(np.clip(v - velocity[0], -params.acc_lim_x * dt, params.acc_lim_x * dt))
        w = velocity[1] + float(np.clip(w - velocity[1], -params.acc_lim_theta * dt, params.acc_lim_theta * dt))
        before = robot[0]
        robot = np.array([robot[0] + v * dt * math.cos(robot[2] + 0.5 * w * dt),
                          robot[1] + v * dt * math.sin(robot[2] + 0.5 * w * dt), robot[2] + w * dt])
        velocity = (v, w)
        if passed_at is None and before < person[0] <= robot[0]:
            passed_at = float(person[1])
        # a walker stops rather than walk into the robot (as the simulator's do)
        ahead = person + walk * dt
        if math.hypot(*(ahead - robot[:2])) >= PERSON_RADIUS + ROBOT_RADIUS + 0.02:
            person = ahead
        least = min(least, math.hypot(*(person - robot[:2])))
    return least, passed_at


def test_a_person_crossing_the_path_is_let_by_and_not_run_into():
    least, passed_at = cross(horizon=1.5)
    assert least > PERSON_RADIUS + ROBOT_RADIUS + 0.05  # never touched, with room to spare
    assert passed_at is not None and passed_at < -PERSON_RADIUS  # it went behind her: she had crossed
    # the same scene scored against where the scan sees her now only: the robot cuts in front of her, and she
    # has to stop for it, against its side
    blind, blind_passed_at = cross(horizon=0.0)
    assert blind < PERSON_RADIUS + ROBOT_RADIUS + 0.05
    assert blind_passed_at is not None and blind_passed_at > 0.0


def test_a_walker_that_leaves_a_narrow_view_is_kept_predicted_with_growing_uncertainty():
    """A person walks across the robot's view and out of it (the scan shows nothing more); while her predicted
    place is hidden from the scan she is kept (lost_keep) round that place, the circle growing; where the scan
    sees her predicted place empty, she is dropped at the timeout as before."""
    from navigation.moving_obstacles import TrackerParams

    robot = np.array([0.0, 0.0, 0.0])
    for hidden, kept in ((lambda pts: np.ones(len(pts), dtype=bool), True),
                         (lambda pts: np.zeros(len(pts), dtype=bool), False)):
        tracker = ObstacleTracker(TrackerParams(lost_keep=3.0))
        for k in range(8):
            tracker.update(0.1 * k, robot, seen_arc(np.array([2.0, 0.9 * 0.1 * k - 0.4]), robot), hidden)
        for k in range(8, 20):  # out of view: no hits
            tracker.update(0.1 * k, robot, np.zeros((0, 2)), hidden)
        lost = tracker.lost(1.9, robot)
        assert bool(len(lost)) is kept
        if kept:
            centre = lost[0]
            assert abs(centre[0] - 2.0) < 0.3 and centre[1] > 0.9  # walked on to the robot's left
            radius = np.hypot(*(lost[1:] - centre).T).max()
            assert 0.25 + 0.2 < radius <= 0.25 + 0.5 + 1e-9
            assert not len(tracker.moving(1.9, robot))  # no longer predicted as if seen


def test_a_walker_lost_just_ahead_slows_the_robot_without_circles_and_not_for_ever():
    """The robot draws level with a walker going its way, out of a narrow view (the short level-4 scene: the patrol
    robot overtook the target robot it had just lost and touched its side). With lost_slow the tracker remembers
    her, predicted on, for lost_near (move_base then creeps): while she is ahead and near, not once she is behind
    the robot or lost_slow s have passed; with lost_keep 0 she is no obstacle circle."""
    from navigation.moving_obstacles import TrackerParams

    hidden = lambda pts: np.ones(len(pts), dtype=bool)  # noqa: E731: out of view, wherever she is
    tracker = ObstacleTracker(TrackerParams(lost_slow=3.0))
    for k in range(8):  # she walks along +x at 0.3 m/s, 1.0 m ahead and 0.3 m to the right of the robot
        robot = np.array([0.0, 0.0, 0.0])
        tracker.update(0.1 * k, robot, seen_arc(np.array([1.0 + 0.03 * k, -0.3]), robot), hidden)
    for k in range(8, 20):
        tracker.update(0.1 * k, np.zeros(3), np.zeros((0, 2)), hidden)
    assert tracker.lost_near(1.9, np.zeros(3), reach=1.6)  # predicted at about x 1.6: ahead, within reach
    assert not tracker.lost_near(1.9, np.zeros(3), reach=1.0)  # out of reach
    assert not tracker.lost_near(1.9, np.array([2.5, 0.0, 0.0]), reach=1.6)  # the robot is past her: behind it
    assert not len(tracker.lost(1.9, np.zeros(3)))  # lost_keep 0: no circle for the planner to steer round
    for k in range(20, 45):
        tracker.update(0.1 * k, np.zeros(3), np.zeros((0, 2)), hidden)
    assert not tracker.lost_near(4.4, np.zeros(3), reach=5.0)  # forgotten after lost_slow
    assert not ObstacleTracker(TrackerParams()).lost_near(0.0, np.zeros(3), reach=5.0)  # off by default


def test_between_two_people_against_it_the_robot_turns_away_from_both():
    """A person stands against the robot's front-left and one against its back-left, each waiting for it (the
    office, seed 2, 75 s): no arc that moves it gets no closer to both, so it turns on the spot, to the right,
    away from them; once turned, an arc away from both is there."""
    params = LocalParams(max_vel_x=0.4, dynamic_padding=0.1)
    robot = np.zeros(3)
    hits = np.concatenate([seen_arc(np.array([0.33, 0.32]), robot), seen_arc(np.array([-0.33, 0.32]), robot)])
    path, goal = np.array([[0.0, 0.0], [3.0, 0.0]]), np.array([3.0, 0.0, 0.0])
    command = compute_command(robot, (0.0, 0.0), path, goal, hits, params, dynamic=hits)
    assert command.ok and command.v == 0.0 and command.w < 0, command
    turned = np.array([0.0, 0.0, -1.2])
    hits_turned = np.concatenate([seen_arc(np.array([0.33, 0.32]), turned), seen_arc(np.array([-0.33, 0.32]), turned)])
    then = compute_command(turned, (0.0, 0.0), path, goal, hits_turned, params, dynamic=hits_turned)
    assert then.ok and then.v > 0, then
