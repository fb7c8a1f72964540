"""sLSTM: the stabilised recurrence is the plain one, state carries across calls, heads stay separate."""

from __future__ import annotations

import pytest
import torch

from ftin.models.layers.slstm import SLSTM, ForgetGate, SLSTMBlock, SLSTMStack


def _unstabilised_reference(cell: SLSTM, x: torch.Tensor) -> torch.Tensor:
    """xLSTM's sLSTM straight from the equations: exp input gate, no stabiliser, dense R (float64)."""
    batch, steps, _ = x.shape
    H, hd, hidden = cell.heads, cell.head_dim, cell.hidden
    pre = cell.input_proj(x).view(batch, steps, H, 4, hd)  # (B, T, head, gate, hd)
    gates = [pre[:, :, :, g].reshape(batch, steps, hidden) for g in range(4)]  # i, f, z, o
    r = cell.recurrent_dense()  # (gate, hidden_in, hidden_out)
    c = n = h = x.new_zeros(batch, hidden)
    outputs = []
    for t in range(steps):
        i_raw, f_raw, z_raw, o_raw = (gates[g][:, t] + h @ r[g] for g in range(4))
        i = torch.exp(i_raw)
        f = torch.sigmoid(f_raw) if cell.forget_gate is ForgetGate.SIGMOID else torch.exp(f_raw)
        c = f * c + i * torch.tanh(z_raw)
        n = f * n + i
        h = torch.sigmoid(o_raw) * c / n
        outputs.append(h)
    return torch.stack(outputs, dim=1)  # (B, T, hidden)


@pytest.mark.parametrize("forget_gate", ["sigmoid", "exp"])
def test_stabilised_recurrence_equals_unstabilised_reference(forget_gate: str) -> None:
    torch.manual_seed(0)
    cell = SLSTM(in_features=5, hidden=8, heads=2, forget_gate=forget_gate).double()
    with torch.no_grad():
        cell.input_proj.bias.normal_()  # move gates away from their init so every term matters
    x = 2.0 * torch.randn(3, 12, 5, dtype=torch.float64)
    with torch.no_grad():
        out, state = cell(x)
        reference = _unstabilised_reference(cell, x)
    assert torch.isfinite(reference).all()
    torch.testing.assert_close(out, reference, rtol=1e-9, atol=1e-9)
    torch.testing.assert_close(state.h, out[:, -1])
    assert (state.n >= 1.0 - 1e-12).all()  # the empty state's first step sets m = i~, so n never < 1


def test_stabiliser_stays_finite_where_plain_exp_overflows() -> None:
    torch.manual_seed(1)
    cell = SLSTM(in_features=4, hidden=4, heads=1)
    with torch.no_grad():
        cell.input_proj.bias.view(1, 4, 4)[:, 0] = 200.0  # exp(200) overflows float32
    x = torch.randn(2, 6, 4)
    with torch.no_grad():
        assert not torch.isfinite(_unstabilised_reference(cell, x)).all()
        out, _ = cell(x)
    assert torch.isfinite(out).all()


def test_state_carries_across_calls() -> None:
    torch.manual_seed(2)
    stack = SLSTMStack(dim=8, n_blocks=2, heads=2).eval()
    x = torch.randn(3, 10, 8)
    with torch.no_grad():
        whole, whole_states = stack(x)
        first, states = stack(x[:, :4])
        second, final_states = stack(x[:, 4:], states)
    torch.testing.assert_close(torch.cat([first, second], dim=1), whole)
    for carried, reference in zip(final_states, whole_states, strict=True):
        for a, b in zip(carried, reference, strict=True):
            torch.testing.assert_close(a, b)
    # A fresh state is not the same as the carried one: the carry is really used.
    restarted, _ = stack(x[:, 4:])
    assert not torch.allclose(restarted, second)


def test_recurrent_weights_are_block_diagonal_per_head() -> None:
    torch.manual_seed(3)
    heads, hidden = 4, 16
    cell = SLSTM(in_features=3, hidden=hidden, heads=heads)
    hd = hidden // heads
    assert cell.recurrent.shape == (heads, hd, 4 * hd)  # off-block weights do not exist
    dense = cell.recurrent_dense()
    mask = torch.block_diag(*[torch.ones(hd, hd)] * heads).bool()
    assert (dense[:, ~mask] == 0).all() and (dense[:, mask] != 0).all()

    # Changing head 0's previous h changes head 0's next output only.
    x = torch.randn(2, 1, 3)
    _, state = cell(torch.randn(2, 5, 3))
    h = state.h.clone()
    h[:, :hd] += 1.0
    with torch.no_grad():
        base, _ = cell(x, state)
        moved, _ = cell(x, state._replace(h=h))
    assert not torch.allclose(moved[..., :hd], base[..., :hd])
    torch.testing.assert_close(moved[..., hd:], base[..., hd:])


def test_block_shapes_gradients_and_residual_switch() -> None:
    torch.manual_seed(4)
    x = torch.randn(2, 5, 12, requires_grad=True)
    block = SLSTMBlock(dim=12, heads=3)
    out, state = block(x)
    assert out.shape == (2, 5, 12) and state.c.shape == (2, 12)
    out.sum().backward()
    assert all(p.grad is not None and torch.isfinite(p.grad).all() for p in block.parameters())
    assert x.grad is not None and torch.isfinite(x.grad).all()

    plain = SLSTMBlock(dim=12, heads=3, residual=False)
    plain.load_state_dict(block.state_dict())
    with torch.no_grad():
        assert not torch.allclose(plain(x)[0], block(x)[0])


def test_bad_sizes_are_rejected_with_the_numbers() -> None:
    with pytest.raises(ValueError, match=r"hidden \(10\).*heads \(4\)"):
        SLSTM(in_features=3, hidden=10, heads=4)
    with pytest.raises(ValueError, match="forget_gate"):
        SLSTM(in_features=3, hidden=8, heads=2, forget_gate="tanh")
    stack = SLSTMStack(dim=8, n_blocks=2, heads=2)
    with pytest.raises(ValueError, match="expected 2 sLSTM states"):
        stack(torch.randn(1, 3, 8), [])
