"""The fly engine's speed: fitness evaluations, generations, convergence vs SGBM, numba compile.

Figures are noisy on a shared 2-core machine: run twice and compare.
"""

from __future__ import annotations

import cProfile
import json
import math
import os
import pstats
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from flylog.fly import EngineConfig, FlyEngine
from flylog.fly.fitness import fitness_numba, fitness_numpy
from flylog.geometry import Pose2D, StereoRig
from flylog.geometry.rolling import STILL
from flylog.sensors import SonarReading, StereoPair

SCENE = Path(__file__).resolve().parents[2] / "fixtures" / "scenes" / "clutter.toml"


def _frame(rig: StereoRig) -> tuple[StereoPair, np.ndarray, SonarReading | None]:
    """A 640×480 pair, its left depth and a sonar reading, from the simulator's renderer."""
    from flylog.scene.load import load_scene
    from flylog.sim.render import Renderer
    from flylog.sim.sonar import true_sonar_ranges

    scene = load_scene(SCENE)
    frame = Renderer(scene, rig).render(scene.start_pose)
    s = scene.spec.sonar
    ranges = true_sonar_ranges(scene, s, scene.start_pose)
    reading = SonarReading(0, ranges, s.mounts(), math.radians(s.cone_deg), s.max_range)
    return StereoPair(0, frame.left, frame.right), frame.depth.astype(float), reading


def _best_rate(fn, count: int, repeats: int) -> float:
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return count / best


def _on_surface_share(xyz, fitness, depth, rig) -> float:
    top = xyz[fitness > np.median(fitness)]
    u, _, v, d = rig.project(top)
    ui = np.clip(np.floor(u + 0.5).astype(int), 0, rig.width - 1)
    vi = np.clip(np.floor(v + 0.5).astype(int), 0, rig.height - 1)
    return float(np.mean(np.abs(d - depth[vi, ui]) <= 0.05 * d))


