"""Reconstruction quality of a model on held-out takes, against the targets of the autoencoder issue.

    python benchmarks/autoencoder.py [--model M] [--pattern '*_walk_*']
Targets: joint error <= 1.5 cm, end effectors <= 3 cm, skating <= 1.5 x the original's, jerk <= 1.2 x.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from elastyle.eval.reconstruction import reconstruction_report
from elastyle.io.dataset import default_data_path, find_clips, labelled_clips
from elastyle.model.file import load_model

TARGETS = {"joint_error_cm": 1.5, "end_effector_error_cm": 3.0, "skating_ratio": 1.5, "jerk_ratio": 1.2}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--model", nargs="+", default=[None])
    parser.add_argument("--data", default=str(default_data_path() or ""))
    parser.add_argument("--pattern", default="*_walk*")
    parser.add_argument("--clips", type=int, default=60, help="held-out clips to use (every n-th of them)")
    parser.add_argument(
        "--smooth-s", type=float, nargs="+", default=[0.0], help="decoder output low-pass sigma(s), s"
    )
    args = parser.parse_args()
    clips = [clip for clip, _ in labelled_clips(find_clips([args.data], pattern=args.pattern), held_out=True)]
    clips = clips[:: max(1, len(clips) // args.clips)]
    motions = [c.read()[0] for c in clips]
    print(f"{len(motions)} held-out clips matching {args.pattern!r}")
    header = (
        f"{'model':<40}{'joint cm':>10}{'effector cm':>12}{'skate cm/s':>11}{'orig':>7}{'skate x':>8}"
        f"{'jerk x':>8}{'train min':>10}"
    )
    print(header)
    for path, smooth_s in ((p, s) for p in args.model for s in args.smooth_s):
        model = load_model(path)
        r = reconstruction_report(model, motions, smooth_s)
        minutes = model.metadata.get("training_minutes", float("nan"))
        name = f"{Path(path).name if path else 'shipped'} smooth {smooth_s:g} s"
        print(
            f"{name:<40}{r['joint_error_cm']:>10.2f}{r['end_effector_error_cm']:>12.2f}"
            f"{r['skating_cm_s']:>11.1f}{r['original_skating_cm_s']:>7.1f}{r['skating_ratio']:>8.2f}{r['jerk_ratio']:>8.2f}{minutes:>10.1f}"
        )
    print("targets: " + ", ".join(f"{k} <= {v}" for k, v in TARGETS.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
