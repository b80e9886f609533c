"""Level 3, patrol: send move_base one goal after another, round and round, in the map frame.

``patrol`` is a client of the ``move_base`` action (actionlib's wire protocol through
:mod:`subsumption.actions`, so it runs the same in-process and against a real move_base). It sends the first
goal, and on each result:

- SUCCEEDED: the goal is reached; the next one is sent (after the last, the first again: a lap is counted);
- PREEMPTED: something above (a higher level, an operator) took the goal away; the same goal is sent again
  (at most `max_resends` times in a row, then it counts as failed);
- ABORTED, REJECTED, RECALLED, LOST: the goal failed. An alarm is raised (what, where) and the goal is
  skipped, never retried for ever; when every goal of a whole lap has failed, the patrol stops and says so.

With ``localization_wait`` > 0, the first goal waits (at most that long) for localization's first estimate on
``pose`` (amcl's ``amcl_pose``): move_base aborts a goal it cannot place the robot for within its own
``wait_for_map``, and on a loaded ROS graph amcl's first estimate came 28 s (simulated, at 3x) after the start,
so the first goal of every lap 1 failed with "no localization". Past the wait it sends anyway and move_base says
what is missing.

A ``hold`` input pauses it: ``true`` cancels the goal under way (a higher level, level 4's pursuit, has the
robot), ``false`` sends that same goal again, so the robot navigates back to where it was heading and patrols on.

It publishes its goals as a latched ``geometry_msgs/PoseArray`` (rviz draws them) and its alarms as
``diagnostic_msgs/DiagnosticStatus`` triggers for the alarm module. move_base not answering within
`server_wait` seconds of the start raises the alarm too, and is logged as an error: a bounded wait, not a
silent hang.
"""
from __future__ import annotations

import math
from pathlib import Path

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from geometry_msgs.msg import Pose, PoseArray, PoseStamped, PoseWithCovarianceStamped
from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
from nav_msgs.msg import OccupancyGrid
from nav_msgs.srv import GetMap, GetMapResponse
from std_msgs.msg import Bool

from subsumption import Input, Module, Output, Param
from subsumption.actions import ActionClient, ClientGoal, GoalStatus
from subsumption.planar import pose_msg
from subsumption.yamlfile import YamlFileError, load as load_yaml

from .alarm import alarm_status

Goal = tuple[float, float, float]


class GoalsError(ValueError):
    """A goal list that cannot be patrolled; the message names the file (or parameter) and the index."""


def parse_goals(data: object, where: str) -> list[Goal]:
    """A YAML goal list, ``[[x, y, yaw], ...]`` (metres, metres, radians; map frame), checked item by item.
    A mapping with a ``goals`` key holding the list is accepted too."""
    if isinstance(data, dict) and "goals" in data:
        data = data["goals"]
    if not isinstance(data, list) or not data:
        raise GoalsError(f"{where}: expected a non-empty list of goals [x, y, yaw], got {type(data).__name__}")
    goals = []
    for i, item in enumerate(data):
        if (not isinstance(item, (list, tuple)) or len(item) != 3
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in item)
                or not all(math.isfinite(v) for v in item)):
            raise GoalsError(f"{where}: goal {i}: expected [x, y, yaw] (three finite numbers), got {item!r}")
        goals.append((float(item[0]), float(item[1]), float(item[2])))
    return goals


def load_goals(path: str | Path) -> list[Goal]:
    """The goals of a YAML goal file (see :func:`parse_goals`); GoalsError names the file."""
    try:
        data = load_yaml(Path(path), "goal file")
    except YamlFileError as error:
        raise GoalsError(str(error)) from None
    return parse_goals(data, str(path))


def pose_of(goal: Goal) -> Pose:
    return pose_msg(goal)


class MapServer(Module):
    """map_server's job: reads a map_server map (YAML + image) and publishes it once, latched, in frame
    `frame_id`: the map built beforehand that localization and navigation work on."""

    map = Output(OccupancyGrid, "the map (latched)", latch=True)
    map_file = Param("", "the map_server YAML file", required=True)
    frame_id = Param("map", "frame of the map")

    def setup(self) -> None:
        from navigation.grid_messages import grid_msg
        from subsumption.mapfile import read_map_file

        if not self.map_file:
            raise ValueError(f"{self.node.resolve('~map_file')}: no map file given")
        grid = grid_msg(read_map_file(self.map_file), self.now(), self.frame_id)
        self.map.publish(grid)
        self.node.service("static_map", GetMap, lambda _request: GetMapResponse(grid))  # map_server's service