def _fitness_figures(pair: StereoPair, rig: StereoRig) -> list[dict]:
    """The fitness kernel's throughput with the engine's default measure (``EngineConfig()``'s
    gradient, similarity and sub-pixel sampling): 7×7 colour fitness evaluations per second on
    a 640×480 pair, for 1 M flies spread uniformly over the left image with inverse depth
    uniform over 0.5–20 m. Every fly counts as an evaluation, as the engine charges them; the
    share that is valid (both windows inside the images: an invalid fly costs its projection
    only) is noted. Parallel and one thread alternate round by round (the same load on both):
    best wall time of 7 rounds, and evaluations per second of CPU (both threads' time, the
    median round), which another tenant's load moves less than the wall time."""
    from numba import get_num_threads

    from flylog.fly.fitness import INVALID_FITNESS

    cfg = EngineConfig()
    measure = {"gradient": cfg.gradient, "similarity": cfg.similarity, "subpixel": cfg.subpixel}
    rng = np.random.default_rng(0)
    n = 1_000_000
    u, v = rng.uniform(3, rig.width - 4, n), rng.uniform(3, rig.height - 4, n)
    xyz = rig.backproject(u, v, 1.0 / rng.uniform(1 / 20.0, 1 / 0.5, n))
    out = np.empty(n)
    index = np.arange(n)

    def score(parallel_min: int) -> None:
        fitness_numba(
            pair.left,
            pair.right,
            xyz,
            rig,
            7,
            1.0,
            index=index,
            out=out,
            parallel_min=parallel_min,
            **measure,
        )

    fitness_numba(pair.left, pair.right, xyz[:1000], rig, 7, 1.0, **measure)  # compile
    score(0)
    wall: dict[int, list[float]] = {0: [], n + 1: []}
    cpu: dict[int, list[float]] = {0: [], n + 1: []}
    for _ in range(7):
        for parallel_min in wall:
            t0, c0 = time.perf_counter(), time.process_time()
            score(parallel_min)
            wall[parallel_min].append(time.perf_counter() - t0)
            cpu[parallel_min].append(time.process_time() - c0)
    valid = (out > INVALID_FITNESS).mean()
    numba_rate, serial_all_rate = n / min(wall[0]), n / min(wall[n + 1])
    cpu_rate = n / float(np.median(cpu[0]))
    m = 50_000
    numpy_rate = _best_rate(
        lambda: fitness_numpy(pair.left, pair.right, xyz[:m], rig, 7, 1.0, **measure), m, 3
    )
    small = np.arange(2500)
    serial_rate = _best_rate(
        lambda: fitness_numba(
            pair.left, pair.right, xyz, rig, 7, 1.0, index=small, out=out, **measure
        ),
        2500,
        50,
    )
    # The same batch size, but other flies every call (as a generation's new children are):
    # their windows are not left in the caches by the previous call.
    batches = index.reshape(-1, 2500)

    def fresh_batches() -> None:
        for batch in batches:
            fitness_numba(pair.left, pair.right, xyz, rig, 7, 1.0, index=batch, out=out, **measure)

    fresh_rate = _best_rate(fresh_batches, n, 3)
    default = f"{cfg.similarity.value}{', sub-pixel' if cfg.subpixel else ''}, " + (
        f"{cfg.gradient.value} gradient"
    )
    return [
        {
            "name": f"fitness evaluations, numba parallel (7×7 RGB, 640×480, {default})",
            "value": numba_rate,
            "unit": "eval/s",
            "reference": "numpy gather",
            "ratio": numba_rate / numpy_rate,
            "note": f"{valid:.0%} of the random flies valid ({numba_rate * valid / 1e6:.1f} M "
            f"valid/s); {get_num_threads()} threads, {numba_rate / serial_all_rate:.2f}× one "
            f"thread; {cpu_rate / 1e6:.1f} M per CPU-second",
        },
        {"name": "fitness evaluations, numpy gather", "value": numpy_rate, "unit": "eval/s"},
        {
            "name": f"fitness evaluations, numba one thread (7×7 RGB, 640×480, {default})",
            "value": serial_all_rate,
            "unit": "eval/s",
            "reference": "numpy gather",
            "ratio": serial_all_rate / numpy_rate,
            "note": f"{n / float(np.median(cpu[n + 1])) / 1e6:.1f} M per CPU-second",
        },
        {
            "name": "fitness evaluations, numba serial batches of 2500 (as in a generation)",
            "value": serial_rate,
            "unit": "eval/s",
        },
        {
            "name": "fitness evaluations, numba serial batches of 2500, other flies each batch",
            "value": fresh_rate,
            "unit": "eval/s",
            "reference": "the same 2500 flies every batch",
            "ratio": fresh_rate / serial_rate,
        },
    ]


def _similarity_figures(pair: StereoPair, rig: StereoRig) -> list[dict]:
    """ZNCC's and sub-pixel sampling's fitness evaluations per second against the zero-mean
    SSD on whole pixels, the same flies in the same run (7×7 RGB, 640×480): all at once in
    parallel, and in serial batches of 2500 as a generation's newcomers are scored; and whole
    generations (5000 flies, every operator) with each."""
    from flylog.fly import Similarity

    rng = np.random.default_rng(0)
    n = 1_000_000
    u, v = rng.uniform(3, rig.width - 4, n), rng.uniform(3, rig.height - 4, n)
    xyz = rig.backproject(u, v, 1.0 / rng.uniform(1 / 20.0, 1 / 0.5, n))
    out = np.empty(n)
    index = np.arange(n)
    small = np.arange(2500)
    variants = [(s, sub) for sub in (False, True) for s in Similarity]
    rates: dict[tuple, float] = {}
    for s, sub in variants:
        kw = {"similarity": s, "subpixel": sub, "out": out}
        fitness_numba(pair.left, pair.right, xyz[:1000], rig, 7, 1.0, similarity=s, subpixel=sub)
        rates[s, sub, "parallel"] = _best_rate(
            lambda kw=kw: fitness_numba(pair.left, pair.right, xyz, rig, 7, 1.0, index=index, **kw),
            n,
            5,
        )
        rates[s, sub, "batch"] = _best_rate(
            lambda kw=kw: fitness_numba(pair.left, pair.right, xyz, rig, 7, 1.0, index=small, **kw),
            2500,
            50,
        )
        config = EngineConfig(similarity=s, subpixel=sub)
        engine = FlyEngine(config, rig, np.random.default_rng(0))
        engine.set_images(pair)
        engine.steps(20)
        rates[s, sub, "generations"] = _best_rate(lambda e=engine: e.steps(100), 100, 3)
    labels = {
        "parallel": ("fitness evaluations, numba parallel (7×7 RGB, 640×480)", "eval/s"),
        "batch": ("fitness evaluations, numba serial batches of 2500", "eval/s"),
        "generations": ("generations, 5000 flies, every operator", "gen/s"),
    }
    base = (Similarity.ZSSD, False)
    return [
        {
            "name": f"{name}, {s.value}{', sub-pixel' if sub else ''}",
            "value": rates[s, sub, key],
            "unit": unit,
            "reference": "the same with zssd on whole pixels",
            "ratio": rates[s, sub, key] / rates[(*base, key)],
        }
        for key, (name, unit) in labels.items()
        for s, sub in variants
        if (s, sub) != base
    ]


