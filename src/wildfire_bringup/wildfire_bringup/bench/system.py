"""Benchmarks of the distributed system (``wildfire bench`` calls :func:`bench_system`).

* lockstep speed-up over real time with 3 aircraft (receding horizon), target >= 5x;
* real time with 8 aircraft at 10 Hz: fraction of decisions that missed their 100 ms slot
  (from every agent's ``/uavK/deadline`` statistics), target < 1 %.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from wildfire_bringup.launcher import Launcher, RunSpec
from wildfire_learning.env import EnvConfig, draw_scenario


def _spec(n: int, duration: float, lockstep: bool, seed: int = 1_000_000) -> RunSpec:
    scenario = draw_scenario(seed, EnvConfig(n_aircraft=n, max_duration_s=duration))
    start = np.stack([scenario.start.x_m, scenario.start.y_m, scenario.start.heading_rad], axis=1)
    return RunSpec(
        n_aircraft=n,
        policy="rh",
        shape="circular",
        wind=(float(scenario.wind[0]), float(scenario.wind[1])),
        seed=seed,
        duration_s=duration,
        start=start,
        lockstep=lockstep,
    )


def bench_system(quick: bool = False) -> dict[str, Any]:
    """Measure lockstep speed-up (3 aircraft) and real-time missed deadlines (8 aircraft)."""
    duration = 20.0 if quick else 60.0
    launcher = Launcher(_spec(3, duration, lockstep=True))
    monitor = launcher.run()
    flown = monitor.status.tick / 10.0 if monitor.status else 0.0
    result: dict[str, Any] = {
        "lockstep_aircraft": 3,
        "lockstep_sim_s": flown,
        "lockstep_wall_s": launcher.wall_s,
        "lockstep_flight_wall_s": launcher.flight_wall_s,
        # Speed of the running system (first tick to last); start-up is reported apart.
        "lockstep_speedup": flown / launcher.flight_wall_s if launcher.flight_wall_s else 0.0,
        "lockstep_startup_s": launcher.wall_s - launcher.flight_wall_s,
    }
    realtime = Launcher(_spec(8, 10.0 if quick else 30.0, lockstep=False))
    monitor = realtime.run()
    decided = sum(v.get("decisions", 0) for v in monitor.deadlines.values())
    missed = sum(v.get("missed", 0) for v in monitor.deadlines.values())
    result |= {
        "realtime_aircraft": 8,
        "realtime_decisions": decided,
        "realtime_missed": missed,
        "realtime_missed_fraction": missed / decided if decided else float("nan"),
        "realtime_compute_ms_max": max(
            (v.get("compute_ms_max", 0.0) for v in monitor.deadlines.values()), default=0.0
        ),
    }
    return result


if __name__ == "__main__":
    import json

    print(json.dumps(bench_system(), indent=2))
