"""Rebuild DQN transitions from a bag recorded by ``wildfire run --record``.

The bag holds what the nodes publish (:mod:`wildfire_msgs_py.contract`); the transitions are
rebuilt by re-running the very functions the environment runs (sensor, belief visits, ego
image, rewards, pairwise states) on the recorded exact states, fire maps and actions, so a
lockstep bag gives the transitions :class:`~wildfire_world.env.WildfireVecEnv` gives for
the same seed (tested).

Topics used (one episode per bag):

* ``/uavK/state_stamped`` (preferred) or ``/uavK/state`` (K = 0, 1, ...): exact
  ``[x, y, heading, bank]``. Stamped states are placed by their stamp (decision tick =
  (stamp - stamp of the first fire map) / 0.1 s, the start pose at tick 0); the unstamped
  ``state`` stream is taken in order (start pose, if recorded, then one per decision; without
  the start pose the first transition is lost). Every aircraft must have every tick.
* ``/uavK/action`` (recorded since the agents publish it): the integer action of each
  decision, taken as recorded (and checked against the banks it turned).
* ``/uavK/bank_cmd`` (bags from before ``action``): the bank commanded at each decision; the
  action is the sign of its change from the previous bank (at the +-50 degree limit an
  unchanged bank means the action towards the limit, which the dynamics ignore). Without it,
  banks of the states are used.
* ``/wildfire/fire_map`` (required): the pre-burnt fire, then one map per fire step. Decision
  ``t`` (1-based) sees fire map ``t // 25``, as in the environment. Maps are placed by their
  header stamps when these increase (step = round(stamp delta / 2.5 s), a re-published map
  replaces the earlier one of the same step), otherwise by order.
* ``/wildfire/belief`` (belief approach only): its first message is the initial belief (the
  ignition seed); the belief is then rebuilt decision by decision.
* Noisy sensing (``metadata.yaml`` ``custom_data`` ``wildfire.sensor``, e.g. ``camera,0.1``,
  written by ``wildfire run --record``): the reports are drawn again, as the agents drew
  them (each aircraft's own seeded stream, from the recorded poses and fire maps), and fused
  into the filtered belief as the aggregator did (with its wind filter where
  ``wildfire.wind_filter`` says so); the seed and shape come from the first
  ``/wildfire/episode`` status. The observation approach's camera images and rewards are
  made from each aircraft's redrawn reports (``wildfire_agent.camera_view``). The recording
  must hold the start pose (the draws run from decision 1).

The last transition is terminal when its decision ended a fire step with fire within
``border_cells`` of the edge (the environment's rule); otherwise the bag simply ends (Ctrl-C or
the time limit) and the transition bootstraps.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np

from wildfire_agent import pairwise
from wildfire_agent.approaches import (
    Approach,
    belief_images,
    belief_rewards,
    sees_cameras,
    sensor_images,
)
from wildfire_agent.camera_view import camera_images, camera_rewards, window_codes
from wildfire_agent.dynamics import (
    BANK_STEP_RAD,
    MAX_BANK_STEPS,
    NUM_ACTIONS,
    AircraftState,
    apply_action,
)
from wildfire_agent.rewards import FireFieldMaps, fire_field_maps, observation_rewards
from wildfire_belief.belief import SharedBelief
from wildfire_belief.sensors import CAMERA_WINDOW, NUM_CAMERAS
from wildfire_belief.visits import visit_windows, visited_cells
from wildfire_learning.bag_sensing import NoisySensing, Sensing, recorded_sensing
from wildfire_learning.errors import LearningError
from wildfire_learning.replay import ImageCodec
from wildfire_msgs_py import belief_codec, codecs, contract
from wildfire_msgs_py.errors import WildfireRosError
from wildfire_msgs_py.system_codecs import episode_from_msg, stamped_state_from_msg
from wildfire_ros.bag import bag_info, read_messages
from wildfire_sim.episode import (
    DECISION_PERIOD_NS,
    DECISIONS_PER_FIRE_STEP,
    FIRE_STEP_NS,
    fire_at_border,
)
from wildfire_sim.grid import geometry_of
from wildfire_world.env import EnvConfig


class Recording(NamedTuple):
    """What a bag holds for rebuilding one episode."""

    fire_maps: list[np.ndarray]
    """Burning grids (100, 100) bool, index = fire step since the aircraft started."""
    states: np.ndarray
    """(T0 + 1, N, 4) exact states [x, y, heading, bank] at decisions t0 .. t0 + T0."""
    first_decision: int
    """Decision index of ``states[0]``: 0 if the start pose was recorded, else 1."""
    bank_cmds: np.ndarray | None
    """(T0, N) commanded banks of decisions first_decision + 1 .., or None."""
    initial_belief: np.ndarray | None
    """(100, 100) bool initial belief (first /wildfire/belief), or None."""
    actions: np.ndarray | None = None
    """(T0, N) int64 recorded actions of decisions first_decision + 1 .., or None (a bag
    without ``/uavK/action``)."""
    sensing: Sensing = Sensing()
    """The aircraft's sensor and pixel error of the run, and its wind filter."""
    episode: tuple[int, str] | None = None
    """Seed and shape of the episode (first ``/wildfire/episode`` status), if recorded."""


