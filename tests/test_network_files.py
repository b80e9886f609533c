"""Small network files shared by the network tests (written into a test's tmp_path), and a way to find a line in them.

No tests here: the name only keeps it among the network tests.
"""
from __future__ import annotations

import textwrap
from pathlib import Path

EXAMPLE = Path(__file__).resolve().parent.parent / "subsumption" / "examples" / "avoid_demo.yaml"
DEMO = "subsumption.examples.avoid_demo"
AVOID = "subsumption.examples.avoid:Avoid"

# Level 0 alone is complete: feelforce -> runaway -> turn -> cmd_vel.
LEVEL0 = f"""\
name: tiny
time_unit: 0.1
external:
  cmd_vel: geometry_msgs/Twist
levels:
  - name: avoid objects
    modules:
      - name: feelforce
        class: {DEMO}:FeelForce
      - name: runaway
        class: {DEMO}:Runaway
        inputs: {{force: feelforce.force}}
      - name: turn
        class: {DEMO}:Turn
        inputs: {{heading: runaway.heading}}
        outputs: {{cmd_vel: cmd_vel}}
"""


# Level 1 without its arbiters: a test appends them.
WANDER = f"""\
  - name: wander
    modules:
      - name: wander
        class: {DEMO}:Wander
      - name: avoid
        class: {AVOID}
        inputs: {{heading: wander.heading, force: feelforce.force}}
    arbiters:
"""


def write(tmp_path: Path, text: str, name: str = "net.yaml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def line_of(path: Path, needle: str, occurrence: int = 1) -> int:
    """1-based line of the `occurrence`-th line containing `needle`."""
    hits = [number for number, line in enumerate(path.read_text().splitlines(), 1) if needle in line]
    assert len(hits) >= occurrence, f"{needle!r} not in {path}"
    return hits[occurrence - 1]
