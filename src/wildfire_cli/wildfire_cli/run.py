"""``wildfire run``: launch the distributed system, one OS process per node.

Starts the fire simulator, the belief aggregator and one agent per aircraft (plus, with
``--record``, a rosbag2 recorder in the launcher), shows progress, stops everything at the
end of the episode or on Ctrl-C (the recording is always finalized) and prints a summary.
``--fast`` (the default) runs in lockstep on sim time and flies exactly what
``wildfire eval --episodes 1`` flies for the same seed; ``--realtime`` runs on wall clocks.
``--hosts K`` spreads the nodes over K virtual hosts (network namespaces joined by a private
bridge, see :mod:`wildfire_testbed.hosts`), which the run creates and removes; ``--netem`` and
``--partition`` inject network faults there (:mod:`wildfire_testbed.netfaults`).
``--agents-per-process K`` composes the agents K to a process (:mod:`wildfire_bringup.run_spec`).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np

from wildfire_cli.common import (
    UserError,
    add_episode_arguments,
    positive_int,
    print_json,
    scenario_settings,
)
from wildfire_cli.progress import progress_bar


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "run",
        help="launch the distributed system (one process per node)",
        description="Launch the fire simulator, the belief aggregator and one agent node per "
        "aircraft as separate processes, optionally recording every topic to a rosbag2 "
        "(MCAP) directory, and summarise the episode.",
    )
    add_episode_arguments(parser, default_seed=0, seed_help="episode seed")
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument(
        "--fast",
        dest="realtime",
        action="store_false",
        help="lockstep on sim time, as fast as the slowest node (default)",
    )
    mode.add_argument(
        "--realtime",
        dest="realtime",
        action="store_true",
        help="every node on wall-clock timers (10 Hz agents, 2.5 s fire steps)",
    )
    parser.set_defaults(realtime=False)
    parser.add_argument(
        "--record",
        type=Path,
        metavar="DIR",
        help="record every topic to this new rosbag2 directory",
    )
    parser.add_argument(
        "--respawn",
        action="store_true",
        help="real time: restart an agent or the aggregator that dies",
    )
    parser.add_argument(
        "--params-file", type=Path, metavar="YAML", help="ros__parameters file passed to every node"
    )
    parser.add_argument(
        "--agent-backend",
        choices=("rclpy", "dds"),
        help="run the agent nodes on this ROS runtime and the rest on the default one "
        "(a mixed system: real rclpy and our Cyclone DDS layer on one wire)",
    )
    parser.add_argument(
        "--agents-per-process",
        type=positive_int,
        metavar="K",
        help="composed agents: at most K agent nodes per process, one executor each, spread "
        "evenly over ceil(N/K) processes (default K = ceil(N/8): one agent per process up to 8 "
        "aircraft, at most 8 agent processes above; with --hosts, per host)",
    )
    parser.add_argument(
        "--hosts",
        type=positive_int,
        metavar="K",
        help="run on K virtual hosts (Linux network namespaces on a private bridge; root): "
        "fire simulator, aggregator and agents on different hosts",
    )
    parser.add_argument(
        "--netem",
        metavar="SPEC",
        help="with --hosts: impair every host's link, tc-netem style, e.g. "
        "'delay 20ms 10ms loss 2%%' (uniform delay 10 to 30 ms, 2 %% of frames lost)",
    )
    parser.add_argument(
        "--partition",
        action="append",
        default=[],
        metavar="HOST:START_S:DURATION_S",
        help="with --hosts: cut host HOST off the bridge START_S seconds after the first tick "
        "and heal it DURATION_S later (repeatable)",
    )
    parser.add_argument(
        "--foxglove",
        nargs="?",
        const=8765,
        type=int,
        metavar="PORT",
        help="watch it live: serve fire, belief, aircraft, paths, camera footprints and score "
        "to Foxglove on ws://127.0.0.1:PORT (default 8765; layout docs/foxglove/wildfire.json)",
    )
    parser.add_argument("--json", action="store_true", help="print a JSON summary")
    parser.add_argument("--png", type=Path, metavar="FILE", help="draw fire, belief and paths")
    parser.add_argument("--log-dir", type=Path, metavar="DIR", help="node logs (default: temp)")
    parser.set_defaults(handler=run)


def resolve_policy(policy: str, config: Any) -> str:
    """``rh``/``rh-paper``/``random`` as is; ``obs``/``belief``/``.pt`` and ``MODULE:ATTR``
    checked (against the world of the run's ``EnvConfig``) and a file made absolute."""
    from dataclasses import replace

    from wildfire_agent.policies import TorchScriptPolicy
    from wildfire_agent.policy_names import (
        BUILTIN_POLICIES,
        EVAL_ONLY_POLICIES,
        EXPECTED_POLICIES,
        SHIPPED_POLICIES,
        is_policy_file,
        is_user_policy,
        resolve_policy_path,
    )
    from wildfire_agent.user_policy import load_user_policy

    if policy in BUILTIN_POLICIES:
        return policy
    if policy in EVAL_ONLY_POLICIES:
        raise UserError(
            f"--policy {policy!r}: expected {EXPECTED_POLICIES} ({policy} reads the fire's "
            "future: `wildfire eval` and `wildfire report` only)"
        )
    if is_user_policy(policy) and not is_policy_file(policy):
        # Checked here, in one line, rather than in every agent; a file is made absolute
        # for the agents' processes, a module is imported from this working directory.
        vec_policy = load_user_policy(policy)
        replace(config, observation=vec_policy.observation).validate()
        module, _, attr = policy.rpartition(":")
        return f"{Path(module).resolve()}:{attr}" if module.endswith(".py") else policy
    if policy not in SHIPPED_POLICIES and not is_policy_file(policy):
        raise UserError(f"--policy {policy!r}: expected {EXPECTED_POLICIES}")
    path = resolve_policy_path(policy).resolve()
    network = TorchScriptPolicy(path)  # a missing or incompatible file fails here, in one line
    replace(config, observation=network.approach).validate()
    network.check_sensor(config.sensor)
    return str(path)


def check_record_dir(path: Path) -> Path:
    if path.exists():
        raise UserError(f"--record {path}: already exists (give a new directory)")
    parent = path.resolve().parent
    with contextlib.suppress(OSError):
        parent.mkdir(parents=True, exist_ok=True)  # as `mkdir -p`: runs/demo needs no runs/
    if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK):
        raise UserError(f"--record {path}: cannot create it ({parent} is not a writable directory)")
    return path