def _rig_kernel_figures(pair: StereoPair, rig: StereoRig) -> list[dict]:
    """The real camera's kernel against the level-only kernel it generalises
    (tests/benchmarks/level_fitness.py), on the same flies in the same run, alternated:
    its level fast path (the fixture logs' rigs), its general path on the same level rig
    (the fast path's flag cleared: the same numbers), and the general path on a tilted,
    rolled rig with an off-centre principal point and doffs. Parallel: the best wall time of
    9 rounds; one thread: the median of 30 paired ratios of this thread's CPU time."""
    import dataclasses

    from flylog.fly.config import Gradient
    from flylog.fly.fitness import fitness_into, images_of
    from flylog.fly.measures import ZSSD
    from flylog.geometry.kernels import LEVEL
    from tests.benchmarks.level_fitness import level_constants, level_fitness

    rng = np.random.default_rng(0)
    n = 1_000_000
    u, v = rng.uniform(3, rig.width - 4, n), rng.uniform(3, rig.height - 4, n)
    depth = 1.0 / rng.uniform(1 / 20.0, 1 / 0.5, n)
    xyz = np.ascontiguousarray(rig.backproject(u, v, depth))
    real = dataclasses.replace(rig, tilt=15.0, roll=2.0, principal_point=(330.0, 230.0), doffs=4.0)
    tilted = np.ascontiguousarray(real.backproject(u, v, depth))  # the same image spread
    h, w, c = pair.left.shape
    rows = (pair.left.reshape(h, w * c), pair.right.reshape(h, w * c), c)
    index = np.arange(n, dtype=np.int64)
    general = rig.constants()
    general[LEVEL] = 0.0
    kernels = {  # name: (flies, constants; None: the level-only kernel)
        "level-only": (xyz, None),
        "fast": (xyz, rig.constants()),
        "general": (xyz, general),
        "tilted": (tilted, real.constants()),
    }
    outs = {name: np.empty(n) for name in kernels}

    def call(name: str, parallel: bool, count: int) -> None:
        points, k = kernels[name]
        if k is None:
            level_fitness(
                *rows, points, index[:count], level_constants(rig), outs[name], parallel=parallel
            )
        else:
            im = images_of(pair.left, pair.right, rig, 7, 1.0, gradient=Gradient.NORM)
            parallel_min = 0 if parallel else n + 1
            fitness_into(im._replace(k=k), ZSSD, points, index[:count], outs[name], parallel_min)

    figures = []
    for parallel, count, repeats in ((True, n, 9), (False, 200_000, 31)):
        clock = time.perf_counter if parallel else time.thread_time
        times: dict[str, list[float]] = {name: [] for name in kernels}
        for name in kernels:
            call(name, parallel, 1000)  # compile
        for _ in range(repeats):  # alternated: the same load on every kernel
            for name in kernels:
                t0 = clock()
                call(name, parallel, count)
                times[name].append(clock() - t0)
        for name in ("fast", "general"):
            np.testing.assert_array_equal(outs[name][:count], outs["level-only"][:count])
        ref = np.array(times["level-only"][1:])
        ratios = {}
        for name in ("fast", "general", "tilted"):
            t = np.array(times[name][1:])
            ratios[name] = float(ref.min() / t.min() if parallel else np.median(ref / t))
        mode = "parallel" if parallel else "one thread"
        figures.append(
            {
                "name": f"fitness evaluations, real-camera rig kernel, {mode}, level rig "
                "(zssd, whole pixels, norm gradient)",
                "value": count / min(times["fast"]),
                "unit": "eval/s",
                "reference": "level-only kernel",
                "ratio": ratios["fast"],
                "note": f"its general path on the same flies {ratios['general']:.3f}×; tilted "
                f"15°, rolled 2°, off-centre principal point, doffs 4 px {ratios['tilted']:.3f}× "
                f"({(outs['tilted'][:count] >= 0).mean():.0%} of those flies valid, "
                f"{(outs['fast'][:count] >= 0).mean():.0%} of the level ones)",
            }
        )
    return figures


