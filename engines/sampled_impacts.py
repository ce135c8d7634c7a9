"""The judge's impacts of sampled motion in plain Python: what the exported scripts print, with no numpy, no chatterbench.

    >>> from chatterbench.engines.sampled_impacts import judged_impacts
    >>> g, dt, R = 9.81, 1e-3, 0.5                       # a ball dropped on a floor, bouncing with R exactly
    >>> t = [k * dt for k in range(901)]                 # to 0.9 s: before the second impact
    >>> v1 = (2 * g) ** 0.5; t1 = v1 / g                 # the first impact: 4.43 m/s at 0.4515 s
    >>> y = [1 - g * s * s / 2 if s < t1 else R * v1 * (s - t1) - g * (s - t1) ** 2 / 2 for s in t]
    >>> vy = [-g * s if s < t1 else R * v1 - g * (s - t1) for s in t]
    >>> found = judged_impacts(t, y, vy, [-g] * len(t), {"lower": [0.0] * len(t)}, {"lower": 0.0}, R, 0.0)
    >>> [(wall, round(tk, 4), round(-vout / vin, 6)) for tk, wall, vin, vout in found]
    [('lower', 0.4515, 0.5)]

Exported scripts (``impact_lines``) record every sample of their run (time t [s], the gap
y = x2 - x1 [m], y' [m/s], y'' of the free motion [m/s^2], each wall's normal force on body
2 [N]) and hand them to ``judged_impacts`` once the run is over: the impacts of the judge's
event log (``comparisons/pipeline/extract.py``, rules 1-4, read it for the why), each with
its incoming and outgoing relative velocity where the body crosses the wall's surface
(``comparisons/pipeline/surface.py``). The same rules, scalar: contacts are runs of samples
with a wall force; an impact is each contact's onset or a velocity jump between two free
samples near the wall; the speeds are the free flight of the last free sample before and the
first after (the velocity from two samples' positions where the step between them is free)
carried to the surface by energy; a bounce inside a stuck stretch (a flight within the band
|y''| f_min^2 / 8 of a flight of f_min after a slow impact, until the bodies separate) is no
impact of the log, the stretch's first is. f_min = max(``FLOOR_STEPS`` dt, ``flight_band``):
the second term is the judge's band x its sticking tolerance x (1 - R), which the exporter
writes (0: the sampling floor alone). Promise: on the same samples, the same impacts, times
and speeds as the judge's log, to rounding (``tests/engines/test_sampled_impacts.py`` checks
it on runs of every built-in scene). This module imports only ``math``: its source is pasted
into the scripts.
"""

import math

FLOOR_STEPS = 4.0  # [steps] the extraction's floor_steps: flights shorter than this many steps do not matter
JUMP_FACTOR = 2.0  # [-] the extraction's jump_factor: a free step's velocity jump over this x |y''| dt is an impact
JUMP_ATOL = 1e-9  # [m/s] the extraction's jump_atol


def first_root(d, u, a, h):
    """Smallest s in [0, h] with d + u s + a s^2 / 2 = 0 (cancellation-free roots); 0 when d <= 0, NaN when none."""
    if d <= 0.0:
        return 0.0
    half = 0.5 * a
    disc = u * u - 4.0 * half * d
    if disc < 0.0:
        return math.nan
    sq = math.sqrt(disc)
    q = -0.5 * (u + (sq if u >= 0.0 else -sq))
    roots = (q / half if half != 0.0 else math.nan, d / q if q != 0.0 else math.nan)
    best = math.nan
    for r in roots:
        if 0.0 <= r <= h and not best <= r:
            best = r
    return best


def surface_velocity(t, d, u, a, k, j):
    """y' of sample k in the wall's normal [m/s]: from the positions of k and its free neighbour j (-1: none)."""
    h = t[j] - t[k] if j >= 0 else 0.0
    if j < 0 or h == 0.0:
        return u[k]
    return (d[j] - d[k]) / h - 0.25 * (a[k] + a[j]) * h


