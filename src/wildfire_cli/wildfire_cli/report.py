"""``wildfire report``: the paper's results table, reproduced on this project's policies."""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

from wildfire_agent.policy_names import policy_source
from wildfire_cli.common import (
    UserError,
    add_comm_argument,
    add_duration_argument,
    add_max_wind_argument,
    add_parallel_arguments,
    add_sensor_arguments,
    comm_model,
    non_negative_int,
    positive_int,
    print_json,
    sensor_settings,
)
from wildfire_cli.progress import progress_bar
from wildfire_learning.comm_sweep import plot_sweep, sweep_markdown
from wildfire_learning.evaluate import TEST_SEED_BASE, EvaluationSummary, evaluate
from wildfire_learning.fleet_report import fleet_markdown, plot_fleet
from wildfire_learning.parallel import EvalJob, evaluate_jobs
from wildfire_learning.plots import (
    CURVE_CSV,
    SEED_CURVES_CSV,
    SEED_CURVES_PNG,
    read_curve,
    write_seed_curves,
)
from wildfire_learning.results_report import (
    PAPER_SCENARIOS,
    Scenario,
    evaluation_path,
    fingerprint,
    load_cached,
    plot_scores,
    policy_id,
    policy_label,
    results_markdown,
    store,
    table_cells,
)
from wildfire_learning.vec_policies import check_world, make_vec_policy
from wildfire_world.env import EnvConfig

DEFAULT_POLICIES = ("obs", "belief", "rh", "rh-paper", "random")
NOISY_DEFAULT_POLICIES = ("belief", "belief-camera", "rh", "rh-belief", "rh-paper", "random")
"""Under noisy sensing: the disc world's observation network sees the truth, so it is left out."""
CAMERA_DEFAULT_POLICIES = (*NOISY_DEFAULT_POLICIES[:2], "obs-camera", *NOISY_DEFAULT_POLICIES[2:])
"""Under cameras: the observation network of that world too (it sees its camera images)."""
SWEEP_FILES = ("comm_sweep.md", "comm_sweep.json", "comm_sweep.png")
"""What ``--comm-sweep`` writes into the report folder."""


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "report",
        help="evaluate policies on the paper's scenarios; write the results table and chart",
        description="Evaluate every policy on every scenario (the same seeds for all), then "
        "write DIR/results.md (our table and the paper's ratios beside ours), "
        "DIR/results.json and DIR/scores.png. Each evaluation is kept in DIR/evaluations and "
        "reused while its seeds, wind, flight limit and policy file are unchanged.",
    )
    parser.add_argument(
        "--policies",
        nargs="+",
        default=None,
        metavar="POLICY",
        help="rh, rh-paper, rh-belief, random, obs, belief, belief-radio, belief-camera, "
        "belief-camera-radio, obs-camera (shipped models) or TorchScript .pt files (default: "
        f"{' '.join(DEFAULT_POLICIES)}; under cameras {' '.join(CAMERA_DEFAULT_POLICIES)}; under "
        f"a noisy disc {' '.join(NOISY_DEFAULT_POLICIES)})",
    )
    # The option's name before "policy" became the one word for it, kept for old scripts.
    parser.add_argument("--controllers", nargs="+", dest="policies", help=argparse.SUPPRESS)
    parser.add_argument(
        "--scenarios",
        nargs="+",
        default=list(PAPER_SCENARIOS),
        metavar="SCENARIO",
        help="SHAPE:N, a fire shape and aircraft count (default, the paper's: "
        f"{' '.join(PAPER_SCENARIOS)}), or a field scenario: field:RxC:ignitions=K:aircraft=N "
        "(seeded fires on an R x C map) or landcover:RxC:ignitions=K:aircraft=N (on a "
        "generated CORINE raster)",
    )
    parser.add_argument("--episodes", type=positive_int, default=20, metavar="K")
    parser.add_argument(
        "--seed",
        type=non_negative_int,
        default=TEST_SEED_BASE,
        metavar="S",
        help=f"first episode seed (default: {TEST_SEED_BASE}, the test range)",
    )
    add_max_wind_argument(parser)
    add_duration_argument(parser)
    add_sensor_arguments(parser)
    links = parser.add_mutually_exclusive_group()
    add_comm_argument(links)
    links.add_argument(
        "--comm-sweep",
        nargs="+",
        type=comm_model,
        metavar="MODEL",
        help="instead of the results table: every policy on the first --scenarios under each "
        "radio model (e.g. ideal range=1000 range=500 range=300 range=150 none), into "
        f"DIR/{SWEEP_FILES[0]}, DIR/{SWEEP_FILES[1]} and DIR/{SWEEP_FILES[2]}",
    )
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("out/report"),
        metavar="DIR",
        help="report folder (default: out/report)",
    )
    parser.add_argument(
        "--fresh", action="store_true", help="evaluate again even where a stored result matches"
    )
    add_parallel_arguments(parser)
    parser.add_argument(
        "--curves",
        nargs="+",
        type=Path,
        metavar="RUN",
        help="evaluate nothing: draw the learning curves of training runs (run directories or "
        f"their {CURVE_CSV}, e.g. one per seed) as mean +- s.e. across the runs, into "
        f"DIR/{SEED_CURVES_CSV} and DIR/{SEED_CURVES_PNG}",
    )
    parser.add_argument(
        "--baseline",
        type=float,
        metavar="SCORE",
        help="with --curves: the receding horizon's validation score, drawn dashed",
    )
    parser.add_argument("--json", action="store_true", help="print a JSON summary")
    parser.set_defaults(handler=run)


