"""The robot's subsumption network for the page: the drawing ``subsumption graph`` makes, as inline SVG.

The SVG comes from the core's :func:`subsumption.network.graph.to_graph`, so the page shows exactly the
picture ``subsumption graph FILE --level N`` draws. Graphviz titles each node with its id
(``arbiter__<name>``), which is how the page finds the circle to light when that arbiter's upper line holds
control. The arbiters' names also tell the terminal which ``<name>/status`` topics to watch.
"""
from __future__ import annotations

from dataclasses import dataclass

from subsumption.arbitration import ArbiterKind
from subsumption.network.check import check_file
from subsumption.network.graph import to_graph

from .config import ConfigError


@dataclass(frozen=True)
class ArbiterInfo:
    name: str
    kind: str
    letter: str
    units: str          # the time constant as the file writes it ("20")
    seconds: float
    upper: str          # the line that takes over ("terminal/cmd_vel")
    lower: str
    level: int

    def as_json(self) -> dict:
        """The arbiter as the page draws it (JSON-ready dict)."""
        return {"name": self.name, "kind": self.kind, "letter": self.letter, "units": self.units,
                "seconds": self.seconds, "upper": self.upper, "lower": self.lower, "level": self.level,
                "node_id": f"arbiter__{self.name}"}


@dataclass(frozen=True)
class NetworkView:
    name: str
    level: int
    svg: str
    arbiters: tuple[ArbiterInfo, ...]


def load_view(path: str, level: int | None) -> NetworkView:
    """Check and draw the network file; a file with problems is a ConfigError naming the first one."""
    result = check_file(path, level)
    if result.errors or result.wiring is None:
        first = result.errors[0] if result.errors else f"{path}: cannot be read"
        more = f" (and {len(result.errors) - 1} more; run `subsumption check {path}`)" if len(result.errors) > 1 else ""
        raise ConfigError(f"~network: {first}{more}")
    wiring = result.wiring
    svg = to_graph(wiring).pipe(format="svg").decode("utf-8")
    svg = svg[svg.index("<svg"):]  # no XML prologue or DOCTYPE: the page inserts it inline
    arbiters = tuple(
        ArbiterInfo(name=a.name, kind=a.kind, letter=ArbiterKind(a.kind).letter,
                    units=f"{a.spec.time_constant:g}" if a.spec.time_constant is not None else "?",
                    seconds=float(a.time_constant or 0.0),
                    upper=a.upper, lower=a.lower, level=a.spec.level)
        for a in wiring.arbiters)
    return NetworkView(wiring.network.name, wiring.level, svg, arbiters)
