"""1,000 malformed files: network files, maps (YAML and PGM) and world files, made by mutating the shipped ones.

Every file the toolkit refuses must be refused with one line per problem that names the file and the place
(``FILE:LINE: what`` for network files, ``FILE: field 'F': what`` for maps and worlds), and the command must
exit non-zero; nothing may escape as a traceback. Mutations that happen to leave a file valid are allowed (and
counted); the test insists that most files are broken, so that it cannot pass by testing nothing.
Everything runs in-process (the CLI's main(), the loaders), so 1,000 files take seconds.
"""
from __future__ import annotations

import random
import re
import shutil
from pathlib import Path

import pytest

from subsim.mapio import MapError, load_map
from subsim.sim import Simulation
from subsim.world import WorldError, load_world
from subsumption import cli

ROOT = Path(__file__).resolve().parent.parent
NETWORKS = [ROOT / "robots" / "wander" / "wander.yaml", ROOT / "subsumption" / "examples" / "avoid_demo.yaml"]
MAPS = ROOT / "subsim" / "maps"
COUNTS = {"network": 400, "map": 300, "world": 300}  # 1,000 files in all

VALUES = ["nan", ".nan", ".inf", "-.inf", "-1", "0", "1e309", "123456789012345678901234567890", "''", "[]", "{}",
          "[1, [2, [3]]]", "true", "null", "~", "&a x", "*a", "!!python/object/apply:os.system ['true']",
          "\"\\x00\"", "\t", "{{{", "]]", "'unterminated", "!!binary AAAA", "<<: *a", "? complex", "- a",
          "\"" + "x" * 5000 + "\"", "0x1F", "1_000", "2001-12-14", "-", "|", ">", "%YAML 9.9"]


def mutate_text(text: str, rng: random.Random) -> bytes:
    """One to three random damages to a YAML text: lines lost, doubled, swapped or re-indented, values and
    keys replaced by hostile ones, bytes that are not UTF-8, deep nesting, truncation."""
    lines = text.splitlines()
    for _ in range(rng.randint(1, 3)):
        i = rng.randrange(len(lines))
        op = rng.randrange(9)
        if op == 0:
            del lines[i]
        elif op == 1:
            lines.insert(i, lines[i])
        elif op == 2:
            j = rng.randrange(len(lines))
            lines[i], lines[j] = lines[j], lines[i]
        elif op == 3:
            lines[i] = (" " * rng.choice((1, 2, 4)) + lines[i]) if rng.random() < 0.5 else lines[i].lstrip()
        elif op in (4, 5):  # a value replaced (the commonest damage a hand edit does)
            lines[i] = re.sub(r":\s*(\S.*)$", lambda _m: ": " + rng.choice(VALUES), lines[i], count=1) \
                if ":" in lines[i] else lines[i] + ": " + rng.choice(VALUES)
        elif op == 6:  # a key misspelt
            lines[i] = re.sub(r"^(\s*-?\s*)([A-Za-z_]+)", lambda m: m.group(1) + m.group(2)[::-1] + "x", lines[i])
        elif op == 7:
            lines.insert(i, rng.choice(["[" * rng.randint(50, 20000), "{a: " * rng.randint(50, 5000),
                                        "- " * rng.randint(50, 5000) + "x", "&a [*a]", "\t\tx: 1"]))
        else:
            lines = lines[: rng.randrange(1, len(lines) + 1)]
            if lines:
                lines[-1] = lines[-1][: rng.randrange(len(lines[-1]) + 1)]
    data = "\n".join(lines).encode()
    if rng.random() < 0.15:  # binary garbage somewhere
        at = rng.randrange(len(data) + 1)
        data = data[:at] + bytes(rng.randrange(256) for _ in range(rng.randint(1, 40))) + data[at:]
    return data


def mutate_pgm(data: bytes, rng: random.Random) -> bytes:
    """A damaged PGM: its header (magic, size, maxval) or its pixels."""
    header_end = data.index(b"\n255\n") + 5
    pixels = data[header_end:]
    op = rng.randrange(8)
    if op == 0:
        return rng.choice([b"P9", b"P6", b"P2", b"XX", b""]) + data[2:]
    if op == 1:
        size = rng.choice([b"0 0", b"-5 10", b"99999999 99999999", b"120", b"a b", b"120 120 120", b"1e3 4"])
        return b"P5\n" + size + b"\n255\n" + pixels
    if op == 2:
        return b"P5\n120 120\n" + rng.choice([b"0", b"65535", b"-1", b"x", b""]) + b"\n" + pixels
    if op == 3:
        return data[: rng.randrange(len(data))]  # truncated
    if op == 4:
        return data[:header_end] + bytes(len(pixels))  # all black: no free cell
    if op == 5:
        return bytes(rng.randrange(256) for _ in range(rng.randint(0, 2000)))
    if op == 6:
        return data[:header_end] + bytes([205]) * len(pixels)  # all unknown
    return b""