# 0.5 rad/s over a readout of 240 rows of 130 µs (31.2 ms): the turn logs' rolling shutter
ROW_TIME_READOUT = Pose2D(0.0, 0.0, 0.5 * 240 * 130e-6)


def _row_time_figures(pair: StereoPair, reading: SonarReading | None, rig: StereoRig) -> list[dict]:
    """Fitness evaluations per second with each fly placed at its row's time (a moving
    readout, :mod:`flylog.geometry.rolling`) against every row at the stamp, same run: the
    engine in replay's rhythm (a new pair every 10 generations, a frame's generations one
    call, 5000 flies, every operator on) and the fitness kernel alone (1 M flies, one
    thread). The two alternate round by round (the same load on both); each figure is a
    ratio of medians over the rounds of evaluations per second of this thread's CPU time."""
    cfg = EngineConfig(flies=5000)
    engines = {}
    for name, readout in (("stamp", STILL), ("rows", ROW_TIME_READOUT)):
        engine = FlyEngine(cfg, rig, np.random.default_rng(0))
        if reading is not None:
            engine.set_sonar(reading)
        pairs = [StereoPair(i, pair.left, pair.right, readout) for i in range(10)]
        engine.set_images(pairs[0])
        engine.steps(20)  # compiled, converged
        engines[name] = (engine, pairs)

    def replay_rhythm(name: str) -> float:
        engine, pairs = engines[name]
        evaluations = 0
        c0 = time.thread_time()
        for p in pairs:
            engine.set_images(p)
            evaluations += sum(s.evaluations for s in engine.steps(10))
        return evaluations / (time.thread_time() - c0)

    rng = np.random.default_rng(0)
    n = 1_000_000
    u, v = rng.uniform(3, rig.width - 4, n), rng.uniform(3, rig.height - 4, n)
    xyz = rig.backproject(u, v, 1.0 / rng.uniform(1 / 20.0, 1 / 0.5, n))
    out, index = np.empty(n), np.arange(n)
    measure = {"gradient": cfg.gradient, "similarity": cfg.similarity, "subpixel": cfg.subpixel}

    def kernel(name: str) -> float:
        readout = STILL if name == "stamp" else ROW_TIME_READOUT
        c0 = time.thread_time()
        fitness_numba(
            pair.left,
            pair.right,
            xyz,
            rig,
            7,
            1.0,
            index=index,
            out=out,
            parallel_min=n + 1,
            readout=readout,
            **measure,
        )
        return n / (time.thread_time() - c0)

    for name in ("stamp", "rows"):
        kernel(name)  # compiled
    rates: dict[str, dict[str, list[float]]] = {"engine": {}, "kernel": {}}
    for _ in range(9):
        for name in ("stamp", "rows"):
            rates["engine"].setdefault(name, []).append(replay_rhythm(name))
            rates["kernel"].setdefault(name, []).append(kernel(name))
    figures = []
    for what, label in (
        ("engine", "engine, replay rhythm, 5000 flies"),
        ("kernel", "fitness kernel, 1 M flies, one thread"),
    ):
        stamp = float(np.median(rates[what]["stamp"]))
        rows = float(np.median(rates[what]["rows"]))
        figures.append(
            {
                "name": f"evaluations per CPU-second, flies at their rows' times ({label})",
                "value": rows,
                "unit": "eval/s",
                "reference": "every row at the stamp (a still readout), same run",
                "ratio": rows / stamp,
                "note": f"medians of 9 interleaved rounds; at the stamp {stamp / 1e6:.2f} M/s",
            }
        )
    return figures


