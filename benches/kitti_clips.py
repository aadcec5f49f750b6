"""The KITTI clip directories the monocular benches read, checked before a run."""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path


def clips_have_poses(clips: Sequence[Path]) -> bool:
    """Whether every clip has its ``poses.txt``; prints an error naming the first that has not."""
    for clip in clips:
        if not (clip / "poses.txt").is_file():
            print(f"error: {clip} has no poses.txt", file=sys.stderr)
            return False
    return True
