"""The pairwise Q-network's dueling head: Q = V + A - mean(A), scriptable, and the same
signature as the paper's, so agent nodes run a dueling policy unchanged."""

from __future__ import annotations

import pytest
import torch

from wildfire_learning.architectures import build_q_network
from wildfire_learning.q_network import DuelingHead


def test_the_dueling_head_adds_the_value_to_the_centred_advantages() -> None:
    head = DuelingHead(3)
    with torch.no_grad():
        head.value.weight.copy_(torch.tensor([[1.0, 0.0, 0.0]]))
        head.value.bias.fill_(0.5)
        head.advantage.weight.copy_(torch.tensor([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]))
        head.advantage.bias.zero_()
    q = head(torch.tensor([[2.0, 1.0, -3.0]]))
    # V = 2.5, A = (1, -3), mean(A) = -1: Q = (2.5 + 2, 2.5 - 2).
    assert q.tolist() == [[4.5, 0.5]]


@pytest.mark.parametrize(("approach", "arch"), [("obs", "paper"), ("belief", "lite")])
def test_a_dueling_network_takes_and_gives_what_the_paper_s_does(approach: str, arch: str) -> None:
    torch.manual_seed(0)
    plain = build_q_network(approach, arch)
    dueling = build_q_network(approach, arch, dueling=True)
    shape = (1, 30, 40) if approach == "obs" else (2, 100, 100)
    images, states = torch.rand(3, *shape), torch.rand(3, 2, 5)
    assert dueling(images, states).shape == plain(images, states).shape == (3, 2, 2)
    # The head differs only in its last layer, and the exported module is scripted.
    names = set(dueling.state_dict()) - set(plain.state_dict())
    assert {name.rsplit(".", 2)[-2] for name in names} == {"value", "advantage"}
    scripted = torch.jit.script(dueling.eval())
    assert torch.equal(scripted(images, states), dueling(images, states))
