"""MuJoCo Warp's step and the adapter's per-step recording on a device: kernels loaded and timed, steps captured.

    >>> from chatterbench.engines.mujoco_warp_engine.kernels import KernelLoad, STEPS_PER_GRAPH
    >>> KernelLoad("cuda", 84.2, True, "~/.cache/warp/1.19.0").describe()    # what a command says of a compile
    'MuJoCo Warp compiled its kernels for device cuda in 84.2 s (cache: ~/.cache/warp/1.19.0)'
    >>> STEPS_PER_GRAPH                       # steps captured in one graph, replayed with one launch
    4

``load_kernels`` loads every kernel a model's step needs (warp compiles them the first time on
a machine and caches them under ``warp.config.kernel_cache_dir``), timed: a ``KernelLoad``
says how long it took and whether warp compiled (its cache grew), and each compile is told to
the functions in ``listeners`` (a command's progress says it: the engine layer prints nothing).

``Stepper`` advances a ``mujoco_warp.Data`` of many worlds ``G`` steps at a time: each step is
``mujoco_warp.step`` followed by the adapter's ``record`` kernel (store every world's state after
the step and its sensors, world by world: arrays (nworld, chunk, size), so that a world's samples
come back in one row, check its acceleration as MuJoCo C's ``mj_checkAcc`` does, load the
next step's controls), the step's place in the chunk read from a device counter that
``advance`` moves on, so that one captured sequence serves every step. Where warp can capture
(CUDA, and the CPU device from warp 1.17) the ``G`` steps are captured once per batch
(``warp.ScopedCapture``, as MuJoCo Warp's own ``testspeed`` captures ``step``) and replayed
with ``warp.capture_launch``: one launch per ``G`` steps instead of some ninety per step;
elsewhere they are launched one by one. The two run the same kernels on the same arrays, so
their results are the same bit for bit (``tests/engines/test_mujoco_warp.py``).
"""

from __future__ import annotations

import functools
import math
import time
from typing import Any, Callable

from .. import warp_cache
from ..recording import MAXVAL
from ..warp_cache import cache_entries, compile_lock
from .worlds import warp_modules

# [steps] captured in one graph (~90 kernel nodes a step); a chunk is a multiple of it. On the CPU device a capture
# costs ~11 ms a step captured (APIC packs each launch's arguments), a replay the same ~44 us a step of 8 worlds
# whether it holds 1, 4 or 16 steps (spring-pair, warp 1.19): 4 captures in 46 ms, not 169 ms for 16, and replays
# within 1% of 16's. With the short blocks' shared rig (rigs.world_slots), MuJoCo Warp's atlas cases took 10 to 26% less
# CPU at --max-runs 100 and its spring pair 18% less wall time (docs/how-to/atlas.md).
STEPS_PER_GRAPH = 4


class KernelLoad(warp_cache.KernelLoad):
    """The loading of a model's kernels on a device (``warp_cache.KernelLoad``)."""

    engine = "MuJoCo Warp"


listeners: list[Callable[[KernelLoad], None]] = []  # called with every load that compiled (not cached)


@functools.cache
def record_kernels() -> tuple[Any, Any]:
    """``(record, advance)``: the per-step kernel (module docstring) and the one that moves the step counter on."""
    wp, _ = warp_modules()
    maxval = wp.constant(wp.float32(MAXVAL))

    @wp.kernel
    def record(step: wp.array(dtype=wp.int32), k0: wp.array(dtype=wp.int32), qpos: wp.array2d(dtype=wp.float32),
               qvel: wp.array2d(dtype=wp.float32), qacc: wp.array2d(dtype=wp.float32),
               sensordata: wp.array2d(dtype=wp.float32), ctrl: wp.array2d(dtype=wp.float32),
               mocap_pos: wp.array2d(dtype=wp.vec3), ctrl_in: wp.array3d(dtype=wp.float32),
               mocap_in: wp.array3d(dtype=wp.vec3), qpos_out: wp.array3d(dtype=wp.float32),
               qvel_out: wp.array3d(dtype=wp.float32), sens_out: wp.array3d(dtype=wp.float32),
               bad_acc: wp.array(dtype=wp.int32)):
        w = wp.tid()
        j = step[0]
        for i in range(qpos.shape[1]):
            qpos_out[w, j, i] = qpos[w, i]
        for i in range(qvel.shape[1]):
            qvel_out[w, j, i] = qvel[w, i]
        for i in range(sensordata.shape[1]):
            sens_out[w, j, i] = sensordata[w, i]
        for i in range(qacc.shape[1]):
            # MuJoCo C's mj_checkAcc (mjWARN_BADQACC): an acceleration past mjMAXVAL or not finite
            if not (wp.abs(qacc[w, i]) <= maxval) and bad_acc[w] > k0[0] + j:
                bad_acc[w] = k0[0] + j
        if j + 1 < ctrl_in.shape[0]:
            for i in range(ctrl.shape[1]):
                ctrl[w, i] = ctrl_in[j + 1, w, i]
            for i in range(mocap_pos.shape[1]):
                mocap_pos[w, i] = mocap_in[j + 1, w, i]

    @wp.kernel
    def advance(step: wp.array(dtype=wp.int32)):
        step[0] = step[0] + wp.int32(1)  # (wp named in the body: the annotations are evaluated in its closure)

    return record, advance


