"""The Siconos side of the ``siconos`` engine: read requests (JSON) on stdin, step each, write its frames on stdout.

Run by an interpreter that has Siconos (Debian's ``python3-siconos`` for ``/usr/bin/python3``),
never imported by chatterbench: it imports only the standard library, numpy and
``siconos.kernel``, so it runs under an interpreter that has no chatterbench. ``protocol.py``
documents the request and the reply; this file implements them, by hand::

    /usr/bin/python3 child.py < request.json > frames.bin

Requests come one after another on stdin (the adapter writes each on one line and keeps the
child for the next run of its process: a child's start, 0.11 s, is paid once, not per strike);
each is answered in full (ready, rows, end frame) before the next is read, each with a model
of its own, and the child exits 0 when stdin ends. A request may span lines (a file written by
hand): lines are read until they make one JSON text.

The model (``protocol.py``): one ``LagrangianLinearTIDS`` of 1 or 2 dofs,
M q'' + C q' + K q = F(t) + contact, one ``LagrangianLinearTIR`` relation per wall
(gap g = row . q + offset >= 0) with ``NewtonImpactNSL(R)``, Moreau-Jean time stepping
(``MoreauJeanOSI(theta)``) with one LCP per step. F(t) is a constant plus harmonics per dof;
Siconos's linear DS reads a plain ``fExt`` vector at both ends of the step, so before the
step t_k -> t_k + dt the child sets fExt = (1 - theta) F(t_k) + theta F(t_k + dt), exactly
the theta-weighted force a time-dependent ``fExt`` plugin would give
(``MoreauJeanOSI::computeResidu``).

Exit codes: 0 when stdin ends; 2 for a request it refuses (one line on stderr, naming the
field); 1 for a failure of Siconos (one line on stderr). Anything Siconos prints goes to
stderr: the data stream is a private copy of the original stdout.
"""

import ctypes
import json
import math
import os
import signal
import struct
import sys

import numpy as np

PROTOCOL = 2
PARENT = "CHATTERBENCH_SICONOS_PARENT"  # the adapter's pid, so that an orphan started too late ends at once
SOLVERS = {"lemke": "SICONOS_LCP_LEMKE", "enum": "SICONOS_LCP_ENUM", "pgs": "SICONOS_LCP_PGS",
           "nsgs": "SICONOS_LCP_NSGS_SBM"}


class BadRequest(ValueError):
    """A request the child refuses; the message names the field."""


def _number(req, key, lo=-math.inf, hi=math.inf):
    v = req.get(key) if isinstance(req, dict) else None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not lo <= v <= hi:
        raise BadRequest(f"{key} = {v!r}: must be a finite number in [{lo:g}, {hi:g}]")
    return float(v)


def _matrix(req, key, rows, cols):
    try:
        a = np.array(req.get(key), dtype=float)
    except (TypeError, ValueError):
        raise BadRequest(f"{key}: must be a {rows} x {cols} array of numbers") from None
    if a.shape != (rows, cols) or not np.isfinite(a).all():
        raise BadRequest(f"{key}: must be a {rows} x {cols} array of finite numbers, got shape {a.shape}")
    return a


