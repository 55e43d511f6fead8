"""A fuzzer for the command line: corrupted and awkward inputs through every command, checked for what a
user must always get (a clear one-line error or a good file, never a traceback, a hang, a non-finite
output, a modified input, or two winners of a race).

    python -m tests.fuzz [--count 1000] [--seed 0]     the full run, with its figures
    pytest tests/test_fuzz.py                          a fast subset (in CI)

Cases come from real clips (the dataset, through ELASTYLE_DATA) or, without it, the three-channel fixture:
line and byte mutations, truncations, extreme values, special files (a pipe, a device, a folder, a
dangling link), extreme options, and concurrent writers of one output.
"""

from __future__ import annotations

import os
import random
import subprocess
import sys
import time
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

import numpy as np

TIMEOUT_S = 20.0
OPTIONS = [
    [], ["--patch-s", "1e-9"], ["--patch-s", "59"], ["--stretch", "0.999"], ["--stretch-step-s", "0"],
    ["--strength", "0:0,1e9:1"], ["--strength", "-1"], ["--smooth-s", "9.9"], ["--residual-smooth-s", "10"],
    ["--whiten-floor", "1e-300"], ["--method", "wct"], ["--method", "adain"], ["--placement", "fixed"],
    ["--timing", "content"], ["--decode", "plain"], ["--root-follows-legs", "1"], ["--no-cleanup"], ["--blend", "nan"],
    ["--at", "1"], ["--patch-s", "inf"], ["--stretch", "-0.5"], ["--jobs", "0"],
]  # fmt: skip


class Outcome(NamedTuple):
    case: str
    exit_code: int | None  # None: did not end within TIMEOUT_S
    problems: list[str]  # what a user must never see; empty when the invocation behaved


def mutations(source: str, rng: random.Random) -> Iterator[tuple[str, bytes]]:
    """Endless (name, file bytes) variants of a BVH text."""
    lines = source.split("\n")
    motion_at = next(i for i, line in enumerate(lines) if line.startswith("Frame Time"))
    while True:
        kind = rng.choice(["line", "byte", "truncate", "value", "header", "bom", "crlf", "duplicate"])
        mutated = list(lines)
        if kind == "line":
            index = rng.randrange(len(mutated))
            mutated[index] = rng.choice(
                ["", "}", "{", "JOINT", "OFFSET 1 2", "CHANNELS 9 Xrotation", "MOTION"]
            )
        elif kind == "byte":
            data = bytearray(source.encode())
            for _ in range(rng.randint(1, 20)):
                data[rng.randrange(len(data))] = rng.randrange(256)
            yield kind, bytes(data)
            continue
        elif kind == "truncate":
            yield kind, source.encode()[: rng.randrange(len(source))]
            continue
        elif kind == "value":
            row = rng.randrange(motion_at + 1, len(mutated) - 1)
            values = mutated[row].split()
            if values:
                values[rng.randrange(len(values))] = rng.choice(
                    ["nan", "inf", "-inf", "3.5e38", "1e308", "1e-320", "0x10", "1_0", "--1", "１"]
                )
                mutated[row] = " ".join(values)
        elif kind == "header":
            mutated[motion_at] = rng.choice(
                [
                    "Frame Time: 0",
                    "Frame Time: -1",
                    "Frame Time: 1e-320",
                    "Frame Time: nan",
                    "Frame Time: 1e9",
                ]
            )
        elif kind == "bom":
            yield kind, b"\xef\xbb\xbf" + source.encode()
            continue
        elif kind == "crlf":
            yield kind, source.replace("\n", "\r\n").encode()
            continue
        elif kind == "duplicate":
            mutated = mutated[: motion_at + 1] + mutated[motion_at + 1 :] * 2
        yield kind, "\n".join(mutated).encode()


