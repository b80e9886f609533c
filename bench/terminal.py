"""The operator terminal's figures: key press to motor command, camera frame to the page's canvas, frames a
second to 1 and to 5 viewers at once, the server's CPU per viewer, the dead-man switch, and a 10-s flood.

Run with the project's interpreter: ``.venv/bin/python -m bench.terminal`` (``make bench``). It starts its own
rosmaster on a free port, launches ``terminal/examples/operator_demo.yaml`` (the terminal on top of a motor
line through a real suppressor and inhibitor), the synthetic camera scene (``terminal.scene``, 640x480 JPEG
at 30 frames a second, stamps on the wall clock) and Debian's chromium through Playwright; it stops every
process it started, by process id. Times are wall-clock on this machine (the browser, the terminal and the
recorder share its clock). Nothing is asserted: the table says each figure, its goal and the ratio.

- key press -> cmd_vel: Playwright presses ArrowUp in the page; the time from just before the press to the
  first Twist with x > 0 arriving at a subscriber of ``terminal/cmd_vel``, and of ``cmd_vel`` after the
  suppressor and inhibitor (the robot's motor line). Also from the page's own keydown time.
- frame -> canvas: the page's draw time minus the frame's header stamp, over every frame drawn.
- fps: frames drawn per second in each of 1, then 5, pages at once; the server's CPU (user + system seconds
  of the terminal process per wall second) with 0, 1 and 5 viewers.
- dead-man: a client drives at 20 Hz, then falls silent (or disconnects); the time from its last command to
  the zero Twist on ``terminal/cmd_vel`` (goal: 0.5 s).
- flood: one client sends 1,000 messages a second for 10 s while a page watches: what got through, the
  page's fps and the robot's own motor line during the flood.
"""
from __future__ import annotations

import argparse
import asyncio
import datetime
import json
import os
import re
import statistics
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

from subsumption.network import load
from subsumption.ros.launch import launch
from subsumption.ros.master import start_master, stop_process
from terminal.scene import read_records

CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]
CLOCK_TICKS = os.sysconf("SC_CLK_TCK")


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    if not ordered:
        return float("nan")
    return ordered[min(len(ordered) - 1, int(round(q / 100 * (len(ordered) - 1))))]


def cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLOCK_TICKS  # utime + stime


