"""Benchmarks of the distributed system (``wildfire bench`` calls :func:`bench_system`).

For each ROS runtime backend (real rclpy on Fast DDS, and our Cyclone DDS layer), in the same
``wildfire bench`` run:

* lockstep speed-up over real time with 3 aircraft (receding horizon), from the first tick to
  the last; target >= 8x on rclpy, and rclpy's flight wall time <= 1.3x the Cyclone layer's;
* CPU time of all node processes per tick of that lockstep flight, a figure that a busy
  machine does not distort, and the tick's wall time split between the barrier (the fire
  simulator's own part), the nodes, the slowest agent, the aggregator and the run monitor;
* real time with 8 aircraft at 10 Hz: fraction of decisions that missed their 100 ms slot
  (from every agent's deadline statistics), target < 1 % on a quiet machine;
* real time under camera sensing (2 aircraft, the belief network, four cameras' reports and
  the filtered belief): missed slots and mean decision compute;
* lockstep under camera sensing (2 aircraft, the camera belief network), with ideal links and
  under ``range=300,loss=0.2``: speed-up (target >= 8x), CPU per tick and the tick split;
* field scale: lockstep speed-up with 16 aircraft on a 500 x 500 map with two fires (target
  >= 2x), and the bytes per simulated second of a recorded run of 2 aircraft at 1000 x 1000
  against the same run on the paper's map (target <= 3x: a bag grows with the aircraft and
  the burning front, not with the map).

The runtime backend is chosen once per process, so each backend is measured in a child
process (``python -m wildfire_bench.system --backend B``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np

from wildfire_sim.tick_split import tick_split_ms

BACKENDS = ("rclpy", "dds")


def _spec(
    n: int,
    duration: float,
    lockstep: bool,
    seed: int = 1_000_000,
    policy: str = "rh",
    sensor: str = "disc",
    field: tuple[int, int, int] | None = None,
    record_dir: Path | None = None,
    comm: str = "ideal",
) -> Any:
    """The run of ``n`` aircraft; ``field``: (rows, cols, ignitions) of a field map."""
    from wildfire_bringup.launcher import RunSpec
    from wildfire_sim.grid import MapGeometry
    from wildfire_sim.landscape import Landscape
    from wildfire_world.env import EnvConfig, draw_scenario

    ground = (
        Landscape() if field is None else Landscape(MapGeometry(*field[:2]), ignitions=field[2])
    )
    config = EnvConfig(
        n_aircraft=n,
        max_duration_s=duration,
        geometry=ground.geometry,
        landscape=None if field is None else ground,
    )
    scenario = draw_scenario(seed, config)
    start = np.stack([scenario.start.x_m, scenario.start.y_m, scenario.start.heading_rad], axis=1)
    return RunSpec(
        n_aircraft=n,
        policy=policy,
        shape="circular",
        wind=(float(scenario.wind[0]), float(scenario.wind[1])),
        seed=seed,
        duration_s=duration,
        start=start,
        lockstep=lockstep,
        sensor=sensor,
        pixel_error=0.1 if sensor == "camera" else 0.0,
        ground=ground,
        record_dir=record_dir,
        comm=comm,
    )


def measure_field(quick: bool) -> dict[str, Any]:
    """Field-scale figures of this process's backend (see the module docstring)."""
    import tempfile

    from wildfire_bringup.launcher import Launcher

    duration = 20.0 if quick else 60.0
    launcher = Launcher(_spec(16, duration, lockstep=True, field=(500, 500, 2)))
    monitor = launcher.run()
    ticks = monitor.status.tick if monitor.status else 0
    result: dict[str, Any] = {
        "field_lockstep_aircraft": 16,
        "field_lockstep_map": "500,500",
        "field_lockstep_speedup": ticks / 10.0 / launcher.flight_wall_s
        if launcher.flight_wall_s
        else 0.0,
        "field_lockstep_nodes_cpu_ms_per_tick": (
            1e3 * launcher.flight_cpu_s / ticks if ticks else float("nan")
        ),
        "field_lockstep_tick_split_ms": tick_split_ms(monitor.tick_split),
    }
    sizes = {}
    with tempfile.TemporaryDirectory() as work:
        for name, field in (("paper", None), ("field", (1000, 1000, 1))):
            bag = Path(work) / name
            run = Launcher(_spec(2, duration / 2, True, policy="rh", field=field, record_dir=bag))
            status = run.run().status
            flown = max(status.tick if status is not None else 0, 1) / 10.0
            sizes[name] = sum(f.stat().st_size for f in bag.iterdir()) / flown
    result |= {
        "paper_bag_bytes_per_sim_s": sizes["paper"],
        "field_bag_bytes_per_sim_s": sizes["field"],
        "field_bag_map": "1000,1000",
        "field_over_paper_bag": sizes["field"] / sizes["paper"],
    }
    return result


