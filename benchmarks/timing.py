"""Does the output take the style's timing? Timing error per method on held-out dataset walk pairs.

python benchmarks/timing.py [--model M] [--pairs 24] [--patch-s 0.5 1.0 ...] [--stretch 0.25 0.5 ...]
    [--smooth-s 0 0.033 ...] [--stretch-centre tempo content]
"""

from __future__ import annotations

import argparse
import sys
from itertools import product

from elastyle.eval.benchmark import benchmark_pairs, score_pairs
from elastyle.io.dataset import default_data_path
from elastyle.model.file import load_model
from elastyle.steps.config import STRETCH_CENTRES, TransferConfig


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--model")
    parser.add_argument("--data", default=str(default_data_path() or ""))
    parser.add_argument("--pairs", type=int, default=24)
    parser.add_argument("--patch-s", type=float, nargs="+", default=[1.0])
    parser.add_argument("--stretch", type=float, nargs="+", default=[0.25])
    parser.add_argument("--smooth-s", type=float, nargs="+", default=[TransferConfig().smooth_s])
    parser.add_argument(
        "--stretch-centre", nargs="+", choices=STRETCH_CENTRES, default=[TransferConfig().stretch_centre]
    )
    parser.add_argument("--methods", nargs="+", default=["elastic", "rigid", "elastic-fixed", "wct", "adain"])
    args = parser.parse_args()
    if not args.data:
        print("no dataset: set ELASTYLE_DATA", file=sys.stderr)
        return 1
    model = load_model(args.model)
    pairs = benchmark_pairs(args.data, args.pairs)["walk"]
    print(f"{len(pairs)} pairs; content cadence - style cadence gap >= 0.15 steps/s")
    print(
        f"{'method':<16}{'patch_s':>8}{'stretch':>8}{'centre':>8}{'smooth':>8}"
        f"{'E median':>10}{'E mean':>8}{'skate':>8}{'jerk x':>8}{'ms':>8}"
    )
    for method in args.methods:
        for patch_s in args.patch_s:
            for stretch, centre, smooth_s in product(args.stretch, args.stretch_centre, args.smooth_s):
                name, placement = (method.split("-") + ["sequential"])[:2]
                config = TransferConfig(
                    method=name, placement=placement, patch_s=patch_s, stretch=stretch, smooth_s=smooth_s,
                    stretch_centre=centre,
                )  # fmt: skip
                s = score_pairs(pairs, model, config)
                print(
                    f"{method:<16}{patch_s:>8.2f}{stretch:>8.2f}{centre:>8}{smooth_s:>8.3f}{s['timing_error_median']:>10.3f}{s['timing_error_mean']:>8.3f}"
                    f"{s['skating_cm_s']:>8.1f}{s['jitter_vs_content']:>8.2f}{1000 * s['seconds_per_transfer']:>8.0f}",
                    flush=True,
                )
    return 0


if __name__ == "__main__":
    sys.exit(main())