def network_files(tmp: Path, rng: random.Random) -> list[Path]:
    paths = []
    for i in range(COUNTS["network"]):
        source = NETWORKS[i % len(NETWORKS)]
        path = tmp / f"net_{i}.yaml"
        path.write_bytes(mutate_text(source.read_text(), rng))
        paths.append(path)
    return paths


def map_files(tmp: Path, rng: random.Random, count: int = COUNTS["map"]) -> list[Path]:
    paths = []
    meta, pgm = (MAPS / "room.yaml").read_text(), (MAPS / "room.pgm").read_bytes()
    for i in range(count):
        folder = tmp / f"map_{i}"
        folder.mkdir()
        if i % 2:
            (folder / "room.yaml").write_bytes(mutate_text(meta, rng))
            (folder / "room.pgm").write_bytes(pgm)
        else:
            (folder / "room.yaml").write_text(meta)
            (folder / "room.pgm").write_bytes(mutate_pgm(pgm, rng))
        paths.append(folder / "room.yaml")
    return paths


def world_files(tmp: Path, rng: random.Random, count: int = COUNTS["world"]) -> list[Path]:
    paths = []
    shutil.copy(MAPS / "room.yaml", tmp / "room.yaml")
    shutil.copy(MAPS / "room.pgm", tmp / "room.pgm")
    sources = [(MAPS / "room_world.yaml").read_text(), (MAPS / "room_people_world.yaml").read_text()]
    for i in range(count):
        path = tmp / f"world_{i}.yaml"
        path.write_bytes(mutate_text(sources[i % 2], rng))
        paths.append(path)
    return paths


def assert_one_line_naming(text: str, path: Path) -> None:
    assert "Traceback" not in text, text
    assert "\n" not in text.strip(), text
    assert text.startswith(f"{path}: field '") or text.startswith(f"{path.parent / 'room.yaml'}: field '"), text


@pytest.fixture(scope="module")
def rng() -> random.Random:
    return random.Random(15)


def test_malformed_network_files(tmp_path, rng, capsys):
    refused = 0
    parser = cli.build_parser()  # once: main() builds it (finding the commands' entry points) on every call
    for path in network_files(tmp_path, rng):
        args = parser.parse_args(["check", str(path)])
        status = int(args.func(args) or 0)  # what cli.main does
        out, err = capsys.readouterr()
        assert "Traceback" not in out + err, (path, err)
        if status == 0:
            continue
        refused += 1
        lines = err.strip().splitlines()
        assert lines, path
        for line in lines[:-1]:  # each problem: FILE:LINE: what
            assert re.match(rf"{re.escape(str(path))}:\d+: \S", line), line
        assert re.fullmatch(rf"{re.escape(str(path))}: \d+ errors?", lines[-1]), lines[-1]
    print(f"\nnetwork files: {refused} of {COUNTS['network']} refused")
    assert refused > COUNTS["network"] * 0.6


def test_malformed_maps(tmp_path, rng):
    refused = 0
    for path in map_files(tmp_path, rng):
        try:
            load_map(path)
        except MapError as error:
            refused += 1
            assert_one_line_naming(str(error), path)
    print(f"\nmaps: {refused} of {COUNTS['map']} refused")
    assert refused > COUNTS["map"] * 0.6


def test_malformed_world_files(tmp_path, rng):
    refused = 0
    for path in world_files(tmp_path, rng):
        try:
            Simulation(load_world(path), seed=0, record=False)
        except (WorldError, MapError) as error:
            refused += 1
            assert_one_line_naming(str(error), path)
    print(f"\nworld files: {refused} of {COUNTS['world']} refused")
    assert refused > COUNTS["world"] * 0.6


def test_the_run_command_exits_non_zero_with_one_line(tmp_path, rng, capsys):
    """A sample of broken maps and worlds through `subsumption run` itself: status 2, one line, no traceback."""
    (tmp_path / "m").mkdir()
    (tmp_path / "w").mkdir()
    maps, worlds = map_files(tmp_path / "m", rng, 16), world_files(tmp_path / "w", rng, 16)
    checked = 0
    for option, path in [("--map", p) for p in maps] + [("--world", p) for p in worlds]:
        try:
            (load_map if option == "--map" else lambda p: Simulation(load_world(p), seed=0, record=False))(path)
            continue  # this mutation left the file valid: a run would start
        except (MapError, WorldError):
            pass
        status = cli.main(["run", "wander", "--level", "0", option, str(path), "--duration", "0.1",
                           "--out", str(tmp_path / "out")])
        out, err = capsys.readouterr()
        assert status == 2, (path, err)
        assert "Traceback" not in out + err and len(err.strip().splitlines()) == 1, err
        assert str(path.parent) in err, err
        checked += 1
    assert checked > 10
