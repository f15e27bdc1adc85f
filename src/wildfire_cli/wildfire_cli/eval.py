"""``wildfire eval``: score a policy on seeded episodes (docs/model.md, Evaluation)."""

from __future__ import annotations

import argparse

from wildfire_agent.policy_names import has_network_file, resolve_policy_path
from wildfire_belief.radio import IDEAL, CommModel
from wildfire_belief.sensors import noisy
from wildfire_cli.common import (
    UserError,
    add_device_argument,
    add_episode_arguments,
    add_parallel_arguments,
    positive_int,
    print_json,
    scenario_settings,
)
from wildfire_cli.progress import progress_bar
from wildfire_learning.device import resolve_device
from wildfire_learning.evaluate import TEST_SEED_BASE, evaluate
from wildfire_learning.parallel import EvalJob, evaluate_jobs
from wildfire_learning.results_report import Scenario
from wildfire_learning.vec_policies import check_world, make_vec_policy
from wildfire_msgs_py.map_geometry import PAPER_MAP, MapGeometry
from wildfire_sim.shapes import Shape
from wildfire_world.env import EnvConfig


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "eval",
        help="score a policy on seeded episodes",
        description="Fly a policy on episodes with seeds S0..S0+K-1 and report the team "
        "score (newly seen burning cells summed over the flight) and belief metrics.",
    )
    add_episode_arguments(
        parser,
        default_seed=TEST_SEED_BASE,
        seed_help=f"first episode seed (default: {TEST_SEED_BASE}, the test range: never "
        "trained or selected on)",
    )
    parser.add_argument("--episodes", type=positive_int, default=20, metavar="K")
    add_parallel_arguments(parser)
    # The CPU by default: the agent nodes run their networks there, and `eval` flies what
    # they fly bit for bit (another device may break a near tie between two Q-values).
    add_device_argument(parser, "cpu", "the Q-network")
    parser.add_argument("--png", metavar="FILE", help="draw the first episode")
    parser.add_argument(
        "--card",
        action="store_true",
        help="record the result in the policy's JSON model card (key "
        "test_evaluations.<shape>_<N>aircraft, with _wind<WX,WY> or _maxwind<W>, "
        "_comm<MODEL>, _sensor<SENSOR>,p=<P> and _map<R,C> appended for those); Q-network "
        "policies only",
    )
    parser.add_argument("--json", action="store_true", help="print a JSON summary")
    parser.set_defaults(handler=run)


def card_key(
    shape: str,
    aircraft: int,
    wind: tuple[float, float] | None,
    max_wind: float | None,
    comm: CommModel = IDEAL,
    sensing: tuple[str, float] = ("disc", 0.0),
    geometry: MapGeometry = PAPER_MAP,
) -> str:
    """Key of an evaluation in a model card: ``circular_2aircraft`` under the default random
    wind, ideal links and the perfect disc, with the wind setting, the radio model and the
    sensing appended otherwise (so it never replaces the default's), e.g.
    ``circular_2aircraft_sensorcamera,p=0.1`` or ``circular_16aircraft_map500,500``."""
    key = Scenario(shape, aircraft).key
    if wind is not None:
        key = f"{key}_wind{wind[0]:g},{wind[1]:g}"
    elif max_wind is not None:
        key = f"{key}_maxwind{max_wind:g}"
    if not comm.ideal:
        key = f"{key}_comm{comm}"
    if noisy(*sensing):
        key = f"{key}_sensor{sensing[0]},p={sensing[1]:g}"
    if not geometry.is_paper:
        key = f"{key}_map{geometry.text}"
    return key


def planning_note(planning_s: float, wall_s: float) -> str:
    """What the summary line says of the policy's planning before the flight: nothing for
    the policies that plan as they fly (their reset takes milliseconds), the seconds and the
    share of the wall time for the oracle, which plans every episode whole first."""
    if planning_s < 0.05:
        return ""
    return f" including {planning_s:.1f} s of planning before the flight ({wall_s:.1f} s wall)"