def check_foxglove_port(port: int | None, hosts: int) -> int | None:
    """``--foxglove``: a free port on 127.0.0.1, not on virtual hosts; None when not given."""
    if port is None:
        return None
    import socket

    if not 1 <= port <= 65535:
        raise UserError(f"--foxglove {port}: expected a port in 1..65535")
    if hosts:
        # Inside a virtual host 127.0.0.1 is the namespace's own loopback: no viewer reaches it.
        raise UserError("--foxglove: not with --hosts (the view serves this machine's loopback)")
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        # As a server binds: a port held only by closed connections (TIME_WAIT) is free.
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind(("127.0.0.1", port))
        except OSError as error:
            raise UserError(
                f"--foxglove {port}: cannot listen on 127.0.0.1:{port} ({error.strerror}); "
                "give another port"
            ) from None
    return port


def check_hosts(count: int | None, n_aircraft: int) -> int:
    """``--hosts``: 0 when not given; else within 1..aircraft+2 and namespaces available."""
    if count is None:
        return 0
    from wildfire_testbed.hosts import max_hosts, namespaces_unavailable

    if count > max_hosts(n_aircraft):
        raise UserError(
            f"--hosts {count}: at most {max_hosts(n_aircraft)} with {n_aircraft} aircraft "
            "(fire simulator, aggregator, one host per agent)"
        )
    reason = namespaces_unavailable()
    if reason is not None:
        raise UserError(f"--hosts {count}: {reason}")
    return count


