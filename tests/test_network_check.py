"""Every kind of problem the loader and `subsumption check` find, each reported as FILE:LINE: naming the thing."""
from __future__ import annotations

import pytest
from test_network_files import DEMO, EXAMPLE, LEVEL0, WANDER, line_of, write

from subsumption.network import NetworkInvalid, check_file, load

ROOT = EXAMPLE.parent.parent.parent


@pytest.fixture(autouse=True)
def ros_package_path(monkeypatch):
    """Existing nodes are looked up the way roslaunch does, on ROS_PACKAGE_PATH."""
    monkeypatch.setenv("ROS_PACKAGE_PATH", f"{ROOT}:/usr/share")


def errors_of(path, level=None) -> list[str]:
    return [str(error) for error in check_file(path, level).errors]


def assert_error(path, needle_line: str, *words: str, occurrence: int = 1, level=None) -> str:
    """Exactly one error at the line holding `needle_line` that mentions every word; return it."""
    prefix = f"{path}:{line_of(path, needle_line, occurrence)}: "
    found = [e for e in errors_of(path, level) if e.startswith(prefix) and all(w in e for w in words)]
    assert len(found) == 1, (prefix, words, errors_of(path, level))
    return found[0]


def test_example_passes():
    result = check_file(EXAMPLE)
    assert result.ok, result.errors
    assert result.summary().startswith(f"{EXAMPLE}: OK: network avoid_demo, levels 0..1")
    assert check_file(EXAMPLE, level=0).ok


def test_level0_of_the_small_network_passes(tmp_path):
    assert errors_of(write(tmp_path, LEVEL0)) == []


def test_a_name_with_a_line_break_stays_on_its_error_line(tmp_path):
    """A control character in a module name (a damaged file) is escaped in the message, not printed raw."""
    path = write(tmp_path, LEVEL0.replace("name: runaway", 'name: "run\\x1caway"'))
    errors = errors_of(path)
    assert errors and all(len(error.splitlines()) == 1 for error in errors), errors
    assert any("run\\x1caway" in error for error in errors), errors


def test_unknown_class(tmp_path):
    path = write(tmp_path, LEVEL0.replace(f"{DEMO}:Runaway", f"{DEMO}:Runaway2"))
    assert_error(path, "name: runaway", "module runaway", "Runaway2")


def test_class_that_is_not_a_module(tmp_path):
    path = write(tmp_path, LEVEL0.replace(f"{DEMO}:Runaway", "subsumption.arbiter:Arbiter"))
    assert_error(path, "name: runaway", "module runaway", "not a subsumption Module subclass")


def test_unimportable_python_module(tmp_path):
    path = write(tmp_path, LEVEL0.replace(f"{DEMO}:Runaway", "no_such_package.mod:Runaway"))
    assert_error(path, "name: runaway", "module runaway", "cannot import 'no_such_package.mod'")


@pytest.mark.parametrize("node, words", [("no_such_pkg/relay", ["package 'no_such_pkg' not found"]),
                                         ("rosout/no_such_exe", ["package 'rosout' has no executable 'no_such_exe'"]),
                                         ("relay", ["not of the form package/type"])])
def test_bad_package_or_type(tmp_path, node, words):
    path = write(tmp_path, LEVEL0 + f"""\
      - name: listener
        node: {node}
        inputs: {{heading: {{from: runaway.heading, type: std_msgs/Float64}}}}
""")
    assert_error(path, "name: listener", "module listener", *words)


def test_existing_node_port_needs_a_type(tmp_path):
    path = write(tmp_path, LEVEL0 + """\
      - name: listener
        node: rostopic/rostopic
        inputs: {heading: runaway.heading}
""")
    assert_error(path, "inputs: {heading: runaway.heading}", "module listener: input heading", "need a 'type'",
                 occurrence=2)


def test_unknown_module_in_reference(tmp_path):
    path = write(tmp_path, LEVEL0.replace("{heading: runaway.heading}", "{heading: runaway2.heading}"))
    assert_error(path, "runaway2.heading", "module turn: input heading", "unknown module 'runaway2'")


def test_unknown_port_in_reference(tmp_path):
    path = write(tmp_path, LEVEL0.replace("{heading: runaway.heading}", "{heading: runaway.direction}"))
    assert_error(path, "runaway.direction", "module turn: input heading", "module runaway has no output 'direction'")