def surface_speed(t, d, u, a, k, j):
    """|y'| where the free flight through sample k meets the surface d = 0 [m/s] (0: it never does)."""
    v = surface_velocity(t, d, u, a, k, j)
    return math.sqrt(max(v * v - 2.0 * a[k] * d[k], 0.0))


def free_neighbour(t, u, a, contact, k, step):
    """k + step when it and k are free samples and the step between them is free flight, else -1."""
    j = k + step
    if not 0 <= j < len(t) or contact[j] or contact[k]:
        return -1
    jump = abs(u[j] - u[k] - 0.5 * (a[k] + a[j]) * (t[j] - t[k]))
    limit = max(JUMP_ATOL, min(JUMP_FACTOR, FLOOR_STEPS) * max(abs(a[k]), abs(a[j])) * abs(t[j] - t[k]))
    return j if jump <= limit else -1


def release_time(t, force, start, stop):
    """When a contact run's force fell to zero [s]: linear in its last two force samples, else mid-step."""
    if stop >= len(t):
        return math.nan
    last = stop - 1
    rel = t[last] + 0.5 * (t[stop] - t[last])
    prev = max(last - 1, 0)
    f1, f0 = force[last], force[prev]
    if last - 1 >= start and f1 > 0.0 and f0 > f1:
        rel = min(max(t[last] + f1 / (f0 - f1) * (t[last] - t[prev]), t[last]), t[stop])
    return rel


def onset(t, d, u, a, contact, force, start, stop):
    """The impact a contact run (samples start .. stop - 1) starts with: its speeds at the surface."""
    n = len(t)
    k = max(start - 1, 0)
    s_in = first_root(d[k], u[k], a[k], t[start] - t[k])
    t_in = t[start] if math.isnan(s_in) else t[k] + s_in
    j = free_neighbour(t, u, a, contact, k, -1)
    v_in = -surface_speed(t, d, u, a, k, j) if surface_velocity(t, d, u, a, k, j) < 0.0 else u[k] + a[k] * (t_in - t[k])
    if start == 0:
        t_in, v_in = t[0], u[0]
    v_out = math.nan
    if stop < n:
        e = stop
        j = free_neighbour(t, u, a, contact, e, 1)
        if surface_velocity(t, d, u, a, e, j) > 0.0 and a[e] < 0.0:  # a rebound the free motion presses back
            v_out = surface_speed(t, d, u, a, e, j)
        else:  # an exit: pulled out of a resting penetration, its speed at release
            s_out = first_root(d[e], -u[e], a[e], t[e] - t[max(e - 1, 0)])
            v_out = u[e] - a[e] * (0.0 if math.isnan(s_out) else s_out)
    return {"t": t_in, "v_minus": v_in, "v_plus": v_out, "t_release": release_time(t, force, start, stop),
            "first": start, "begin": stop if stop < n else n, "contact": True}


def jump(t, d, u, a, contact, k):
    """The impact between free samples k and k + 1 (a velocity jump the free motion cannot make, near the wall), or
    None."""
    h = t[k + 1] - t[k]
    a_max = max(abs(a[k]), abs(a[k + 1]))
    if contact[k] or contact[k + 1] or min(d[k], d[k + 1]) > max(abs(u[k]), abs(u[k + 1])) * h + a_max * h * h:
        return None
    if u[k + 1] - u[k] - 0.5 * (a[k] + a[k + 1]) * h <= max(JUMP_ATOL, min(JUMP_FACTOR, FLOOR_STEPS) * a_max * h):
        return None
    s_fwd = first_root(d[k], u[k], a[k], h)
    s_bwd = first_root(d[k + 1], -u[k + 1], a[k + 1], h)
    t_j = t[k] + s_fwd if not math.isnan(s_fwd) else (t[k + 1] - s_bwd if not math.isnan(s_bwd) else t[k + 1])
    return {"t": t_j, "v_minus": u[k] + a[k] * (t_j - t[k]), "v_plus": u[k + 1] - a[k + 1] * (t[k + 1] - t_j),
            "t_release": t_j, "first": k + 1, "begin": k + 1, "contact": False}


