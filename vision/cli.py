"""`subsumption enrol`: a folder of photos of the people allowed in the building -> a face model file."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path


def register_enrol(commands: argparse._SubParsersAction) -> None:
    """Add ``subsumption enrol`` to the command (an entry point of the ``subsumption.commands`` group)."""
    enrol = commands.add_parser(
        "enrol", help="enrol the people in a folder of photos: write the face model detect uses (~model)",
        description="Find the face in every photo of PHOTOS (one subfolder per person, or files named after "
                    "the person: grace.jpg, grace_2.jpg), learn each face as the robot's camera will see it, and "
                    "write the model file for the detect module's ~model parameter.")
    enrol.add_argument("photos", type=Path, help="folder of photos")
    enrol.add_argument("-o", "--output", type=Path, required=True, help="model file to write (.npz)")
    enrol.add_argument("--recognizer", default="lbph", help="lbph (default) or eigen")
    enrol.add_argument("--detector", default="haar_alt2", help="face detector (default haar_alt2)")
    enrol.set_defaults(func=cmd_enrol)


def cmd_enrol(args: argparse.Namespace) -> int:
    """``subsumption enrol``: learn the faces in a folder of photos and write the model file; exit status 2 on bad
    input."""
    from .faces import DetectorError, FaceDetector
    from .recognition import ModelError, enrol

    try:
        model = enrol(args.photos, args.recognizer, FaceDetector(args.detector), log=print)
        path = model.save(args.output)
    except (ModelError, DetectorError) as error:
        print(f"subsumption enrol: {error}", file=sys.stderr)
        return 2
    except OSError as error:
        print(f"subsumption enrol: cannot write {args.output}: {error.strerror or error}", file=sys.stderr)
        return 2
    print(f"{path}: {len(model.people)} enrolled ({', '.join(model.people)}), "
          f"{int((model.labels != 0).sum())} views, unknown beyond "
          + ", ".join(f"{model.names[k]} {v:.0f}" for k, v in sorted(model.thresholds.items())))
    return 0