def measure_system(quick: bool = False, smoke: bool = False) -> dict[str, Any]:
    """Lockstep speed-up (3 aircraft) and real-time missed deadlines (8 aircraft), this process's
    backend (``smoke``: 2 s of each, to check that they run)."""
    from wildfire_bringup.launcher import Launcher
    from wildfire_ros.runtime import BACKEND, rmw_implementation

    duration = 2.0 if smoke else 20.0 if quick else 60.0
    launcher = Launcher(_spec(3, duration, lockstep=True))
    monitor = launcher.run()
    ticks = monitor.status.tick if monitor.status else 0
    flown = ticks / 10.0
    result: dict[str, Any] = {
        "backend": BACKEND,
        "rmw": rmw_implementation(),
        "lockstep_aircraft": 3,
        "lockstep_sim_s": flown,
        "lockstep_score": round(monitor.score),
        "lockstep_wall_s": launcher.wall_s,
        "lockstep_flight_wall_s": launcher.flight_wall_s,
        # Speed of the running system (first tick to last); start-up is reported apart.
        "lockstep_speedup": flown / launcher.flight_wall_s if launcher.flight_wall_s else 0.0,
        "lockstep_startup_s": launcher.wall_s - launcher.flight_wall_s,
        # CPU time of every node process over the flight, per tick: unlike wall time it does
        # not depend on what else the machine is doing.
        "lockstep_nodes_cpu_ms_per_tick": (
            1e3 * launcher.flight_cpu_s / ticks if ticks else float("nan")
        ),
        # Mean wall ms per tick: the barrier's own part (fire), the nodes' (announcement to
        # the last acknowledgement), and who it waits for (wildfire_sim.tick_split).
        "lockstep_tick_split_ms": tick_split_ms(monitor.tick_split),
    }
    # (A smoke run starts 3 aircraft: 8 would take 10 s of node start-up to fly 2 s.)
    realtime_aircraft = 3 if smoke else 8
    realtime = Launcher(
        _spec(realtime_aircraft, 2.0 if smoke else 10.0 if quick else 30.0, lockstep=False)
    )
    monitor = realtime.run()
    decided = sum(v.get("decisions", 0) for v in monitor.deadlines.values())
    missed = sum(v.get("missed", 0) for v in monitor.deadlines.values())
    result |= {
        "realtime_aircraft": realtime_aircraft,
        "realtime_decisions": decided,
        "realtime_missed": missed,
        "realtime_missed_fraction": missed / decided if decided else float("nan"),
        "realtime_compute_ms_max": max(
            (v.get("compute_ms_max", 0.0) for v in monitor.deadlines.values()), default=0.0
        ),
    }
    if not smoke:  # the camera world in real time: 2 aircraft, the shipped belief network
        from wildfire_agent.policy_names import resolve_policy_path

        belief = str(resolve_policy_path("belief").resolve())
        camera = Launcher(_spec(2, 10.0 if quick else 30.0, False, policy=belief, sensor="camera"))
        deadlines = camera.run().deadlines.values()
        decided = sum(v.get("decisions", 0) for v in deadlines)
        result |= {
            "realtime_camera_decisions": decided,
            "realtime_camera_missed_fraction": (
                sum(v.get("missed", 0) for v in deadlines) / decided if decided else float("nan")
            ),
            "realtime_camera_compute_ms_mean": float(
                np.mean([v.get("compute_ms_mean", np.nan) for v in deadlines])
            ),
        }
        result |= measure_camera_lockstep(quick)
        result |= measure_field(quick)
    return result