def check_faults(args: argparse.Namespace, hosts: int) -> tuple[Any, tuple[Any, ...]]:
    """``--netem`` and ``--partition``: parsed, and only with ``--hosts``."""
    from wildfire_testbed.netfaults import FaultSpecError, NetemSpec, Partition, check_partitions

    netem = None
    if args.netem is not None:
        if not hosts:
            raise UserError("--netem: only with --hosts (it impairs the virtual hosts' links)")
        try:
            netem = NetemSpec.parse(args.netem)
        except FaultSpecError as error:
            raise UserError(f"--netem {args.netem!r}: {error}") from None
    partitions = []
    for text in args.partition:
        if not hosts:
            raise UserError("--partition: only with --hosts (it cuts a virtual host off)")
        try:
            partitions.append(Partition.parse(text, hosts))
        except FaultSpecError as error:
            raise UserError(f"--partition {error}") from None
    try:
        check_partitions(partitions)
    except FaultSpecError as error:
        raise UserError(f"--partition: {error}") from None
    return netem, tuple(partitions)


def build_spec(args: argparse.Namespace) -> Any:
    from wildfire_bringup.launcher import RunSpec, with_ground_file
    from wildfire_cli.run_params import check_params_file
    from wildfire_sim.shapes import Shape
    from wildfire_world.config import EnvConfig, draw_scenario

    hosts = check_hosts(args.hosts, args.aircraft)
    netem, partitions = check_faults(args, hosts)
    shape = Shape.parse(args.shape)
    if args.respawn and not args.realtime:
        raise UserError("--respawn: only with --realtime (lockstep runs are exact replays)")
    # The scenario only (no environment flies here): observe nothing.
    config = EnvConfig(
        shapes=(shape.value,), observation="none", **scenario_settings(args)
    ).validate()
    policy = resolve_policy(args.policy, config)
    ground = config.ground
    scenario = draw_scenario(args.seed, config)
    start = np.stack([scenario.start.x_m, scenario.start.y_m, scenario.start.heading_rad], axis=1)
    # Rasters go to the nodes in a ground file, written now: a parameters file is checked
    # against every node's command line, the file's path included.
    return with_ground_file(
        RunSpec(
            n_aircraft=args.aircraft,
            policy=policy,
            shape=shape.value,
            wind=(float(scenario.wind[0]), float(scenario.wind[1])),
            seed=args.seed,
            duration_s=args.duration,
            start=start,
            lockstep=not args.realtime,
            record_dir=check_record_dir(args.record) if args.record else None,
            respawn=args.respawn,
            log_dir=args.log_dir,
            params_file=check_params_file(args.params_file) if args.params_file else None,
            agent_backend=args.agent_backend,
            hosts=hosts,
            netem=netem,
            partitions=partitions,
            comm=str(config.comm),
            sensor=config.sensor,
            pixel_error=config.pixel_error,
            wind_filter=config.wind_filter,
            foxglove_port=check_foxglove_port(args.foxglove, hosts),
            agents_per_process=args.agents_per_process,
            ground=ground,
            preburn_area_m2=config.preburn_area_m2,
        )
    )


