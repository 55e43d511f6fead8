"""Shared fixtures: real dataset clips (skipped cleanly without the dataset) and tiny synthetic BVH files."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import settings

from elastyle.core.motion import Motion
from elastyle.io.dataset import ClipRef, default_data_path, find_clips
from elastyle.model.file import load_model

NO_DATA_REASON = (
    "dataset not found: set ELASTYLE_DATA to the Bandai Namco Research Motion Dataset 2 zip or folder"
)


def pytest_report_header() -> str:
    """One line atop every run: the dataset the real-data tests read, or why they skip."""
    data = default_data_path()
    if data is not None and data.exists():
        return f"elastyle data: {data}"
    return f"elastyle data: {data or 'none'} not found, real-data tests skip ({NO_DATA_REASON})"


settings.register_profile(
    "elastyle", derandomize=True, deadline=None, database=None
)  # the same examples every run
settings.load_profile("elastyle")


@pytest.fixture(scope="session", autouse=True)
def private_cache(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """Every test (and every command it runs) caches style libraries in a temporary folder, never in the
    user's ~/.cache/elastyle."""
    folder = tmp_path_factory.mktemp("cache")
    names = ("ELASTYLE_CACHE", "MPLCONFIGDIR")  # matplotlib's font cache too
    before = {name: os.environ.get(name) for name in names}
    os.environ["ELASTYLE_CACHE"] = str(folder)
    os.environ["MPLCONFIGDIR"] = str(tmp_path_factory.mktemp("matplotlib"))
    yield folder
    for name, value in before.items():
        if value is None:
            os.environ.pop(name, None)
        else:
            os.environ[name] = value


@pytest.fixture(scope="session")
def data_path() -> Path:
    path = default_data_path()
    if path is None or not path.exists():
        pytest.skip(NO_DATA_REASON)
    return path


@pytest.fixture(scope="session")
def dataset_clips(data_path: Path) -> list[ClipRef]:
    return find_clips([data_path])


def clip_named(clips: list[ClipRef], stem: str) -> ClipRef:
    return next(c for c in clips if c.stem == stem)


@pytest.fixture(scope="session")
def run_pairs(dataset_clips: list[ClipRef]) -> list[tuple[str, Motion, Motion]]:
    """Held-out runs: two neutral takes, each given the first held-out take of every other style (12 pairs,
    named "content <- style"). A skating figure of one pair swings with small changes of the decoded feet
    (the floor measure counts a toe that skims the floor at take-off); a set's median does not."""
    runs = [c for c in dataset_clips if c.stem.startswith("dataset-2_run_") and int(c.stem[-3:]) % 5 == 0]
    styles: dict[str, ClipRef] = {}
    for clip in sorted(runs, key=lambda c: c.stem):
        styles.setdefault(clip.stem.split("_")[2], clip)
    contents = [clip_named(dataset_clips, f"dataset-2_run_normal_{take}") for take in ("005", "010")]
    return [
        (f"{content.stem} <- {style.stem}", content.read()[0], style.read()[0])
        for content in contents
        for name, style in styles.items()
        if name != "normal"
    ]


@pytest.fixture(scope="module")
def model():  # type: ignore[no-untyped-def]
    """The shipped model."""
    return load_model()


@pytest.fixture(scope="module")
def content(dataset_clips: list[ClipRef]) -> Motion:
    """A held-out neutral walk (take % 5 == 0), the content of the transfer tests."""
    return clip_named(dataset_clips, "dataset-2_walk_normal_005").read()[0]


@pytest.fixture(scope="module")
def style_clip(dataset_clips: list[ClipRef]) -> Motion:
    """A held-out active walk, their style."""
    return clip_named(dataset_clips, "dataset-2_walk_active_010").read()[0]


@pytest.fixture(scope="session")
def walk_clip(dataset_clips: list[ClipRef]) -> ClipRef:
    return clip_named(dataset_clips, "dataset-2_walk_normal_001")


DATA = Path(__file__).parent / "data"
# a 3-channel skeleton of another naming scheme (pelvis, spine, legs), three hand-checkable frames
THREE_CHANNEL_BVH = (DATA / "three_channel.bvh").read_text()


@pytest.fixture
def three_channel_bvh(tmp_path: Path) -> Path:
    path = tmp_path / "tiny_xyz.bvh"
    path.write_text(THREE_CHANNEL_BVH)
    return path
