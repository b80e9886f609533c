"""Face detection at known distances, enrolled versus unknown faces, and the enrol command, on frames
composited from real photos (vision.photoscene: f * H / d perspective, true boxes known)."""
from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from subsumption.cli import main as subsumption_main
from support import photoscene as ps
from vision.boxes import Box
from vision.faces import DetectorError, FaceDetector, to_gray
from vision.recognition import FaceModel, ModelError, enrol, face_chip


@pytest.fixture(scope="module")
def detector():
    return FaceDetector()


def _write_photos(folder, photos):
    folder.mkdir(parents=True, exist_ok=True)
    for photo in photos:
        cv2.imwrite(str(folder / f"{photo.name}.png"), photo.rgb[:, :, ::-1])
    return folder


@pytest.fixture(scope="module")
def grace_only(tmp_path_factory):
    """Grace Hopper is staff; the astronaut and every LFW face are strangers."""
    folder = _write_photos(tmp_path_factory.mktemp("staff"), [ps.grace_hopper()])
    return enrol(folder, log=lambda _: None)


@pytest.mark.parametrize("distance_m", [1.0, 2.0, 3.0])
@pytest.mark.parametrize("turn_deg", [0.0, 30.0])
def test_faces_found_at_known_distances_with_the_size_perspective_gives(detector, distance_m, turn_deg):
    frame = ps.render([ps.Placed(ps.astronaut(), -0.25 * distance_m, distance_m, 0.45, turn_deg),
                       ps.Placed(ps.grace_hopper(), 0.25 * distance_m, distance_m, 0.45, -turn_deg)], seed=3)
    found = detector.detect(to_gray(frame.rgb))
    for name, truth in frame.faces.items():
        matches = [box for box in found if box.iou(Box.of(truth)) >= 0.5]
        assert matches, f"{name} at {distance_m} m not found: {[b.ints() for b in found]} vs {truth}"
        expected_px = ps.FOCAL_PX * 0.16 / distance_m  # the face is 0.16 m tall: h = f * H / d
        assert matches[0].h == pytest.approx(expected_px, rel=0.25)
    assert len(found) == 2


def test_no_face_in_pictures_that_are_not_faces(detector):
    """Every non-face picture of skimage.data (a cat, coins with heads on them, a clock, textures...) near and
    far, four to a frame."""
    false = []
    names = list(ps.NON_FACES)
    for distance_m in (1.0, 2.5):
        for first in range(0, len(names), 4):
            group = names[first:first + 4]
            frame = ps.render([ps.Placed(ps.non_face(name, 0.4), (k - 1.5) * 0.45 * distance_m, distance_m, 0.4)
                               for k, name in enumerate(group)], seed=first)
            false += [(group, distance_m, box.ints()) for box in detector.detect(to_gray(frame.rgb))]
    assert false == []


def test_enrolled_person_is_named_and_strangers_are_unknown(grace_only, detector):
    rng = np.random.default_rng(11)
    for photo, expected in ((ps.grace_hopper(), "grace_hopper"), (ps.astronaut(), "")):
        for _ in range(6):
            d = ps.distance_for_face_height(rng.uniform(30, 110))
            frame = ps.render([ps.Placed(photo, rng.uniform(-0.3, 0.3) * d, d, 0.45, rng.uniform(-30, 30))],
                              seed=int(rng.integers(1000)))
            gray = to_gray(frame.rgb)
            box = next(b for b in detector.detect(gray) if b.iou(Box.of(frame.faces[photo.name])) > 0.4)
            assert grace_only.identify(gray, box).name == expected
    # 50 faces of other people (LFW 50-99, never seen in enrolment: its cohort is LFW 0-49)
    strangers = []
    for index in range(50, 100):
        frame = ps.render([ps.Placed(ps.lfw_portrait(index), 0.0, 1.5, 0.45)], seed=index)
        gray = to_gray(frame.rgb)
        strangers.append(grace_only.identify_chip(face_chip(gray, Box.of(frame.faces[f"lfw{index}"]))).name)
    assert strangers == [""] * 50


def test_enrol_command_writes_a_model_that_loads(tmp_path):
    folder = _write_photos(tmp_path / "staff", [ps.astronaut(), ps.grace_hopper()])
    out = tmp_path / "models" / "staff.npz"
    assert subsumption_main(["enrol", str(folder), "-o", str(out)]) == 0
    model = FaceModel.load(out)
    assert model.people == ["astronaut", "grace_hopper"]
    assert all(math.isfinite(t) and t > 0 for t in model.thresholds.values())


def test_enrol_bad_input_one_line_errors(tmp_path, capsys):
    assert subsumption_main(["enrol", str(tmp_path / "missing"), "-o", str(tmp_path / "m.npz")]) == 2
    assert capsys.readouterr().err.strip() == f"subsumption enrol: {tmp_path / 'missing'}: no such folder of photos"
    faceless = tmp_path / "faceless"
    faceless.mkdir()
    cv2.imwrite(str(faceless / "cat.png"), ps.non_face("chelsea").rgb)
    assert subsumption_main(["enrol", str(faceless), "-o", str(tmp_path / "m.npz")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cat.png: no face found" in err[0]
    (tmp_path / "broken.npz").write_bytes(b"not a model")
    with pytest.raises(ModelError, match="broken.npz: not a face model file"):
        FaceModel.load(tmp_path / "broken.npz")
    with pytest.raises(DetectorError, match="unknown face detector 'yolo'"):
        FaceDetector("yolo")
    from subsumption.testing import Harness
    from vision.modules import Detect
    with pytest.raises(ModelError, match=r"/module_under_test: parameter ~model: .*missing.npz: no such face model"):
        Harness(Detect, params={"model": str(tmp_path / "missing.npz")})