def _generation_figures(pair, depth, reading, rig) -> list[dict]:
    engine = FlyEngine(EngineConfig(flies=5000), rig, np.random.default_rng(0))
    engine.set_images(pair)
    if reading is not None:
        engine.set_sonar(reading)
    for _ in range(20):
        engine.step()
    gens = 300
    rate = _best_rate(lambda: [engine.step() for _ in range(gens)], gens, 3)
    # Replay's rhythm: a new pair every 10 generations makes every fly stale once per frame.
    frames, per_frame = 30, 10
    pairs = [StereoPair(i, pair.left, pair.right) for i in range(frames)]

    def replay_rhythm() -> None:
        for p in pairs:
            engine.set_images(p)
            for _ in range(per_frame):
                engine.step()

    def replay_calls() -> None:  # as replay calls it: a frame's generations in one call
        for p in pairs:
            engine.set_images(p)
            engine.steps(per_frame)

    # alternated, so that both see the same load: the best of 5 rounds each
    rounds = [
        (_best_rate(replay_rhythm, 300, 1), _best_rate(replay_calls, 300, 1)) for _ in range(5)
    ]
    replay_rate, batched_rate = (max(r) for r in zip(*rounds, strict=True))
    # Time to the convergence figure (80 % of the top half within 5 % of the true depth),
    # from a fresh population; the share is checked between generations, off the clock.
    engine = FlyEngine(EngineConfig(flies=5000), rig, np.random.default_rng(1))
    engine.set_images(pair)
    spent, generations, share = 0.0, 0, 0.0
    while share < 0.8 and generations < 200:
        t0 = time.perf_counter()
        engine.step()
        spent += time.perf_counter() - t0
        generations += 1
        pop = engine.population
        share = _on_surface_share(pop.xyz, pop.fitness, depth, rig)
    grey_l = cv2.cvtColor(pair.left, cv2.COLOR_RGB2GRAY)
    grey_r = cv2.cvtColor(pair.right, cv2.COLOR_RGB2GRAY)
    sgbm = cv2.StereoSGBM_create(
        minDisparity=0, numDisparities=64, blockSize=7, mode=cv2.STEREO_SGBM_MODE_SGBM_3WAY
    )
    sgbm.compute(grey_l, grey_r)
    sgbm_time = min(
        (lambda t0: (sgbm.compute(grey_l, grey_r), time.perf_counter() - t0)[1])(
            time.perf_counter()
        )
        for _ in range(5)
    )
    return [
        {
            "name": "generations per second, 5000 flies, every operator on (sonar too)",
            "value": rate,
            "unit": "gen/s",
        },
        {
            "name": "generations per second, replay rhythm (new pair every 10 generations)",
            "value": replay_rate,
            "unit": "gen/s",
            "note": f"engine alone would take {9000 / replay_rate:.1f} s of the reference "
            "replay (9000 generations; target < 6 s with I/O)",
        },
        {
            "name": "generations per second, replay rhythm, a frame's 10 generations one call",
            "value": batched_rate,
            "unit": "gen/s",
            "reference": "one call a generation",
            "ratio": batched_rate / replay_rate,
            "note": f"{9000 / batched_rate:.1f} s of engine for the 60 s reference replay",
        },
        {
            "name": "engine time to converge on one 640×480 frame",
            "value": spent,
            "unit": "s",
            "reference": "OpenCV StereoSGBM 3WAY, 64 disparities, same frame",
            "ratio": spent / sgbm_time,
            "note": f"{generations} generations to share {share:.2f}; "
            f"SGBM {sgbm_time * 1e3:.1f} ms",
        },
    ]


def _captured_bundles(engine: FlyEngine) -> tuple:
    """The arguments of the engine's next :func:`~flylog.fly.generation.generations_kernel`
    call (one generation is run to get them)."""
    import flylog.fly.numba_backend as engine_module

    real, captured = engine_module.generations_kernel, []

    def spy(*args):
        captured.append(args)
        return real(*args)

    engine_module.generations_kernel = spy
    try:
        engine.steps(1)
    finally:
        engine_module.generations_kernel = real
    return captured[0]