def check_policies(names: list[str]) -> list[str]:
    """Distinct policy names, each known and loadable, with distinct short names (their
    stored evaluations would overwrite each other)."""
    policies = list(dict.fromkeys(names))
    for name in policies:
        make_vec_policy(name)  # a bad name or file fails now, not hours into the report
    ids = [policy_id(name) for name in policies]
    for short in set(ids):
        if ids.count(short) > 1:
            raise UserError(f"--policies: two policies are both named {short!r}; rename one")
    return policies


def collect_results(
    args: argparse.Namespace,
    scenarios: list[Scenario],
    policies: list[str],
    base: EnvConfig,
    seeds: list[int],
) -> tuple[dict[str, dict[str, dict[str, Any]]], list[str]]:
    """Evaluation JSON of every (scenario, policy), stored or flown now; and the labels
    of those flown now."""
    results: dict[str, dict[str, dict[str, Any]]] = {s.key: {} for s in scenarios}
    evaluated: list[str] = []
    todo: list[tuple[Scenario, str, EnvConfig, dict[str, Any], Path, str]] = []

    def show(label: str, stored: dict[str, Any], note: str) -> None:
        if not args.json:
            # On stderr, like the bar: stdout carries the report alone (`| head` or a
            # redirect never interrupts the evaluations or mixes with them).
            score = f"{stored['score_mean']:.1f} ± {stored['score_sem']:.1f}"
            print(f"{label}: {score} ({note})", file=sys.stderr)

    for scenario in scenarios:
        config = scenario.config(base, args.out / "rasters")
        for policy in policies:
            policy_file = policy_source(policy)  # a network's file, or your policy's module
            identity = fingerprint(
                policy,
                policy_file,
                seeds,
                base.max_wind,
                args.duration,
                base.comm,
                base.sensor,
                base.pixel_error,
                base.wind_filter,
            )
            path = evaluation_path(
                args.out,
                policy,
                scenario,
                base.comm,
                base.sensor,
                base.pixel_error,
                base.wind_filter,
            )
            stored = None if args.fresh else load_cached(path, identity)
            label = f"{policy_label(policy)} on {scenario.title}"
            if stored is None:
                todo.append((scenario, policy, config, identity, path, label))
            else:
                show(label, stored, f"stored in {path}")
                results[scenario.key][policy] = stored

    def done(index: int, summary: EvaluationSummary, note: str) -> None:
        scenario, policy, _, identity, path, label = todo[index]
        stored = store(path, identity, summary.to_json())
        evaluated.append(label)
        show(label, stored, note)
        results[scenario.key][policy] = stored

    if args.workers > 1 or args.ray is not None:
        jobs = [EvalJob(policy, config, tuple(seeds)) for _, policy, config, *_ in todo]
        where = f"on Ray at {args.ray}" if args.ray else f"on {args.workers} workers"
        episodes = len(jobs) * len(seeds)
        with progress_bar(f"report {where}", episodes, enabled=not args.json) as bar:
            evaluate_jobs(
                jobs,
                args.workers,
                args.ray,
                on_job_done=lambda index, summary: done(index, summary, f"evaluated {where}"),
                progress=lambda flown, total: bar(flown),
            )
    else:
        for index, (_, policy, config, _, _, label) in enumerate(todo):
            start = time.perf_counter()
            with progress_bar(label, config.max_decisions, enabled=not args.json) as bar:
                summary = evaluate(
                    make_vec_policy(policy),
                    config,
                    seeds,
                    policy_name=policy,
                    progress=lambda flown, total: bar(flown),
                )
            done(index, summary, f"evaluated in {time.perf_counter() - start:.0f} s")
    # In the table's order, whatever order the evaluations finished in.
    ordered = {s.key: {c: results[s.key][c] for c in policies} for s in scenarios}
    evaluated.sort(key=lambda label: [t[5] for t in todo].index(label))
    return ordered, evaluated