def _special_files(folder: Path) -> list[tuple[str, Path]]:
    specials = []
    if hasattr(os, "mkfifo"):
        pipe = folder / "pipe.bvh"
        os.mkfifo(pipe)
        specials.append(("pipe", pipe))
    if Path("/dev/zero").exists():
        specials.append(("device", Path("/dev/zero")))
    directory = folder / "folder.bvh"
    directory.mkdir()
    specials.append(("folder", directory))
    dangling = folder / "dangling.bvh"
    dangling.symlink_to(folder / "nowhere.bvh")
    specials.append(("dangling-link", dangling))
    return specials


def _run(args: list[str], env: dict[str, str]) -> tuple[int | None, str]:
    try:
        result = subprocess.run(
            [sys.executable, "-m", "elastyle.cli", *args], capture_output=True, text=True,
            timeout=TIMEOUT_S, env=env, stdin=subprocess.DEVNULL,
        )  # fmt: skip
    except subprocess.TimeoutExpired:
        return None, ""
    return result.returncode, result.stderr


def _check(
    case: str,
    code: int | None,
    stderr: str,
    output: Path | None,
    inputs: dict[Path, bytes],
    named: tuple[str, ...],
) -> Outcome:
    """What went wrong in one invocation; `named`: the file names its error line may name."""
    problems = []
    if code is None:
        problems.append("hang")
    elif "Traceback" in stderr or "internal error" in stderr:
        problems.append("traceback")
    elif code not in (0, 1, 2):
        problems.append(f"exit {code}")
    if code == 1:
        errors = [line for line in stderr.splitlines() if line.startswith("elastyle: error:")]
        if len(errors) != 1:
            problems.append("not one error line")
        elif not any(name in errors[0] for name in named):
            problems.append(f"error names no file: {errors[0][:80]}")
    if code == 0 and output is not None and output.suffix == ".bvh" and output.exists():
        from elastyle.io.bvh_read import read_bvh

        motion = read_bvh(output)[0]
        if not (np.all(np.isfinite(motion.rotations)) and np.all(np.isfinite(motion.translations))):
            problems.append("non-finite output")
    for path, data in inputs.items():
        if path.read_bytes() != data:
            problems.append(f"input modified: {path.name}")
    return Outcome(case, code, problems)