@functools.cache
def graphs(device: str) -> bool:
    """Whether warp captures graphs on ``device`` (CUDA; the CPU device from warp 1.17): a one-kernel capture tried."""
    wp, _ = warp_modules()
    _, advance = record_kernels()
    try:
        with wp.ScopedDevice(device):
            step = wp.zeros(1, dtype=wp.int32)
            wp.launch(advance, dim=1, inputs=[step])  # loaded before the capture
            with wp.ScopedCapture() as capture:
                wp.launch(advance, dim=1, inputs=[step])
            wp.capture_launch(capture.graph)
            wp.synchronize()
            return int(step.numpy()[0]) == 2
    except Exception:  # noqa: BLE001  no capture here: steps are launched one by one
        return False


def load_kernels(model: Any, data: Any, device: str) -> KernelLoad:
    """Load the kernels of one step of ``model`` on ``data`` (a one-world ``mujoco_warp.Data`` it may advance) and
    the recording's, timed (any wait for another process's compile included: ``warp_cache.compile_lock``); a compile
    is told to ``listeners``."""
    wp, mjw = warp_modules()
    cache = str(wp.config.kernel_cache_dir or "")
    start = time.perf_counter()
    with compile_lock(cache, "mujoco_warp"), wp.ScopedDevice(device):  # one process compiles at a time; the others then load
        before = cache_entries(cache)
        mjw.step(model, data)
        wp.launch(record_kernels()[1], dim=1, inputs=[wp.zeros(1, dtype=wp.int32)])  # loads the recording's module
        wp.synchronize()
        compiled = cache_entries(cache) > before
    load = KernelLoad(device, time.perf_counter() - start, compiled, cache)
    if load.compiled:
        for listener in listeners:
            listener(load)
    return load


class Stepper:
    """``G`` steps of ``model`` on ``data`` with the recording (module docstring), captured where warp can.

    ``arrays``: the record kernel's arrays after its counter and chunk start (``record_kernels``), fixed for the
    batch (their contents change between chunks, never the arrays). ``start(k0)`` sets the counter to 0 and the
    chunk's first step; ``run(c)`` advances at least ``c`` steps, in launches of ``G`` (a chunk of steps is a
    multiple of ``G``, so only the run's last chunk may step past its end, whose samples nobody reads).
    """

    def __init__(self, model: Any, data: Any, nworld: int, arrays: list, device: str,
                 steps_per_graph: int = STEPS_PER_GRAPH) -> None:
        wp, mjw = warp_modules()
        record, advance = record_kernels()
        self.G, self.device = steps_per_graph, device
        with wp.ScopedDevice(device):
            self.step, self.k0 = wp.zeros(1, dtype=wp.int32), wp.zeros(1, dtype=wp.int32)

        def one() -> None:
            mjw.step(model, data)
            wp.launch(record, dim=nworld, inputs=[self.step, self.k0, *arrays])
            wp.launch(advance, dim=1, inputs=[self.step])

        self.one, self.graph, self.capture_s = one, None, 0.0
        if graphs(device):
            start = time.perf_counter()
            with wp.ScopedDevice(device), wp.ScopedCapture() as capture:
                for _ in range(self.G):
                    one()
            self.graph, self.capture_s = capture.graph, time.perf_counter() - start

    def start(self, k0: int) -> None:
        """The next chunk starts at step ``k0``: its samples go to positions 0, 1, ... of the chunk's arrays."""
        self.step.zero_()
        self.k0.fill_(k0)

    def run(self, c: int) -> None:
        """At least ``c`` steps: ``ceil(c / G)`` graph launches where captured, else exactly ``c`` steps."""
        wp, _ = warp_modules()
        with wp.ScopedDevice(self.device):
            if self.graph is None:
                for _ in range(c):
                    self.one()
            else:
                for _ in range(math.ceil(c / self.G)):
                    wp.capture_launch(self.graph)