def _stage_figures(pair, reading, rig) -> list[dict]:
    """The stages of one generation (5000 flies, sonar on, a new pair every 10 generations),
    each compiled stage called alone from Python on the engine's own bundles, in the
    kernel's order: the median over 400 generations of each call's thread CPU time (the
    dispatch of a call, ~2 µs, included; the Generator's typing, measured by a no-op
    kernel, is charged to breeding)."""
    import numba

    from flylog.fly.fusion import score_into
    from flylog.fly.generation import rows_order_into
    from flylog.fly.neighbours import fly_neighbour_counts_into
    from flylog.fly.operators import immigrants_and_children_into
    from flylog.fly.population import _cut_and_gather
    from flylog.fly.selection import shared_fitness_into

    engine = FlyEngine(EngineConfig(flies=5000), rig, np.random.default_rng(0))
    engine.set_images(pair)
    engine.set_sonar(reading)
    engine.steps(20)
    _, _, rng, im, measure, a, b, _, fu, se, br, _, sc = _captured_bundles(engine)
    noop = numba.njit(lambda rng, x: 0)
    noop(rng, a.xyz)
    times: dict[str, list[float]] = {}

    def timed(name, fn, *args):
        t0 = time.thread_time()
        out = fn(*args)
        times.setdefault(name, []).append(time.thread_time() - t0)
        return out

    n, height = len(a.xyz), im.lrows.shape[0]
    for g in range(440):
        if g % 10 == 0:
            a.stale[:] = True
        m = int(a.stale.sum())
        sc.stale_index[:m] = np.flatnonzero(a.stale)
        what = "all 5000 stale flies (new pair)" if m == n else "stale flies (none)"
        index = timed(
            "row order, stale",
            rows_order_into,
            a.xyz,
            sc.stale_index[:m],
            im.k,
            height,
            sc.row_scratch,
        )
        timed(f"fitness, {what}", score_into, im, measure, fu, a, index, index)
        timed(
            "neighbour counts (grid)",
            fly_neighbour_counts_into,
            a.xyz,
            im.k,
            a.fitness,
            se.radius,
            se.grid,
            se.ints,
            se.floats,
            se.counts,
        )
        score = se.work[:n]
        timed(
            "sharing (median)",
            shared_fitness_into,
            a.fitness,
            se.counts,
            se.coefficient,
            se.work[n:],
            score,
        )
        cut = _cut_and_gather
        kept = timed("selection cut and gather", cut, score, se.survivors, se.work, a, b)
        at = n - br.n_immigrants
        timed(
            "breeding: children and immigrants",
            immigrants_and_children_into,
            rng,
            b.xyz[:kept],
            br,
            fu.tolerance,
            b.xyz[kept:at],
            b.xyz[at:],
        )
        timed("Generator typing (no-op kernel)", noop, rng, b.xyz)
        order = timed(
            "row order, newcomers",
            rows_order_into,
            b.xyz,
            sc.newcomers,
            im.k,
            height,
            sc.row_scratch,
        )
        timed("fitness, 2500 newcomers", score_into, im, measure, fu, b, order, order)
        a, b = b, a
    typing = float(np.median(times.pop("Generator typing (no-op kernel)")[40:]))
    figures = []
    for name, values in times.items():
        per = np.median(values[4:] if "new pair" in name else values[40:])
        if name.startswith("breeding"):
            per -= typing
        figures.append({"name": f"stage: {name}", "value": per * 1e6, "unit": "µs/call"})
    return figures


def _bundle_figures(pair, reading, rig) -> list[dict]:
    """The cost of passing the generation's inputs as bundles: a call of
    :func:`~flylog.fly.generation.generations_kernel` that runs no generation (its dispatch:
    typing the seven bundles, the measure and the Generator) against a no-op kernel given the
    same values one by one, alternated in the same run; and both against a 10-generation call."""
    import numba

    engine = FlyEngine(EngineConfig(flies=5000), rig, np.random.default_rng(0))
    engine.set_images(pair)
    engine.set_sonar(reading)
    engine.steps(20)
    args = _captured_bundles(engine)
    from flylog.fly.generation import generations_kernel

    _, made, rng, *bundles = args
    flat = [rng]
    for bundle in bundles:
        flat.extend(bundle if isinstance(bundle, tuple) else (bundle,))
    names = ", ".join(f"a{i}" for i in range(len(flat)))
    scope: dict = {}
    exec(f"def noop({names}):\n    return 0", scope)  # one named parameter per value
    noop = numba.njit(scope["noop"])
    noop(*flat)
    generations_kernel(0, made, rng, *bundles)
    calls = 2000
    bundled, positional = [], []
    for _ in range(7):
        t0 = time.thread_time()
        for _ in range(calls):
            generations_kernel(0, made, rng, *bundles)
        bundled.append((time.thread_time() - t0) / calls)
        t0 = time.thread_time()
        for _ in range(calls):
            noop(*flat)
        positional.append((time.thread_time() - t0) / calls)
    ten = 1.0 / _best_rate(lambda: engine.steps(10), 1, 20)
    return [
        {
            "name": "generation kernel's dispatch, seven bundles",
            "value": min(bundled) * 1e6,
            "unit": "µs/call",
            "reference": f"a no-op kernel of the same {len(flat)} values one by one",
            "ratio": min(bundled) / min(positional),
            "note": f"{min(bundled) / ten:.2%} of a 10-generation call ({ten * 1e3:.2f} ms)",
        }
    ]


