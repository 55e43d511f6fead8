"""Shared fixtures: real dataset clips (skipped cleanly without the dataset) and tiny synthetic BVH files."""

from __future__ import annotations

from pathlib import Path

import pytest

from elastyle.io.dataset import ClipRef, default_data_path, find_clips

NO_DATA_REASON = (
    "dataset not found: set ELASTYLE_DATA to the Bandai Namco Research Motion Dataset 2 zip or folder"
)


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
def walk_clip(dataset_clips: list[ClipRef]) -> ClipRef:
    return clip_named(dataset_clips, "dataset-2_walk_normal_001")


THREE_CHANNEL_BVH = """HIERARCHY
ROOT pelvis
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Xrotation Yrotation Zrotation
  JOINT spine
  {
    OFFSET 0 10 0
    CHANNELS 3 Xrotation Yrotation Zrotation
    End Site
    {
      OFFSET 0 10 0
    }
  }
  JOINT LeftLeg
  {
    OFFSET 3 0 0
    CHANNELS 3 Xrotation Yrotation Zrotation
    JOINT LeftFoot
    {
      OFFSET 0 -10 0
      CHANNELS 3 Xrotation Yrotation Zrotation
      End Site
      {
        OFFSET 0 0 2
      }
    }
  }
  JOINT RightLeg
  {
    OFFSET -3 0 0
    CHANNELS 3 Xrotation Yrotation Zrotation
    JOINT RightFoot
    {
      OFFSET 0 -10 0
      CHANNELS 3 Xrotation Yrotation Zrotation
      End Site
      {
        OFFSET 0 0 2
      }
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.0083333
0 20 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
1 20 0 90 0 0 0 0 0 10 0 0 0 0 0 0 0 0 0 0 0
2 20 0 0 90 0 0 0 0 0 0 0 45 30 0 0 0 0 0 0 5
"""


@pytest.fixture
def three_channel_bvh(tmp_path: Path) -> Path:
    path = tmp_path / "tiny_xyz.bvh"
    path.write_text(THREE_CHANNEL_BVH)
    return path
