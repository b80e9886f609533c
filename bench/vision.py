"""Per-frame cost and accuracy of the vision candidates at 640x480, on one core, on the same recorded frames.

Frames are composited from real photos (tests/support/photoscene.py: astronaut, Grace Hopper, 100 LFW faces, 16 non-face
pictures of skimage.data) with their true face boxes. Tables:

  (1) detect: each face detector (and alt2 + its verifier) -- ms per full frame, share of faces found by size,
      false detections on non-face pictures;
  (2) recognize: cv2.face LBPH and Eigenfaces -- ms per face, share right for enrolled, strangers and LFW 50-99;
  (3) track: each short-term tracker alone and inside the TLD-style tracker on the occlusion scenes -- ms per
      frame, IoU >= 0.5 share while the target is in view, confident frames while hidden, on the other face,
      time to re-find after the occlusion; OpenCV's legacy TLD alone for comparison;
  (4) pipeline: detect + track + follow as modules on the LocalRuntime (detect scanning at 10 Hz): ms per frame
      and frames per second, alarm latency from the first frame with the face >= 30 px tall.

Usage: .venv/bin/python -m bench.vision [--seeds N] [--quick] [--only detect recognize track pipeline] [--strip OUT.png]   (--strip: only draw the tracker through an occlusion)
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

import cv2
import numpy as np

from tests.support import photoscene as ps
from vision.boxes import Box
from vision.faces import DETECTORS, FaceDetector, to_gray
from vision.recognition import RECOGNIZERS, enrol, face_chip
from vision.replay import Pipeline
from vision.tracking import SHORT_TERM, TargetTracker, TrackerSettings

from .tables import markdown_table


# Time is the process's CPU time: what "one core" buys, and the same whether the machine is idle or shared (the
# wall clock on a loaded machine counts other processes' turns too). cv2 runs single-threaded (main()).
CLOCK = time.process_time


def table(title: str, header: list[str], rows: list[list[str]]) -> None:
    """Print `title`, then the Markdown table."""
    print(f"\n{title}\n")
    print(markdown_table(header, rows))


def detection_frames(count: int):
    rng = np.random.default_rng(0)
    frames = []
    for k in range(count):
        px = [24, 26, 30, 35, 40, 50, 60, 80, 100][k % 9]
        photo = [ps.astronaut(), ps.grace_hopper(), ps.lfw_portrait(50 + k % 50)][k % 3]
        d = ps.distance_for_face_height(px)
        x = rng.uniform(-0.3, 0.3) * d
        pictures = [ps.Placed(ps.non_face(ps.NON_FACES[(k + j) % len(ps.NON_FACES)], 0.45), -2.0 + 1.3 * j, 4.0,
                              0.3 + 0.4 * j) for j in range(4)]
        frames.append((px, ps.render([ps.Placed(photo, x, d, 0.3 + rng.uniform(-0.05, 0.2) * d,
                                                 rng.uniform(-30, 30))] + pictures, seed=k)))
    return frames


def bench_detect(quick: bool) -> None:
    frames = detection_frames(27 if quick else 63)
    rows = []
    variants = [(m, None, 1.1, 24) for m in DETECTORS] + [("haar_alt2", "haar_alt", 1.1, 24)]
    variants += [("haar_alt2", "haar_alt", scale, px) for scale, px in ((1.15, 24), (1.2, 24), (1.25, 24), (1.2, 26))]
    for method, verifier, scale, min_px in variants:
        detector = FaceDetector(method, min_face_px=min_px, scale_factor=scale, verifier=verifier)
        found_by_size: dict[int, list[bool]] = {}
        false, spent = 0, 0.0
        for px, frame in frames:
            gray = to_gray(frame.rgb)
            start = CLOCK()
            boxes = detector.detect(gray)
            spent += CLOCK() - start
            truth = [Box.of(b) for b in frame.faces.values()]
            for t in truth:
                found_by_size.setdefault(px, []).append(any(b.iou(t) >= 0.5 for b in boxes))
            false += sum(1 for b in boxes if not any(b.iou(t) >= 0.3 for t in truth))
        small = np.mean([v for px, vs in found_by_size.items() if px < 30 for v in vs])
        big = np.mean([v for px, vs in found_by_size.items() if px >= 30 for v in vs])
        rows.append([method + (f" + {verifier}" if verifier else ""), f"{scale:g}", str(min_px),
                     f"{1000 * spent / len(frames):.1f}",
                     f"{small:.2f}", f"{big:.2f}", str(false)])
    table(f"(1) detect: one full 640x480 frame, {len(frames)} frames, 1 face + 4 non-face pictures each",
          ["detector", "scale step", "min px", "CPU ms/frame", "found 24-26 px", "found >= 30 px", "false detections"], rows)


def bench_recognize(folder: Path, quick: bool) -> None:
    detector = FaceDetector()
    rng = np.random.default_rng(7)

    def chips(photo, count, seed):
        out = []
        r = np.random.default_rng(seed)
        while len(out) < count:
            d = ps.distance_for_face_height(r.uniform(28, 120))
            frame = ps.render([ps.Placed(photo, r.uniform(-0.3, 0.3) * d, d, 0.45, r.uniform(-30, 30))],
                              seed=int(r.integers(10**6)))
            gray = to_gray(frame.rgb)
            hits = [b for b in detector.detect(gray) if b.iou(Box.of(frame.faces[photo.name])) > 0.4]
            if hits:
                out.append(face_chip(gray, hits[0]))
        return out

    n = 10 if quick else 30
    grace, astronaut = chips(ps.grace_hopper(), n, 1), chips(ps.astronaut(), n, 2)
    lfw = []
    for index in range(50, 100):
        frame = ps.render([ps.Placed(ps.lfw_portrait(index), 0.0, rng.uniform(1.2, 2.5), 0.45)], seed=index)
        lfw.append(face_chip(to_gray(frame.rgb), Box.of(frame.faces[f"lfw{index}"])))
    rows = []
    for method in RECOGNIZERS:
        start = CLOCK()
        model = enrol(folder, method, detector, log=lambda _: None)
        enrol_s = CLOCK() - start
        start = CLOCK()
        right_known = np.mean([model.identify_chip(c).name == "grace_hopper" for c in grace])
        right_stranger = np.mean([model.identify_chip(c).name == "" for c in astronaut])
        right_lfw = np.mean([model.identify_chip(c).name == "" for c in lfw])
        per_face = (CLOCK() - start) / (len(grace) + len(astronaut) + len(lfw))
        ratio_known = max(model._nearest_enrolled(c)[1] for c in grace) / model.thresholds[1]
        ratio_unknown = min(min(model._nearest_enrolled(c)[1] for c in astronaut + lfw) / model.thresholds[1], 99)
        rows.append([method, f"{1000 * per_face:.2f}", f"{right_known:.2f}", f"{right_stranger:.2f}", f"{right_lfw:.2f}",
                     f"{ratio_known:.2f} / {ratio_unknown:.2f}", f"{enrol_s:.1f}"])
    table(f"(2) recognize: Grace Hopper enrolled; {len(grace)} views of her, {len(astronaut)} of the astronaut "
          "(a stranger), 50 LFW strangers", ["recognizer", "CPU ms/face", "enrolled named", "astronaut unknown",
                                             "LFW unknown", "distance/threshold: worst enrolled / nearest stranger",
                                             "enrol s"], rows)


def occlusion_frames(seed: int, fps: float):
    walkers, passersby, still, timing = ps.occlusion_scene(seed)
    return list(ps.sequence(walkers, timing["duration_s"], fps, passersby, still, seed=seed)), timing


def score_track(frames, timing, update) -> dict:
    on, hidden_conf, other, refound, spent = [], 0, 0, None, 0.0
    for t, frame in frames[1:]:
        start = CLOCK()
        box, confident = update(frame)
        spent += CLOCK() - start
        truth, distractor = frame.faces.get("astronaut"), frame.faces.get("grace_hopper")
        hit = bool(truth) and confident and box is not None and box.iou(Box.of(truth)) >= 0.5
        if truth:
            on.append(hit)
        elif confident:
            hidden_conf += 1
        if confident and box is not None and distractor and box.iou(Box.of(distractor)) > 0.2:
            other += 1
        if refound is None and t >= timing["hidden_until_s"] and hit:
            refound = t
    back = next(t for t, f in frames if t >= timing["hidden_until_s"] and "astronaut" in f.faces)
    return {"ms": 1000 * spent / (len(frames) - 1), "iou": float(np.mean(on)), "hidden": hidden_conf,
            "other": other, "refound": None if refound is None else refound - back}


def bench_track(seeds: int, quick: bool) -> None:
    rows = []
    scenes = [occlusion_frames(seed, 30.0) for seed in range(10, 10 + seeds)]
    for name in SHORT_TERM:
        for tld_style in (False, True):
            if name == "tld" and tld_style or quick and name in ("csrt", "tld"):
                continue
            results = []
            for frames, timing in scenes:
                first = frames[0][1]
                start_box = Box.of(first.faces["astronaut"])
                if tld_style:
                    tracker = TargetTracker(TrackerSettings(short_term=name))
                    tracker.start(first.rgb, start_box)

                    def update(frame, tracker=tracker):
                        state = tracker.update(frame.rgb)
                        return state.box, state.confident
                else:
                    plain = SHORT_TERM[name]()
                    plain.init(first.rgb, start_box.ints())

                    def update(frame, plain=plain):
                        ok, found = plain.update(frame.rgb)
                        return (Box.of(found) if ok else None), bool(ok)
                results.append(score_track(frames, timing, update))
            refound = [r["refound"] for r in results]
            rows.append([("TLD-style + " if tld_style else "alone: ") + name,
                         f"{np.mean([r['ms'] for r in results]):.1f}", f"{np.mean([r['iou'] for r in results]):.3f}",
                         str(sum(r["hidden"] for r in results)), str(sum(r["other"] for r in results)),
                         "never" if None in refound else f"{max(refound):.2f}"])
    table(f"(3) track: occlusion scenes (3 s behind a passer-by, another face beside), 30 fps, seeds 10-{9 + seeds}",
          ["tracker", "CPU ms/frame", "IoU >= 0.5 in view", "confident while hidden", "frames on the other face",
           "re-found after back in view (s, worst)"], rows)


PIPELINES = {  # name: (detect's parameters, track's)
    "whole image every scan (before)": ({"full_every": 1}, {"full_search_every": 1}),
    "whole image every 5th scan while a suspect is in view, every 2nd search while lost": ({}, {}),
    "as above, rows above the horizon (+16, the patrol robot's)": ({"below_horizon_px": 16}, {}),
    "as above, the newest frame scanned within 0.15 of a core (cpu_share)":
        ({"below_horizon_px": 16, "cpu_share": 0.15}, {}),
}


def bench_pipeline(folder: Path, seeds: int) -> None:
    from vision.recognition import enrol as make_model
    model = make_model(folder, log=lambda _: None).save(folder / "staff.npz")
    rows = []
    for seed in range(20, 20 + seeds):
        walkers, passersby, still, timing = ps.entering_scene(seed)
        frames = list(ps.sequence(walkers, timing["duration_s"], 30.0, passersby, still, seed=seed))
        firsts = [t for t, f in frames if "astronaut" in f.faces and f.faces["astronaut"][3] >= 30
                  and Box.of(f.faces["astronaut"]).inside(ps.WIDTH, ps.HEIGHT)]
        in_view = [t for t, f in frames if "astronaut" in f.faces]
        for name, (detect, track) in PIPELINES.items():
            pipeline = Pipeline(detect={"model": str(model), **detect}, track=track)
            start = CLOCK()
            recording = pipeline.run(frames)
            per_frame = (CLOCK() - start) / len(frames)
            alarm = recording.alarms[0][0] - firsts[0] if recording.alarms and firsts else None
            truth = {t: Box.of(f.faces["astronaut"]) for t, f in frames if "astronaut" in f.faces}
            boxes = [(t, Box.from_roi(info.roi)) for t, info in recording.boxes]
            tracked = [t for t, box in boxes if box.area > 0 and t in truth and box.iou(truth[t]) >= 0.5]
            after = [t for t in in_view if recording.alarms and t >= recording.alarms[0][0]]
            share = len(tracked) / len(after) if after else float("nan")
            rows.append([str(seed), name, f"{1000 * per_frame:.1f}", f"{1 / per_frame:.1f}",
                         "none" if alarm is None else f"{alarm:.2f}", str(len(recording.alarms)), f"{share:.3f}"])
    table("(4) pipeline: detect (10 Hz scans) + track + follow modules on the LocalRuntime, a stranger walks in, "
          "30 fps frames (render time excluded)", ["seed", "scans", "CPU ms/frame", "frames/s",
                                                     "alarm after face >= 30 px (s)", "alarms",
                                                     "IoU >= 0.5 after the alarm"], rows)


def draw_strip(path: Path, seed: int = 11) -> Path:
    """The TLD-style tracker through the occlusion scene: before, hidden, coming back, re-found."""
    from vision.strip import StripFrame, camera_strip
    frames, timing = occlusion_frames(seed, 30.0)
    tracker = TargetTracker()
    tracker.start(frames[0][1].rgb, Box.of(frames[0][1].faces["astronaut"]))
    back = next(t for t, f in frames if t >= timing["hidden_until_s"] and "astronaut" in f.faces)
    wanted = [0.5, timing["hidden_from_s"] - 0.1, timing["hidden_from_s"] + 1.5, back - 0.1, back, back + 0.1,
              back + 0.2, back + 1.0]
    strip = []
    for t, frame in frames[1:]:
        state = tracker.update(frame.rgb)
        if any(abs(t - w) < 1 / 60 for w in wanted):
            truth = frame.faces.get("astronaut")
            strip.append(StripFrame(t, frame.rgb, state.box, state.confident, Box.of(truth) if truth else None,
                                    state.source))
    return camera_strip(strip, path)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="fewer frames, no CSRT and legacy TLD")
    parser.add_argument("--only", nargs="+", choices=("detect", "recognize", "track", "pipeline"),
                        default=("detect", "recognize", "track", "pipeline"), help="the tables to make")
    parser.add_argument("--strip", type=Path, help="only write a strip of frames: the tracker through an occlusion")
    args = parser.parse_args()
    cv2.setNumThreads(1)
    if args.strip:
        print(draw_strip(args.strip))
        return 0
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "staff"
        folder.mkdir()
        cv2.imwrite(str(folder / "grace_hopper.png"), ps.grace_hopper().rgb[:, :, ::-1])
        print(f"bench.vision: one core (cv2.setNumThreads(1)), OpenCV {cv2.__version__}")
        if "detect" in args.only:
            bench_detect(args.quick)
        if "recognize" in args.only:
            bench_recognize(folder, args.quick)
        if "track" in args.only:
            bench_track(args.seeds, args.quick)
        if "pipeline" in args.only:
            bench_pipeline(folder, args.seeds)
    return 0


if __name__ == "__main__":
    sys.exit(main())