class RebuiltSequence(NamedTuple):
    """One aircraft's trajectory: T + 1 observations and T transitions."""

    aircraft: int
    images: np.ndarray
    """(T + 1, C, H, W) uint8, encoded with :class:`ImageCodec` of the approach."""
    states: np.ndarray
    """(T + 1, K, 5) float32 normalised pairwise states."""
    actions: np.ndarray
    """(T,) int64."""
    rewards: np.ndarray
    """(T,) float64 training reward of the approach."""
    terminated: np.ndarray
    """(T,) float32."""


def _stamp_ns(message: object) -> int:
    header = getattr(message, "header", None)
    return 0 if header is None else codecs.time_from_msg(header.stamp)


def _place_fire_maps(maps: list[tuple[int, np.ndarray]], bag: Path) -> list[np.ndarray]:
    """Fire maps indexed by fire step (see the module docstring)."""
    stamps = [stamp for stamp, _ in maps]
    if (
        len(maps) > 1
        and all(b >= a for a, b in itertools.pairwise(stamps))
        and (stamps[-1] > stamps[0])
    ):
        by_step: dict[int, np.ndarray] = {}
        for stamp, grid in maps:
            by_step[round((stamp - stamps[0]) / FIRE_STEP_NS)] = grid
        steps = sorted(by_step)
        if steps != list(range(len(steps))):
            missing = sorted(set(range(steps[-1] + 1)) - set(steps))
            raise LearningError(f"bag {bag}: fire maps of fire steps {missing[:5]} are missing")
        return [by_step[s] for s in steps]
    return [grid for _, grid in maps]


def _place_stamped_states(
    stamps: list[list[int]], states: list[list[np.ndarray]], start_ns: int, bag: Path
) -> tuple[np.ndarray, int]:
    """(T + 1, N, 4) states over the ticks every aircraft has, and the first tick."""
    by_tick: list[dict[int, np.ndarray]] = []
    for aircraft_stamps, aircraft_states in zip(stamps, states, strict=True):
        if not aircraft_stamps:
            raise LearningError(f"bag {bag}: an aircraft has no state message")
        ticks = [round((stamp - start_ns) / DECISION_PERIOD_NS) for stamp in aircraft_stamps]
        by_tick.append(dict(zip(ticks, aircraft_states, strict=True)))
    first = max(min(ticks) for ticks in by_tick)
    last = min(max(ticks) for ticks in by_tick)
    missing = [t for t in range(first, last + 1) if any(t not in ticks for ticks in by_tick)]
    if first < 0 or missing:
        raise LearningError(
            f"bag {bag}: states of decision ticks {missing[:5] or [first]} missing or before "
            "the first fire map"
        )
    array = np.array([[ticks[t] for ticks in by_tick] for t in range(first, last + 1)])
    return array.reshape(-1, len(by_tick), 4), first