def output_dir(out_dir: Path) -> Path:
    """``--out``, made if missing; a one-line error if it cannot hold the report."""
    if out_dir.exists() and not out_dir.is_dir():
        raise UserError(f"--out {out_dir}: exists and is not a directory")
    out_dir.mkdir(parents=True, exist_ok=True)
    if not os.access(out_dir, os.W_OK):
        raise UserError(f"--out {out_dir}: not writable")
    return out_dir


def load_curves(runs: list[Path]) -> list[list[dict[str, float]]]:
    """The learning curve of each ``--curves`` run, or a one-line error naming the run."""
    curves = []
    for run in runs:
        path = run / CURVE_CSV if run.is_dir() else run
        try:
            curve = read_curve(path)
        except (OSError, ValueError, UnicodeDecodeError) as error:
            raise UserError(
                f"--curves {run}: expected a training run's {CURVE_CSV} ({error})"
            ) from None
        if not curve or not {"iteration", "score_mean"} <= curve[0].keys():
            raise UserError(f"--curves {run}: expected a training run's {CURVE_CSV} with rows")
        curves.append(curve)
    return curves


def run_curves(args: argparse.Namespace) -> int:
    """``--curves``: mean +- s.e. across training runs, evaluating nothing."""
    curves = load_curves(args.curves)
    out_dir = output_dir(args.out)
    labels = [run.name if run.is_dir() else run.parent.name for run in args.curves]
    rows = write_seed_curves(curves, labels, args.baseline, out_dir)
    files = [str(out_dir / SEED_CURVES_CSV), str(out_dir / SEED_CURVES_PNG)]
    if args.json:
        # A column older runs lack averages to NaN, which is no JSON: null instead.
        curve = [{k: None if v != v else v for k, v in row.items()} for row in rows]
        print_json({"runs": labels, "curve": curve, "files": files})
    else:
        for row in rows:
            print(
                f"iteration {row['iteration']:.0f}: score {row['score_mean']:.1f} +- "
                f"{row['score_sem']:.1f}, training reward {row['reward_mean']:.4f} +- "
                f"{row['reward_sem']:.4f} ({row['runs']:.0f} runs)"
            )
        print("wrote " + ", ".join(files))
    return 0


