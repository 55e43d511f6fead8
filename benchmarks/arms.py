"""How well the arms' keep decision tells another action from another manner, on held-out pairs.

    python benchmarks/arms.py [--pairs 2] [--option arm_rhythm_above=0.2 ...]

Each arm keeps the content's action where its hand is elsewhere or goes back and forth where the matched
style window's does not (`steps.arms`, `TransferConfig.arm_offset_above` and `arm_rhythm_above`). This
script pairs held-out takes (take % 5 == 0) of the dataset's gait and gesture contents, a `normal` take as
content and a take of another style as style, up to `--pairs` pairs for every content type and style clip
type, transfers each with the given options, and reads the explain record: per patch and arm, the hand
offset, the rhythm difference and the share of the content's action kept (a mirrored window's arms are
its clip's other arms).

Each arm is labelled by what it does in its clip's content type: `swing` (walks, turns, runs), `wave`,
`raise` (the hand the gesture names, or both) or `idle` (the other hand of a one-handed gesture). A keep
decision is right where the labels differ (another action: keep) and where they agree (another manner of
the same action: swap). The table gives, per label pair, the patches, the median of both measures and the
mean share kept; the summary the mean share kept over all patches of another action (want 1) and of the same
action (want 0). The labels come from the dataset's file names and serve this measurement only. They
are per clip, not per moment: a raise-up's rise matched with a wave clip's own rise counts as another
action, though swapping it is right, so a row such as raise <- wave mixes both.
"""

from __future__ import annotations

import argparse
import itertools
import logging
import sys
from collections import defaultdict

import numpy as np
from speed import config_option  # benchmarks/ is the script's own folder

from elastyle.io.dataset import default_data_path, find_clips, labelled_clips
from elastyle.model.file import load_model
from elastyle.pipeline import transfer
from elastyle.steps.config import TransferConfig

CONTENTS = (
    "walk", "run", "walk-turn-left", "wave-left-hand", "wave-right-hand", "wave-both-hands",
    "raise-up-left-hand", "raise-up-right-hand", "raise-up-both-hands",
)  # fmt: skip
ARMS = ("left-arm", "right-arm")


def arm_action(content: str, arm: str) -> str:
    """What an arm does in a dataset content type: swing, wave, raise or idle."""
    if not content.startswith(("wave", "raise-up")):
        return "swing"
    kind = "wave" if content.startswith("wave") else "raise"
    side = arm.split("-")[0]
    return kind if content.endswith("both-hands") or f"-{side}-" in content else "idle"


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--data", default=str(default_data_path() or ""))
    parser.add_argument("--pairs", type=int, default=2, help="pairs per content type and style clip type")
    parser.add_argument("--option", action="append", default=[], help="a TransferConfig field, NAME=VALUE")
    args = parser.parse_args()
    if not args.data:
        print("no data: set ELASTYLE_DATA or pass --data", file=sys.stderr)
        return 2
    logging.getLogger("elastyle").setLevel(logging.ERROR)
    config = TransferConfig.of(None, **dict(config_option(o) for o in args.option))
    normal: dict[str, list] = defaultdict(list)
    styled: dict[str, list] = defaultdict(list)
    for clip, label in labelled_clips(find_clips([args.data]), held_out=True):
        if label.content in CONTENTS:
            (normal if label.style == "normal" else styled)[label.content].append(clip)
    model = load_model()
    measures: dict[tuple[str, str], list[tuple[float, float, float]]] = defaultdict(list)
    for content_type, style_type in itertools.product(CONTENTS, CONTENTS):
        contents, styles = sorted(normal[content_type], key=str), sorted(styled[style_type], key=str)
        for i in range(min(args.pairs, len(contents), len(styles))):
            content = contents[i].read()[0]
            style = styles[(7 * i + len(content_type)) % len(styles)].read()[0]  # spread over the styles
            record = transfer(content, style, config, model=model).explain
            for patch in record["styles"][0]["patches"]:
                for arm, other in zip(ARMS, ARMS[::-1]):
                    part = patch["parts"][arm]
                    window_arm = other if patch["style_mirrored"] else arm  # a mirrored window's sides swap
                    key = (arm_action(content_type, arm), arm_action(style_type, window_arm))
                    measures[key].append(
                        (part["hand_offset"], part["rhythm_difference"], part["content_share"])
                    )
    print(f"{'content arm <- style arm':<26}{'patches':>8}{'offset':>8}{'rhythm':>8}{'kept':>7}")
    kept_other: list[float] = []
    kept_same: list[float] = []
    for (content_arm, style_arm), rows in sorted(measures.items()):
        values = np.array(rows)
        print(
            f"{content_arm + ' <- ' + style_arm:<26}{len(values):>8}{np.median(values[:, 0]):>8.2f}"
            f"{np.median(values[:, 1]):>8.2f}{np.mean(values[:, 2]):>7.2f}"
        )
        (kept_same if content_arm == style_arm else kept_other).extend(values[:, 2])
    print(
        f"\nanother action: mean share kept {np.mean(kept_other):.2f} over {len(kept_other)} patches (want 1)"
    )
    print(f"the same action: mean share kept {np.mean(kept_same):.2f} over {len(kept_same)} patches (want 0)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
