"""The skeleton layer: skeletons, rotations, motions, resampling, limbs and mirroring (no transfer logic)."""