def run_comm_sweep(
    args: argparse.Namespace, scenario: Scenario, policies: list[str], base: EnvConfig
) -> int:
    """``--comm-sweep``: the policies on one scenario under each radio model."""
    models = list(dict.fromkeys(args.comm_sweep))
    out_dir = output_dir(args.out)
    seeds = list(range(args.seed, args.seed + args.episodes))
    results: dict[str, dict[str, dict[str, Any]]] = {}
    evaluated: list[str] = []
    for model in models:
        by_scenario, flown = collect_results(
            args, [scenario], policies, replace(base, comm=model), seeds
        )
        results[str(model)] = by_scenario[scenario.key]
        evaluated += [f"{label} ({model})" for label in flown]
    protocol = (
        f"Seeds {seeds[0]}..{seeds[-1]} ({len(seeds)} episodes, the same for every policy and "
        f"radio model), random wind in [-{base.max_wind:g}, {base.max_wind:g}]^2, flights of "
        f"at most {args.duration:g} s (docs/model.md, Radio links)."
    )
    markdown = sweep_markdown(results, models, policies, scenario.title, protocol)
    md_path, json_path, png_path = (out_dir / name for name in SWEEP_FILES)
    md_path.write_text(markdown)
    plot_sweep(results, models, policies, png_path)
    files = [str(md_path), str(json_path), str(png_path)]
    summary = {
        "protocol": protocol,
        "scenario": scenario.key,
        "seeds": seeds,
        "comm": [str(m) for m in models],
        "policies": policies,
        "scores": {str(m): {p: results[str(m)][p]["score_mean"] for p in policies} for m in models},
        "evaluated": evaluated,
        "files": files,
    }
    json_path.write_text(json.dumps(summary, indent=1) + "\n")
    if args.json:
        print_json(summary)
    else:
        print(markdown)
        print("wrote " + ", ".join(files))
    return 0


def run(args: argparse.Namespace) -> int:
    if args.curves:
        return run_curves(args)
    scenarios = list(dict.fromkeys(Scenario.parse(text) for text in args.scenarios))
    base = EnvConfig(
        observation="none", max_duration_s=args.duration, comm=args.comm, **sensor_settings(args)
    )
    if args.max_wind is not None:
        base = replace(base, max_wind=args.max_wind)
    base.validate()
    defaults: tuple[str, ...] = DEFAULT_POLICIES
    if base.noisy:
        defaults = CAMERA_DEFAULT_POLICIES if base.sensor == "camera" else NOISY_DEFAULT_POLICIES
    policies = check_policies(args.policies or list(defaults))
    for policy in policies:  # a policy this world cannot fly fails now, not mid-report
        check_world(make_vec_policy(policy), base)
    out_dir = output_dir(args.out)
    seeds = list(range(args.seed, args.seed + args.episodes))

    if args.comm_sweep:
        return run_comm_sweep(args, scenarios[0], policies, base)
    results, evaluated = collect_results(args, scenarios, policies, base, seeds)
    protocol = (
        f"Seeds {seeds[0]}..{seeds[-1]} ({len(seeds)} episodes, the same for every policy), "
        f"random wind in [-{base.max_wind:g}, {base.max_wind:g}]^2, flights of at most "
        f"{args.duration:g} s ending when the fire comes within {base.border_cells} cells of the "
        "border (docs/model.md, Evaluation)."
    )
    if not base.comm.ideal:
        protocol += f" Radio links {base.comm} (docs/model.md, Radio links)."
    if base.noisy:
        protocol += (
            f" Sensor {base.sensor}, pixel error {base.pixel_error:g}: the team keeps a "
            "probability of burning per cell, and a cell scores at most once per episode "
            "(docs/model.md, Realistic sensing)."
        )
    markdown = results_markdown(results, scenarios, policies, protocol)
    fleets = fleet_markdown(results, scenarios, policies)
    if fleets:
        markdown += "\n" + fleets
    (out_dir / "results.md").write_text(markdown)
    plot_scores(results, scenarios, policies, out_dir / "scores.png")
    figures = ["scores.png"]
    if plot_fleet(results, scenarios, policies, out_dir / "fleet.png"):
        figures.append("fleet.png")
    cells = table_cells(results)
    summary_json = {
        "protocol": protocol,
        "seeds": seeds,
        "max_wind": base.max_wind,
        "duration_s": args.duration,
        "comm": str(base.comm),
        "scenarios": [s.key for s in scenarios],
        "policies": policies,
        "cells": {s: {c: vars(cell) for c, cell in row.items()} for s, row in cells.items()},
        "evaluated": evaluated,
        "reused": len(scenarios) * len(policies) - len(evaluated),
        "files": [str(out_dir / name) for name in ("results.md", "results.json", *figures)],
    }
    (out_dir / "results.json").write_text(json.dumps(summary_json, indent=1) + "\n")
    if args.json:
        print_json(summary_json)
    else:
        print(markdown)
        print("wrote " + ", ".join(summary_json["files"]))
    return 0