def parse(text):
    """The request as checked Python values; BadRequest for anything else."""
    try:
        req = json.loads(text)
    except (ValueError, UnicodeDecodeError) as exc:
        raise BadRequest(f"not a JSON request ({exc})") from None
    if not isinstance(req, dict):
        raise BadRequest("the request must be a JSON object")
    if req.get("protocol") != PROTOCOL:
        raise BadRequest(f"protocol = {req.get('protocol')!r}: this child speaks protocol {PROTOCOL}")
    mass = req.get("mass")
    if not isinstance(mass, list) or len(mass) not in (1, 2):
        raise BadRequest(f"mass = {mass!r}: must be a list of 1 or 2 masses [kg]")
    n = len(mass)
    out = {"mass": _matrix({"m": [mass]}, "m", 1, n)[0], "n": n}
    if not (out["mass"] > 0).all():
        raise BadRequest(f"mass = {mass!r}: must be > 0")
    out["stiffness"] = _matrix(req, "stiffness", n, n)
    out["damping"] = _matrix(req, "damping", n, n)
    out["q0"] = _matrix({"q0": [req.get("q0")]}, "q0", 1, n)[0]
    out["v0"] = _matrix({"v0": [req.get("v0")]}, "v0", 1, n)[0]
    force = req.get("force")
    if not isinstance(force, list) or len(force) != n:
        raise BadRequest(f"force: must be a list of {n} {{constant, harmonics}} objects")
    out["force"] = []
    for i, f in enumerate(force):
        if not isinstance(f, dict):
            raise BadRequest(f"force[{i}]: must be an object with constant and harmonics")
        harmonics = _matrix({"h": f.get("harmonics")}, "h", len(f.get("harmonics") or []), 3) \
            if f.get("harmonics") else np.zeros((0, 3))
        out["force"].append((_number(f, "constant"), harmonics))
    walls = req.get("walls")
    if not isinstance(walls, list) or not 1 <= len(walls) <= 2:
        raise BadRequest("walls: must be a list of 1 or 2 walls {name, row, offset}")
    out["walls"] = []
    for i, w in enumerate(walls):
        if not isinstance(w, dict):
            raise BadRequest(f"walls[{i}]: must be an object with name, row and offset")
        out["walls"].append((_matrix({"row": [w.get("row")]}, "row", 1, n)[0], _number(w, "offset")))
    out["restitution"] = _number(req, "restitution", 0.0, 1.0)
    out["t0"] = _number(req, "t0")
    out["dt"] = _number(req, "dt", 0.0)
    if not out["dt"] > 0:
        raise BadRequest(f"dt = {out['dt']!r}: must be > 0")
    out["theta"] = _number(req, "theta", 0.0, 1.0)
    out["tolerance"] = _number(req, "tolerance", 0.0)
    steps, chunk = req.get("steps"), req.get("chunk")
    for key, v in (("steps", steps), ("chunk", chunk)):
        if isinstance(v, bool) or not isinstance(v, int) or v < 1:
            raise BadRequest(f"{key} = {v!r}: must be an integer >= 1")
    out["steps"], out["chunk"] = steps, chunk
    if req.get("solver") not in SOLVERS:
        raise BadRequest(f"solver = {req.get('solver')!r}: must be one of {', '.join(SOLVERS)}")
    out["solver"] = req["solver"]
    if not isinstance(req.get("bare", False), bool):
        raise BadRequest("bare: must be true or false")
    out["bare"] = req.get("bare", False)
    return out


def forces(spec, t):
    """F(t) per dof [N] at times t (shape (len(t), n)): constant + sum A sin(omega t + phase)."""
    out = np.empty((len(t), len(spec)))
    for i, (constant, harmonics) in enumerate(spec):
        out[:, i] = constant
        for amplitude, omega, phase in harmonics:
            out[:, i] += amplitude * np.sin(omega * t + phase)
    return out


def build(req):
    """The Siconos model and time stepping of the request: (simulation, ds, interactions)."""
    import siconos.kernel as sk
    import siconos.numerics as sn

    n = req["n"]
    mass = np.diag(req["mass"])
    k, c = req["stiffness"], req["damping"]
    if k.any() or c.any():
        ds = sk.LagrangianLinearTIDS(req["q0"], req["v0"], mass, k, c)
    else:
        ds = sk.LagrangianLinearTIDS(req["q0"], req["v0"], mass)
    ds.setFExtPtr(np.zeros(n))
    nsds = sk.NonSmoothDynamicalSystem(req["t0"], req["t0"] + req["steps"] * req["dt"])
    nsds.insertDynamicalSystem(ds)
    inters = []
    for row, offset in req["walls"]:
        inter = sk.Interaction(sk.NewtonImpactNSL(req["restitution"]),
                               sk.LagrangianLinearTIR(row.reshape(1, n), np.array([offset])))
        nsds.link(inter, ds)
        inters.append(inter)
    lcp = sk.LCP(getattr(sn, SOLVERS[req["solver"]]))
    lcp.numericsSolverOptions().dparam[sn.SICONOS_DPARAM_TOL] = req["tolerance"]
    sim = sk.TimeStepping(nsds, sk.TimeDiscretisation(req["t0"], req["dt"]), sk.MoreauJeanOSI(req["theta"]), lcp)
    return sim, ds, inters


