"""Planners: dynamic programming and approximate DP on models (Algorithms 1-9)."""
