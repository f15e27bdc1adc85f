"""``wildfire train``: deep Q-learning of a policy, in simulation or from recorded bags.

Every field of :class:`wildfire_learning.train_config.TrainConfig` is an option
(``--total-samples``, ``--num-envs``, ``--lr`` ...). A run writes under ``--run-dir`` (default
``runs/<approach>-<arch>-s<seed>``): ``checkpoint.pt`` + ``replay.npz`` (``--resume``
continues from them), ``learning_curve.csv``/``.png`` and ``train_summary.json``; the policy
goes to ``--out`` (default ``<run-dir>/<approach>_policy.pt``) with its card as a sidecar JSON.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import fields
from pathlib import Path
from typing import Any

from wildfire_cli.common import (
    CAMERA_PIXEL_ERROR,
    UserError,
    add_device_argument,
    comm_model,
    map_size,
    non_negative_int,
    pixel_error,
    positive_float,
    positive_int,
    print_json,
    unit_interval,
)
from wildfire_learning.checkpoint import CHECKPOINT_FILE, load_checkpoint
from wildfire_learning.device import resolve_device
from wildfire_learning.dqn import train
from wildfire_learning.train_config import RunOptions, TrainConfig, resolve_config
from wildfire_learning.train_status import Status
from wildfire_msgs_py.stop_signals import interrupt_on_stop_signals


def add_config_options(parser: argparse.ArgumentParser) -> None:
    """One option per :class:`TrainConfig` field, from the field's type and metadata."""
    for spec in fields(TrainConfig):
        meta = spec.metadata
        default = spec.default
        option = "--" + meta.get("name", spec.name.replace("_", "-"))
        # argparse %-formats help strings: escape the texts' own percent signs.
        help_text = f"{meta['help']} (default: {default})".replace("%", "%%")
        # Defaults stay None so a resumed run keeps its saved values unless overridden.
        common: dict[str, Any] = {"dest": spec.name, "default": None, "help": help_text}
        if "choices" in meta:
            parser.add_argument(option, choices=meta["choices"], **common)
        elif meta.get("pixel_error"):
            parser.add_argument(option, type=pixel_error, metavar="P", **common)
        elif meta.get("map_size"):
            # Checked as --map-size is everywhere, stored as its text.
            parser.add_argument(
                option, type=lambda text: map_size(text).text, metavar="R,C", **common
            )
        elif meta.get("path"):
            # Stored absolute: a resumed run finds the file from any directory.
            parser.add_argument(
                option, type=lambda text: str(Path(text).resolve()), metavar="FILE", **common
            )
        elif isinstance(default, str) and "choices" not in meta and not meta.get("comm"):
            parser.add_argument(option, metavar="NAME", **common)
        elif meta.get("comm"):
            # Checked as --comm is everywhere, stored as its canonical text.
            parser.add_argument(
                option, type=lambda text: str(comm_model(text)), metavar="MODEL", **common
            )
        elif isinstance(default, bool):
            parser.add_argument(option, action=argparse.BooleanOptionalAction, **common)
        elif isinstance(default, tuple):
            parser.add_argument(option, nargs="+", metavar="SHAPE", **common)
        elif isinstance(default, float):
            kind = unit_interval if meta.get("unit") else positive_float
            parser.add_argument(option, type=kind, **common)
        else:
            kind = positive_int if meta["min"] >= 1 else non_negative_int
            parser.add_argument(option, type=kind, **common)


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "train",
        help="train a DQN policy (simulation or recorded bags)",
        description="Deep Q-learning of the pairwise Q-network (observation- or belief-based) "
        "with batched environments, replay prefill, target network and AdaMax; periodic "
        "evaluation on held-out seeds, learning curve, checkpoints (--resume) and a "
        "TorchScript export with a JSON card.",
    )
    add_config_options(parser)
    parser.add_argument("--run-dir", type=Path, help="run directory (checkpoints, curve)")
    parser.add_argument("--out", type=Path, metavar="FILE.pt", help="exported policy file")
    parser.add_argument("--resume", action="store_true", help="continue the run in --run-dir")
    parser.add_argument(
        "--baseline",
        metavar="SCORE|FILE.json",
        help="receding-horizon score on the evaluation seeds (a number, or a "
        "`wildfire eval --json` output), drawn dashed on the learning curve",
    )
    parser.add_argument(
        "--from-bag",
        nargs="+",
        type=Path,
        metavar="DIR",
        help="rebuild transitions from recorded bags (`wildfire run --record`)",
    )
    parser.add_argument(
        "--init-from",
        type=Path,
        metavar="POLICY.pt",
        help="start from the weights of an exported policy of the same "
        "approach and architecture (fine-tuning; recorded in the card)",
    )
    parser.add_argument(
        "--online",
        action="store_true",
        help="with --from-bag: prefill the replay with the bag transitions, "
        "then train in simulation (default: train on the bags only)",
    )
    parser.add_argument(
        "--log-every",
        type=positive_float,
        default=60.0,
        metavar="SECONDS",
        help="when stderr is not a terminal (nohup), print a status line this often (default: 60)",
    )
    parser.add_argument(
        "--time-limit",
        type=positive_float,
        metavar="SECONDS",
        help="stop learning after this much wall time (the prefill included), then evaluate "
        "and export as at the end; --resume carries on towards --iterations",
    )
    add_device_argument(parser, "auto", "the networks and replay mini-batches")
    parser.add_argument("--json", action="store_true", help="print a JSON summary")
    parser.set_defaults(handler=run)