def test_port_the_class_does_not_have(tmp_path):
    path = write(tmp_path, LEVEL0.replace("{force: feelforce.force}", "{force: feelforce.force, speed: feelforce.force}"))
    assert_error(path, "speed: feelforce.force", "module runaway", "has no input 'speed'")


def test_unknown_param(tmp_path):
    path = write(tmp_path, LEVEL0.replace("{force: feelforce.force}", "{force: feelforce.force}\n        params: {gian: 2}"))
    assert_error(path, "name: runaway", "module runaway", "has no param 'gian'")


def test_unknown_topic(tmp_path):
    path = write(tmp_path, LEVEL0.replace("{force: feelforce.force}", "{force: sonar}"))
    errors = errors_of(path)
    assert f"{path}:{line_of(path, 'force: sonar')}: module runaway: input force: unknown topic 'sonar' " \
           f"(not a module.port and not declared under external)" in errors


def test_output_with_no_reader(tmp_path):
    path = write(tmp_path, LEVEL0.replace("        outputs: {cmd_vel: cmd_vel}\n", ""))
    assert_error(path, "name: turn", "module turn: output cmd_vel has no reader")


def test_input_with_no_writer(tmp_path):
    path = write(tmp_path, LEVEL0.replace("        inputs: {force: feelforce.force}\n", ""))
    assert_error(path, "name: runaway", "module runaway: input force has no writer")


def test_type_mismatch_across_a_wire(tmp_path):
    path = write(tmp_path, LEVEL0.replace("{heading: runaway.heading}", "{heading: feelforce.force}"))
    error = assert_error(path, "heading: feelforce.force", "module turn: input heading")
    assert "geometry_msgs/Vector3Stamped" in error and "std_msgs/Float64" in error


def test_type_mismatch_with_an_external_topic(tmp_path):
    path = write(tmp_path, LEVEL0.replace("cmd_vel: geometry_msgs/Twist", "cmd_vel: std_msgs/Float64"))
    error = assert_error(path, "outputs: {cmd_vel: cmd_vel}", "module turn: output cmd_vel", "external topic cmd_vel")
    assert "geometry_msgs/Twist" in error


def test_unknown_message_type(tmp_path):
    path = write(tmp_path, LEVEL0.replace("cmd_vel: geometry_msgs/Twist", "cmd_vel: geometry_msgs/Twisty"))
    assert_error(path, "cmd_vel: geometry_msgs/Twisty", "external topic cmd_vel", "unknown message type")




def test_type_mismatch_across_an_arbiter(tmp_path):
    path = write(tmp_path, LEVEL0 + WANDER + """\
      - {kind: suppressor, upper: feelforce.force, lower: turn.heading, time_constant: 20}
      - {kind: suppressor, upper: avoid.heading, lower: runaway.heading, time_constant: 20}
""")
    error = assert_error(path, "upper: feelforce.force", "arbiter suppressor_turn_heading", "must have one type")
    assert "geometry_msgs/Vector3Stamped" in error and "std_msgs/Float64" in error


def test_an_inhibitor_may_have_another_upper_type(tmp_path):
    path = write(tmp_path, LEVEL0 + WANDER + """\
      - {kind: inhibitor, upper: feelforce.force, lower: turn.heading, time_constant: 20}
      - {kind: suppressor, upper: avoid.heading, lower: runaway.heading, time_constant: 20}
""")
    assert errors_of(path) == []


def test_arbiter_upper_must_be_an_output(tmp_path):
    path = write(tmp_path, LEVEL0 + WANDER + """\
      - {kind: suppressor, upper: cmd_vel, lower: turn.heading, time_constant: 20}
      - {kind: suppressor, upper: avoid.heading, lower: runaway.heading, time_constant: 20}
""")
    assert_error(path, "upper: cmd_vel", "arbiter suppressor_turn_heading", "upper must be a module output")


def test_arbiter_lower_port_unknown(tmp_path):
    path = write(tmp_path, LEVEL0 + WANDER + """\
      - {kind: suppressor, upper: avoid.heading, lower: turn.nothing, time_constant: 20}
""")
    assert_error(path, "lower: turn.nothing", "arbiter suppressor_turn_nothing: lower", "module turn has no line 'nothing'")


def test_duplicate_module_names(tmp_path):
    path = write(tmp_path, LEVEL0 + f"""\
      - name: runaway
        class: {DEMO}:Runaway
        inputs: {{force: feelforce.force}}
""")
    assert_error(path, "name: runaway", "duplicate name: module runaway", occurrence=2)


