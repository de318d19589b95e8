#!/usr/bin/env python
"""Render benchmark: each track's observation render and official step, beside
raw MuJoCo in the same run, at the earlier small image size and at the official one.

    python tests/benchmarks/bench_render.py [--quick] [--rounds R] [--size WxH]
        [--tracks track1,track2] [--families a,b] [--gpu | --no-gpu] [--json out.json]

Cases: Track 1 ``standard`` and ``challenge`` (one house each, seed ``--track1-seed``),
Track 2 ``standard`` and ``challenge`` for each of ``--families`` (one sampled instance
each, seed ``--track2-seed``), each at the earlier small size (Track 1 96x72, Track 2 128x96) and at
the size the split's own config asks for (``simhost.worlds.track1.SPLITS[split].config.image_size``,
``simhost.worlds.track2.SPLITS[split].bench.observation.image_size``); ``--size WxH`` adds one more
size (a candidate before the tracks adopt it). For each case and size, in one process:

1. record: ``reset(seed)``, then a policy's actions (Track 1: ``bench_track1``'s seeded
   wander and ``open``/``pick`` mix; Track 2: the family's privileged scripted expert, its
   episode repeated as needed); the first steps warm the renderer up and are not timed;
2. ours: ``reset(seed)`` and ``env.step`` on the recorded actions, on the split's official
   config (physics, observation, RGB-D as the split renders it), one clock reading around
   each call; the physics state before each step and the controls after it are kept
   (untimed). The process's peak resident memory (``VmHWM``) is read right after: what one
   env of that split costs a worker, interpreter and imports included;
3. render: at states of the recorded steps (``mj_setState`` + ``mj_forward``, untimed), our
   observation render (Track 1 ``HouseSim.render_rgbd``, Track 2 the env's observation
   render: RGB, depth and segmentation where the split has it) against a raw
   ``mujoco.Renderer`` of the same model at the same size rendering the same images (every
   camera of the observation: Track 1 ``eye``, Track 2 each of ``CAMERAS``; same geom groups
   and scene flags as ours, one ``update_scene`` per camera and one ``render()`` per image),
   alternating which goes first;
4. floor: from each kept state, with the step's final controls, as many raw ``mj_step`` as
   that step advanced the physics (``data.time`` / ``timestep``), timed together; the floor
   of a step is that plus the raw render times the renders per step (1 for Track 1; Track 2
   renders every ``period_steps`` control steps);
5. bare: a second env of the same split with ``render_rgbd`` off replays the actions: the
   step without a render against the same raw ``mj_step`` blocks.

Step figures are means per step (steps differ: a Track 1 ``move`` runs ~85 substeps, a
``noop`` few; Track 2 renders every 2nd or 3rd step), render figures medians per call; each
process is one round of one case and size, rounds interleave every case and size (so load
elsewhere spreads over all), and the table shows the median over rounds of each figure and
of each ratio (a ratio is taken within its round: both sides ran seconds apart in one
process, so the machine's load cancels out of it). Rendering is
through EGL (``MUJOCO_GL=egl``). On a CPU-only machine that is Mesa's llvmpipe; where a
GPU is found (``/dev/nvidia0`` or ``nvidia-smi``; ``--gpu`` / ``--no-gpu`` decide), every
round also runs on it, and the CPU rows are forced onto Mesa (glvnd's vendor file); each
group of rows names the GL renderer that made it. Nothing else depends on a GPU.

Goals: render <= 1.2x raw, step <= 1.2x floor, < 20 ms per step at the
official size on a CPU-only worker, < 250 MB peak per env. Not collected by pytest.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import shutil
import signal
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from _machine import die_with_parent, load_average, machine_line, reap, run_child  # noqa: E402  (sibling)

ROOT = Path(__file__).resolve().parents[2]
TODAY = {"track1": (96, 72), "track2": (128, 96)}
"""(width, height) of the small sizes the splits used to observe at, for comparison."""
SPLITS = ("standard", "challenge")
MESA_VENDOR = Path("/usr/share/glvnd/egl_vendor.d/50_mesa.json")
GOALS = {"render": 1.2, "step": 1.2, "ms": 20.0, "mib": 250.0}
# per case and round: (timed steps, warm-up steps, render pairs), full / quick
COUNTS = {"track1": ((60, 5, 30), (24, 3, 12)), "track2": ((150, 6, 40), (60, 4, 16))}


# ================================================================================ children

def _status_kib(field: str) -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1])
    return -1


def _gl_renderer() -> str:
    """The OpenGL renderer string of the current (EGL) context, if it can be read (twice:
    PyOpenGL raises a GL error left over from earlier calls, and that clears it)."""
    for _ in range(2):
        with contextlib.suppress(Exception):
            from OpenGL import GL

            return str(GL.glGetString(GL.GL_RENDERER).decode())
    return "?"


def _gl_of(owner: Any) -> Any:
    """Our renderer (whatever holds the ``MjvScene``: a ``mujoco.Renderer`` or a track's own
    camera), for its scene flags; None before the first render or when it has no scene."""
    for name in ("_camera", "_renderer"):
        gl = getattr(owner, name, None)
        if gl is not None and hasattr(gl, "scene"):
            return gl
    return None


def _option_of(owner: Any) -> Any:
    """Our ``MjvOption`` (geom groups shown), where the track keeps one."""
    opt = getattr(owner, "_scene_option", None)
    if opt is None:
        opt = getattr(_gl_of(owner), "option", None)
    return opt


class _Track1:
    """A Track 1 house of a split: envs, camera, observation render, policy."""

    cameras: tuple[str, ...] = ("eye",)

    def __init__(self, split: str, size: tuple[int, int], seed: int) -> None:
        from simhost.worlds.track1 import HouseEnv

        self.split, self.size, self.seed = split, size, seed
        self.env = HouseEnv(split=split, render_rgbd=True, image_size=size)

    @property
    def sim(self) -> Any:
        return self.env.house.sim

    def model_data(self, env: Any = None) -> tuple[Any, Any]:
        sim = (env or self.env).house.sim
        return sim.model, sim.data

    def bare(self) -> Any:
        from simhost.worlds.track1 import HouseEnv

        return HouseEnv(split=self.split, render_rgbd=False)

    def renders_per_step(self) -> float:
        return 1.0

    def channels(self) -> tuple[str, ...]:
        return ("rgb", "depth", "segmentation")

    def render_ours(self) -> None:
        self.sim.render_rgbd(*self.size)

    def ours_renderer(self) -> Any:
        return _gl_of(self.sim)

    def scene_option(self) -> Any:
        import mujoco

        opt = _option_of(self.sim)
        if opt is None:
            opt = mujoco.MjvOption()
            opt.geomgroup[:] = 1
        return opt

    def record(self, count: int) -> list[list[Any]]:
        """One episode of ``count`` wandering steps (``bench_track1``'s mix)."""
        import numpy as np
        from bench_track1 import MIX, _action  # sibling: one copy of the wander

        rng = np.random.default_rng(self.seed)
        obs, info = self.env.reset(seed=self.seed)
        actions, backoff = [], False
        for i in range(count):
            code = MIX[i % len(MIX)]
            action = _action(rng, code, obs, info, backoff)
            obs, _, terminated, truncated, info = self.env.step(action)
            actions.append(action)
            if code == "m":
                backoff = bool(info["collided"])
            if terminated or truncated:
                break
        return [actions]


class _Track2:
    """A Track 2 instance of a split and family."""

    def __init__(self, split: str, family: str, size: tuple[int, int], seed: int) -> None:
        from simhost.worlds.track2 import CAMERAS, BenchEnv

        self.cameras: tuple[str, ...] = tuple(CAMERAS)
        self.split, self.family, self.size, self.seed = split, family, size, seed
        w, h = size
        self.env = BenchEnv(family=family, instance_seed=seed, split=split, render_rgbd=True,
                            image_size=(h, w))

    def model_data(self, env: Any = None) -> tuple[Any, Any]:
        e = env or self.env
        return e.model, e.data

    def bare(self) -> Any:
        from simhost.worlds.track2 import BenchEnv

        return BenchEnv(family=self.family, instance_seed=self.seed, split=self.split,
                        render_rgbd=False)

    def renders_per_step(self) -> float:
        return 1.0 / self.env.config.observation.period_steps

    def channels(self) -> tuple[str, ...]:
        seg = self.env.config.observation.segmentation
        return ("rgb", "depth", "segmentation") if seg else ("rgb", "depth")

    def render_ours(self) -> None:
        render = getattr(self.env, "render_observation", None) or self.env._render_obs
        render()

    def ours_renderer(self) -> Any:
        return _gl_of(self.env)

    def scene_option(self) -> Any:
        import mujoco

        return _option_of(self.env) or mujoco.MjvOption()

    def record(self, count: int) -> list[list[Any]]:
        """The privileged expert's episode, repeated until ``count`` steps."""
        from simhost.worlds.track2 import ScriptedExpert

        self.env.reset(seed=self.seed)
        expert = ScriptedExpert(self.env)
        actions: list[Any] = []
        while True:
            try:
                a = expert()
            except StopIteration:
                break
            _, _, terminated, truncated, _ = self.env.step(a)
            actions.append(a)
            if terminated or truncated:
                break
        if not actions:
            raise RuntimeError(f"{self.family}: the expert gave no action")
        return [actions] * math.ceil(count / len(actions))


class _RawRenderer:
    """A plain ``mujoco.Renderer`` of the case's model: the same images as ours."""

    def __init__(self, case: Any) -> None:
        import mujoco

        m, d = case.model_data()
        w, h = case.size
        self.case, self.data = case, d
        self.r = mujoco.Renderer(m, h, w)
        ours = case.ours_renderer()
        if ours is not None:  # the same scene flags (shadows, reflections, ...) as ours
            self.r.scene.flags[:] = ours.scene.flags[:]
        else:
            flags = self.r.scene.flags
            flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0
            flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
        self.option = case.scene_option()
        self.channels = case.channels()

    def render(self) -> None:
        r = self.r
        for camera in self.case.cameras:
            r.update_scene(self.data, camera=camera, scene_option=self.option)
            r.render()
            if "depth" in self.channels:
                r.enable_depth_rendering()
                r.render()
                r.disable_depth_rendering()
            if "segmentation" in self.channels:
                r.enable_segmentation_rendering()
                r.render()
                r.disable_segmentation_rendering()

    def close(self) -> None:
        self.r.close()


def _replay(env: Any, seed: int, episodes: list[list[Any]], warm: int, n: int,
            keep: bool, model_data: Any) -> dict[str, Any]:
    """``env.step`` on the recorded actions from ``reset(seed)``; the first ``warm`` steps
    untimed. With ``keep``: the state before and controls after each timed step."""
    import mujoco
    import numpy as np

    sig = mujoco.mjtState.mjSTATE_INTEGRATION
    clock = time.perf_counter_ns
    out: dict[str, Any] = {"ns": [], "k": [], "states": [], "ctrls": []}
    done = 0
    for actions in episodes:
        env.reset(seed=seed)
        m, d = model_data(env)
        size = mujoco.mj_stateSize(m, sig)
        for a in actions:
            if done >= warm + n:
                return out
            t_sim = d.time
            if keep and done >= warm:
                st = np.empty(size)
                mujoco.mj_getState(m, d, st, sig)
            t0 = clock()
            _, _, terminated, truncated, _ = env.step(a)
            dt = clock() - t0
            if done >= warm:
                out["ns"].append(dt)
                out["k"].append(max(0, round((d.time - t_sim) / m.opt.timestep)))
                if keep:
                    out["states"].append(st)
                    out["ctrls"].append(d.ctrl.copy())
            done += 1
            if terminated or truncated:
                break
    return out


def child_main(spec: dict[str, Any]) -> dict[str, Any]:
    import mujoco

    base_kib = _status_kib("VmRSS")
    size = (int(spec["size"][0]), int(spec["size"][1]))
    n, warm, pairs = spec["n"], spec["warm"], spec["pairs"]
    case: Any = (_Track1(spec["split"], size, spec["seed"]) if spec["track"] == "track1"
                 else _Track2(spec["split"], spec["family"], size, spec["seed"]))
    clock = time.perf_counter_ns
    out: dict[str, Any] = {}
    try:
        episodes = case.record(warm + n)
        ours = _replay(case.env, case.seed, episodes, warm, n, True, case.model_data)
        out["hwm_kib"] = _status_kib("VmHWM")
        out["base_kib"] = base_kib
        out["step_ns"], out["k"] = ours["ns"], ours["k"]
        m, d = case.model_data()
        sig = mujoco.mjtState.mjSTATE_INTEGRATION
        # render: ours against raw at the recorded states, in alternating blocks (each
        # renderer has its own GL context: switching at every call would time the switch)
        raw = _RawRenderer(case)
        out["render_ns"], out["raw_render_ns"] = [], []
        try:
            raw.render()  # its context is current now: the GL renderer's name
            out["gl"] = _gl_renderer()
            stride = max(1, len(ours["states"]) // pairs)
            states = ours["states"][::stride][:pairs]
            for half in (states[0::2], states[1::2]):
                for fn, key in ((case.render_ours, "render_ns"), (raw.render, "raw_render_ns")):
                    fn()  # the context switch, untimed
                    for st in half:
                        mujoco.mj_setState(m, d, st, sig)
                        mujoco.mj_forward(m, d)
                        t0 = clock()
                        fn()
                        out[key].append(clock() - t0)
        finally:
            raw.close()
        # floor physics: the same substeps from the same states, with the final controls
        step = mujoco.mj_step
        out["phys_ns"] = []
        for st, ctrl, k in zip(ours["states"], ours["ctrls"], ours["k"], strict=True):
            mujoco.mj_setState(m, d, st, sig)
            d.ctrl[:] = ctrl
            t0 = clock()
            for _ in range(k):
                step(m, d)
            out["phys_ns"].append(clock() - t0)
        out["renders_per_step"] = case.renders_per_step()
        # a step without a render, on an env of the same split with rendering off
        bare = case.bare()
        try:
            got = _replay(bare, case.seed, episodes, warm, n, False, case.model_data)
            out["bare_ns"], out["bare_k"] = got["ns"], got["k"]
        finally:
            bare.close()
    finally:
        case.env.close()
    return out


# ============================================================================ orchestrator

class Runner:
    """Starts and always reaps the benchmark's child processes."""

    def __init__(self, timeout_s: float) -> None:
        self.timeout_s = timeout_s
        self.procs: list[subprocess.Popen[bytes]] = []

    def env(self, device: str) -> dict[str, str]:
        env = dict(
            os.environ,
            PYTHONPATH=os.pathsep.join([str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]),
            PYTHONUNBUFFERED="1",
            MUJOCO_GL="egl",
        )
        if device == "cpu" and _has_gpu() and MESA_VENDOR.is_file():
            env["__EGL_VENDOR_LIBRARY_FILENAMES"] = str(MESA_VENDOR)
            env["LIBGL_ALWAYS_SOFTWARE"] = "1"
        return env

    def kill_all(self) -> None:
        reap(self.procs)

    def run(self, spec: dict[str, Any], device: str) -> dict[str, Any]:
        argv = [sys.executable, str(Path(__file__).resolve()), "--child", json.dumps(spec)]
        return run_child(argv, self.procs, env=self.env(device), cwd=ROOT,
                         timeout_s=self.timeout_s)


def _has_gpu() -> bool:
    return Path("/dev/nvidia0").exists() or shutil.which("nvidia-smi") is not None


def official_size(track: str, split: str) -> tuple[int, int]:
    """(width, height) of the split's own observation config."""
    if track == "track1":
        from simhost.worlds.track1 import SPLITS as T1

        w, h = T1[split].config.image_size
        return int(w), int(h)
    from simhost.worlds.track2 import SPLITS as T2

    h, w = T2[split].bench.observation.image_size
    return int(w), int(h)


def _parse_size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--size wants WIDTHxHEIGHT, e.g. 256x192, not "
                                         f"{text!r}") from None
    if not (16 <= w <= 1280 and 16 <= h <= 960):
        raise argparse.ArgumentTypeError(f"--size {text}: 16x16 to 1280x960")
    return w, h


def plan(families: list[str], extra: tuple[int, int] | None,
         seeds: tuple[int, int],
         tracks: tuple[str, ...] = ("track1", "track2")) -> list[dict[str, Any]]:
    """Every case and size the benchmark runs, in table order."""
    cases: list[dict[str, Any]] = [
        {"track": "track1", "split": s, "family": None, "seed": seeds[0],
         "label": f"T1 {s}"} for s in SPLITS if "track1" in tracks]
    cases += [{"track": "track2", "split": s, "family": f, "seed": seeds[1],
               "label": f"T2 {s[:4]} {f}"} for s in SPLITS for f in families
              if "track2" in tracks]
    out = []
    for c in cases:
        sizes: list[tuple[tuple[int, int], str]] = [(TODAY[c["track"]], "today")]
        official = official_size(c["track"], c["split"])
        if official != TODAY[c["track"]]:
            sizes.append((official, "split"))
        else:
            sizes[0] = (official, "today=split")
        if extra is not None and extra not in (s for s, _ in sizes):
            sizes.append((extra, "--size"))
        out += [{**c, "size": list(s), "source": src} for s, src in sizes]
    return out


def _summary(parts: list[dict[str, Any]]) -> dict[str, Any]:
    """Median over rounds of each round's figure (step means, render medians)."""

    def mean_ms(ns: list[int]) -> float:
        return sum(ns) / len(ns) / 1e6

    def med_ms(ns: list[int]) -> float:
        return float(statistics.median(ns)) / 1e6

    per_round = []
    for p in parts:
        raw_render = med_ms(p["raw_render_ns"])
        phys = mean_ms(p["phys_ns"])
        r = {
            "render_ms": med_ms(p["render_ns"]),
            "raw_render_ms": raw_render,
            "step_ms": mean_ms(p["step_ns"]),
            "floor_ms": phys + p["renders_per_step"] * raw_render,
            "bare_ms": mean_ms(p["bare_ns"]),
            "phys_ms": phys,
            "substeps": sum(p["k"]) / len(p["k"]),
        }
        # ratios within a round (the same process, seconds apart): load cancels out
        r["render_x"] = r["render_ms"] / r["raw_render_ms"]
        r["step_x"] = r["step_ms"] / r["floor_ms"]
        r["bare_x"] = r["bare_ms"] / phys if phys > 0 else math.nan
        per_round.append(r)
    out: dict[str, Any] = {k: statistics.median(r[k] for r in per_round) for k in per_round[0]}
    out["peak_mib"] = max(p["hwm_kib"] for p in parts) / 1024
    out["import_mib"] = max(p["base_kib"] for p in parts) / 1024
    out["rounds"] = len(parts)
    out["step_round_ms"] = [r["step_ms"] for r in per_round]
    out["gl"] = parts[0].get("gl", "?")
    out["renders_per_step"] = parts[0]["renders_per_step"]
    return out


def _mark(value: float, goal: float) -> str:
    return " " if value <= goal else "!"


def table(rows: list[tuple[dict[str, Any], dict[str, Any] | str]]) -> list[str]:
    """One 80-column table: a row per case and size, ``!`` beside a missed goal."""
    head = (f"{'case':<20}{'size':>8} {'render':>7}{'raw':>6}{'x':>6} "
            f"{'step':>7}{'floor':>7}{'x':>6} {'bare x':>7} {'MiB':>5}")
    units = (f"{'':<20}{'':>8} {'ms':>7}{'ms':>6}{'':>6} {'ms':>7}{'ms':>7}{'':>6} {'':>7} "
             f"{'peak':>5}")
    lines = [head, units, "-" * 80]
    for spec, r in rows:
        size = f"{spec['size'][0]}x{spec['size'][1]}"
        if isinstance(r, str):
            lines.append(f"{spec['label']:<20}{size:>8} FAILED: {r.splitlines()[0][:40]}")
            continue
        official = spec["source"] != "today"
        lines.append(
            f"{spec['label']:<20}{size:>8} {r['render_ms']:>7.2f}{r['raw_render_ms']:>6.2f}"
            f" {r['render_x']:>4.2f}{_mark(r['render_x'], GOALS['render'])}"
            f"{r['step_ms']:>7.2f}"
            f"{' ' if not official else _mark(r['step_ms'], GOALS['ms'])}"
            f"{r['floor_ms']:>6.2f} {r['step_x']:>4.2f}{_mark(r['step_x'], GOALS['step'])}"
            f"{r['bare_x']:>7.2f} {r['peak_mib']:>5.0f}{_mark(r['peak_mib'], GOALS['mib'])}"
        )
    return [line.rstrip() for line in lines]


LEGEND = """\
render: our observation render (RGB, depth, segmentation as the split has them), median
  per call; raw: a plain mujoco.Renderer of the same model, same size and images; x: ratio
step: mean ms of env.step on the split's official config (physics, observation, RGB-D);
  floor: the same raw mj_step substeps plus the raw render per rendered step; x: ratio
bare x: a step with rendering off against the raw mj_step substeps alone
MiB peak: VmHWM of the process holding one env (interpreter and imports included)
! a goal missed: render and step <= {render}x, < {ms:.0f} ms per step at the split's size
  (marked on the step), peak < {mib:.0f} MiB. Figures and ratios: medians over the rounds."""


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--child", default="", help=argparse.SUPPRESS)
    ap.add_argument("--quick", action="store_true", help="fewer steps, one round")
    ap.add_argument("--rounds", type=int, default=None, help="interleaved rounds (default 3)")
    ap.add_argument("--size", type=_parse_size, default=None,
                    help="one more size, WIDTHxHEIGHT (e.g. 256x192)")
    ap.add_argument("--tracks", default="track1,track2",
                    help="the tracks whose cases run (comma-separated)")
    ap.add_argument("--families", default="insertion,opening",
                    help="Track 2 families (comma-separated)")
    ap.add_argument("--track1-seed", type=int, default=20_001)
    ap.add_argument("--track2-seed", type=int, default=60_001)
    gpu = ap.add_mutually_exclusive_group()
    gpu.add_argument("--gpu", dest="gpu", action="store_true", default=None,
                     help="also run every round on the GPU through EGL")
    gpu.add_argument("--no-gpu", dest="gpu", action="store_false", help="CPU (Mesa) only")
    ap.add_argument("--json", type=Path, default=None, help="write the figures here")
    args = ap.parse_args()
    if args.child:
        die_with_parent()
        sys.path.insert(0, str(ROOT))
        print(json.dumps(child_main(json.loads(args.child))), flush=True)
        return 0

    sys.path.insert(0, str(ROOT))
    from simhost.worlds.track2 import FAMILIES

    families = [f for f in args.families.split(",") if f]
    unknown = [f for f in families if f not in FAMILIES]
    if unknown:
        ap.error(f"unknown Track 2 famil{'y' if len(unknown) == 1 else 'ies'} {unknown}; "
                 f"one of {', '.join(FAMILIES)}")
    devices = ["cpu"]
    if args.gpu is True and not _has_gpu():
        print("--gpu: no GPU found (/dev/nvidia0, nvidia-smi): CPU rows only", file=sys.stderr)
    elif args.gpu is not False and _has_gpu():
        devices.append("gpu")
    rounds = max(1, args.rounds or (1 if args.quick else 3))
    which = 1 if args.quick else 0
    tracks = tuple(t for t in args.tracks.split(",") if t)
    if not tracks or set(tracks) - {"track1", "track2"}:
        ap.error(f"--tracks wants track1, track2 or both, not {args.tracks!r}")
    specs = plan(families, args.size, (args.track1_seed, args.track2_seed), tracks)

    def on_term(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, on_term)
    print(machine_line("mujoco", "numpy", extra="MUJOCO_GL=egl"))
    print(f"{len(specs)} cases x sizes, {rounds} interleaved round(s), one fresh process "
          f"each; devices {', '.join(devices)}; load average {load_average()}", flush=True)
    t_start = time.monotonic()
    parts: dict[tuple[str, int], list[dict[str, Any]]] = {}
    failed: dict[tuple[str, int], str] = {}
    runner = Runner(timeout_s=60.0 if args.quick else 150.0)
    try:
        for rnd in range(rounds):
            for device in devices:
                for i, spec in enumerate(specs):
                    if (device, i) in failed:
                        continue
                    n, warm, pairs = COUNTS[spec["track"]][which]
                    t0 = time.monotonic()
                    try:
                        out = runner.run({**spec, "n": n, "warm": warm, "pairs": pairs}, device)
                    except RuntimeError as e:
                        failed[(device, i)] = str(e)
                        print(f"  {spec['label']} {spec['size']}: FAILED\n{e}", file=sys.stderr)
                        continue
                    parts.setdefault((device, i), []).append(out)
                    print(f"  round {rnd + 1}/{rounds} {device} {spec['label']:<20} "
                          f"{spec['size'][0]}x{spec['size'][1]}: step "
                          f"{sum(out['step_ns']) / len(out['step_ns']) / 1e6:.2f} ms mean "
                          f"({time.monotonic() - t0:.1f} s)", file=sys.stderr, flush=True)
    finally:
        runner.kill_all()
    report: dict[str, Any] = {}
    for device in devices:
        rows: list[tuple[dict[str, Any], dict[str, Any] | str]] = []
        for i, spec in enumerate(specs):
            got: dict[str, Any] | str = failed.get((device, i)) or _summary(parts[(device, i)])
            rows.append((spec, got))
            key = f"{device}/{spec['label']}/{spec['size'][0]}x{spec['size'][1]}"
            report[key] = got if isinstance(got, str) else {**got, "source": spec["source"]}
        gl = next((r["gl"] for _, r in rows if isinstance(r, dict)), "?")
        print(f"\n{device.upper()}: GL renderer {gl}")
        print("\n".join(table(rows)))
    print("\n" + LEGEND.format(**GOALS))
    print(f"\nload average {load_average()}; total {time.monotonic() - t_start:.0f} s")
    if args.json:
        args.json.write_text(json.dumps(report, indent=1))
    return 0 if not failed else 1


if __name__ == "__main__":
    sys.exit(main())
