"""Comparisons of engine trajectories with the reference: events, episodes, verdicts, reports."""
