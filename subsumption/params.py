"""Parameter tables from the `Param` declarations: what ``subsumption params`` prints.

A module's parameters are declared once, in its class, with a default, a type, bounds and a line saying what
each does and in which unit. The tables of the documentation are printed from those declarations (``--markdown``)
rather than written by hand, so that the reference cannot drift from the code (tests/test_docs_params.py
compares them).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from .module import Module, Param


@dataclass(frozen=True)
class ParamRow:
    """One parameter as a table shows it; `value` is what a network file sets (None: the default holds)."""

    name: str
    type_name: str
    default: Any
    low: float | None
    high: float | None
    doc: str
    value: Any = None


def rows(module_class: type[Module], values: dict[str, Any] | None = None) -> list[ParamRow]:
    """The parameters of `module_class` in declaration order, with the values a network file gives them."""
    values = values or {}
    return [_row(param, values.get(name)) for name, param in module_class.interface.params.items()]


def _row(param: Param, value: Any) -> ParamRow:
    return ParamRow(param.name, param.type_name, param.default, param.min, param.max,
                    " ".join(param.doc.split()), value)


def bounds(row: ParamRow) -> str:
    """``0 to 5``, ``>= 0``, ``<= 1`` or '' for a parameter's inclusive bounds."""
    if row.low is not None and row.high is not None:
        return f"{row.low:g} to {row.high:g}"
    if row.low is not None:
        return f">= {row.low:g}"
    if row.high is not None:
        return f"<= {row.high:g}"
    return ""


def _value(value: Any) -> str:
    """A value as YAML would write it (``true``, ``0.5``, ``map``), which is how a user sets it."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, str):
        return value if value else "''"
    return str(value)


def _cell(text: str) -> str:
    """Text safe inside a Markdown table cell (a ``|`` would start a new cell)."""
    return text.replace("|", "\\|")


def markdown_table(module_class: type[Module], values: dict[str, Any] | None = None) -> str:
    """A Markdown table of the parameters of `module_class`; a column of the network file's values when given."""
    table = rows(module_class, values)
    if not table:
        return "(no parameters)"
    with_values = values is not None and any(row.value is not None for row in table)
    head = ["parameter", "type", "default", "range"] + (["in the network"] if with_values else []) + ["what it does"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for row in table:
        cells = [f"`{row.name}`", row.type_name, f"`{_cell(_value(row.default))}`", bounds(row)]
        if with_values:
            cells.append("" if row.value is None else f"`{_cell(_value(row.value))}`")
        cells.append(_cell(row.doc))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def text_table(module_class: type[Module], values: dict[str, Any] | None = None) -> str:
    """The parameters of `module_class` as aligned plain-text lines, for a terminal."""
    table = rows(module_class, values)
    if not table:
        return "  (no parameters)"
    width = max(len(row.name) for row in table)
    lines = []
    for row in table:
        set_here = "" if row.value is None else f", set to {_value(row.value)}"
        limits = f", {bounds(row)}" if bounds(row) else ""
        lines.append(f"  {row.name:{width}} = {_value(row.default)} ({row.type_name}{limits}{set_here})  {row.doc}"
                     .rstrip())
    return "\n".join(lines)


def ports_table(module_class: type[Module]) -> str:
    """A Markdown table of the topics `module_class` reads and writes (``subsumption info MODULE --markdown``).

    The names are the module's own, before a network file or a launch file remaps them: an input subscribes to
    its name (relative), an output publishes on ``~name`` (private to its node)."""
    from .module import type_name
    interface = module_class.interface
    lines = ["| topic | in/out | type | what it carries |", "|---|---|---|---|"]
    for direction, ports in (("in", interface.inputs), ("out", interface.outputs)):
        for port in ports.values():
            notes = []
            if getattr(port, "latest", False):
                notes.append("newest message only")
            if getattr(port, "latch", False):
                notes.append("latched")
            if getattr(port, "finite", True) is False:
                notes.append("NaN/inf passed")
            doc = " ".join(port.doc.split()) + (f" ({', '.join(notes)})" if notes else "")
            lines.append(f"| `{port.topic()}` | {direction} | `{type_name(port.msg_type)}` | {_cell(doc)} |")
    return "\n".join(lines) if len(lines) > 2 else "(no topics)"


BLOCK_START = "<!-- subsumption {command} {target} --markdown -->"
BLOCK_END = "<!-- end of generated table -->"
_BLOCK = (r"<!-- subsumption (?P<command>params|info) (?P<target>\S+) --markdown -->\n"
          r"(?P<table>(?:(?!<!-- ).)*?)\n?<!-- end of generated table -->")


def generated_blocks(text: str) -> list[tuple[str, str, str]]:
    """The (command, module class, table) triples a Markdown text holds between the markers of a generated
    table: ``params`` for a parameter table, ``info`` for a table of topics."""
    import re
    return [(found["command"], found["target"], found["table"]) for found in re.finditer(_BLOCK, text, flags=re.S)]


def generated_table(command: str, target: str) -> str:
    """What ``subsumption params|info TARGET --markdown`` prints for a module class."""
    from .loading import load_module_class
    module_class = load_module_class(target)
    return markdown_table(module_class) if command == "params" else ports_table(module_class)


def refresh_blocks(text: str) -> str:
    """`text` with every generated table printed again from the code (how docs/ are brought up to date)."""
    import re

    def table(found: "re.Match[str]") -> str:
        command, target = found["command"], found["target"]
        return f"{BLOCK_START.format(command=command, target=target)}\n{generated_table(command, target)}\n{BLOCK_END}"
    return re.sub(_BLOCK, table, text, flags=re.S)


def main(argv: list[str] | None = None) -> int:
    """``python -m subsumption.params FILE.md ...``: print every generated table of those files again, in place."""
    import sys
    from pathlib import Path
    files = sys.argv[1:] if argv is None else argv
    if not files:
        print("usage: python -m subsumption.params FILE.md ... (rewrites their generated parameter tables)",
              file=sys.stderr)
        return 2
    for name in files:
        path = Path(name)
        text = path.read_text()
        fresh = refresh_blocks(text)
        if fresh != text:
            path.write_text(fresh)
            print(f"{name}: tables printed again")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