# The engine's kernels and operators, as cProfile names them (file, function).
_PROFILED = [
    # one compiled call a step (or a run of steps): scoring, selection, newcomers, scouts
    ("generation.py", "generations_kernel"),
    ("fitness.py", "fitness_into"),  # the parallel kernel, for the stale flies of a new frame
    ("engine.py", "step"),
]


def _profile_figures(pair, reading, rig) -> list[dict]:
    """Per-kernel time per generation in replay's rhythm (a new pair after motion every 10
    generations, sonar on), from cProfile: tottime, and the cumulative whole step. The
    stages inside the generation's one compiled call are not seen by cProfile. The same
    images every frame: caches and branch predictors fare better than on
    a log (see the log-rhythm figure)."""
    engine = FlyEngine(EngineConfig(flies=5000), rig, np.random.default_rng(0))
    engine.set_images(pair)
    engine.set_sonar(reading)
    for _ in range(10):
        engine.step()
    frames, per_frame = 100, 10
    from flylog.geometry import Pose2D

    profile = cProfile.Profile()
    profile.enable()
    for i in range(frames):
        engine.apply_motion(Pose2D(0.01, 0.0, 0.002))
        engine.set_images(StereoPair(i + 1, pair.left, pair.right))
        for _ in range(per_frame):
            engine.step()
    profile.disable()
    stats = pstats.Stats(profile).stats  # type: ignore[attr-defined]
    gens = frames * per_frame
    figures = []
    for (path, _, name), (_, _, tottime, cumtime, _) in stats.items():
        for file, function in _PROFILED:
            if path.endswith(file) and name == function:
                cumulative = name == "step"
                seconds = cumtime if cumulative else tottime
                figures.append(
                    {
                        "name": f"profile: {file} {name} ({'cum' if cumulative else 'own'})",
                        "value": seconds / gens * 1e3,
                        "unit": "ms/gen",
                    }
                )
    return sorted(figures, key=lambda f: -f["value"])


_COMPILE_PROBE = """
import time, json
t0 = time.perf_counter()
import numpy as np
from flylog.fly import EngineConfig, FlyEngine
from flylog.geometry import Pose2D, StereoRig
from flylog.geometry.rolling import STILL
from flylog.sensors import StereoPair
t1 = time.perf_counter()
rig = StereoRig(width=64, height=48, focal_px=50.0)
img = np.random.default_rng(0).integers(0, 256, (48, 64, 3), dtype=np.uint8)
engine = FlyEngine(EngineConfig(flies=100), rig, np.random.default_rng(0))
engine.set_images(StereoPair(0, img, img))
engine.step()
t2 = time.perf_counter()
print(json.dumps({"import": t1 - t0, "first_step": t2 - t1}))
"""


def _compile_figures() -> list[dict]:
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        command = [sys.executable, "-c", _COMPILE_PROBE]
        runs = [
            json.loads(subprocess.run(command, env=env, check=True, capture_output=True).stdout)
            for _ in range(2)
        ]
    cold, warm = runs[0]["first_step"], runs[1]["first_step"]
    return [
        {"name": "numba compile at first use (empty cache)", "value": cold, "unit": "s"},
        {
            "name": "first step in a second process (cache=True)",
            "value": warm,
            "unit": "s",
            "reference": "empty cache",
            "ratio": warm / cold,
        },
    ]


