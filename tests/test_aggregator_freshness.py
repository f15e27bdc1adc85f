"""Real-time merging: a late, older visit never undoes a newer one (no ROS)."""

from __future__ import annotations

import numpy as np

from wildfire_belief.aggregator import BeliefAggregator
from wildfire_belief.visits import VISIT_WINDOW
from wildfire_msgs_py.codecs import VisitWindow


def window(row0: int, col0: int, burning: bool) -> VisitWindow:
    """A visit of the one cell ``(row0 + 1, col0 + 1)``."""
    visited = np.zeros((VISIT_WINDOW, VISIT_WINDOW), dtype=bool)
    visited[1, 1] = True
    return VisitWindow(row0, col0, visited, visited & burning)


def test_a_late_older_visit_is_cut_and_cannot_score_a_cell_twice() -> None:
    aggregator = BeliefAggregator(np.zeros((100, 100), dtype=bool))
    assert aggregator.merge(aggregator.fresher_visits([(10, window(40, 40, True))])) == 1
    # The visit of stamp 5 (cell not burning yet) arrives after the one of stamp 10: dropped.
    late = aggregator.fresher_visits([(5, window(40, 40, False))])
    assert not late[0].visited.any()
    aggregator.merge(late)
    assert aggregator.burning[41, 41]
    # A newer visit finds the cell already believed burning: no second reward.
    assert aggregator.merge(aggregator.fresher_visits([(20, window(40, 40, True))])) == 0
    assert aggregator.score == 1


def test_one_batch_is_applied_in_stamp_order_and_keeps_other_cells() -> None:
    aggregator = BeliefAggregator(np.zeros((100, 100), dtype=bool))
    batch = [(30, window(10, 10, True)), (20, window(10, 10, False)), (25, window(60, 60, True))]
    kept = aggregator.fresher_visits(batch)
    # In stamp order: 20 (the cell), 25 (another cell), 30 (the cell again, newer).
    assert [w.visited.sum() for w in kept] == [1, 1, 1]
    aggregator.merge(kept)
    assert aggregator.burning[11, 11] and aggregator.burning[61, 61]
    # Cells off the map are simply not visited.
    edge = aggregator.fresher_visits([(40, window(-2, -2, True))])
    assert edge[0].visited.sum() == 0