def jumps(t, d, u, a, contact):
    """The impacts between two free samples: velocity jumps the free motion cannot make, near the wall."""
    found = (jump(t, d, u, a, contact, k) for k in range(len(t) - 1))
    return [imp for imp in found if imp is not None]


def first_impact(t, d, u, a, contact, force):
    """The first impact on one wall, by first sample: ``wall_impacts(...)[0]`` without the flight after it (no
    ``next_first``, ``apex``, ``a_release``, ``a_onset``, ``flight``), read only up to it; None when there is none.

    A jump's first sample k + 1 is free and a contact run's is not, so the first impact is the first jump before the
    first contact run, else that run's onset, else (no contact at all) the first jump."""
    n = len(t)
    start = next((k for k in range(n) if contact[k]), n)
    for k in range(min(start, n - 1)):
        imp = jump(t, d, u, a, contact, k)
        if imp is not None:
            return imp
    if start == n:
        return None
    stop = next((k for k in range(start, n) if not contact[k]), n)
    return onset(t, d, u, a, contact, force, start, stop)


def wall_impacts(t, d, u, a, contact, force):
    """Every impact on one wall (normal coordinates: d the distance, u = n y', a = n y''), by first sample, with
    the flight after it: apex (highest d), a_release and a_onset (a at its first free sample and before it)."""
    n = len(t)
    runs, start = [], None
    for k in range(n + 1):
        inside = k < n and contact[k]
        if inside and start is None:
            start = k
        elif not inside and start is not None:
            runs.append((start, k))
            start = None
    imps = [onset(t, d, u, a, contact, force, s, e) for s, e in runs] + jumps(t, d, u, a, contact)
    imps.sort(key=lambda imp: imp["first"])
    for i, imp in enumerate(imps):
        nxt = imps[i + 1]["first"] if i + 1 < len(imps) else n
        imp["next_first"] = nxt
        imp["apex"] = max(d[imp["begin"]:nxt]) if imp["begin"] < nxt else -math.inf
        imp["a_release"] = a[min(imp["begin"], n - 1)]
        imp["a_onset"] = a[max(imp["first"] - 1, 0)]
        imp["flight"] = imps[i + 1]["t"] - imp["t_release"] if i + 1 < len(imps) else math.nan
    return imps


def stuck_stretches(imps, f_min, n, u_last):
    """(first, last, released) impact indices of every stuck stretch: from a slow impact while flights stay in the band."""
    band = [-imp["a_release"] * f_min * f_min / 8.0 if imp["a_release"] < 0.0 else 0.0 for imp in imps]
    held = [imp["begin"] >= n for imp in imps]
    out, m, i = [], len(imps), 0
    while i < m:
        imp = imps[i]
        judged = imp["next_first"] < n
        resting = imp["a_onset"] < 0.0 and abs(u_last) <= -imp["a_onset"] * f_min / 2.0
        if (band[i] > 0.0 and imp["apex"] <= band[i] and judged) or (held[i] and (imp["first"] == 0 or resting)):
            j, h = i, band[i]
            while j < m and (held[j] or imps[j]["apex"] <= max(h, band[j])):
                h = max(h, band[j])
                j += 1
            out.append((i, min(j, m - 1), j < m and not held[j]))
            i = j + 1
            continue
        v_plus = imp["v_plus"]
        if imp["contact"] and imp["a_onset"] < 0.0 and imp["a_release"] >= 0.0 and math.isfinite(v_plus) and \
                v_plus <= -imp["a_onset"] * f_min / 2.0:
            out.append((i, i, True))
        i += 1
    return out


