"""Reading YAML files that may be hostile: the one loader for network, world and map files.

``yaml.safe_load`` constructs no arbitrary objects, but it is not safe from everything a file can hold:

- a binary file gives a traceback from deep inside the reader (or a confusing "special characters" error);
- deep nesting (``[[[[...]]]]``) makes the recursive composer overflow the stack (RecursionError);
- an alias bomb ("billion laughs": each anchor repeating the one before ten times) is a few hundred bytes
  that expand into billions of nodes as soon as anything walks or prints the document;
- a huge file is read whole into memory;
- some scalars fail in Python itself (an integer of 5,000 digits, the date 2024-13-45: ValueError).

Here every file is size-checked and decoded as UTF-8 first, composed with depth and expansion limits
(an alias counts as the whole subtree it repeats, so the expansion is bounded before anything walks it),
and every failure becomes a :class:`YamlFileError` whose text is one line naming the file (and the line).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml
from yaml.constructor import SafeConstructor

from .errors import InputFileError

MAX_BYTES = 4 * 1024 * 1024  # network, world and map files are a few kilobytes
MAX_DEPTH = 64  # nesting of lists and mappings
MAX_NODES = 200_000  # nodes of the document with every alias expanded


YamlFileError = InputFileError  # the one bad-input-file error, under this module's name


class _BoundedLoader(yaml.SafeLoader):
    """SafeLoader whose composer refuses deep nesting and documents that expand beyond MAX_NODES."""

    def __init__(self, stream: str, file: str) -> None:
        super().__init__(stream)
        self.file = file
        self._depth = 0
        self._sizes: dict[int, int] = {}  # id(node) -> its size with aliases expanded

    def compose_node(self, parent: yaml.Node | None, index: Any) -> yaml.Node:
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH:
                raise YamlFileError(self.file, f"nested more than {MAX_DEPTH} levels deep",
                                    self.peek_event().start_mark.line + 1)
            node = super().compose_node(parent, index)
        finally:
            self._depth -= 1
        self._measure(node)
        return node

    def _measure(self, node: yaml.Node) -> int:
        """The node's expanded size (an alias returns the anchored node, already measured: its size counts
        again wherever it is repeated); raises as soon as it passes MAX_NODES."""
        known = self._sizes.get(id(node))
        if known is not None:
            return known
        if isinstance(node, yaml.SequenceNode):
            size = 1 + sum(self._sizes.get(id(child), 1) for child in node.value)
        elif isinstance(node, yaml.MappingNode):
            size = 1 + sum(self._sizes.get(id(k), 1) + self._sizes.get(id(v), 1) for k, v in node.value)
        else:
            size = 1
        if size > MAX_NODES:
            raise YamlFileError(self.file, f"expands to more than {MAX_NODES} values (aliases repeating "
                                           f"aliases?)", node.start_mark.line + 1)
        self._sizes[id(node)] = size
        return size


def read_text(path: str | Path, what: str = "file") -> str:
    """The file's text: at most MAX_BYTES, UTF-8, no NUL bytes; else a YamlFileError naming it."""
    path = Path(path)
    try:
        with path.open("rb") as stream:
            data = stream.read(MAX_BYTES + 1)
    except OSError as error:
        raise YamlFileError(path, f"cannot read {what}: {error.strerror or error}") from None
    if len(data) > MAX_BYTES:
        raise YamlFileError(path, f"larger than {MAX_BYTES // (1024 * 1024)} MB: not a {what}")
    if b"\0" in data:
        raise YamlFileError(path, f"binary data (a NUL byte at offset {data.index(0)}): not a {what}")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as error:
        raise YamlFileError(path, f"not UTF-8 text (byte 0x{data[error.start]:02x} at offset {error.start}): "
                                  f"not a {what}") from None


def compose(text: str, file: str | Path) -> yaml.Node | None:
    """The node graph of one YAML document (with marks, for line numbers), within the limits above."""
    loader = None
    try:
        loader = _BoundedLoader(text, str(file))
        return loader.get_single_node()
    except yaml.MarkedYAMLError as error:
        mark = error.problem_mark or error.context_mark
        raise YamlFileError(file, f"not valid YAML: {error.problem or error.context or error}",
                            mark.line + 1 if mark else None) from None
    except yaml.reader.ReaderError as error:  # a control character: no mark object, a line to count
        line = text.count("\n", 0, error.position) + 1
        raise YamlFileError(file, f"not valid YAML: character #x{error.character:04x} is not allowed",
                            line) from None
    except yaml.YAMLError as error:
        raise YamlFileError(file, f"not valid YAML: {error}") from None
    except RecursionError:  # a limit above should come first; never let it out as a traceback
        raise YamlFileError(file, "nested too deeply") from None
    finally:
        if loader is not None:
            loader.dispose()


def construct(node: yaml.Node, file: str | Path) -> Any:
    """The plain Python value of a composed node (what yaml.safe_load gives), failures as YamlFileError."""
    try:
        return SafeConstructor().construct_document(node)
    except yaml.MarkedYAMLError as error:
        mark = error.problem_mark or error.context_mark
        raise YamlFileError(file, f"not valid YAML: {error.problem or error}",
                            mark.line + 1 if mark else None) from None
    except (ValueError, OverflowError, TypeError) as error:  # e.g. a 5,000-digit integer, the date 2024-13-45
        raise YamlFileError(file, f"bad value near line {node.start_mark.line + 1}: {error}",
                            node.start_mark.line + 1) from None


def load(path: str | Path, what: str = "YAML file") -> Any:
    """yaml.safe_load of the file at `path`, bounded (see the module's doc); every problem a YamlFileError."""
    node = compose(read_text(path, what), path)
    return None if node is None else construct(node, path)


def brief(value: Any, limit: int = 60) -> str:
    """repr(value) cut to `limit` characters, for one-line error messages about values read from files."""
    import reprlib

    short = reprlib.Repr()
    short.maxstring = short.maxother = limit
    short.maxlist = short.maxdict = 6
    text = short.repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


__all__ = ["YamlFileError", "read_text", "compose", "construct", "load", "brief", "MAX_BYTES", "MAX_DEPTH",
           "MAX_NODES"]