def run(args: argparse.Namespace) -> int:
    shape = Shape.parse(args.shape)
    device = resolve_device(args.device)
    vec_policy = make_vec_policy(args.policy, device=device)  # a bad name or file fails now
    if args.card and not has_network_file(args.policy):
        raise UserError(f"--card: policy {args.policy} has no model card (a Q-network has)")
    config = EnvConfig(
        shapes=(shape.value,), observation=vec_policy.observation, **scenario_settings(args)
    ).validate()
    check_world(vec_policy, config)
    seeds = list(range(args.seed, args.seed + args.episodes))
    if args.workers > 1 or args.ray is not None:
        job = EvalJob(args.policy, config, tuple(seeds), bool(args.png), str(device))
        with progress_bar(f"eval {args.policy}", len(seeds), enabled=not args.json) as bar:
            (summary,) = evaluate_jobs(
                [job], args.workers, args.ray, progress=lambda done, total: bar(done)
            )
    else:
        with progress_bar(
            f"eval {args.policy}", config.max_decisions, enabled=not args.json
        ) as bar:
            summary = evaluate(
                vec_policy,
                config,
                seeds,
                policy_name=args.policy,
                record=bool(args.png),
                progress=lambda done, total: bar(done),
            )
    if args.png:
        from wildfire_learning.plots import plot_episode

        first = summary.episodes[0]
        assert first.trajectory is not None
        assert first.final_burning is not None
        assert first.final_affected is not None
        assert first.final_belief is not None
        plot_episode(
            first.final_burning,
            first.final_affected,
            first.final_belief,
            first.trajectory,
            args.png,
            f"{args.policy}, {args.aircraft} aircraft, {first.shape}, seed {first.seed}, "
            f"wind {first.wind[0]:+.2f},{first.wind[1]:+.2f}: score {first.score}",
        )
    result = summary.to_json() | {
        "aircraft": args.aircraft,
        "shape": shape.value,
        "duration_s": args.duration,
        "wind": config.wind,
        "max_wind": config.max_wind,
        "comm": str(config.comm),
        "sensor": config.sensor,
        "pixel_error": config.pixel_error,
        **config.ground.summary(),
    }
    if config.preburn_area_m2 > 0:
        result["preburn_area_m2"] = config.preburn_area_m2
    if args.card:
        from wildfire_learning.export import record_evaluation

        sensing = (config.sensor, config.pixel_error)
        scenario = card_key(
            shape.value, args.aircraft, args.wind, args.max_wind, config.comm, sensing,
            config.geometry,
        )  # fmt: skip
        if config.landscape is not None:
            scenario = f"{scenario}_{config.landscape.key}"
        if config.preburn_area_m2 > 0:
            scenario = f"{scenario}_preburn{config.preburn_area_m2:g}m2"
        card = record_evaluation(resolve_policy_path(args.policy), scenario, result)
        if not args.json:
            print(f"recorded {scenario} in {card}")
    if args.json:
        print_json(result)
    else:
        print(
            f"{args.policy}: score {result['score_mean']:.1f} ± {result['score_sem']:.1f} "
            f"(mean ± s.e., {args.episodes} episodes, {args.aircraft} aircraft, {shape.value}), "
            f"{result['ceiling_fraction']:.0%} of the ceiling {result['score_ceiling_mean']:.1f}; "
            f"belief IoU {result['belief_iou_mean']:.2f}, mean age at fire "
            f"{result['mean_age_burning_s']:.1f} s, "
            f"{result['seconds_per_decision'] * 1e3:.2f} ms per decision"
            + planning_note(result["planning_s"], result["wall_time_s"])
        )
        if config.noisy:
            print(
                f"{config.sensor} sensing, pixel error {config.pixel_error:g}: "
                f"{result['false_alarms_mean']:.1f} false alarms per episode, "
                f"{result['flipped_fraction']:.1%} of the reports flipped"
            )
        if args.png:
            print(f"wrote {args.png}")
    return 0