def _baseline(text: str | None) -> float | None:
    if text is None:
        return None
    try:
        return float(text)
    except ValueError:
        pass
    path = Path(text)
    if not path.is_file():
        raise UserError(f"--baseline {text}: expected a number or a `wildfire eval --json` file")
    try:
        value = json.loads(path.read_text())["score_mean"]
        return float(value)
    except (json.JSONDecodeError, KeyError, TypeError, ValueError):
        raise UserError(f"--baseline {path}: expected JSON with a numeric 'score_mean'") from None


def given_options(args: argparse.Namespace) -> dict[str, Any]:
    """The :class:`TrainConfig` values given on the command line (lists read as tuples); a
    camera without ``--pixel-error`` gets the camera's usual error, as everywhere."""
    given = {
        spec.name: tuple(value) if isinstance(value, list) else value
        for spec in fields(TrainConfig)
        if (value := getattr(args, spec.name)) is not None
    }
    if given.get("sensor") == "camera" and "pixel_error" not in given:
        given["pixel_error"] = CAMERA_PIXEL_ERROR
    return given


def build_config(args: argparse.Namespace, saved: dict[str, Any] | None) -> TrainConfig:
    """Defaults < saved checkpoint config < options given on the command line."""
    return resolve_config(saved, given_options(args))


