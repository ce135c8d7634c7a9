"""The subcommands, in the order ``chatterbench --help`` lists them, each with its one-line help.

    >>> from chatterbench.comparisons.cli.commands import COMMANDS
    >>> list(COMMANDS)[:3], COMMANDS["scenes"]
    (['scenes', 'engines', 'run'], 'list the built-in scenes')

Each is the module ``cli/NAME.py`` (its ``register`` adds its parser, with this help). The
table imports nothing, so ``chatterbench --help`` lists every subcommand without loading one,
and ``chatterbench NAME ...`` loads only NAME's module (``main.build_parser``): a ``--help``
costs the imports of what it describes, not pandas, numba or the engines (issue 33).
"""

COMMANDS = {
    "scenes": "list the built-in scenes",
    "engines": "list every engine (built in and plugins): extra or package, version, status",
    "run": "run one scene in the reference or an engine; print its episodes",
    "compare": "run the reference and the engines on a scene; judge every episode",
    "judge": "judge any simulator's trajectory file (CSV, Parquet) against the reference",
    "report": "every scene on every engine: one self-contained HTML report and a Markdown twin",
    "gate": "run accuracy checks from a gate file; exit 1 if any fails (for CI)",
    "platemap": "map which strikes on a wall end in sliding: reference, Feigin's plate, engines",
    "tune": "find the cheapest engine settings whose episodes all match within the tolerances",
    "atlas": "every engine's band-robust frontier on every scene: one table and chart, resumable",
    "calibrate": "each engine's effective restitution against impact speed (where R drifts)",
    "sweep": "run a grid of scene fields and engine settings; one row per engine and point",
    "chart": "draw the work-precision chart or a stability map from a finished sweep dataset",
    "bench": "benchmarks: reference speed, engine steps per second, plate map, sweeps, tune, --help",
}
