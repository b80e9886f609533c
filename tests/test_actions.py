"""subsumption.actions: actionlib's protocol on the core's NodeHandle, in-process and against ROS's own actionlib.

The in-process tests wire a module-side client to a module-side server in one LocalRuntime; the ROS tests put
our server under a real ``actionlib.SimpleActionClient`` and our client against a real
``actionlib.SimpleActionServer``, each in its own process on a private master."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from actionlib_msgs.msg import GoalStatusArray
from actionlib.msg import TestAction as CountAction
from actionlib.msg import TestFeedback as CountFeedback
from actionlib.msg import TestGoal as CountGoal
from actionlib.msg import TestResult as CountResult

from subsumption import LocalRuntime
from subsumption.actions import ActionClient, ActionServer, GoalStatus, ServerGoal

ROOT = Path(__file__).resolve().parent.parent


class Worker:
    """A server that succeeds a positive goal after 1 s, aborts a negative one at once, and works on 0 forever."""

    def __init__(self, runtime: LocalRuntime, single_goal: bool = True) -> None:
        self.node = runtime.node("worker")
        self.server = ActionServer(self.node, "work", CountAction, self.on_goal, on_cancel=self.on_cancel,
                                   single_goal=single_goal)
        self.cancelled: list[str] = []

    def on_goal(self, handle: ServerGoal) -> None:
        if handle.goal.goal < 0:
            handle.accept()
            handle.abort(CountResult(result=-1), "negative goals cannot be reached")
            return
        handle.accept()
        handle.feedback(CountFeedback(feedback=handle.goal.goal))
        if handle.goal.goal > 0:
            self.node.call_later(1.0, lambda: handle.active and handle.succeed(CountResult(result=2 * handle.goal.goal),
                                                                                 "done"))

    def on_cancel(self, handle: ServerGoal) -> None:
        self.cancelled.append(handle.id)
        handle.cancelled(CountResult(result=0), "cancelled on request")


def make() -> tuple[LocalRuntime, Worker, ActionClient, list]:
    runtime = LocalRuntime()
    worker = Worker(runtime)
    client = ActionClient(runtime.node("caller"), "/work", CountAction)
    done: list = []
    return runtime, worker, client, done


def test_goal_succeeds_with_result_and_feedback():
    runtime, worker, client, done = make()
    feedback, active = [], []
    goal = client.send_goal(CountGoal(goal=3), done=done.append, active=active.append,
                            feedback=lambda g, f: feedback.append(f.feedback))
    runtime.run_for(0.5)  # the goal waits for the server's first status, then goes
    assert goal.status == GoalStatus.ACTIVE and active == [goal] and feedback == [3] and not done
    runtime.run_for(1.5)
    assert done == [goal] and goal.status == GoalStatus.SUCCEEDED and goal.result.result == 6
    assert goal.text == "done" and goal.status_name == "SUCCEEDED"


def test_abort_cancel_and_preemption_by_a_newer_goal():
    runtime, worker, client, done = make()
    failing = client.send_goal(CountGoal(goal=-1), done=done.append)
    runtime.run_for(0.5)
    assert failing.status == GoalStatus.ABORTED and failing.text == "negative goals cannot be reached"
    endless = client.send_goal(CountGoal(goal=0), done=done.append)
    runtime.run_for(0.5)
    endless.cancel()
    runtime.run_for(0.5)
    assert endless.status == GoalStatus.PREEMPTED and worker.cancelled == [endless.id]
    first = client.send_goal(CountGoal(goal=0), done=done.append)
    runtime.run_for(0.5)
    second = client.send_goal(CountGoal(goal=5), done=done.append)
    runtime.run_for(2.0)
    assert first.status == GoalStatus.PREEMPTED and first.text == "preempted by a newer goal"
    assert second.status == GoalStatus.SUCCEEDED
    assert done == [failing, endless, first, second]


def test_status_lists_goals_and_forgets_finished_ones():
    runtime, worker, client, done = make()
    goal = client.send_goal(CountGoal(goal=1), done=done.append)
    runtime.run_for(2.0)
    assert goal.done and goal.id in worker.server.goals
    runtime.run_for(6.0)  # status_list_timeout 5 s
    assert goal.id not in worker.server.goals


def test_a_lost_goal_is_sent_again_and_a_resend_is_not_a_second_goal():
    runtime = LocalRuntime()
    client = ActionClient(runtime.node("caller"), "/work", CountAction)
    status = runtime.node("fake_status").publisher("/work/status", GoalStatusArray)
    goal = client.send_goal(CountGoal(goal=1))
    status.publish(GoalStatusArray())  # a server seen, but nobody listening on /work/goal yet: the goal is lost
    runtime.run_for(0.1)
    worker = Worker(runtime)  # now the server is there
    got: list = []
    original = worker.on_goal
    worker.server.on_goal = lambda h: (got.append(h.id), original(h))
    runtime.run_for(3.0)
    assert got == [goal.id] and goal.status == GoalStatus.SUCCEEDED


def test_wrong_goal_type_is_refused_by_name():
    runtime, worker, client, done = make()
    with pytest.raises(TypeError, match="/work: goal must be TestGoal, got TestResult"):
        client.send_goal(CountResult(result=1))


# Against ROS's own actionlib ----------------------------------------------------------------------------

OUR_SERVER = r"""
import rospy
from actionlib.msg import TestAction, TestFeedback, TestResult
from subsumption.ros.runtime import init_node
from subsumption.actions import ActionServer
node = init_node("our_server")
def on_goal(h):
    h.accept()
    if h.goal.goal < 0:
        h.abort(TestResult(result=-1), "negative goals cannot be reached")
    elif h.goal.goal > 0:
        node.call_later(0.5, lambda: h.active and h.succeed(TestResult(result=2 * h.goal.goal), "done"))