class Patrol(Module):
    """Patrols a list of goals through move_base: next goal on success, the same again when preempted, an
    alarm and the next one when a goal fails; counts goals sent and reached and laps. `hold` pauses it.

    It also hears the network monitor's reports of deaths (`liveness`): when a node the network file marks
    ``critical: WHAT`` dies, it raises the alarm "WHAT lost" (spoken), and when WHAT is one of `fails_goal`
    (navigation) the goal under way fails at once and no goal is sent until that node is back (respawned): a
    dead move_base answers nothing, and the robot must not wait on it in silence. Meanwhile the lower levels
    drive (navigation's suppressor lets go within its time constant)."""

    hold = Input(Bool, "true: pause (the goal under way is cancelled); false: go on to that same goal")
    pose = Input(PoseWithCovarianceStamped, "localization's estimate (amcl_pose): the first goal waits for it")
    liveness = Input(DiagnosticStatus, "the network monitor's deaths and returns (<network>_monitor/liveness)")
    goals = Output(PoseArray, "the goals, in order, frame `frame_id` (latched, for rviz)", latch=True)
    alarm = Output(DiagnosticStatus, "alarm triggers: a goal that failed, move_base not answering")
    goal_list = Param([], "goals [[x, y, yaw], ...] in the map frame (m, m, rad); used when not empty")
    goal_file = Param("", "a YAML file holding the goal list (when goal_list is empty)", per_run=True)
    action = Param("move_base", "name of the move_base action")
    frame_id = Param("map", "frame of the goals")
    laps = Param(0, "laps to patrol, then stop (0: for ever)", min=0)
    max_resends = Param(3, "a goal preempted more often than this in a row counts as failed", min=0)
    server_wait = Param(30.0, "s to wait for move_base at the start before raising the alarm", min=0.0)
    start_delay = Param(1.0, "s after start before the first goal (localization settles)", min=0.0)
    localization_wait = Param(0.0, "s the first goal waits at most for an estimate on `pose` (0: no wait)",
                              min=0.0)
    fails_goal = Param(["navigation"], "what, when a critical node that provides it dies, fails the goal under "
                                       "way and holds the patrol until it is back")

    def setup(self) -> None:
        if self.goal_list:
            self.route = parse_goals(self.goal_list, self.node.resolve("~goal_list"))
        elif self.goal_file:
            self.route = load_goals(self.goal_file)
        else:
            raise GoalsError(f"{self.node.resolve('~goal_list')}: no goals (set ~goal_list or ~goal_file)")
        self.client = ActionClient(self.node, self.action, MoveBaseAction)
        self.index = 0
        self.sent = 0
        self.reached = 0
        self.completed_laps = 0
        self.failed: list[int] = []
        self.stopped = ""
        self._resends = 0
        self._failures_in_a_row = 0
        self._current: ClientGoal | None = None
        self.holding = False
        self.localized = False
        self._start_due = False  # start_delay is over
        self._waiting = self.localization_wait > 0  # the first goal waits for localization
        self.lost: dict[tuple[str, str], str] = {}  # (dead critical node, what) -> what the robot lost with it
        self.every(10.0, self._keep_lost_raised)
        self._publish_goals()
        self.after(self.start_delay, self._first_goal)
        if self._waiting:
            self.after(self.start_delay + self.localization_wait, self._stop_waiting)
        self.after(self.server_wait, self._check_server)

    def _publish_goals(self) -> None:
        array = PoseArray()
        array.header.frame_id = self.frame_id
        array.poses = [pose_of(goal) for goal in self.route]
        self.goals.publish(array)

    def _check_server(self) -> None:
        if not self.client.server_seen:
            text = f"move_base is not answering on {self.client.name} after {self.server_wait:g} s"
            self.log(text, "error")
            self.alarm.publish(alarm_status("navigation", text, level=DiagnosticStatus.ERROR))

    def on_pose(self, msg: PoseWithCovarianceStamped) -> None:
        if not self.localized:
            self.localized = True
            if self._waiting:
                self.log("localized: the first goal goes")
                self._waiting = False
                if self._start_due:
                    self._send_current()

    def _first_goal(self) -> None:
        self._start_due = True
        self._send_current()

    def _stop_waiting(self) -> None:
        if self._waiting:
            self._waiting = False
            self.log(f"no estimate on {self.node.resolve('pose')} within {self.localization_wait:g} s: "
                     f"sending the first goal anyway", "warn")
            self._send_current()

    def on_hold(self, msg: Bool) -> None:
        if bool(msg.data) == self.holding:
            return
        self.holding = bool(msg.data)
        if self.holding:
            self.log(f"hold: goal {self.index} paused")
            current, self._current = self._current, None  # its PREEMPTED result is not ours to act on
            if current is not None:
                current.cancel()
        else:
            self.log(f"hold released: back to goal {self.index}")
            self._send_current()

    def on_liveness(self, msg: DiagnosticStatus) -> None:
        values = {kv.key: kv.value for kv in msg.values}
        event, node = values.get("event", ""), msg.name.lstrip("/")
        # a node hosting several modules (a group) may take several functions with it: "navigation,camera"
        for what in [w for w in values.get("critical", "").split(",") if w]:
            if event == "death":
                self._lost(node, what, values.get("how", "").split(" (")[0] or "died")
            elif event in ("respawn", "back"):
                self._back(node, what, event)

    def _lost(self, node: str, what: str, how: str) -> None:
        self.lost[(node, what)] = what
        text = f"{what.capitalize()} lost: {node} {how}."
        self.log(text, "error")
        alarm = alarm_status(f"{what} lost", text, level=DiagnosticStatus.ERROR)
        if what in self.fails_goal and self._current is not None:
            current, self._current = self._current, None  # no result will come from a dead server
            current.cancel()
            current.done = True
            self._resends = 0
            self.failed.append(self.index)
            x, y, _ = self.route[self.index]
            self.log(f"goal {self.index} ({x:.2f}, {y:.2f}) failed: {what} lost", "warn")
            alarm = alarm_status(f"{what} lost", text, x, y, self.frame_id, level=DiagnosticStatus.ERROR)
            alarm.values.append(KeyValue("goal", str(self.index)))
            self._advance()  # the failed goal is skipped, as any failed goal; nothing is sent while lost
        self.alarm.publish(alarm)

    def _back(self, node: str, what: str, event: str) -> None:
        if self.lost.pop((node, what), None) is None or what in self.lost.values():
            return
        self.log(f"{what} back: {node} {'respawned' if event == 'respawn' else 'answers again'}")
        self.alarm.publish(alarm_status(f"{what} lost", f"{what.capitalize()} back.", level=DiagnosticStatus.OK))
        if what in self.fails_goal:
            self._send_current()

    def _navigation_lost(self) -> bool:
        return any(what in self.fails_goal for what in self.lost.values())

    def _keep_lost_raised(self) -> None:
        """A lost function's alarm stays raised while it is lost (the alarm module clears a silent one)."""
        for what in set(self.lost.values()):
            nodes = ", ".join(sorted(n for (n, _), w in self.lost.items() if w == what))
            self.alarm.publish(alarm_status(f"{what} lost", f"{what.capitalize()} lost: {nodes} down.",
                                            level=DiagnosticStatus.ERROR))

    def _send_current(self) -> None:
        if self.stopped or self.holding or self._waiting or self._current is not None or self._navigation_lost():
            return
        goal = MoveBaseGoal()
        goal.target_pose = PoseStamped()
        goal.target_pose.header.frame_id = self.frame_id
        goal.target_pose.pose = pose_of(self.route[self.index])
        self.sent += 1
        x, y, _ = self.route[self.index]
        self.log(f"goal {self.index} ({x:.2f}, {y:.2f}) sent")
        self._current = self.client.send_goal(goal, done=self._on_done)

    def _on_done(self, handle: ClientGoal) -> None:
        if handle is not self._current:
            return
        self._current = None
        x, y, _ = self.route[self.index]
        if handle.status == GoalStatus.SUCCEEDED:
            self.reached += 1
            self._resends = 0
            self._failures_in_a_row = 0
            self.log(f"goal {self.index} reached")
            self._advance()
        elif handle.status == GoalStatus.PREEMPTED and self._resends < self.max_resends:
            self._resends += 1
            self.log(f"goal {self.index} preempted: sending it again ({self._resends}/{self.max_resends})")
            self._send_current()
        else:
            self._resends = 0
            self._failures_in_a_row += 1
            self.failed.append(self.index)
            why = handle.text or handle.status_name.lower()
            text = f"Patrol goal {self.index} at x {x:.1f}, y {y:.1f} failed: {why}. Skipping it."
            self.log(text, "warn")
            status = alarm_status("navigation", text, x, y, self.frame_id)
            status.values.append(KeyValue("goal", str(self.index)))
            self.alarm.publish(status)
            if self._failures_in_a_row >= len(self.route):
                self.stopped = f"every goal of a whole lap failed; patrol stopped"
                self.log(self.stopped, "error")
                self.alarm.publish(alarm_status("patrol", "Patrol stopped: no goal can be reached.",
                                                level=DiagnosticStatus.ERROR))
                return
            self._advance()

    def _advance(self) -> None:
        self.index += 1
        if self.index == len(self.route):
            self.index = 0
            self.completed_laps += 1
            self.log(f"lap {self.completed_laps} done")
            if self.laps and self.completed_laps >= self.laps:
                self.stopped = f"{self.completed_laps} laps done"
                return
        self._send_current()