class Bench:
    def __init__(self, args: argparse.Namespace, work: Path) -> None:
        self.args = args
        self.work = work
        self.record = work / "record.jsonl"
        self.record.touch()
        self.processes: list[subprocess.Popen] = []
        self.launched = None
        self.port = 0
        self.terminal_pid = 0

    # world --------------------------------------------------------------------------------------------
    def start(self, env: dict[str, str]) -> None:
        text = (ROOT / "terminal/examples/operator_demo.yaml").read_text()
        network_file = self.work / "operator_demo.yaml"
        network_file.write_text(text.replace("        params:\n", "        params:\n          port: 0\n", 1))
        self.launch_log = self.work / "launch.log"
        with self.launch_log.open("w") as log:
            self.launched = launch(load(network_file), xml=self.work / "operator_demo.launch", env=env,
                                   stdout=log, stderr=subprocess.STDOUT)
        self.processes.append(subprocess.Popen(
            [sys.executable, "-m", "terminal.scene", "--rate", str(self.args.fps), "--size", self.args.size,
             "--alarm-period", "20", "--record", str(self.record)],
            env=env, cwd=ROOT, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            match = re.search(r"^rosbridge: ws://127\.0\.0\.1:(\d+)$", self.launch_log.read_text(), re.M)
            if match:
                self.port = int(match.group(1))
                break
            time.sleep(0.1)
        else:
            raise RuntimeError(f"the terminal did not start; see {self.launch_log}")
        out = subprocess.run(["ps", "-eo", "pid,args"], capture_output=True, text=True).stdout
        self.terminal_pid = next(int(line.split()[0]) for line in out.splitlines()
                                 if "nodes/terminal" in line and "__name:=terminal" in line)
        time.sleep(2.0)  # the scene's first frames, tf and map

    def stop(self) -> None:
        if self.launched is not None:
            self.launched.stop()
        for process in self.processes:
            stop_process(process, signal.SIGTERM, timeout=5)

    def records(self, topic: str, since: float = 0.0) -> list[dict]:
        """What the scene's recorder heard on `topic` from `since` (wall clock) on."""
        return read_records(self.record, topic, since)

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}/"

    # browser ------------------------------------------------------------------------------------------
    def open_page(self, browser, viewport=None):
        context = browser.new_context(viewport=viewport or {"width": 1280, "height": 900})
        page = context.new_page()
        page.goto(self.url)
        deadline = time.monotonic() + 20
        drawn = "window.terminalStats && window.terminalStats.drawn > 3"
        while time.monotonic() < deadline and not page.evaluate(drawn):
            time.sleep(0.1)
        return page

    def key_presses(self, browser) -> dict[str, list[float]]:
        page = self.open_page(browser)
        page.wait_for_selector("#network svg g.node")
        to_terminal, to_robot, from_page = [], [], []
        for _ in range(self.args.presses):
            begin = time.time()
            page.keyboard.down("ArrowUp")
            time.sleep(0.12)
            page.keyboard.up("ArrowUp")
            time.sleep(0.15)
            keydown = page.evaluate("window.terminalStats.keyEvents.filter(e => e.down).slice(-1)[0].at") / 1000
            moving = [r for r in self.records("/terminal/cmd_vel", begin) if r["msg"]["linear"]["x"] > 0]
            robot = [r for r in self.records("/cmd_vel", begin) if r["msg"]["linear"]["x"] == 0.3]
            if moving:
                to_terminal.append(moving[0]["t"] - begin)
                from_page.append(moving[0]["t"] - keydown)
            if robot:
                to_robot.append(robot[0]["t"] - begin)
            time.sleep(0.6)  # let the suppressor hand the motor line back (T = 0.5 s)
        page.context.close()
        return {"terminal": to_terminal, "robot": to_robot, "page": from_page}

    def viewers(self, browser, count: int, seconds: float) -> tuple[list[float], list[float], float]:
        pages = [self.open_page(browser) for _ in range(count)]
        time.sleep(3.0)  # every page caught up with what queued while the others opened
        before = [page.evaluate("window.terminalStats.drawn") for page in pages]
        lat_before = [page.evaluate("window.terminalStats.latencies.length") for page in pages]
        cpu0, wall0 = cpu_seconds(self.terminal_pid), time.monotonic()
        time.sleep(seconds)
        cpu1, wall1 = cpu_seconds(self.terminal_pid), time.monotonic()
        fps = [(page.evaluate("window.terminalStats.drawn") - b) / (wall1 - wall0) for page, b in zip(pages, before)]
        latencies = []
        for page, n in zip(pages, lat_before):
            latencies += page.evaluate(f"window.terminalStats.latencies.slice({n})")
        for page in pages:
            page.context.close()
        return fps, latencies, (cpu1 - cpu0) / (wall1 - wall0)

    def idle_cpu(self, seconds: float) -> float:
        cpu0, wall0 = cpu_seconds(self.terminal_pid), time.monotonic()
        time.sleep(seconds)
        return (cpu_seconds(self.terminal_pid) - cpu0) / (time.monotonic() - wall0)

    def screenshot(self, browser, path: str) -> None:
        """The page with a manual target selected and the operator driving (the suppressor lit)."""
        page = self.open_page(browser, {"width": 1400, "height": 1000})
        page.wait_for_selector("#network svg g.node")
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline and "no active alarm" in page.locator("#alarms-active").inner_text():
            time.sleep(0.2)
        box = page.locator("#camera").bounding_box()
        page.mouse.move(box["x"] + box["width"] * 0.42, box["y"] + box["height"] * 0.3)
        page.mouse.down()
        page.mouse.move(box["x"] + box["width"] * 0.62, box["y"] + box["height"] * 0.82, steps=4)
        page.mouse.up()
        page.keyboard.press("Enter")
        page.keyboard.down("ArrowUp")
        page.wait_for_selector("#network g.node.lit")
        time.sleep(0.5)
        page.screenshot(path=path, full_page=True)
        page.keyboard.up("ArrowUp")
        page.context.close()

    # rosbridge clients --------------------------------------------------------------------------------
    async def _deadman_trial(self, ending: str) -> float | None:
        import aiohttp

        async with aiohttp.ClientSession() as session:
            ws = await session.ws_connect(f"ws://127.0.0.1:{self.port}/")
            for _ in range(6):
                await ws.send_json({"op": "publish", "topic": "terminal/cmd_vel", "msg": {"linear": {"x": 0.1}}})
                await asyncio.sleep(0.05)
            if ending == "silence":
                await asyncio.sleep(1.0)
            await ws.close()
        return None

    def deadman(self, ending: str, trials: int) -> list[float]:
        delays = []
        for _ in range(trials):
            since = time.time()
            run_async(self._deadman_trial(ending))
            time.sleep(0.3)
            commands = self.records("/terminal/cmd_vel", since)
            moving = [c for c in commands if c["msg"]["linear"]["x"] != 0]
            stops = [c for c in commands if moving and c["t"] > moving[-1]["t"] and c["msg"]["linear"]["x"] == 0]
            if moving and stops:
                delays.append(stops[0]["t"] - moving[-1]["t"])
            time.sleep(0.6)
        return delays

    async def _flood(self, seconds: float, rate: int, frame: str) -> dict:
        import aiohttp

        notices = 0
        async with aiohttp.ClientSession() as session:
            ws = await session.ws_connect(f"ws://127.0.0.1:{self.port}/", max_msg_size=0)

            async def read():
                nonlocal notices
                async for message in ws:
                    if '"flood:' in message.data:
                        notices += 1

            reader = asyncio.get_running_loop().create_task(read())
            begin = time.monotonic()
            sent = 0
            while time.monotonic() - begin < seconds:
                due = int((time.monotonic() - begin) * rate)
                while sent < due:
                    await ws.send_str(frame)
                    sent += 1
                await asyncio.sleep(0.002)
            elapsed = time.monotonic() - begin
            await asyncio.sleep(0.5)
            alive = not ws.closed
            reader.cancel()
            await ws.close()
        return {"sent": sent, "rate": sent / elapsed, "notices": notices, "alive": alive}

    def flood(self, browser, seconds: float, frame: str) -> dict:
        """1,000 frames a second from one client while a page watches: what the page, ROS and the robot saw."""
        page = self.open_page(browser)
        time.sleep(2.0)
        drawn0 = page.evaluate("window.terminalStats.drawn")
        wall0, since = time.monotonic(), time.time()
        cpu0 = cpu_seconds(self.terminal_pid)
        result = run_async(self._flood(seconds, 1000, frame))
        wall1 = time.monotonic()
        result["cpu"] = (cpu_seconds(self.terminal_pid) - cpu0) / (wall1 - wall0)
        result["viewer_fps"] = (page.evaluate("window.terminalStats.drawn") - drawn0) / (wall1 - wall0)
        page.context.close()
        result["published"] = len([r for r in self.records("/terminal/cmd_vel", since) if r["t"] < since + seconds])
        result["cruise"] = len([r for r in self.records("/cmd_vel", since)
                                if r["t"] < since + seconds and r["msg"]["linear"]["x"] == 0.2])
        time.sleep(1.0)  # the suppressor hands the line back
        return result


def run_async(coroutine) -> object:
    """Run a coroutine to completion on a thread of its own (Playwright's sync API holds this thread's loop)."""
    result: list = []
    thread = threading.Thread(target=lambda: result.append(asyncio.run(coroutine)))
    thread.start()
    thread.join()
    return result[0]


def watch_screenshot(url_file: Path, path: str, lit: str, wait: float, query: str = "", delay: float = 0.3) -> int:
    """A screenshot of a terminal some run started (``subsumption run patrol --level 5`` writes its URLs to
    ``OUT/logs/terminal_urls.json``): the page opened as a viewer once the terminal is up, taken the moment the
    arbiter `lit` is lit (its upper line holds control), or after `wait` s with whatever is on it."""
    from playwright.sync_api import sync_playwright

    deadline = time.monotonic() + wait
    while not url_file.exists():
        if time.monotonic() > deadline:
            print(f"bench.terminal: {url_file} did not appear within {wait:g} s", file=sys.stderr)
            return 1
        time.sleep(0.5)
    url = json.loads(url_file.read_text())["terminal"]
    if query:
        url += ("&" if "?" in url else "?") + query
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path="/usr/bin/chromium", args=CHROMIUM_ARGS)
        try:
            page = browser.new_context(viewport={"width": 1400, "height": 1000}).new_page()
            page.goto(url)
            page.wait_for_selector("#network svg g.node", timeout=60_000)
            seen = False
            while time.monotonic() < deadline:
                seen = page.locator(f"#arbiter-{lit}.lit").count() > 0
                if seen:
                    break
                time.sleep(0.2)
            time.sleep(delay)
            page.screenshot(path=path, full_page=True)
            snapshot = page.request.get(url.split("?")[0] + "snapshot?topic=camera/rgb/image_raw/compressed")
            if snapshot.ok:  # the newest frame on the robot, to compare with what the page drew
                Path(path).with_suffix(".snapshot.jpg").write_bytes(snapshot.body())
            print(f"{path}: {'with ' + lit + ' lit' if seen else lit + ' never lit: the page as it was'}")
        finally:
            browser.close()
    return 0