with node.lock:
    server = ActionServer(node, "/work", TestAction, on_goal, single_goal=True)
rospy.spin()
"""

REAL_CLIENT = r"""
import json, rospy, actionlib
from actionlib.msg import TestAction, TestGoal
rospy.init_node("real_client")
client = actionlib.SimpleActionClient("/work", TestAction)
assert client.wait_for_server(rospy.Duration(20)), "server not found"
out = {}
client.send_goal(TestGoal(goal=4)); client.wait_for_result(rospy.Duration(10))
out["positive"] = [client.get_state(), client.get_result().result, client.get_goal_status_text()]
client.send_goal(TestGoal(goal=-2)); client.wait_for_result(rospy.Duration(10))
out["negative"] = [client.get_state(), client.get_goal_status_text()]
client.send_goal(TestGoal(goal=0)); rospy.sleep(0.5); client.cancel_goal(); client.wait_for_result(rospy.Duration(10))
out["cancelled"] = [client.get_state(), client.get_goal_status_text()]
print(json.dumps(out))
"""

REAL_SERVER = r"""
import rospy, actionlib
from actionlib.msg import TestAction, TestResult
rospy.init_node("real_server")
def execute(goal):
    start = rospy.get_time()
    while rospy.get_time() - start < 0.5:
        if server.is_preempt_requested():
            server.set_preempted(TestResult(result=0), "preempted"); return
        rospy.sleep(0.05)
    if goal.goal < 0:
        server.set_aborted(TestResult(result=-1), "negative")
    elif goal.goal == 0:
        while not server.is_preempt_requested() and not rospy.is_shutdown():
            rospy.sleep(0.05)
        server.set_preempted(TestResult(result=0), "preempted")
    else:
        server.set_succeeded(TestResult(result=3 * goal.goal), "tripled")
server = actionlib.SimpleActionServer("/work", TestAction, execute, auto_start=False)
server.start()
rospy.spin()
"""

OUR_CLIENT = r"""
import json, threading, rospy
from actionlib.msg import TestAction, TestGoal
from subsumption.ros.runtime import init_node
from subsumption.actions import ActionClient
node = init_node("our_client")
finished = threading.Event()
out = {}
with node.lock:
    client = ActionClient(node, "/work", TestAction)
    def after_first(g):
        out["positive"] = [g.status_name, g.result.result, g.text]
        node.call_later(0.1, lambda: client.send_goal(TestGoal(goal=0), done=after_second, active=cancel_it))
    def cancel_it(g):
        node.call_later(0.3, g.cancel)
    def after_second(g):
        out["cancelled"] = [g.status_name, g.text]
        finished.set()
    client.send_goal(TestGoal(goal=7), done=after_first)  # sent when the server shows up
finished.wait(30)
print(json.dumps(out))
"""


def run_script(ros_processes, script: str) -> dict:
    process = ros_processes.start([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    out, err = process.communicate(timeout=60)
    assert process.returncode == 0, err[-3000:]
    return json.loads(out.strip().splitlines()[-1])


@pytest.mark.timeout(90)
def test_real_simple_action_client_against_our_server(ros_processes):
    ros_processes.start([sys.executable, "-c", OUR_SERVER])
    out = run_script(ros_processes, REAL_CLIENT)
    assert out["positive"] == [GoalStatus.SUCCEEDED, 8, "done"]
    assert out["negative"] == [GoalStatus.ABORTED, "negative goals cannot be reached"]
    assert out["cancelled"][0] == GoalStatus.PREEMPTED


@pytest.mark.timeout(90)
def test_our_client_against_real_simple_action_server(ros_processes):
    ros_processes.start([sys.executable, "-c", REAL_SERVER])
    out = run_script(ros_processes, OUR_CLIENT)
    assert out["positive"] == ["SUCCEEDED", 21, "tripled"]
    assert out["cancelled"] == ["PREEMPTED", "preempted"]