def read_recording(bag_dir: str | Path, need_belief: bool) -> Recording:
    """Read the topics of one episode; raise :class:`LearningError` on bad or missing input."""
    bag = Path(bag_dir)
    try:
        topics = {t.name for t in bag_info(bag).topics}
    except WildfireRosError as error:
        raise LearningError(str(error)) from None
    aircraft = sorted(
        k
        for t in topics
        if (k := contract.aircraft_index(t)) is not None and t == contract.STATE.resolve(k)
    )
    if any(contract.RADIO.resolve(k) in topics for k in aircraft):
        # Its aircraft decided on their own replicas and heard peers, which the ground
        # station's belief and the true poses are not.
        raise LearningError(
            f"bag {bag}: recorded under limited radio links ({contract.RADIO.resolve(0)}): "
            "rebuilding its transitions is not supported (record with ideal links)"
        )
    sensing = recorded_sensing(bag)
    noisy = sensing.noisy
    belief_topic = [contract.BELIEF.name] if need_belief and not noisy else []
    required = [contract.FIRE_MAP.name] + belief_topic + ([contract.EPISODE.name] if noisy else [])
    missing = [t for t in required if t not in topics]
    if not aircraft:
        missing.append("/uavK/state")
    if missing or aircraft != list(range(len(aircraft))):
        expected = ", ".join(
            ["/wildfire/fire_map", "/uav0/state", "/uav1/state", "..."]
            + (["/wildfire/belief"] if need_belief else [])
        )
        raise LearningError(
            f"bag {bag}: missing topic {', '.join(missing) or '/uavK/state (numbering)'} "
            f"(expected {expected} as recorded by `wildfire run --record`)"
        )
    stamped_topics = {contract.STATE_STAMPED.resolve(k): k for k in aircraft}
    use_stamped = all(t in topics for t in stamped_topics)
    state_topics = (
        stamped_topics if use_stamped else {contract.STATE.resolve(k): k for k in aircraft}
    )
    cmd_topics = {contract.BANK_CMD.resolve(k): k for k in aircraft}
    use_cmds = all(t in topics for t in cmd_topics)
    action_topics = {contract.ACTION.resolve(k): k for k in aircraft}
    use_actions = all(t in topics for t in action_topics)
    wanted = [contract.FIRE_MAP.name, *state_topics] + (list(cmd_topics) if use_cmds else [])
    wanted += list(action_topics) if use_actions else []
    wanted += belief_topic + ([contract.EPISODE.name] if noisy else [])
    episode: tuple[int, str] | None = None

    fire: list[tuple[int, np.ndarray]] = []
    states: list[list[np.ndarray]] = [[] for _ in aircraft]
    stamps: list[list[int]] = [[] for _ in aircraft]
    cmds: list[list[float]] = [[] for _ in aircraft]
    actions: list[list[int]] = [[] for _ in aircraft]
    belief: np.ndarray | None = None
    try:
        for record in read_messages(bag, wanted):
            if record.topic in state_topics:
                k = state_topics[record.topic]
                if use_stamped:
                    stamp, values = stamped_state_from_msg(record.message)
                    stamps[k].append(stamp)
                    states[k].append(values)
                else:
                    states[k].append(codecs.state_from_msg(record.message))
            elif record.topic in cmd_topics:
                cmds[cmd_topics[record.topic]].append(codecs.bank_cmd_from_msg(record.message))
            elif record.topic in action_topics:
                actions[action_topics[record.topic]].append(codecs.action_from_msg(record.message))
            elif record.topic == contract.FIRE_MAP.name:
                grid = codecs.fire_grid_from_msg(record.message)
                # Every fire map of a run has its first one's shape (the run's map).
                if fire and grid.shape != fire[0][1].shape:
                    raise LearningError(
                        f"bag {bag}: fire map of shape {grid.shape}, "
                        f"expected {fire[0][1].shape} as the bag's first"
                    )
                fire.append((_stamp_ns(record.message), grid))
            elif record.topic == contract.BELIEF.name and belief is None:
                belief = belief_codec.belief_from_msg(record.message)
            elif record.topic == contract.EPISODE.name and episode is None:
                status = episode_from_msg(record.message).values
                episode = int(status.get("seed", -1)), status.get("shape", "")
    except WildfireRosError as error:
        raise LearningError(str(error)) from None
    if not fire:
        raise LearningError(f"bag {bag}: no message on /wildfire/fire_map")

    if use_stamped:
        state_array, first = _place_stamped_states(stamps, states, fire[0][0], bag)
        decisions = len(state_array) - 1
        # Command (and action) i is that of decision i + 1.
        cmd_array = _per_decision(cmds, first, decisions, np.float64) if use_cmds else None
        action_array = _per_decision(actions, first, decisions, np.int64) if use_actions else None
        if decisions < 1:
            raise LearningError(f"bag {bag}: fewer than two poses per aircraft")
        return Recording(
            _place_fire_maps(fire, bag),
            state_array,
            first,
            cmd_array,
            belief,
            action_array,
            sensing,
            episode,
        )

    # Align the aircraft: the same number of poses (a Ctrl-C may cut one stream short).
    poses = min(len(s) for s in states)
    commands = cmds if use_cmds else actions if use_actions else None
    if commands is not None:
        counts = [len(c) for c in commands]
        with_start = all(len(s) >= c + 1 for s, c in zip(states, counts, strict=True))
        first = 0 if with_start else 1
        # The node publishes states only after decisions: without the start pose, the first
        # command has no pose before it, so it is dropped.
        cmds, actions = [c[first:] for c in cmds], [a[first:] for a in actions]
        decisions = min(poses - 1, *(len(c) - first for c in commands))
    else:
        first, decisions = 0, poses - 1
    if decisions < 1:
        raise LearningError(f"bag {bag}: fewer than two poses per aircraft, nothing to rebuild")
    state_array = np.stack([np.stack(s[: decisions + 1]) for s in states], axis=1)
    return Recording(
        fire_maps=_place_fire_maps(fire, bag),
        states=state_array,
        first_decision=first,
        bank_cmds=_per_decision(cmds, 0, decisions, np.float64) if use_cmds else None,
        initial_belief=belief,
        actions=_per_decision(actions, 0, decisions, np.int64) if use_actions else None,
        sensing=sensing,
        episode=episode,
    )