def summarise(spec: Any, monitor: Any, wall_s: float, flight_wall_s: float) -> dict[str, Any]:
    """Summary metrics of a finished run (score, ceiling and trajectory-derived metrics)."""
    from wildfire_belief.belief import belief_iou, mean_age_at_burning, score_ceiling
    from wildfire_sim.ignition import ignite
    from wildfire_sim.tick_split import tick_split_ms

    trajectory = monitor.trajectory()
    status = monitor.status
    decisions = status.tick if status is not None else 0
    flown = (
        np.hypot(*np.diff(trajectory[:, :, :2], axis=0).transpose(2, 0, 1)).sum(axis=0)
        if len(trajectory) > 1
        else np.zeros(spec.n_aircraft)
    )
    from wildfire_ros.runtime import BACKEND, rmw_implementation

    result: dict[str, Any] = {
        "backend": BACKEND,
        "rmw": rmw_implementation(),
        "policy": spec.policy,
        "aircraft": spec.n_aircraft,
        "shape": spec.shape,
        "seed": spec.seed,
        "wind": list(spec.wind),
        "mode": spec.mode,
        **spec.ground.summary(),
        "score": round(monitor.score),
        "decisions": decisions,
        "flight_time_s": decisions / 10.0,
        "end": status.phase if status is not None else "unknown",
        "wall_time_s": wall_s,
        "flight_wall_time_s": flight_wall_s,
        # Simulated over wall time from the first tick to the last (start-up excluded).
        "speedup": (decisions / 10.0) / flight_wall_s if flight_wall_s > 0 else 0.0,
        "distance_flown_m": flown.tolist(),
        "trajectory_points": len(trajectory),
        # Received messages each node refused (malformed, out of range, replayed, ...).
        "dropped_inputs": monitor.dropped_inputs(),
    }
    belief, ages = monitor.final_belief()
    if monitor.union is not None:
        # Lockstep: the score is the union's; the ground station's beside it (short of it when
        # the aggregator died mid-flight under limited links).
        result["aggregator_score"] = round(monitor.ground_score)
    # What flew, whatever it was.
    result |= {"sensor": spec.sensor, "pixel_error": spec.pixel_error, "comm": spec.comm}
    result["wind_filter"] = spec.wind_filter
    if (filtered := monitor.filtered) is not None:
        result["false_alarms"] = filtered.false_alarms
        result["flipped_fraction"] = filtered.flipped_fraction()
    if spec.limited_links:
        flight_s = max(decisions, 1) / 10.0
        result["radio_bytes_per_s_per_aircraft"] = float(monitor.radio_bytes.mean() / flight_s)
        result["radio_bytes_per_message"] = float(
            monitor.radio_bytes.sum() / max(int(monitor.radio_messages.sum()), 1)
        )
        if monitor.radio_links:
            result["radio_links"] = {f"uav{k}": v for k, v in sorted(monitor.radio_links.items())}
            catch_up = sum(v.get("catch_up_bytes_sent", 0.0) for v in monitor.radio_links.values())
            # Of those bytes, the catch-up sections (rare bursts after a link returns).
            result["radio_catch_up_bytes_per_s_per_aircraft"] = (
                catch_up / flight_s / spec.n_aircraft
            )
    if monitor.fire is not None and belief is not None:
        result["belief_iou"] = float(belief_iou(belief[None], monitor.fire[None])[0])
        if ages is not None:
            age = mean_age_at_burning(ages[None], monitor.fire[None])[0]
            result["mean_age_burning_s"] = None if np.isnan(age) else float(age)
    if monitor.fire is not None and len(trajectory):
        rows, cols = np.nonzero(monitor.fire)
        if rows.size:
            centres = np.stack([(cols + 0.5) * 10.0, (rows + 0.5) * 10.0], axis=1)
            last = trajectory[-1, :, :2]
            result["final_distance_to_fire_m"] = (
                np.hypot(*(last[:, None, :] - centres[None]).transpose(2, 0, 1))
                .min(axis=1)
                .tolist()
            )
    if monitor.tick_split:
        # Lockstep: mean wall ms per tick, by part (wildfire_sim.tick_split).
        result["tick_split_ms"] = tick_split_ms(monitor.tick_split)
    if monitor.deadlines:
        result["deadlines"] = {f"uav{k}": v for k, v in sorted(monitor.deadlines.items())}
        decided = sum(v.get("decisions", 0) for v in monitor.deadlines.values())
        missed = sum(v.get("missed", 0) for v in monitor.deadlines.values())
        result["missed_deadline_fraction"] = missed / decided if decided else 0.0
    ignition = ignite(spec.seed, spec.shape, spec.ground)
    if monitor.burned is not None:
        # The belief starts as the ignition seed (docs/model.md, Shared belief), as in the
        # aggregator.
        # Under noise a cell believed burning at the start can lose that belief and score
        # later (once): every cell that burns in flight counts, as in `wildfire eval`.
        start = np.zeros_like(ignition.burning) if spec.noisy else ignition.burning
        ceiling = score_ceiling(monitor.burned[None], start)[0]
        result["score_ceiling"] = int(ceiling)
        result["ceiling_fraction"] = result["score"] / max(int(ceiling), 1)
    if monitor.fuel is not None:
        initial = ignition.fuel
        result["_affected"] = (monitor.fuel < initial) | (
            monitor.fire if monitor.fire is not None else False
        )
    return result


def network_faults(launcher: Any) -> dict[str, Any]:
    """The summary's ``network_faults``: the impairment, how it was applied, the partitions."""
    network = launcher.network
    result: dict[str, Any] = {}
    if network.netem is not None:
        result["netem"] = network.netem.describe()
        result["netem_applied_with"] = network.netem_via
        if network.switch_counters:
            result["switch_frames"] = network.switch_counters
    if launcher.partitions is not None:
        result["partitions"] = launcher.partitions.summary()
    return result