def run(args: argparse.Namespace) -> int:
    device = resolve_device(args.device)
    saved: dict[str, Any] | None = None
    if args.resume:
        if args.run_dir is None:
            raise UserError("--resume: give the --run-dir of the run to continue")
        saved = load_checkpoint(args.run_dir)["config"]
    config = build_config(args, saved).validate()
    if args.from_bag and not args.online and config.iterations == 0:
        raise UserError("--from-bag: give --iterations K (offline training runs K iterations)")
    run_dir = args.run_dir or Path("runs") / f"{config.approach}-{config.arch}-s{config.seed}"
    if not args.resume and (run_dir / CHECKPOINT_FILE).exists():
        raise UserError(f"--run-dir {run_dir}: holds a run already (use --resume or a new dir)")
    out = args.out or run_dir / f"{config.approach}_policy.pt"
    if out.suffix != ".pt":
        raise UserError(f"--out {out}: expected a .pt file name")
    options = RunOptions(
        run_dir=run_dir,
        out=out,
        resume=args.resume,
        baseline_score=_baseline(args.baseline),
        bag_dirs=tuple(args.from_bag or ()),
        offline=bool(args.from_bag) and not args.online,
        init_policy=args.init_from,
        device=str(device),
        time_limit_s=args.time_limit,
    )
    # The run creates its own directory, so an --out inside it is fine before it exists.
    if args.out is not None:
        try:
            out.parent.mkdir(parents=True, exist_ok=True)  # as `mkdir -p`
        except OSError as error:
            raise UserError(f"--out {out}: cannot create {out.parent} ({error.strerror})") from None

    # `kill PID` of a background run checkpoints like Ctrl-C does (see dqn.train).
    interrupt_on_stop_signals()
    with _progress(enabled=not args.json, log_every_s=args.log_every) as report:
        # Only the options given: a resumed run merges them over its checkpoint's config as
        # build_config did (a TrainConfig could not tell a default given from one not given).
        result = train(given_options(args), options, report)

    evaluation = result.card["evaluation"]
    summary = {
        "approach": config.approach,
        "arch": config.arch,
        "device": str(device),
        "out": str(result.out),
        "run_dir": str(run_dir),
        "iterations": result.state.iterations,
        "samples": result.state.samples,
        "episodes": result.state.episodes,
        "transitions": result.transitions_from_bags,
        "wall_time_s": round(result.state.wall_time_s, 2),
        "samples_per_s": round(result.samples_per_s, 1),
        "iterations_per_s": round(result.iterations_per_s, 2),
        "prefill_samples_per_s": round(result.prefill_samples_per_s, 1),
        "replay_mb": round(result.replay_bytes / 2**20, 1),
        "max_rss_mb": round(result.max_rss_mb, 1),
        "score_mean": evaluation["score_mean"],
        "score_sem": evaluation["score_sem"],
        "receding_horizon_score": evaluation["receding_horizon_score"],
        "learning_curve": result.card["learning_curve"],
        "config": result.card["config"],
    }
    if args.json:
        print_json(summary)
    else:
        print(
            f"trained {config.approach}/{config.arch}: {result.state.iterations} iterations, "
            f"{result.state.samples} samples in {result.state.wall_time_s:.0f} s; score "
            f"{evaluation['score_mean']:.1f} +- {evaluation['score_sem']:.1f} on "
            f"{evaluation['episodes']} held-out episodes"
        )
        print(f"wrote {result.out} (+ {result.out.with_suffix('.json').name}), curve in {run_dir}")
    return 0


class _progress:
    """A rich progress bar on a terminal; without one, a status line every ``log_every_s``."""

    def __init__(self, enabled: bool, log_every_s: float) -> None:
        self.enabled = enabled and sys.stderr.isatty()
        self.log_every_s = log_every_s
        self.last_log = time.monotonic()
        self.progress: Any = None
        self.task: Any = None

    def log(self, status: Status) -> None:
        now = time.monotonic()
        if now - self.last_log < self.log_every_s:
            return
        self.last_log = now
        score = "-" if status.last_score is None else f"{status.last_score:.1f}"
        print(
            f"{time.strftime('%H:%M:%S')} {status.phase}: iteration {status.iterations}/"
            f"{status.target_iterations} samples {status.samples} epsilon "
            f"{status.epsilon:.3f} loss {status.loss:.4g} last score {score}",
            file=sys.stderr,
            flush=True,
        )

    def __enter__(self) -> Any:
        if not self.enabled:
            return None if sys.stderr.isatty() else self.log
        from rich.progress import (
            BarColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        self.progress = Progress(
            TextColumn("[bold]{task.fields[phase]}"),
            BarColumn(),
            TextColumn("{task.completed}/{task.total} it"),
            TextColumn(
                "samples {task.fields[samples]} eps {task.fields[eps]} "
                "loss {task.fields[loss]} score {task.fields[score]}"
            ),
            TimeElapsedColumn(),
            TimeRemainingColumn(),
        )
        self.progress.__enter__()
        self.task = self.progress.add_task(
            "train", total=1, phase="", samples=0, eps="", loss="", score="-"
        )
        return self.update

    def update(self, status: Status) -> None:
        self.progress.update(
            self.task,
            total=max(status.target_iterations, 1),
            completed=status.iterations,
            phase=status.phase,
            samples=status.samples,
            eps=f"{status.epsilon:.2f}",
            loss=f"{status.loss:.3g}",
            score="-" if status.last_score is None else f"{status.last_score:.0f}",
        )

    def __exit__(self, *exc: object) -> None:
        if self.progress is not None:
            self.progress.__exit__(*exc)


__all__ = ["add_config_options", "add_parser", "build_config", "given_options", "run"]