def run_fuzz(content: str, style: str, folder: Path, count: int, seed: int = 0) -> list[Outcome]:
    """`count` invocations of mutated content and style files, special files, extreme options and
    clobbering attempts; then races of two writers. content, style: BVH text of the model's skeleton."""
    rng = random.Random(seed)
    env = {**os.environ, "ELASTYLE_CACHE": str(folder / "cache")}
    content_path, style_path = folder / "content.bvh", folder / "style.bvh"
    content_path.write_text(content)
    style_path.write_text(style)
    inputs = {content_path: content_path.read_bytes(), style_path: style_path.read_bytes()}
    outcomes = []
    for name, special in _special_files(folder):
        for args in (["info", str(special)], ["transfer", str(special), "--style", str(style_path), "-o",
                     str(folder / "o.bvh")], ["transfer", str(content_path), "--style", str(special), "-o",
                     str(folder / "o.bvh")]):  # fmt: skip
            code, stderr = _run(args, env)
            outcomes.append(_check(f"special:{name}:{args[0]}", code, stderr, None, inputs, _names(args)))
    variants = mutations(content, rng)
    for index in range(count):
        kind, data = next(variants)
        bad = folder / f"case{index}.bvh"
        bad.write_bytes(data)
        output = folder / f"out{index}.bvh"
        command = rng.choice(["info", "convert", "transfer-content", "transfer-style", "options", "clobber"])
        if command == "info":
            args = ["info", str(bad)]
        elif command == "convert":
            args = ["convert", str(bad), "-o", str(output), *rng.choice([[], ["--mirror"], ["--fps", "60"]])]
        elif command == "transfer-content":
            args = ["transfer", str(bad), "--style", str(style_path), "-o", str(output)]
        elif command == "transfer-style":
            args = ["transfer", str(content_path), "--style", str(bad), "-o", str(output)]
        elif command == "options":
            args = [
                "transfer",
                str(content_path),
                "--style",
                str(style_path),
                "-o",
                str(output),
                *rng.choice(OPTIONS),
            ]
        else:
            target = rng.choice([content_path, style_path])
            args = ["transfer", str(content_path), "--style", str(style_path), "--force",
                    *rng.choice([["-o", str(target)], ["-o", str(output), "--explain", str(target)]])]  # fmt: skip
        code, stderr = _run(args, env)
        outcomes.append(_check(f"{command}:{kind}", code, stderr, output, inputs, _names(args)))
        bad.unlink(missing_ok=True)
        output.unlink(missing_ok=True)
    return outcomes + races(content_path, style_path, folder, max(2, count // 20), env, inputs)


def races(
    content: Path, style: Path, folder: Path, trials: int, env: dict[str, str], inputs: dict[Path, bytes]
) -> list[Outcome]:
    """Two transfers to the same new output started together: exactly one may succeed."""
    outcomes = []
    for trial in range(trials):
        output = folder / f"race{trial}.bvh"
        args = [
            sys.executable,
            "-m",
            "elastyle.cli",
            "transfer",
            str(content),
            "--style",
            str(style),
            "-o",
            str(output),
        ]
        started = [
            subprocess.Popen(args, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            for _ in range(2)
        ]
        codes = [process.wait(timeout=60) for process in started]
        problems = [] if sorted(codes) == [0, 1] else [f"race: exit codes {codes}"]
        outcomes.append(
            Outcome("race", max(codes), problems + _check("race", 0, "", output, inputs, ()).problems)
        )
    return outcomes


def _names(args: list[str]) -> tuple[str, ...]:
    """The file names on a command line (what an error about a file must name)."""
    return tuple(Path(a).name for a in args if a.endswith((".bvh", ".json", ".npz")) or a.startswith("/dev/"))


def summary(outcomes: list[Outcome], seconds: float) -> str:
    """The figures of a run, one per line."""
    problems = Counter(p.split(":")[0] for o in outcomes for p in o.problems)
    exits = Counter(o.exit_code for o in outcomes)
    names = (
        "traceback",
        "hang",
        "non-finite output",
        "input modified",
        "race",
        "not one error line",
        "error names no file",
    )
    lines = [
        f"invocations: {len(outcomes)} in {seconds:.0f} s; exit codes {dict(sorted(exits.items(), key=str))}",
        *(f"{name}: {problems.get(name, 0)}" for name in names),
    ]
    failing = [o for o in outcomes if o.problems][:20]
    lines += [f"  {o.case}: {', '.join(o.problems)}" for o in failing]
    return "\n".join(lines)


def dataset_pair() -> tuple[str, str] | None:
    """A held-out walk and a style walk from the dataset, as text (None without the dataset)."""
    from elastyle.io.dataset import default_data_path, find_clips

    data = default_data_path()
    if data is None or not Path(data).exists():
        return None
    clips = {c.stem: c for c in find_clips([str(data)], pattern="dataset-2_walk_*")}
    return clips["dataset-2_walk_normal_005"].data().decode(), clips[
        "dataset-2_walk_active_010"
    ].data().decode()


def main(argv: list[str] | None = None) -> int:
    import argparse
    import tempfile

    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--count", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    pair = dataset_pair()
    if pair is None:
        print(
            "no dataset: set ELASTYLE_DATA (or put ../shared/data/bandai-namco-2.zip beside the project)",
            file=sys.stderr,
        )
        return 1
    with tempfile.TemporaryDirectory() as folder:
        started = time.perf_counter()
        outcomes = run_fuzz(*pair, Path(folder), args.count, args.seed)
        print(summary(outcomes, time.perf_counter() - started))
    return 1 if any(o.problems for o in outcomes) else 0