def test_duplicate_arbiter_names(tmp_path):
    path = write(tmp_path, LEVEL0 + WANDER + """\
      - {kind: suppressor, upper: avoid.heading, lower: turn.heading, time_constant: 20}
      - {kind: suppressor, upper: avoid.heading, lower: turn.heading, time_constant: 10}
""")
    assert_error(path, "time_constant: 10", "duplicate name: arbiter suppressor_turn_heading")


def test_missing_time_constant(tmp_path):
    path = write(tmp_path, LEVEL0 + WANDER + """\
      - {kind: suppressor, upper: avoid.heading, lower: turn.heading}
""")
    assert_error(path, "lower: turn.heading}", "arbiter suppressor_turn_heading: time_constant is required")


def test_non_positive_time_constant(tmp_path):
    path = write(tmp_path, LEVEL0 + WANDER + """\
      - kind: suppressor
        upper: avoid.heading
        lower: turn.heading
        time_constant: -2
""")
    error = assert_error(path, "time_constant: -2", "arbiter suppressor_turn_heading")
    assert error == f"{path}:{line_of(path, 'time_constant: -2')}: arbiter suppressor_turn_heading: " \
                    f"time_constant must be > 0, got -2"


def test_unknown_keys(tmp_path):
    path = write(tmp_path, LEVEL0.replace("time_unit: 0.1", "time_unit: 0.1\ncolour: red")
                 .replace("class: subsumption.examples.avoid_demo:Turn",
                          "class: subsumption.examples.avoid_demo:Turn\n        input: {heading: x}"))
    assert_error(path, "colour: red", "network: unknown key 'colour'")
    assert_error(path, "input: {heading: x}", "module turn: unknown key 'input'")


def test_unknown_arbiter_kind(tmp_path):
    path = write(tmp_path, LEVEL0 + WANDER + """\
      - {kind: subsumer, upper: avoid.heading, lower: turn.heading, time_constant: 20}
""")
    assert_error(path, "kind: subsumer", "kind must be one of inhibitor, suppressor, defaulter, got 'subsumer'")


def test_a_level_may_not_read_a_higher_level(tmp_path):
    path = write(tmp_path, LEVEL0.replace("{heading: runaway.heading}", "{heading: wander.heading}") + WANDER
                 + "      - {kind: suppressor, upper: avoid.heading, lower: turn.heading, time_constant: 20}\n")
    assert_error(path, "heading: wander.heading}", "module turn: input heading", "belongs to level 1")


def test_external_written_twice(tmp_path):
    path = write(tmp_path, LEVEL0 + f"""\
      - name: turn2
        class: {DEMO}:Turn
        inputs: {{heading: runaway.heading}}
        outputs: {{cmd_vel: cmd_vel}}
""")
    assert_error(path, "cmd_vel: geometry_msgs/Twist", "external topic cmd_vel is written by 2 lines")


def test_no_such_level(tmp_path):
    path = write(tmp_path, LEVEL0)
    assert_error(path, "name: tiny", "no level 3", level=3)


def test_yaml_syntax_error(tmp_path):
    path = write(tmp_path, LEVEL0.replace("inputs: {force: feelforce.force}", "inputs: {force: feelforce.force"))
    [error] = errors_of(path)
    assert error.startswith(f"{path}:") and "not valid YAML" in error


def test_every_error_is_reported_at_once(tmp_path):
    path = write(tmp_path, LEVEL0.replace("time_unit: 0.1", "time_unit: 0.1\ncolour: red")
                 .replace("{heading: runaway.heading}", "{heading: runaway.direction}")
                 .replace(f"{DEMO}:FeelForce", f"{DEMO}:Nothing"))
    errors = errors_of(path)
    assert any("unknown key 'colour'" in e for e in errors)
    assert any("no output 'direction'" in e for e in errors)
    assert any("module feelforce" in e and "Nothing" in e for e in errors)


def test_load_raises_with_every_structural_error(tmp_path):
    path = write(tmp_path, LEVEL0.replace("time_unit: 0.1", "time_unit: -1\ncolour: red"))
    with pytest.raises(NetworkInvalid) as raised:
        load(path)
    assert [str(e) for e in raised.value.errors] == [
        f"{path}:2: time_unit must be > 0 seconds, got -1", f"{path}:3: network: unknown key 'colour' "
        f"(expected one of description, external, levels, name, time_unit)"]