def _log_calls(log: Path, seconds: float) -> tuple[StereoRig, list[tuple[str, object]]]:
    """The engine calls of ``flylog replay LOG --generations-per-frame 10`` over the first
    ``seconds`` of the reference ``log``, in order, recorded through the replay's own clock."""
    from flylog.geometry import relative
    from flylog.io.pairing import pair_stereo
    from flylog.io.reader import open_log
    from flylog.replay.clock import VirtualClock
    from flylog.replay.config import ReplayConfig
    from flylog.replay.run import clock_config
    from flylog.sensors import OdomReading
    from flylog.sources.inputs import SENSOR_TOPICS, replay_inputs

    reader = open_log(log)
    inputs = replay_inputs(reader, goal=None)
    config = ReplayConfig(generations_per_frame=10)
    calls: list[tuple[str, object]] = []

    class Recorder:
        pose = None

        def deliver(self, record):
            if isinstance(record, StereoPair):
                calls.append(("images", record))
            elif isinstance(record, SonarReading):
                calls.append(("sonar", record))
            elif isinstance(record, OdomReading):
                if self.pose is not None:
                    calls.append(("motion", relative(self.pose, record.pose)))
                self.pose = record.pose

        def generation(self, keep_published=True):
            evaluations = 5000 if calls[-1][0] == "images" else 2500
            calls.append(("step", None))
            return evaluations, config.generation_cost_ns(evaluations)

        def run_generations(self, count, keep_published):
            evaluations = 5000 if calls[-1][0] == "images" else 2500
            costs = [evaluations] + [2500] * (count - 1)
            calls.append(("steps", count))
            return [(e, config.generation_cost_ns(e)) for e in costs]

        def publish(self, t_ns):
            calls.append(("publish", None))

        def tick(self, name, t_ns):
            pass

    clock = VirtualClock(Recorder(), clock_config(config, inputs.rig))
    end = inputs.start_ns + round(seconds * 1e9)
    for message in pair_stereo(reader.messages(SENSOR_TOPICS)):
        if message.log_time_ns > end:
            break
        clock.feed(message.value)
    clock.finish(end)
    return inputs.rig, calls


def _log_rhythm_figures(out_dir: Path) -> list[dict]:
    """The replay's rhythm on real data: the engine's CPU time per generation (this thread's,
    so other processes' load counts less) over the first 10 s of the reference log, every
    call the replay makes (images, sonar, odometry, steps, a snapshot per generation)."""
    from tests.benchmarks.bench_replay import reference_log

    rig, calls = _log_calls(reference_log(out_dir), 10.0)

    def replay() -> tuple[float, int]:
        engine = FlyEngine(EngineConfig(), rig, np.random.default_rng(0))
        steps = 0
        t0 = time.thread_time()
        for kind, value in calls:
            if kind == "images":
                engine.set_images(value)
            elif kind == "sonar":
                engine.set_sonar(value)
            elif kind == "motion":
                engine.apply_motion(value)
            elif kind == "step":
                engine.step()
                steps += 1
            elif kind == "steps":  # the generations no tick comes between: one call
                engine.steps(value)
                steps += value
            else:
                _ = engine.population
        return time.thread_time() - t0, steps

    replay()  # compile, warm up
    seconds, steps = min(replay() for _ in range(3))
    return [
        {
            "name": "engine CPU time per generation, reference log's rhythm (10 s)",
            "value": seconds / steps * 1e3,
            "unit": "ms/gen",
            "note": f"{steps} generations; the 60 s replay runs ~9010: "
            f"{seconds / steps * 9010:.1f} s of engine",
        }
    ]


def run(out_dir: Path) -> list[dict]:
    rig = StereoRig()
    pair, depth, reading = _frame(rig)
    return (
        _fitness_figures(pair, rig)
        + _similarity_figures(pair, rig)
        + _rig_kernel_figures(pair, rig)
        + _generation_figures(pair, depth, reading, rig)
        + _row_time_figures(pair, reading, rig)
        + _profile_figures(pair, reading, rig)
        + _stage_figures(pair, reading, rig)
        + _bundle_figures(pair, reading, rig)
        + _log_rhythm_figures(out_dir)
        + _compile_figures()
    )