def measure_camera_lockstep(quick: bool) -> dict[str, Any]:
    """Lockstep speed-up of the camera world (2 aircraft, the camera belief network), with
    ideal links and under ``range=300,loss=0.2`` (each aircraft's own filtered replica)."""
    from wildfire_agent.policy_names import resolve_policy_path
    from wildfire_bringup.launcher import Launcher

    network = str(resolve_policy_path("belief-camera").resolve())
    result: dict[str, Any] = {}
    for key, comm in (("camera", "ideal"), ("camera_radio", "range=300,loss=0.2")):
        spec = _spec(2, 20.0 if quick else 60.0, True, policy=network, sensor="camera", comm=comm)
        launcher = Launcher(spec)
        monitor = launcher.run()
        ticks = monitor.status.tick if monitor.status else 0
        wall = launcher.flight_wall_s
        result |= {
            f"{key}_lockstep_speedup": ticks / 10.0 / wall if wall else 0.0,
            f"{key}_lockstep_nodes_cpu_ms_per_tick": (
                1e3 * launcher.flight_cpu_s / ticks if ticks else float("nan")
            ),
            f"{key}_lockstep_tick_split_ms": tick_split_ms(monitor.tick_split),
        }
    return result


def _backend_available(backend: str) -> bool:
    if backend == "dds":
        return True
    try:
        import rclpy  # noqa: F401
    except ImportError:
        return False
    return True


def bench_system(quick: bool = False, smoke: bool = False) -> dict[str, Any]:
    """Both backends, one after the other, each in its own process; flat figures by backend."""
    from wildfire_ros.runtime import BACKEND

    result: dict[str, Any] = {}
    # A smoke run checks the runtime in use only (the tests run it once on each).
    for backend in (BACKEND,) if smoke else BACKENDS:
        if not _backend_available(backend):
            result[f"{backend}_skipped"] = "rclpy does not import (no ROS 2 Jazzy wheels here)"
            continue
        command = [sys.executable, "-m", "wildfire_bench.system", "--backend", backend]
        env = {**os.environ, "WILDFIRE_ROS_BACKEND": backend}
        done = subprocess.run(
            [*command, *(["--quick"] if quick else []), *(["--smoke"] if smoke else [])],
            env=env,
            capture_output=True,
            text=True,
            check=False,
        )
        if done.returncode != 0:
            tail = (done.stderr.strip().splitlines() or ["no output"])[-1]
            result[f"{backend}_failed"] = tail
            continue
        figures = json.loads(done.stdout)
        result[f"{backend}_rmw"] = figures.pop("rmw")
        figures.pop("backend")
        result |= {f"{backend}_{key}": value for key, value in figures.items()}
    if "rclpy_lockstep_flight_wall_s" in result and "dds_lockstep_flight_wall_s" in result:
        # Same seed and flight on both: the wall-time ratio compares the runtimes alone.
        result["rclpy_over_dds_lockstep_wall"] = (
            result["rclpy_lockstep_flight_wall_s"] / result["dds_lockstep_flight_wall_s"]
        )
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description="Distributed-system figures of one backend.")
    parser.add_argument("--backend", choices=BACKENDS, required=True)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--smoke", action="store_true")
    args = parser.parse_args()
    if os.environ.get("WILDFIRE_ROS_BACKEND") != args.backend:
        os.environ["WILDFIRE_ROS_BACKEND"] = args.backend
    print(json.dumps(measure_system(args.quick, args.smoke)))


if __name__ == "__main__":
    main()
