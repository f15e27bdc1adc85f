"""The agent's and the aggregator's parameter tables and the protocols they make, without
ROS: defaults build a working protocol, a bad value is refused in one line, and an agent
says ready once and only once its reports are heard."""

from __future__ import annotations

from typing import Any

import pytest

from wildfire_agent.agent_parameters import PARAMETERS as AGENT_PARAMETERS
from wildfire_agent.agent_parameters import agent_protocol
from wildfire_agent.agent_protocol import DeadlineOut, Mode
from wildfire_agent.errors import AgentConfigError
from wildfire_belief.aggregator_parameters import PARAMETERS as AGGREGATOR_PARAMETERS
from wildfire_belief.aggregator_parameters import aggregator_protocol
from wildfire_belief.filtered_aggregator import FilteredAggregator


def defaults(table: Any, **values: Any) -> dict[str, Any]:
    return {spec.name: spec.default for spec in table} | values


def test_the_agent_defaults_make_a_lockstep_protocol() -> None:
    protocol = agent_protocol(defaults(AGENT_PARAMETERS, aircraft=1, n_aircraft=3), lambda: 0)
    assert (protocol.k, protocol.n, protocol.mode) == (1, 3, Mode.LOCKSTEP)
    assert protocol.name_tag == "uav1" and protocol.radio is None
    assert sorted(protocol.peer_states) == [0, 2]
    limited = agent_protocol(defaults(AGENT_PARAMETERS, comm="range=300"), lambda: 0)
    assert limited.radio is not None


@pytest.mark.parametrize(
    ("values", "expected"),
    [
        ({"aircraft": 2, "n_aircraft": 2}, "aircraft 2: expected 0..1"),
        ({"comm": "range=-1"}, "range"),
        ({"policy": "nope"}, "unknown policy 'nope'"),
        ({"policy": "no_such_module_here:Policy"}, "cannot import no_such_module_here"),
    ],
)
def test_a_bad_agent_value_is_refused_in_one_line(values: dict[str, Any], expected: str) -> None:
    with pytest.raises(AgentConfigError, match=expected) as error:
        agent_protocol(defaults(AGENT_PARAMETERS, **values), lambda: 0)
    assert "\n" not in str(error.value)


def test_an_agent_says_ready_once_its_reports_are_heard() -> None:
    protocol = agent_protocol(defaults(AGENT_PARAMETERS), lambda: 0)
    assert not protocol.on_startup(False)
    assert protocol.on_startup(True)
    assert not protocol.on_startup(True)  # once


def test_deadline_statistics_carry_the_radio_status_under_limited_links() -> None:
    ideal = agent_protocol(defaults(AGENT_PARAMETERS), lambda: 0).deadline(0, force=True)
    limited = agent_protocol(defaults(AGENT_PARAMETERS, comm="range=300"), lambda: 0)
    (out,) = limited.deadline(0, force=True)
    assert isinstance(out, DeadlineOut) and out.radio is not None
    assert isinstance(ideal[0], DeadlineOut) and ideal[0].radio is None


def test_the_aggregator_defaults_and_noisy_sensing() -> None:
    protocol = aggregator_protocol(defaults(AGGREGATOR_PARAMETERS, n_aircraft=3), lambda: 0)
    assert protocol.filtered is None and protocol.sources == 1
    camera = aggregator_protocol(
        defaults(AGGREGATOR_PARAMETERS, sensor="camera", pixel_error=0.1), lambda: 0
    )
    assert isinstance(camera.filtered, FilteredAggregator) and camera.sources == 4
    with pytest.raises(ValueError, match="wind"):
        aggregator_protocol(defaults(AGGREGATOR_PARAMETERS, wind_filter=True), lambda: 0)