def run(args: argparse.Namespace) -> int:
    from wildfire_bringup.launcher import Launcher, NodeFailure
    from wildfire_msgs_py.stop_signals import interrupt_on_stop_signals
    from wildfire_testbed.hosts import HostNetworkError

    if args.png is not None and not os.access(args.png.resolve().parent, os.W_OK):
        raise UserError(f"--png {args.png}: its directory is not writable")
    from wildfire_cli.run_params import with_params_file

    spec, from_file = with_params_file(args, build_spec, add_parser)
    launcher = Launcher(spec)
    # `kill`/`timeout` stop the run like Ctrl-C: children stopped, recording finalized.
    interrupt_on_stop_signals()
    total = round(args.duration * 10)
    if spec.foxglove_port is not None:
        print(f"Foxglove live view: ws://127.0.0.1:{spec.foxglove_port}", file=sys.stderr)
    label = f"run {args.policy} ({spec.mode})"
    if spec.hosts:
        label += f" on {spec.hosts} hosts"
    try:
        with progress_bar(label, total, enabled=not args.json) as bar:
            monitor = launcher.run(progress=bar)
    except NodeFailure as error:
        where = f"; recording finalized in {spec.record_dir}" if spec.record_dir else ""
        raise UserError(f"{error}{where} (logs in {launcher.log_dir})") from None
    except HostNetworkError as error:
        raise UserError(f"--hosts {spec.hosts}: {error}") from None
    network = launcher.network
    result = summarise(spec, monitor, launcher.wall_s, launcher.flight_wall_s)
    affected = result.pop("_affected", None)
    if spec.record_dir is not None:
        result["record"] = str(spec.record_dir)
    if spec.params_file is not None:
        # What the file changed from the defaults (the rest of the summary shows it flown).
        result |= {"params_file": str(spec.params_file), "from_params_file": from_file}
    if launcher.respawns:
        result["respawns"] = launcher.respawns
    if launcher.lost:
        result["lost_nodes"] = launcher.lost
    if composed := {name: list(nodes) for name, nodes in launcher.layout.items() if len(nodes) > 1}:
        result["composed_agents"] = composed
    if spec.foxglove_port is not None:
        result["foxglove"] = f"ws://127.0.0.1:{spec.foxglove_port}"
    if network is not None:
        result["hosts"] = network.summary()
        faults = network_faults(launcher)
        if faults:
            result["network_faults"] = faults
    if args.png is not None and monitor.fire is not None and monitor.belief is not None:
        from wildfire_learning.plots import plot_episode

        trajectory = monitor.trajectory()
        plot_episode(
            monitor.fire,
            affected if affected is not None else monitor.fire,
            monitor.belief,
            trajectory[:, :, :2],
            args.png,
            f"distributed {args.policy}, {spec.n_aircraft} aircraft, {spec.shape}, seed "
            f"{spec.seed}, wind {spec.wind[0]:+.2f},{spec.wind[1]:+.2f}: score {result['score']}",
        )
        result["png"] = str(args.png)
    if args.json:
        print_json(result)
    else:
        missed = result.get("missed_deadline_fraction")
        ceiling = (
            f" ({result['ceiling_fraction']:.0%} of the ceiling {result['score_ceiling']})"
            if "score_ceiling" in result
            else ""
        )
        print(
            f"{args.policy}, {spec.n_aircraft} aircraft, {spec.shape}, seed {spec.seed} "
            f"({spec.mode}): score {result['score']}{ceiling} "
            f"after {result['flight_time_s']:.1f} s "
            f"({result['end']}); belief IoU {result.get('belief_iou', float('nan')):.2f}; "
            f"{result['wall_time_s']:.1f} s wall ({result['speedup']:.1f}x real time)"
            + (f"; missed deadlines {100 * missed:.2f} %" if missed is not None else "")
        )
        if from_file:
            print(f"from {spec.params_file}: {', '.join(f'{k} {v}' for k, v in from_file.items())}")
        for host in result.get("hosts", []):
            print(f"host {host['namespace']} ({host['address']}): {', '.join(host['nodes'])}")
        for key in ("record", "png"):
            if key in result:
                print(f"wrote {result[key]}")
    return 0
