"""Reading and writing clips: BVH files, datasets (files, folders, globs, zips), safe output."""
