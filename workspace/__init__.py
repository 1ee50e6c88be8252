"""Across the workspace: lobe maps over poses and placements, pose and placement optimization."""
