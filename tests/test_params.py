"""Module parameters: typed from their default (or declared), checked with errors naming the parameter, written
back where the runtime keeps parameters, changeable on a running module, and checked in network files."""
from __future__ import annotations

import pytest
from std_msgs.msg import Float64
from test_network_files import LEVEL0, write

from subsumption import LocalRuntime, Module, Output, Param, ParamError
from subsumption.examples.avoid_demo import Wander
from subsumption.network import check_file
from subsumption.testing import Harness


class Knobs(Module):
    ratio = Param(0.5, "a float")
    count = Param(12, "an int")
    name = Param("odom", "a string")
    flag = Param(False, "a bool")
    gains = Param([1.0, 2.0], "a list")
    bounded = Param(1.0, "a float in [0, 2]", min=0.0, max=2.0)
    declared = Param(0, "a float declared as such", type=float)


class Ticker(Module):
    """Sends `value` every `period` s: a parameter read in setup only (period) and one read at every use."""

    out = Output(Float64)
    period = Param(1.0)
    value = Param(0.0)

    def setup(self) -> None:
        self.every(self.period, lambda: self.out.publish(Float64(self.value)))


def test_types_come_from_defaults_or_declarations():
    params = Knobs.interface.params
    assert {name: p.type for name, p in params.items()} == {
        "ratio": float, "count": int, "name": str, "flag": bool, "gains": list, "bounded": float, "declared": float}
    assert params["declared"].default == 0.0 and isinstance(params["declared"].default, float)
    assert "param  bounded = 1.0 (float, min 0, max 2)  a float in [0, 2]" in Knobs.describe()


@pytest.mark.parametrize("name,value,expected", [
    ("ratio", 3, 3.0), ("ratio", 2.5, 2.5), ("count", 7, 7), ("count", 7.0, 7), ("name", "map", "map"),
    ("flag", True, True), ("gains", [3], [3]), ("bounded", 2, 2.0), ("bounded", 0.0, 0.0)])
def test_good_values_are_taken_and_typed(name, value, expected):
    got = Knobs.interface.params[name].coerce(value, f"/knobs/{name}")
    assert got == expected and type(got) is type(expected)


@pytest.mark.parametrize("name,value,message", [
    ("ratio", "abc", "/knobs/ratio must be a number, got 'abc' (str)"),
    ("ratio", True, "/knobs/ratio must be a number, got True (bool)"),
    ("count", 7.5, "/knobs/count must be an integer, got 7.5 (float)"),
    ("count", "12", "/knobs/count must be an integer, got '12' (str)"),
    ("name", 3, "/knobs/name must be a string, got 3 (int)"),
    ("flag", 1, "/knobs/flag must be a boolean (true or false), got 1 (int)"),
    ("gains", 1.0, "/knobs/gains must be a list, got 1.0 (float)"),
    ("bounded", -0.5, "/knobs/bounded must be >= 0, got -0.5"),
    ("bounded", 2.5, "/knobs/bounded must be <= 2, got 2.5")])
def test_bad_values_are_refused_naming_the_parameter(name, value, message):
    with pytest.raises(ParamError) as raised:
        Knobs.interface.params[name].coerce(value, f"/knobs/{name}")
    assert str(raised.value) == message


def test_a_default_that_contradicts_the_declared_type_is_caught_at_the_class():
    with pytest.raises(ParamError, match="must be an integer"):
        Param("twelve", type=int)


def test_a_module_with_a_bad_value_does_not_start():
    runtime = LocalRuntime()
    with pytest.raises(ParamError, match=r"^/robot1/wander/period must be a number, got 'abc' \(str\)$"):
        runtime.add_module(Wander, "/robot1/wander", params={"period": "abc"})


def test_every_value_in_use_is_written_back():
    runtime = LocalRuntime()
    node_params = {"count": 3}
    module = runtime.add_module(Knobs, "knobs", params=node_params)
    written = runtime.nodes["/knobs"]._params
    assert written == {"ratio": 0.5, "count": 3, "name": "odom", "flag": False, "gains": [1.0, 2.0], "bounded": 1.0,
                       "declared": 0.0}
    assert module.count == 3


def test_reconfigure_a_running_module():
    harness = Harness(Ticker, params={"period": 1.0, "value": 1.0})
    harness.run_for(2.5)
    changed = harness.module.reconfigure({"value": 2, "period": 0.25})  # an int for a float: taken as 2.0
    assert changed == {"value": 2.0, "period": 0.25}
    harness.run_for(1.0)
    times = [round(t, 3) for t, _ in harness.outputs["out"]]
    values = [msg.data for _, msg in harness.outputs["out"]]
    # setup ran again: its old 1-s timer is gone, the new one ticks every 0.25 s from the change
    assert times == [1.0, 2.0, 2.75, 3.0, 3.25, 3.5] and values == [1.0, 1.0, 2.0, 2.0, 2.0, 2.0]
    assert harness.runtime.nodes["/module_under_test"]._params["period"] == 0.25


def test_a_refused_reconfigure_changes_nothing():
    harness = Harness(Ticker, params={"period": 1.0, "value": 1.0})
    with pytest.raises(ParamError, match="/module_under_test/value must be a number"):
        harness.module.reconfigure({"period": 0.5, "value": "x"})  # the good one is not applied either
    with pytest.raises(ParamError, match="/module_under_test/period: refused, the module failed with the new "
                                         "values: ValueError: .*timer period must be > 0"):
        harness.module.reconfigure({"period": -1.0})
    with pytest.raises(ParamError, match="has no param 'nope'"):
        harness.module.reconfigure({"nope": 1})
    harness.run_for(2.0)
    assert harness.module.period == 1.0 and len(harness.sent("out")) == 2  # the 1-s timer still runs, once
    assert harness.runtime.nodes["/module_under_test"]._params["period"] == 1.0


def test_check_reports_bad_values_in_a_network_file(tmp_path):
    text = LEVEL0.replace(":FeelForce\n", ":FeelForce\n        params: {period: fast, y: 2}\n")
    result = check_file(write(tmp_path, text))
    assert [str(e) for e in result.errors] == [
        f"{tmp_path / 'net.yaml'}:8: module feelforce: param period must be a number, got 'fast' (str)"]