def _per_decision(
    streams: list[list[float]] | list[list[int]], first: int, decisions: int, dtype: type
) -> np.ndarray | None:
    """(decisions, N) values ``first .. first + decisions - 1`` of each aircraft's stream, or
    None when a stream is too short to cover them (a cut recording)."""
    if min(len(s) for s in streams) < first + decisions:
        return None
    return np.array([s[first : first + decisions] for s in streams], dtype=dtype).T


def actions_from_banks(previous_bank_rad: np.ndarray, commanded_bank_rad: np.ndarray) -> np.ndarray:
    """Actions (0: -5 deg, 1: +5 deg) that turn ``previous`` into ``commanded`` banks."""
    before = np.rint(np.asarray(previous_bank_rad) / BANK_STEP_RAD).astype(np.int64)
    after = np.rint(np.asarray(commanded_bank_rad) / BANK_STEP_RAD).astype(np.int64)
    delta = after - before
    held = delta == 0
    if np.any(np.abs(delta) > 1) or np.any(held & (np.abs(before) != MAX_BANK_STEPS)):
        raise LearningError(
            "bank commands: consecutive banks must differ by exactly one 5 degree step "
            "(or stay at the 50 degree limit); is the bag from a lockstep run?"
        )
    return np.where(held, (before > 0).astype(np.int64), (delta > 0).astype(np.int64))


def checked_actions(actions: np.ndarray, bank_steps: np.ndarray) -> np.ndarray:
    """Recorded ``actions`` (T, N), refused unless each turned ``bank_steps[t]`` into
    ``bank_steps[t + 1]`` (T + 1, N) as the dynamics do."""
    if np.any((actions < 0) | (actions >= NUM_ACTIONS)):
        raise LearningError(f"bag: /uavK/action values outside 0..{NUM_ACTIONS - 1}")
    if not np.array_equal(apply_action(bank_steps[:-1], actions), bank_steps[1:]):
        raise LearningError(
            "bag: /uavK/action disagrees with the recorded banks; is the bag from a lockstep run?"
        )
    return actions


