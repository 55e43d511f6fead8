"""What a model can represent, per content type: reconstruction error on held-out takes of each.

    python benchmarks/contents.py [--model A.npz B.npz ...] [--clips 12]

For every content type of the dataset (walk, run, turns, waves, raise-ups), up to `--clips` held-out takes
(take % 5 == 0, never trained on) go through the model at strength 0 with the report's decoding (content
latents decoded, the content's root path): mean joint position error relative to the hips, and the same at
hands and feet (cm). A leave-content-out study trains with `elastyle train --exclude 'dataset-2_run_*'` and
reads the left-out row here. Targets: 0.6 cm / 1.2 cm on every content; a left-out content 1.5 / 3.0 cm.

Then motions no clip of the dataset holds, built from the same held-out takes: each walk with the arms of a
right-hand wave or of a two-handed raise (joint for joint), and each walk resampled to 2.5 times its speed,
measured as `transfer` measures a content clip (`model.depth.clip_depth`: mean joint error, cm).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from elastyle.core.motion import Motion
from elastyle.core.parts import body_parts
from elastyle.eval.reconstruction import reconstruction_report
from elastyle.io.dataset import default_data_path, find_clips, labelled_clips
from elastyle.model.depth import clip_depth
from elastyle.model.file import StyleModel, load_model

FAST = 2.5  # the composites' faster walks: this many times the walk's speed


def with_arms_of(body: Motion, arms: Motion) -> Motion:
    """`body` (legs, spine, root path) with the arms of `arms` (same skeleton), over their common frames."""
    frames = min(body.num_frames, arms.num_frames)
    parts = body_parts(body.skeleton)
    joints = np.concatenate([parts["left-arm"], parts["right-arm"]])
    rotations = body.rotations[:frames].copy()
    rotations[:, joints] = arms.rotations[:frames, joints]
    return Motion(body.skeleton, rotations, body.translations[:frames].copy(), body.fps)


def composites(motions: dict[str, list[Motion]]) -> dict[str, list[Motion]]:
    """Motions the dataset does not hold, from held-out takes of its contents."""
    walks = motions["walk"]
    return {
        "held-out walks": walks,
        "walks with a right-hand wave's arms": [
            with_arms_of(w, a) for w, a in zip(walks, motions["wave-right-hand"])
        ],
        "walks with a two-handed raise's arms": [
            with_arms_of(w, a) for w, a in zip(walks, motions["raise-up-both-hands"])
        ],
        f"walks at {FAST:g} times their speed": [
            w.sample(np.arange(0, w.num_frames - 1, FAST)) for w in walks
        ],
    }


def composite_errors(model: StyleModel, clips: dict[str, list[Motion]]) -> dict[str, float]:
    """Mean `clip_depth` error (cm) of each group of clips."""
    return {
        name: float(np.mean([clip_depth(model, m, name)[0] for m in group])) for name, group in clips.items()
    }


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--model", nargs="+", default=[None], help="model files (default: the shipped one)")
    parser.add_argument("--data", default=str(default_data_path() or ""))
    parser.add_argument("--clips", type=int, default=12, help="held-out takes per content type")
    args = parser.parse_args()
    by_content: dict[str, list] = {}
    for clip, label in labelled_clips(find_clips([args.data]), held_out=True):
        by_content.setdefault(label.content, []).append(clip)
    motions = {}
    for content, clips in sorted(by_content.items()):
        chosen = clips[:: max(1, len(clips) // args.clips)][: args.clips]
        motions[content] = [c.read()[0] for c in chosen]
    for path in args.model:
        model = load_model(path)
        name = Path(path).name if path else "shipped"
        minutes = model.metadata.get("training_minutes", float("nan"))
        print(f"\n{name} (latent {model.config.latent_channels}, {minutes} min training)")
        print(f"{'content':<22}{'clips':>6}{'joint cm':>10}{'hands/feet cm':>15}")
        joints, effectors = [], []
        for content, clips in motions.items():
            report = reconstruction_report(model, clips)
            joints.append(report["joint_error_cm"])
            effectors.append(report["end_effector_error_cm"])
            print(f"{content:<22}{len(clips):>6}{joints[-1]:>10.2f}{effectors[-1]:>15.2f}")
        print(f"{'mean':<22}{'':>6}{np.mean(joints):>10.2f}{np.mean(effectors):>15.2f}")
        print(f"{'motions no clip holds':<40}{'clips':>6}{'joint cm':>10}")
        built = composites(motions)
        for group, error in composite_errors(model, built).items():
            print(f"{group:<40}{len(built[group]):>6}{error:>10.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
