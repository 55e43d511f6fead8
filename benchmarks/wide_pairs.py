"""A wider set of held-out pairs for the independent referee, so one pair does not decide a figure.

    python benchmarks/wide_pairs.py -o /tmp/wide_pairs.json
    python ../shared/referee/referee.py --pairs /tmp/wide_pairs.json --name NAME --jobs 2 \
        --cmd "elastyle transfer {content} --style {style} -o {out}"

The referee scores 78 fixed pairs, 18 per gesture and cross set, where one pair moves a figure by 0.06.
This script writes 192 pairs in the referee's pair format (its `--pairs` file), every clip a held-out take
(take % 5 == 0) of the dataset, the content always a `normal` take: walk 18, turn 12 and run 12 (each
style), gesture 72 (each wave and raise-up given each of the six styles, twice) and cross 78 (a run given
a walk's style and a walk given a run's, twice per style; a turning walk given a straight walk's; each
wave given the same hand's raise-up and the other way round; a walk given a wave's). Takes are chosen by
fixed rotations of the sorted take lists, so the file is the same on every machine.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict

from elastyle.io.dataset import default_data_path, find_clips, labelled_clips

STYLES = ("active", "elderly", "exhausted", "feminine", "masculine", "youthful")
HANDS = ("left-hand", "right-hand", "both-hands")
GESTURES = tuple(f"{kind}-{hand}" for kind in ("wave", "raise-up") for hand in HANDS)


def wide_pairs(takes: dict[tuple[str, str], list[str]]) -> list[dict[str, str]]:
    """Pairs from held-out clip stems per (content type, style), each list sorted."""
    pairs: list[dict[str, str]] = []

    def add(set_name: str, group: str, content: str, style: tuple[str, str], i: int, j: int) -> None:
        contents, styles = takes.get((content, "normal"), []), takes.get(style, [])
        if not contents or not styles:
            return
        content_clip, style_clip = contents[i % len(contents)], styles[j % len(styles)]
        pair_id = f"{set_name}_{group}_{style[1]}{style_clip[-3:]}_on_{content}{content_clip[-3:]}"
        if any(p["id"] == pair_id for p in pairs):
            return
        pairs.append(
            {
                "id": pair_id,
                "set": set_name,
                "group": group,
                "content_clip": content_clip,
                "style_clip": style_clip,
                "content_label": content,
                "style_label": style[1],
                "style_content": style[0],
            }
        )

    for k, style in enumerate(STYLES):
        for i in range(3):
            add("walk", "walk", "walk", ("walk", style), i + k, 2 * i + k + 3)
        for i in range(2):
            add("run", "run", "run", ("run", style), i + k + 1, i + k + 4)
        for turn in ("walk-turn-left", "walk-turn-right"):
            add("turn", turn, turn, (turn, style), k + 2, k + 5)
    for gesture in GESTURES:
        for k, style in enumerate(STYLES):
            for i in range(2):
                add("gesture", gesture, gesture, (gesture, style), i + k + 1, i + 2 * k + 1)
    for k, style in enumerate(STYLES):
        for i in range(2):
            add("cross", "run<-walk", "run", ("walk", style), i + k, i + k + 7)
            add("cross", "walk<-run", "walk", ("run", style), i + k + 2, i + k + 6)
        add("cross", "turn<-walk", "walk-turn-left", ("walk", style), k, k + 9)
        add("cross", "turn<-walk", "walk-turn-right", ("walk", style), k + 1, k + 10)
        for hand in HANDS:
            add("cross", "wave<-raise", f"wave-{hand}", (f"raise-up-{hand}", style), k + 3, k + 1)
            add("cross", "raise<-wave", f"raise-up-{hand}", (f"wave-{hand}", style), k + 4, k + 2)
            add("cross", "walk<-wave", "walk", (f"wave-{hand}", style), k + 5, k + 3)
    return pairs


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--data", default=str(default_data_path() or ""))
    parser.add_argument("-o", "--output", required=True, help="the pairs file to write (JSON)")
    args = parser.parse_args()
    if not args.data:
        print("no data: set ELASTYLE_DATA or pass --data", file=sys.stderr)
        return 2
    takes: dict[tuple[str, str], list[str]] = defaultdict(list)
    for clip, label in labelled_clips(find_clips([args.data]), held_out=True):
        takes[(label.content, label.style)].append(clip.stem)
    pairs = wide_pairs({key: sorted(stems) for key, stems in takes.items()})
    about = "wider held-out pairs written by elastyle's benchmarks/wide_pairs.py"
    with open(args.output, "w") as handle:
        json.dump(
            {"about": about, "sets": ["walk", "turn", "run", "gesture", "cross"], "pairs": pairs}, handle
        )
    counts: dict[str, int] = defaultdict(int)
    for pair in pairs:
        counts[pair["set"]] += 1
    print(f"wrote {args.output}: {len(pairs)} pairs ({', '.join(f'{s} {n}' for s, n in counts.items())})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