def rebuild_transitions(
    recording: Recording, approach: str, config: EnvConfig
) -> list[RebuiltSequence]:
    """Per-aircraft transitions of a recording (see the module docstring)."""
    codec = ImageCodec.for_approach(approach, recording.sensing.sensor)
    states = recording.states
    t0 = recording.first_decision
    # The last usable decision must have its fire map.
    last = min(t0 + len(states) - 1, len(recording.fire_maps) * DECISIONS_PER_FIRE_STEP - 1)
    states = states[: last - t0 + 1]
    decisions = len(states) - 1
    if decisions < 1:
        raise LearningError("bag: the fire maps do not cover any decision")
    n = states.shape[1]
    bank_steps = np.rint(states[..., 3] / BANK_STEP_RAD).astype(np.int64)
    if recording.actions is not None:
        actions = checked_actions(recording.actions[:decisions], bank_steps)
    elif recording.bank_cmds is not None:
        actions = actions_from_banks(states[:-1, :, 3], recording.bank_cmds[:decisions])
    else:
        actions = actions_from_banks(states[:-1, :, 3], states[1:, :, 3])

    geometry = geometry_of(recording.fire_maps[0])
    belief = SharedBelief(1, geometry)
    camera_world = sees_cameras(approach, recording.sensing.sensor)
    noisy = NoisySensing.of(
        recording.sensing,
        recording.episode,
        recording.first_decision,
        recording.states.shape[1],
        approach,
        config.preburn_steps,
    )
    if approach == Approach.BELIEF and noisy is None:
        if recording.initial_belief is None:
            raise LearningError("bag: the belief approach needs /wildfire/belief")
        belief.reset([0], recording.initial_belief)

    images: list[np.ndarray] = []
    pair_states: list[np.ndarray] = []
    rewards = np.zeros((decisions, n), dtype=np.float64)
    maps: FireFieldMaps | None = None
    maps_index = -1
    for i in range(decisions + 1):
        t = t0 + i
        step = t // DECISIONS_PER_FIRE_STEP
        burning = recording.fire_maps[step]
        pose = AircraftState(
            x_m=states[i, :, 0][None],
            y_m=states[i, :, 1][None],
            heading_rad=states[i, :, 2][None],
            bank_steps=bank_steps[i][None],
        )
        team = 0
        # Each aircraft's camera reports of this decision (none before the first).
        codes = np.zeros((1, n, NUM_CAMERAS, CAMERA_WINDOW, CAMERA_WINDOW), dtype=np.uint8)
        origin = np.zeros((2, 1, n), dtype=np.int64)
        if noisy is not None and t >= 1:
            team, reports = noisy.sense(pose, burning)
            if camera_world:
                own_codes, row0, col0 = window_codes(reports)
                codes, origin = own_codes[None], np.stack([row0, col0])[:, None]
        elif approach == Approach.BELIEF and t >= 1:
            # Decision t moved the aircraft, then visited (the environment's order).
            belief.tick()
            windows = visit_windows(pose.x_m, pose.y_m, geometry)
            env_idx, cell = visited_cells(windows, geometry)
            truth = burning[cell // geometry.cols, cell % geometry.cols]
            team = int(belief.visit(env_idx, cell, truth)[0])
        weights = config.obs_weights
        if i >= 1 and camera_world:
            rewards[i - 1] = camera_rewards(codes, origin[0], origin[1], pose, weights)[0]
        elif i >= 1 and approach == Approach.OBS:
            if maps is None or maps_index != step:
                maps, maps_index = fire_field_maps(burning[None], weights), step
            rewards[i - 1] = observation_rewards(maps, pose.x_m, pose.y_m, pose.bank_rad, weights)[
                0
            ]
        elif i >= 1:
            team_reward = np.array([team])
            rewards[i - 1] = belief_rewards(
                team_reward, pose, weights, config.belief_proximity_weight
            )[0]
        if camera_world:
            image = camera_images(codes, origin[0], origin[1], pose)[0]
        elif approach == Approach.OBS:
            image = sensor_images(burning[None], pose)[0]
        elif noisy is not None:
            fused = noisy.team
            shown = belief_codec.published_probability(fused.burning, fused.probability())
            image = belief_images(shown[None], fused.age_s()[None], pose)[0]
        else:
            image = belief_images(belief.burning, belief.age_s(), pose)[0]
        images.append(codec.encode(image))
        pair_states.append(pairwise.normalise(pairwise.pairwise_states(pose))[0])

    terminated = np.zeros(decisions, dtype=np.float32)
    t_last = t0 + decisions
    if t_last % DECISIONS_PER_FIRE_STEP == 0 and fire_at_border(
        recording.fire_maps[t_last // DECISIONS_PER_FIRE_STEP], config.border_cells
    ):
        terminated[-1] = 1.0
    image_stack = np.stack(images)  # (T + 1, N, C, H, W)
    state_stack = np.stack(pair_states)  # (T + 1, N, K, 5)
    return [
        RebuiltSequence(
            aircraft=k,
            images=np.ascontiguousarray(image_stack[:, k]),
            states=np.ascontiguousarray(state_stack[:, k]),
            actions=actions[:, k].copy(),
            rewards=rewards[:, k].copy(),
            terminated=terminated.copy(),
        )
        for k in range(n)
    ]


def transitions_from_bags(
    bag_dirs: Iterable[str | Path] | Sequence[str | Path], approach: str, config: EnvConfig
) -> list[RebuiltSequence]:
    """Rebuilt sequences of every aircraft of every bag."""
    sequences: list[RebuiltSequence] = []
    for bag in bag_dirs:
        recording = read_recording(bag, need_belief=approach == Approach.BELIEF)
        if recording.states.shape[1] != config.n_aircraft:
            raise LearningError(
                f"bag {bag}: {recording.states.shape[1]} aircraft, the network is trained "
                f"for {config.n_aircraft} (give --n-aircraft {recording.states.shape[1]})"
            )
        sequences += rebuild_transitions(recording, approach, config)
    return sequences


__all__ = [
    "RebuiltSequence",
    "Recording",
    "actions_from_banks",
    "checked_actions",
    "read_recording",
    "rebuild_transitions",
    "transitions_from_bags",
]
