"""The judging pipeline: reference solution, extraction from samples, per-impact judging, verdicts, summary.

scene -> ``solution`` (Feigin's model, both modes, scales) | engine trajectory ->
``extract`` (impacts, sticking, exits; each wall's impacts in ``wall_impacts``) -> ``judge`` (pairs, errors, verdicts from
``vocabulary`` with ``tolerances``) -> ``compare`` (all engines) -> ``summary`` (one row each).
The lowest stage of ``comparisons/`` (pipeline <- studies <- outputs <- ci <- cli), so it also
holds ``atomic``, the file writes every stage above it makes.
"""