def step(req, out):
    """Build the request's model, write the ready frame, step it, writing frames to the binary stream ``out``, and
    write the end frame (``protocol.py``: the parent times the frames, not the child)."""
    sim, ds, inters = build(req)
    out.write(struct.pack("<q", 0))  # ready: the model is built, stepping starts
    out.flush()
    n, dt, theta, total, chunk = req["n"], req["dt"], req["theta"], req["steps"], req["chunk"]
    varying = any(len(h) for _, h in req["force"])
    if not varying:
        ds.setFExtPtr(forces(req["force"], np.zeros(1))[0])
    width = 2 * n + len(inters)
    for k0 in range(0, total, chunk):
        m = min(chunk, total - k0)
        times = req["t0"] + dt * np.arange(k0, k0 + m + 1)
        if varying:
            f = forces(req["force"], times)
            fext = (1.0 - theta) * f[:-1] + theta * f[1:]
        rows = np.empty((m, width)) if not req["bare"] else None
        for j in range(m):
            if varying:
                ds.setFExtPtr(fext[j])
            sim.computeOneStep()
            if rows is not None:
                rows[j, :n] = ds.q()
                rows[j, n:2 * n] = ds.velocity()
                for w, inter in enumerate(inters):
                    rows[j, 2 * n + w] = inter.lambda_(1)[0]
            sim.nextStep()
        if rows is not None:
            out.write(struct.pack("<q", m) + rows.astype("<f8").tobytes())
            out.flush()
    out.write(struct.pack("<q", -1))
    out.flush()


def die_with_parent():
    """Ask Linux to SIGKILL this process when its parent dies (a killed run leaves no child stepping on); a parent
    that died before the request took effect (its pid in ``PARENT``, set by the adapter) ends the child here."""
    if not sys.platform.startswith("linux"):
        return
    try:
        ctypes.CDLL(None).prctl(1, signal.SIGKILL, 0, 0, 0)  # PR_SET_PDEATHSIG (linux/prctl.h)
    except (OSError, AttributeError):  # no prctl: the child ends at its next frame, on a broken pipe
        return
    parent = os.environ.get(PARENT, "")
    if parent.isdigit():  # the adapter (maybe through a wrapper script): gone or a zombie means it died
        try:
            with open(f"/proc/{parent}/stat") as f:
                dead = f.read().rsplit(")", 1)[1].split()[0] in ("Z", "X")
        except (OSError, IndexError):
            dead = True
        if dead:
            os._exit(1)


def requests(stream):
    """Each request's text (bytes) on the binary ``stream``, in order: lines are read until they make one JSON text
    (the adapter's are one line each); what is left at the end that makes none is yielded for ``parse`` to refuse."""
    text = b""
    for line in iter(stream.readline, b""):
        text += line
        if not text.strip():
            text = b""
            continue
        try:
            json.loads(text)
        except ValueError:  # not a whole JSON text yet (or never: the end of stdin says)
            continue
        yield text
        text = b""
    if text.strip():
        yield text


def main():
    die_with_parent()
    data = os.fdopen(os.dup(1), "wb")  # the frames' own copy of stdout
    os.dup2(2, 1)  # whatever Siconos prints goes to stderr
    for text in requests(sys.stdin.buffer):
        try:
            req = parse(text)
        except BadRequest as exc:
            sys.stderr.write(f"siconos child: bad request: {exc}\n")
            return 2
        try:
            step(req, data)
        except BrokenPipeError:  # the parent stopped reading (a blow-up it cut): not a failure of Siconos
            return 0
        except Exception as exc:  # noqa: BLE001  a Siconos failure is reported in one line
            sys.stderr.write(f"siconos child: {type(exc).__name__}: "
                             f"{str(exc).strip().splitlines()[0] if str(exc).strip() else ''}\n")
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