def row(name: str, value: float, unit: str, goal: str, ratio: str) -> str:
    return f"| {name} | {value:.1f} {unit} | {goal} | {ratio} |"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--presses", type=int, default=60, help="key presses to time")
    parser.add_argument("--fps", type=float, default=30.0, help="camera frames a second of the scene")
    parser.add_argument("--size", default="640x480", help="camera frame size")
    parser.add_argument("--seconds", type=float, default=8.0, help="seconds per viewer measurement")
    parser.add_argument("--flood-seconds", type=float, default=10.0)
    parser.add_argument("--screenshot", help="also write a screenshot of the page here (PNG)")
    parser.add_argument("--screenshot-only", action="store_true", help="only write --screenshot, measure nothing")
    parser.add_argument("--watch", type=Path, metavar="URL_FILE",
                        help="screenshot (to --screenshot) a terminal already running, found by the URL file it "
                             "writes (~url_file), when the arbiter --lit is lit; measure nothing")
    parser.add_argument("--lit", default="operator_drives", help="with --watch: the arbiter to wait for")
    parser.add_argument("--wait", type=float, default=600.0, help="with --watch: seconds to wait at most")
    parser.add_argument("--query", default="", help="with --watch: added to the page's URL (fps=5: fewer frames)")
    parser.add_argument("--delay", type=float, default=0.3, help="with --watch: seconds from lit to the picture")
    args = parser.parse_args()
    if args.watch:
        if not args.screenshot:
            parser.error("--watch needs --screenshot PATH")
        return watch_screenshot(args.watch, args.screenshot, args.lit, args.wait, args.query, args.delay)

    from playwright.sync_api import sync_playwright

    master = start_master()
    env = dict(os.environ, ROS_MASTER_URI=master.uri, ROS_HOSTNAME="127.0.0.1", PYTHONUNBUFFERED="1")
    env["PATH"] = f"{Path(sys.executable).parent}:{env.get('PATH', '')}"
    with tempfile.TemporaryDirectory(prefix="bench_terminal_") as work:
        bench = Bench(args, Path(work))
        try:
            bench.start(env)
            with sync_playwright() as playwright:
                browser = playwright.chromium.launch(executable_path="/usr/bin/chromium", args=CHROMIUM_ARGS)
                try:
                    if args.screenshot_only:
                        bench.screenshot(browser, args.screenshot)
                        return 0
                    idle = bench.idle_cpu(args.seconds / 2)
                    fps1, lat1, cpu1 = bench.viewers(browser, 1, args.seconds)
                    fps5, lat5, cpu5 = bench.viewers(browser, 5, args.seconds)
                    keys = bench.key_presses(browser)
                    refused = bench.flood(browser, args.flood_seconds, '{"op": "publish", "topic": "/map", "msg": {}}')
                    commands = bench.flood(browser, args.flood_seconds,
                                           '{"op": "publish", "topic": "terminal/cmd_vel", "msg": {}}')
                    if args.screenshot:
                        bench.screenshot(browser, args.screenshot)
                finally:
                    browser.close()
            silence = bench.deadman("silence", 8)
            disconnect = bench.deadman("disconnect", 8)
        finally:
            bench.stop()
            master.stop()

    ms = lambda values, q: 1000 * percentile(values, q)  # noqa: E731
    print(f"Terminal benchmark, {datetime.date.today()}, camera {args.size} JPEG at {args.fps:g} fps, "
          f"{len(keys['terminal'])} key presses\n")
    print("| figure | measured | goal | measured / goal |")
    print("|---|---|---|---|")
    for name, values in (("key press -> terminal/cmd_vel", keys["terminal"]),
                         ("key press -> cmd_vel on the robot (after S and I)", keys["robot"])):
        print(row(f"{name}, p50", ms(values, 50), "ms", "", ""))
        print(row(f"{name}, p99", ms(values, 99), "ms", "<= 30 ms", f"{ms(values, 99) / 30:.2f}"))
    print(row("page keydown -> terminal/cmd_vel, p50", ms(keys["page"], 50), "ms", "", ""))
    print(row("page keydown -> terminal/cmd_vel, p99", ms(keys["page"], 99), "ms", "", ""))
    print(row("camera frame -> canvas (1 viewer), p50", ms(lat1, 50), "ms", "", ""))
    print(row("camera frame -> canvas (1 viewer), p99", ms(lat1, 99), "ms", "<= 100 ms", f"{ms(lat1, 99) / 100:.2f}"))
    print(row("camera frame -> canvas (5 viewers), p99", ms(lat5, 99), "ms", "<= 100 ms", f"{ms(lat5, 99) / 100:.2f}"))
    print(row("fps, 1 viewer", fps1[0], "fps", ">= 15", f"{fps1[0] / 15:.2f}"))
    print(row("fps, 5 viewers (slowest)", min(fps5), "fps", ">= 15", f"{min(fps5) / 15:.2f}"))
    mean5 = statistics.mean(fps5)
    print(row("fps, 5 viewers (mean)", mean5, "fps", "", f"{mean5 / fps1[0]:.2f} of 1 viewer"))
    print(row("server CPU, no viewer", 100 * idle, "% of a core", "", ""))
    print(row("server CPU, 1 viewer", 100 * cpu1, "% of a core", "", ""))
    print(row("server CPU, 5 viewers", 100 * cpu5, "% of a core", "", ""))
    print(row("server CPU per viewer (5 viewers - none) / 5", 100 * (cpu5 - idle) / 5, "% of a core", "", ""))
    print(row("dead-man, silence -> zero Twist, max", ms(silence, 100), "ms", "<= 500 ms",
              f"{ms(silence, 100) / 500:.2f} ({len(silence)} trials)"))
    print(row("dead-man, disconnect -> zero Twist, max", ms(disconnect, 100), "ms", "<= 500 ms",
              f"{ms(disconnect, 100) / 500:.2f} ({len(disconnect)} trials)"))
    print(f"\nFlood, {args.flood_seconds:g} s from one client while a page watches (cruise: the robot's own "
          f"motor line, 10 commands a second when nothing suppresses it):\n")
    print("| flood | sent | per second | reached terminal/cmd_vel | flood notices | connection | page fps | "
          "cruise commands on cmd_vel | server CPU |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, flood in (("publishes to /map (refused)", refused), ("publishes to terminal/cmd_vel", commands)):
        print(f"| {name} | {flood['sent']} | {flood['rate']:.0f} | {flood['published']} | {flood['notices']} | "
              f"{'open' if flood['alive'] else 'closed'} | {flood['viewer_fps']:.1f} | {flood['cruise']} | "
              f"{100 * flood['cpu']:.0f} % |")
    print("\nThe command flood holds the motor line (the suppressor passes the operator's commands, 100 a second "
          "at most after a burst of 200), so cruise's commands are suppressed: that is what an operator is for.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
