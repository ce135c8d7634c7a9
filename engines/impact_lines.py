"""The impact printer of the exported scripts: Python lines that turn "the wall pushed in this step" into impacts.

    >>> from chatterbench.engines.impact_lines import detection_lines, state_lines
    >>> code = "\\n".join(["ks = [False] * 3 + [True] + [False] * 4", *state_lines(max_contact_steps=5),
    ...                    "for k, pushing in enumerate(ks):", "    t0, v0 = k * 0.1, (-2.0 - 0.1 * k if k < 4 else 1.0)",
    ...                    *detection_lines("    ")])
    >>> exec(code, {})
    # impact: a contact entered at |v_in| > 3 |dv| (dv: the largest velocity change over a free step so far, |y''| dt) ...
    impact t=0.300000 v_in=-2.3 v_out=1 e=0.434783

Every exported script (``mujoco_engine.export``, ``pybullet_engine.export``) steps its engine
and, per step k, knows ``t0`` and ``v0`` (the time [s] and the relative velocity y' [m/s] the
step starts from) and ``pushing`` (a wall's normal force was positive in the step). A contact
is the run of pushing steps; its impact is printed, ``impact t=... v_in=... v_out=... e=...``,
with v_in the velocity before its first step and v_out after its last (e = -v_out / v_in),
once the bodies have then flown apart for ``MIN_FLIGHT_STEPS`` steps. The script's first line,
``# impact: ...`` (``HEADER``), says which contacts count. Not printed: a contact entered slower
than ``MIN_SPEED_STEPS`` x the largest velocity change over a free step seen so far (|y''| dt:
a speed the step cannot resolve; it is a resting or sliding body that the solver lets go and
touches again, e.g. where a sliding phase ends, seen before as ``v_in=-1.07e-07 ... e=1.98``),
a contact longer than ``max_contact_steps`` (the bodies came to rest against the wall and
later left it: a stick and an exit, not an impact), one followed by a shorter flight (a body
at rest that the solver alternately pushes and releases every step or two), and one still
pushing when the run ends.
"""

from __future__ import annotations

MIN_FLIGHT_STEPS = 3  # steps apart after a contact for it to count as an impact (rest jitter is 1-2 steps)
MIN_SPEED_STEPS = 3  # an impact's |v_in| exceeds this many free steps' velocity change (|y''| dt)
HEADER = (f"# impact: a contact entered at |v_in| > {MIN_SPEED_STEPS} |dv| (dv: the largest velocity change over a free "
          "step so far, |y''| dt) that the bodies leave within {LONGEST_CONTACT} steps and fly apart for "
          f"{MIN_FLIGHT_STEPS}; slower contacts (a sliding or resting body let go and touched again) are not impacts")


def docstring(lines: list[str]) -> list[str]:
    """A script's docstring from ``lines``, safe for any text in them (a scene name may hold quotes, backslashes)."""
    text = "\n".join(lines).replace("\\", "\\\\").replace('"""', '\\"\\"\\"')
    return ['"""' + text, '"""']


def state_lines(max_contact_steps: int) -> list[str]:
    """The printer's state, set once before the loop."""
    return [f"LONGEST_CONTACT = {int(max_contact_steps)}  # steps; a longer contact is a rest, not an impact",
            f"MIN_FLIGHT = {MIN_FLIGHT_STEPS}  # steps apart after a contact for it to count as an impact",
            f"MIN_SPEED = {MIN_SPEED_STEPS}  # |v_in| > MIN_SPEED * dv: slower is a sliding or resting body's lift-off",
            f"print(f{HEADER!r})",
            "touching, pending, flight = False, False, 0",
            "v_last, dv = None, 0.0  # y' before the last step; the largest |change of y'| over a free step [m/s]",
            "k_in = k_out = 0",
            "t_in = v_in = v_out = 0.0"]


def detection_lines(indent: str) -> list[str]:
    """The per-step lines, after the step (``t0``, ``v0``, ``pushing`` and ``k`` known)."""
    lines = [
        "if v_last is not None and flight >= 2:  # the last step and the one before were free: v0 - v_last = y'' dt",
        "    dv = max(dv, abs(v0 - v_last))",
        "v_last = v0",
        "if pushing:",
        "    if not touching:",
        "        touching, pending, k_in, t_in, v_in = True, False, k, t0, v0",
        "    flight = 0",
        "else:",
        "    if touching:  # the contact ended before this step: v0 is its exit velocity",
        "        touching, pending, k_out, v_out = False, True, k, v0",
        "    flight += 1",
        "    if pending and flight >= MIN_FLIGHT:",
        "        pending = False",
        "        if k_out - k_in <= LONGEST_CONTACT and abs(v_in) > MIN_SPEED * dv and v_in != 0.0:",
        '            print(f"impact t={t_in:.6f} v_in={v_in:.6g} v_out={v_out:.6g} e={-v_out / v_in:.6g}")',
    ]
    return [indent + line for line in lines]