def sticking_start(imps, i, j, restitution, dt):
    """When the stuck stretch of impacts i .. j starts sticking [s]: its own ladder extrapolated, else Feigin's."""
    flight = [imp["flight"] for imp in imps]
    bounce = [imp["t_release"] - imp["t"] <= imp["flight"] for imp in imps]
    k = i
    while k < j and math.isfinite(flight[k + 1]) and 0.0 < flight[k + 1] < flight[k] and bounce[k + 1]:
        k += 1
    if k > i and math.isfinite(flight[i]) and flight[i] - flight[k] > dt:
        rho = (flight[k] / flight[i]) ** (1.0 / (k - i))
        return max(imps[i]["t"], imps[k]["t_release"] + flight[k] / (1.0 - rho))
    v_plus, a = imps[i]["v_plus"], imps[i]["a_release"]
    if j > i and a < 0.0 and math.isfinite(v_plus) and v_plus > 0.0 and restitution < 1.0:
        return imps[i]["t"] + 2.0 * v_plus / ((1.0 - restitution) * -a)
    return imps[i]["t"]


def logged(imps, t, u_last, restitution, dt, f_min):
    """The impacts of one wall the judge's log has: all but the bounces inside a stuck stretch (its first stays)."""
    n = len(t)
    stuck = [False] * len(imps)
    for i, j, released in stuck_stretches(imps, f_min, n, u_last):
        end = imps[j]["t_release"] if released else t[-1]
        if released and end - sticking_start(imps, i, j, restitution, dt) < f_min:
            continue  # the bodies part before they could have come to rest: bounces, not a stick
        for k in range(i + 1, j + 1):
            stuck[k] = True
    return [imp for imp, s in zip(imps, stuck) if not s]


def judged_impacts(t, y, vy, acc, forces, walls, restitution, flight_band):
    """The judge's impacts of a sampled run (module docstring), by time: (t [s], wall, v_in, v_out [m/s]).

    ``t``, ``y``, ``vy``, ``acc``: per sample, the time, the gap y = x2 - x1, y' and y'' of the free
    motion; ``forces``: wall -> its normal force per sample [N] (a contact where > 0); ``walls``:
    wall -> its position in y [m] ("lower", "upper"); ``flight_band`` [s]: the judge's band x sticking
    tolerance x (1 - R). v_in and v_out are y' before and after (v_in < 0 on the lower wall); v_out is
    NaN for a contact the run ends in.
    """
    steps = sorted(t[k + 1] - t[k] for k in range(len(t) - 1))
    if not steps:
        return []
    m = len(steps)
    dt = steps[m // 2] if m % 2 else 0.5 * (steps[m // 2 - 1] + steps[m // 2])  # the median, as the judge takes it
    f_min = max(FLOOR_STEPS * dt, flight_band)
    out = []
    for wall, position in walls.items():
        nrm = 1.0 if wall == "lower" else -1.0
        d = [nrm * (v - position) for v in y]
        u = [nrm * v for v in vy]
        a = [nrm * v for v in acc]
        force = forces[wall]
        contact = [f > 0.0 for f in force]
        for imp in logged(wall_impacts(t, d, u, a, contact, force), t, u[-1], restitution, dt, f_min):
            out.append((imp["t"], wall, nrm * imp["v_minus"], nrm * imp["v_plus"]))
    out.sort(key=lambda row: row[0])
    return out


def contact_rest(t, d, force, t0, t1):
    """What a wall's contact does over the rest window [t0, t1] [s] after a stick: (onsets, open share, largest gap).

    ``d``: per sample, the distance from the wall's surface [m] (> 0: off the wall); ``force``: the wall's normal
    force per sample [N] (a contact where > 0). ``onsets``: samples in the window whose contact starts there (open
    the sample before); the open share [1]: the window's time the contact is open (a sample holds its step); the
    largest gap [m]: max(d, 0). (0, nan, nan) where the window holds fewer than two samples. The judge's persistence
    check (``comparisons/pipeline/persistence.py``) reads the same from a run's contact flags.
    """
    ks = [k for k in range(len(t)) if t0 <= t[k] <= t1]
    if len(ks) < 2:
        return 0, math.nan, math.nan
    closed = [force[k] > 0.0 for k in ks]
    onsets = sum(1 for i in range(1, len(ks)) if closed[i] and not closed[i - 1])
    open_time = sum(t[ks[i + 1]] - t[ks[i]] for i in range(len(ks) - 1) if not closed[i])
    return onsets, open_time / (t[ks[-1]] - t[ks[0]]), max(0.0, max(d[k] for k in ks))
