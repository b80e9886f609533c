"""``subsumption graph``: a network drawn the way Brooks draws one (the paper's Fig. 1 and Fig. 3).

Modules are boxes, filled with one colour per level (a legend names the levels); wires carry the name of
what flows; arbiters are small circles marked S, I or D with their time constant in the file's units, as
Brooks writes "S 20"; upper lines come into an arbiter dashed. External topics sit at the edges as plain
text, sensors on the left, actuators on the right. Everything is read from the :class:`Wiring`, so the
picture shows exactly what runs at that level.
"""
from __future__ import annotations

from pathlib import Path

import graphviz

from ..arbitration import ArbiterKind
from .wiring import End, Wiring

LEVEL_COLOURS = ["#cfe2f3", "#d9ead3", "#fff2cc", "#f4cccc", "#d9d2e9", "#fce5cd", "#d0e0e3", "#ead1dc"]
FONT = "Helvetica"


def _node_id(end: End) -> str:
    return f"{end.kind}__{end.name}"  # no colon: dot reads "a:b" as node a, port b


def to_graph(wiring: Wiring) -> graphviz.Digraph:
    """The drawing as a graphviz Digraph (render it with :func:`draw`)."""
    network = wiring.network
    graph = graphviz.Digraph(network.name, graph_attr={
        "rankdir": "LR", "fontname": FONT, "nodesep": "0.35", "ranksep": "0.55", "newrank": "true",
        "label": f"{network.name}: levels 0..{wiring.level}", "labelloc": "t", "fontsize": "16"},
        node_attr={"fontname": FONT, "fontsize": "12"}, edge_attr={"fontname": FONT, "fontsize": "10"})
    for module in wiring.modules:
        graph.node(_node_id(End("module", module.name)), module.name, shape="box", style="filled,rounded",
                   fillcolor=LEVEL_COLOURS[module.spec.level % len(LEVEL_COLOURS)], penwidth="1.2",
                   tooltip=module.spec.class_path or module.spec.node or "")
    unit = network.time_unit
    for arbiter in wiring.arbiters:
        letter = ArbiterKind(arbiter.kind).letter
        units = f"{arbiter.spec.time_constant:g}" if arbiter.spec.time_constant is not None else "?"
        graph.node(_node_id(End("arbiter", arbiter.name)),
                   f'<<B>{letter}</B><BR/><FONT POINT-SIZE="9">{units}</FONT>>', shape="circle", width="0.5",
                   fixedsize="true", style="filled", fillcolor=LEVEL_COLOURS[arbiter.spec.level % len(LEVEL_COLOURS)],
                   fontsize="12", tooltip=f"{arbiter.name}: {arbiter.kind}, T = {units} x {unit:g} s")
    sources = {w.source.name for w in wiring.wires if w.source.kind == "external"}
    targets = {w.target.name for w in wiring.wires if w.target.kind == "external"}
    for rank, topics in (("source", sources - targets), ("sink", targets), ("same", sources & targets)):
        with graph.subgraph() as side:
            side.attr(rank=rank)
            for topic in sorted(topics):
                side.node(_node_id(End("external", topic)), topic, shape="plaintext", fontsize="12")
    for wire in wiring.wires:
        attributes = {"label": wire.label, "tooltip": f"{wire.topic} ({wire.type})"}
        if wire.target.kind == "arbiter" and wire.target.port == "upper":
            attributes["style"] = "dashed"
        if wire.target.kind == "arbiter" or wire.source.kind == "arbiter":
            attributes["arrowsize"] = "0.7"
        graph.edge(_node_id(wire.source), _node_id(wire.target), **attributes)
    graph.subgraph(_legend(wiring))
    return graph


def _legend(wiring: Wiring) -> graphviz.Digraph:
    """A small table of the levels and their colours, plus the time unit the arbiters' numbers are in."""
    rows = "".join(
        f'<TR><TD BGCOLOR="{LEVEL_COLOURS[level.index % len(LEVEL_COLOURS)]}">level {level.index}</TD>'
        f'<TD ALIGN="LEFT">{_escape(level.name)}</TD></TR>'
        for level in wiring.network.levels[: wiring.level + 1])
    unit = (f'<TR><TD COLSPAN="2">S suppressor, I inhibitor, D defaulter<BR/>'
            f'time constant n: n &#215; {wiring.network.time_unit:g} s</TD></TR>')
    legend = graphviz.Digraph("cluster_legend", graph_attr={"label": "", "style": "invis"})
    legend.node("legend", f'<<TABLE BORDER="0" CELLBORDER="1" CELLSPACING="0" CELLPADDING="4">{rows}{unit}</TABLE>>',
                shape="plaintext", fontsize="11")
    return legend


def _escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def draw(wiring: Wiring, out: str | Path) -> Path:
    """Render the drawing to `out`; its suffix (.svg, .png, .pdf, ...) picks the format. Returns the file."""
    return render(to_graph(wiring), out)


def render(graph: graphviz.Digraph | graphviz.Source, out: str | Path) -> Path:
    """Render any graphviz graph to `out` in the format its suffix names, leaving no dot source beside it."""
    out = Path(out)
    graph.render(outfile=str(out), format=out.suffix.lstrip(".").lower() or "svg", cleanup=True)
    stray = out.with_suffix(".gv")
    if stray.exists():
        stray.unlink()
    return out
