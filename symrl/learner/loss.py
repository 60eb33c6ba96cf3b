"""The TESEO update (paper 8.3, ``research/ALGORITHM.md`` section 1 step 6 and end of trial).

Per transition (s, a, r, s'), on the previous winner i' (the neuron that chose a):

    delta = r + gamma * u_i - u_i'   (u_i: the winner at s', whatever its expert; 0 if terminated)
    |delta| > theta:  grow a neuron at x' (p = reflex(x'), u = u_i' + delta, mu = 0)
    else:             u_i'  += eta * delta                      TD(0)
                      mu_i' += beta * delta * (xi' - mu_i')     REINFORCE (sigma^2-scaled)
                      c_i'  += kappa * (x' - c_i')  if delta > 0

These are the gradient steps of 1/2 delta^2 (target detached, lr eta) and of
-delta * log N(xi'; mu, sigma^2) (lr beta * sigma^2); ``tests/learner/test_loss.py`` checks
them against autograd. Growth replaces rows, which an optimizer cannot follow, so the update is
applied in place under ``no_grad`` (research/TORCHRL.md) and ``forward`` returns diagnostics.

End of trial (:meth:`end_trial`): after a goal-reaching trial whose total reinforcement beats
every earlier successful one, each neuron used gets p <- the action it took and mu <- 0; then
T <- max(T_min, lambda_T * T).
"""

from __future__ import annotations

import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.objectives import LossModule

from symrl.learner.policy import MixtureOfExpertsPolicy, Observation

__all__ = ["TeseoLoss"]


class TeseoLoss(LossModule):
    """Online per-transition update of a :class:`MixtureOfExpertsPolicy` (no optimizer)."""

    def __init__(self, policy: MixtureOfExpertsPolicy) -> None:
        super().__init__()
        # A plain reference, not a submodule: the policy's parameters are its own (and are
        # saved with it), the loss only adapts them.
        object.__setattr__(self, "policy", policy)
        self.config = policy.config

    @property
    def in_keys(self) -> list:
        return [
            "expert", "winner", "x", "xi", "sigma",
            ("next", "reward"), ("next", "terminated"), ("next", "truncated"),
        ]  # fmt: skip

    @property
    def out_keys(self) -> list[str]:
        return ["td_error", "new_neurons", "neurons"]

    @torch.no_grad()
    def forward(self, td: TensorDictBase) -> TensorDictBase:
        """Update the previous winner from one transition (batch [1] from the collector, or []).

        Returns ``td_error`` (delta), ``new_neurons`` (grown while processing this transition:
        at the next state if novel, or error-driven at the previous one) and ``neurons``."""
        policy = self.policy
        delta, grown = self.update(td)
        return TensorDict(
            td_error=torch.tensor(delta), new_neurons=torch.tensor(grown),
            neurons=torch.tensor(policy.total_neurons()),
        )  # fmt: skip

    def update(self, td: TensorDictBase) -> tuple[float, int]:
        """The per-step rules; returns (TD error, neurons grown for this transition)."""
        cfg, policy = self.config, self.policy
        if policy.options is not None:  # the option critics need every reinforcement
            collision = td.get(("next", "collision"), None)
            policy.options.record(
                float(td.get(("next", "reward")).reshape(-1)[0]),
                collision is not None and bool(collision.reshape(-1)[0]),
            )
        if not cfg.learning:
            return 0.0, 0
        row = 0 if td.batch_dims else None

        def col(key):
            value = td.get(key)
            return value[row] if row is not None else value

        def scalar(key):  # one element whatever the batch shape: .item() is a single call
            return td.get(key).item()

        k, i = scalar("expert"), scalar("winner")
        if i < 0:
            return 0.0, 0
        r = scalar(("next", "reward"))
        terminated = scalar(("next", "terminated"))
        truncated = scalar(("next", "truncated"))
        expert = policy.experts[k]
        grown = 0

        # Utility of the state reached: the next winner (grown if novel) is perceived now,
        # before adapting i', and held for the policy's next action (paper 8.3 order).
        if terminated:
            u_next = 0.0
        else:
            obs = Observation.from_td(td, ("next",), row)
            nxt = policy.perceive(obs, reward=r, grow=not truncated)
            if truncated:  # the trial ends here: bootstrap from the nearest neuron, grow nothing
                u_next = (
                    float(policy.experts[nxt.expert].rows.utilities[nxt.winner])
                    if nxt.winner >= 0 else float(expert.rows.utilities[i])
                )  # fmt: skip
            else:
                policy.hold(nxt)
                grown += int(nxt.grown)
                u_next = float(policy.experts[nxt.expert].rows.utilities[nxt.winner])

        rows = expert.rows  # fetched after any growth: storage may have moved
        u_prev = float(rows.utilities[i])
        delta = r + cfg.gamma * u_next - u_prev
        x = col("x")
        if abs(delta) > cfg.error_threshold:
            # Error-driven growth (paper 8.1): split the situation instead of adapting i'.
            obs_prev = Observation.from_td(td, (), row)
            expert.add(x, policy.new_neuron_action(obs_prev, k), u_prev + delta)
            grown += 1
        else:
            xi = scalar("xi")
            mu = float(rows.means[i])
            rows.utilities[i] = u_prev + cfg.eta * delta
            rows.means[i] = mu + cfg.beta * delta * (xi - mu)
            if delta > 0:
                expert.shift_centre(i, x, cfg.kappa)
        return delta, grown

    @torch.no_grad()
    def end_trial(self, record: dict) -> dict:
        """Action replacement after a better successful trial, then cooling; returns what it did
        (``replaced`` neurons, ``best_total`` so far, ``improved``).

        ``record`` needs ``reached_goal`` and ``total_reinforcement``; it is passed on to the
        policy's own :meth:`~MixtureOfExpertsPolicy.end_trial`.
        """
        cfg, policy = self.config, self.policy
        replaced = 0
        improved = False
        if cfg.learning:
            total = float(record["total_reinforcement"])
            if bool(record["reached_goal"]) and total > float(policy.best_total):
                improved = True
                policy.best_total.fill_(total)
                if cfg.replace_actions:
                    replaced = sum(e.replace_actions() for e in policy.experts)
            cooled = max(cfg.temperature_min, cfg.cooling * float(policy.temperature))
            policy.temperature.fill_(cooled)
        policy.end_trial(record)
        return {"replaced": replaced, "best_total": float(policy.best_total), "improved": improved}

    def extra_repr(self) -> str:
        c = self.config
        return (
            f"gamma={c.gamma}, eta={c.eta}, beta={c.beta}, kappa={c.kappa}, "
            f"theta={c.error_threshold}"
        )
